//! A component with view-dependent colour carries its SH coefficients in the `.glb` as
//! `_SH_0` … `_SH_{(d+1)²−1}` attributes (read back through the `gltf` parser, in the
//! order of the written vertices) with `sh_degree` in the node's extras; bad
//! coefficients are refused naming the component and vertex.

mod common;

use objectsplat_export::{ShColors, build_glb};

/// Coefficient `k` of vertex `v`: distinct for every (vertex, coefficient, channel).
fn coefficient(v: usize, k: usize) -> [f32; 3] {
    [v as f32, k as f32 * 0.5, -(v as f32) - k as f32 * 0.25]
}

#[test]
fn sh_coefficients_round_trip_through_the_glb() {
    let degree = 3;
    let per_vertex = 16;
    let chair =
        common::cuboid(3, "chair", [0.0; 3], [1.0; 3], common::CORNER_COLOURS).with_sh(ShColors {
            degree,
            coefficients: (0..8)
                .flat_map(|v| (0..per_vertex).map(move |k| coefficient(v, k)))
                .collect(),
        });
    let positions = chair.positions.clone();
    let (bytes, _) = build_glb(&[chair, common::floor()], None).unwrap();
    let gltf = gltf::Gltf::from_slice(&bytes).unwrap();
    let blob = gltf.blob.as_deref().unwrap();
    let document = &gltf.document;
    let node = document
        .nodes()
        .find(|n| n.name() == Some("obj_3_chair"))
        .unwrap();
    let extras: serde_json::Value =
        serde_json::from_str(node.extras().as_ref().unwrap().get()).unwrap();
    assert_eq!(extras["sh_degree"], 3);
    let primitive = node.mesh().unwrap().primitives().next().unwrap();
    let reader = primitive.reader(|_| Some(blob));
    let written: Vec<[f32; 3]> = reader.read_positions().unwrap().collect();
    // Each written vertex is one of the input's (compaction may reorder them).
    let source: Vec<usize> = written
        .iter()
        .map(|p| positions.iter().position(|q| q == p).unwrap())
        .collect();
    let attribute = |name: String| {
        primitive
            .attributes()
            .find(|(s, _)| s.to_string() == name)
            .map(|(_, a)| a)
    };
    for k in 0..per_vertex {
        let accessor = attribute(format!("_SH_{k}")).unwrap_or_else(|| panic!("no _SH_{k}"));
        let view = accessor.view().unwrap();
        let data = &blob[view.offset()..view.offset() + view.length()];
        let values: Vec<f32> = data
            .chunks(4)
            .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect();
        for (w, &v) in source.iter().enumerate() {
            assert_eq!(
                values[w * 3..w * 3 + 3],
                coefficient(v, k),
                "_SH_{k} of vertex {w}"
            );
        }
    }
    assert!(attribute("_SH_16".into()).is_none());
    // The floor has no bands: no attributes, no extra.
    let floor = document
        .nodes()
        .find(|n| n.name() == Some("background"))
        .unwrap();
    let floor_primitive = floor.mesh().unwrap().primitives().next().unwrap();
    assert!(
        floor_primitive
            .attributes()
            .all(|(s, _)| !s.to_string().starts_with("_SH"))
    );
}

#[test]
fn bad_coefficients_are_refused_naming_the_vertex() {
    let cuboid = || common::cuboid(3, "chair", [0.0; 3], [1.0; 3], common::CORNER_COLOURS);
    let short = cuboid().with_sh(ShColors {
        degree: 1,
        coefficients: vec![[0.0; 3]; 8 * 4 - 1],
    });
    let err = format!("{:#}", build_glb(&[short], None).unwrap_err());
    common::assert_mentions(&err, &["obj_3_chair", "31 SH coefficients for 8 vertices"]);
    let mut coefficients = vec![[0.0; 3]; 8 * 4];
    coefficients[4 * 5 + 2][1] = f32::NAN;
    let nan = cuboid().with_sh(ShColors {
        degree: 1,
        coefficients,
    });
    let err = format!("{:#}", build_glb(&[nan], None).unwrap_err());
    common::assert_mentions(
        &err,
        &["obj_3_chair", "vertex 5", "non-finite SH coefficient"],
    );
    let degree = cuboid().with_sh(ShColors {
        degree: 4,
        coefficients: vec![[0.0; 3]; 8 * 25],
    });
    let err = format!("{:#}", build_glb(&[degree], None).unwrap_err());
    common::assert_mentions(&err, &["SH degree 4"]);
}
