//! Bad export input is an error naming the component and the offending element, never a panic
//! and never a silently wrong file.

mod common;

use objectsplat_export::{SrgbColors, build_glb};

fn error_of(objects: &[objectsplat_export::ExportObject]) -> String {
    format!(
        "{:#}",
        build_glb(objects, None).expect_err("must be rejected")
    )
}

#[test]
fn nan_position_is_rejected_with_component_and_vertex() {
    let mut objects = common::scene();
    objects[0].positions[5][1] = f32::NAN;
    let e = error_of(&objects);
    assert!(
        e.contains("obj_3_chair") && e.contains("vertex 5") && e.contains("non-finite"),
        "{e}"
    );
}

#[test]
fn infinite_position_is_rejected() {
    let mut objects = common::scene();
    objects[2].positions[1][2] = f32::INFINITY;
    let e = error_of(&objects);
    assert!(e.contains("background") && e.contains("vertex 1"), "{e}");
}

#[test]
fn out_of_range_or_nan_float_colour_is_rejected() {
    for bad in [f32::NAN, 1.5, -0.1] {
        let mut objects = common::scene();
        if let SrgbColors::F32(c) = &mut objects[2].colors_srgb {
            c[2][0] = bad;
        }
        let e = error_of(&objects);
        assert!(
            e.contains("background") && e.contains("vertex 2 colour"),
            "{e}"
        );
    }
}

#[test]
fn face_index_past_the_vertices_is_rejected() {
    let mut objects = common::scene();
    objects[0].faces[4] = [0, 1, 8];
    let e = error_of(&objects);
    assert!(
        e.contains("obj_3_chair") && e.contains("face 4") && e.contains("8 vertices"),
        "{e}"
    );
}

#[test]
fn colour_count_mismatch_is_rejected() {
    let mut objects = common::scene();
    objects[0].colors_srgb = SrgbColors::U8(vec![[0, 0, 0]; 3]);
    let e = error_of(&objects);
    assert!(
        e.contains("obj_3_chair") && e.contains("3 colours for 8 vertices"),
        "{e}"
    );
}

#[test]
fn duplicate_component_is_rejected() {
    let mut objects = common::scene();
    objects.push(objects[0].clone());
    let e = error_of(&objects);
    assert!(e.contains("obj_3_chair appears twice"), "{e}");
}

#[test]
fn asset_extras_must_be_an_object() {
    let e = format!(
        "{:#}",
        build_glb(&common::scene(), Some(&serde_json::json!([1, 2]))).unwrap_err()
    );
    assert!(e.contains("asset extras must be a JSON object"), "{e}");
}

#[test]
fn write_glb_names_the_file() {
    let mut objects = common::scene();
    objects[0].positions[0][0] = f32::NAN;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.glb");
    let e = format!(
        "{:#}",
        objectsplat_export::write_glb(&path, &objects, None).unwrap_err()
    );
    assert!(e.contains("out.glb") && e.contains("obj_3_chair"), "{e}");
    assert!(!path.exists(), "nothing is written for bad input");
}
