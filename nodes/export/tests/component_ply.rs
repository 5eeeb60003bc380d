//! Per-component PLY files, read back with an independent PLY parser (`ply-rs`): one file
//! per component, the same cleaned triangles as the `.glb`, sRGB `uchar` colours, Z-up.

mod common;

use objectsplat_export::ply::write_component_plys;
use objectsplat_export::{SrgbColors, build_glb};
use ply_rs::ply::{DefaultElement, Property};

struct ReadBack {
    positions: Vec<[f32; 3]>,
    colours: Vec<[u8; 3]>,
    faces: Vec<[usize; 3]>,
}

fn read(path: &std::path::Path) -> ReadBack {
    let mut file = std::fs::File::open(path).unwrap();
    let ply = ply_rs::parser::Parser::<DefaultElement>::new()
        .read_ply(&mut file)
        .expect("parses as PLY");
    assert_eq!(
        ply.header.encoding,
        ply_rs::ply::Encoding::BinaryLittleEndian
    );
    let float = |e: &DefaultElement, k: &str| match e.get(k) {
        Some(Property::Float(v)) => *v,
        other => panic!("{k}: expected float, got {other:?}"),
    };
    let uchar = |e: &DefaultElement, k: &str| match e.get(k) {
        Some(Property::UChar(v)) => *v,
        other => panic!("{k}: expected uchar, got {other:?}"),
    };
    let vertices = &ply.payload["vertex"];
    let positions = vertices
        .iter()
        .map(|v| [float(v, "x"), float(v, "y"), float(v, "z")])
        .collect();
    let colours = vertices
        .iter()
        .map(|v| [uchar(v, "red"), uchar(v, "green"), uchar(v, "blue")])
        .collect();
    let faces = ply.payload["face"]
        .iter()
        .map(|f| match f.get("vertex_indices") {
            Some(Property::ListInt(l)) if l.len() == 3 => {
                [l[0] as usize, l[1] as usize, l[2] as usize]
            }
            other => panic!("face: expected 3 ints, got {other:?}"),
        })
        .collect();
    ReadBack {
        positions,
        colours,
        faces,
    }
}

#[test]
fn one_file_per_component_with_the_glb_triangles_and_srgb_colours() {
    let dir = tempfile::tempdir().unwrap();
    let objects = common::scene();
    let paths = write_component_plys(dir.path(), &objects).unwrap();
    let names: Vec<_> = paths
        .iter()
        .map(|p| p.file_name().unwrap().to_str().unwrap().to_string())
        .collect();
    assert_eq!(
        names,
        ["obj_3_chair.ply", "obj_7_desk_lamp.ply", "background.ply"]
    );

    let (_, summary) = build_glb(&objects, None).unwrap();
    for ((path, object), exported) in paths.iter().zip(&objects).zip(&summary) {
        let back = read(path);
        assert_eq!(back.faces.len(), exported.triangles, "{}", path.display());
        assert_eq!(
            back.positions.len(),
            exported.vertices,
            "{}",
            path.display()
        );
        // Every written triangle is an input triangle (same corners, same winding, Z-up
        // coordinates untouched) and every vertex keeps its sRGB colour.
        for (t, face) in back.faces.iter().enumerate() {
            let corners = face.map(|v| back.positions[v]);
            let original = object.faces[t].map(|v| object.positions[v as usize]);
            assert_eq!(corners, original, "{} face {t}", path.display());
            for (k, &v) in face.iter().enumerate() {
                let source = object.faces[t][k] as usize;
                let expected = match &object.colors_srgb {
                    SrgbColors::U8(c) => c[source],
                    SrgbColors::F32(c) => c[source].map(|x| (x * 255.0).round() as u8),
                };
                assert_eq!(back.colours[v], expected, "{} vertex {v}", path.display());
            }
        }
    }
    // The lamp's unused far vertex is not written.
    let lamp = read(&paths[1]);
    assert!(lamp.positions.iter().all(|p| p[0] < 2.0));
}

#[test]
fn bad_component_names_the_output_file() {
    let dir = tempfile::tempdir().unwrap();
    let mut objects = common::scene();
    objects[1].positions[2][0] = f32::NAN;
    let e = format!(
        "{:#}",
        write_component_plys(dir.path(), &objects).unwrap_err()
    );
    assert!(
        e.contains("obj_7_desk_lamp.ply") && e.contains("vertex 2"),
        "{e}"
    );
}
