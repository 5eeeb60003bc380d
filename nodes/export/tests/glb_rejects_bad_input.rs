//! Bad export input is an error naming the component and the offending element, never a panic
//! and never a silently wrong file.

mod common;

use objectsplat_export::{SrgbColors, build_glb};

/// The error exporting the test scene gives after `spoil` changes it.
fn error_of(spoil: impl FnOnce(&mut Vec<objectsplat_export::ExportObject>)) -> String {
    let mut objects = common::scene();
    spoil(&mut objects);
    format!(
        "{:#}",
        build_glb(&objects, None).expect_err("must be rejected")
    )
}

#[test]
fn nan_position_is_rejected_with_component_and_vertex() {
    let e = error_of(|objects| objects[0].positions[5][1] = f32::NAN);
    common::assert_mentions(&e, &["obj_3_chair", "vertex 5", "non-finite"]);
}

#[test]
fn infinite_position_is_rejected() {
    let e = error_of(|objects| objects[2].positions[1][2] = f32::INFINITY);
    common::assert_mentions(&e, &["background", "vertex 1"]);
}

#[test]
fn out_of_range_or_nan_float_colour_is_rejected() {
    for bad in [f32::NAN, 1.5, -0.1] {
        let e = error_of(|objects| {
            if let SrgbColors::F32(c) = &mut objects[2].colors_srgb {
                c[2][0] = bad;
            }
        });
        common::assert_mentions(&e, &["background", "vertex 2 colour"]);
    }
}

#[test]
fn face_index_past_the_vertices_is_rejected() {
    let e = error_of(|objects| objects[0].faces[4] = [0, 1, 8]);
    common::assert_mentions(&e, &["obj_3_chair", "face 4", "8 vertices"]);
}

#[test]
fn colour_count_mismatch_is_rejected() {
    let e = error_of(|objects| objects[0].colors_srgb = SrgbColors::U8(vec![[0, 0, 0]; 3]));
    common::assert_mentions(&e, &["obj_3_chair", "3 colours for 8 vertices"]);
}

#[test]
fn duplicate_component_is_rejected() {
    let e = error_of(|objects| objects.push(objects[0].clone()));
    common::assert_mentions(&e, &["obj_3_chair appears twice"]);
}

#[test]
fn asset_extras_must_be_an_object() {
    let e = format!(
        "{:#}",
        build_glb(&common::scene(), Some(&serde_json::json!([1, 2]))).unwrap_err()
    );
    common::assert_mentions(&e, &["asset extras must be a JSON object"]);
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
    common::assert_mentions(&e, &["out.glb", "obj_3_chair"]);
    assert!(!path.exists(), "nothing is written for bad input");
}
