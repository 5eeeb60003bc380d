//! `render` with `appearance: "exported"` draws the scene as the `.glb` holds it:
//! a semi-transparent, soft-edged member with view-dependent colour shows, inside
//! its faces, exactly its flat colour (its DC colour, or the trainer's bake where
//! it has one) over nothing — what a user opening the export sees.

mod common;

use objectsplat_core::{Image, Split};
use objectsplat_raster::save_model;

/// A half-transparent, soft-edged chair with a first SH band that tints it
/// toward the camera, its DC colour (0.9, 0.1, 0.1), and `flat` as its baked
/// flat colours (none when empty).
fn tinted_chair(flat: Vec<[f32; 3]>) -> objectsplat_raster::Model<f32> {
    let mut chair = common::square([0.0, 0.0, 0.0], 1.0, [0.9, 0.1, 0.1]);
    chair.opacity_logits = vec![0.0; 4];
    chair.sigma = 1.0;
    chair.sh_degree = 1;
    for rows in &mut chair.sh {
        rows[1] = [0.3, 0.3, 0.3];
        rows[2] = [0.3, 0.3, 0.3];
        rows[3] = [0.3, 0.3, 0.3];
    }
    chair.flat_dc = flat;
    chair
}

#[test]
fn a_soft_translucent_member_renders_opaque_in_its_dc_colour() {
    exported_shows(tinted_chair(Vec::new()), [0.9, 0.1, 0.1]);
}

#[test]
fn a_baked_member_renders_in_its_flat_colour() {
    let flat = [0.3f32, 0.6, 0.45];
    let dc = flat.map(|c| ((c as f64 - 0.5) / objectsplat_raster::sh::SH_DC) as f32);
    exported_shows(tinted_chair(vec![dc; 4]), flat);
}

/// Renders the chair before a wall as trained and as exported: inside a face
/// the export shows exactly `colour`, the trained render does not.
fn exported_shows(chair: objectsplat_raster::Model<f32>, colour: [f32; 3]) {
    let tmp = tempfile::tempdir().unwrap();
    let models = tmp.path().join("models");
    save_model(
        &common::square([0.0, 3.0, 0.0], 6.0, [0.2, 0.3, 0.8]),
        &models.join("background"),
    )
    .unwrap();
    save_model(&chair, &models.join("obj_3_chair")).unwrap();
    let scene = common::run(
        &objectsplat_scene::nodes::Compose,
        &[("models", &models)],
        "()",
        &tmp.path().join("compose"),
    )
    .outputs["scene"]
        .clone();
    let cam = common::front_camera(64, 64);
    let frames = common::write_frames_from(tmp.path(), cam, &[("f0", Split::Test)]);

    let render = |appearance: &str| {
        let run = common::run(
            &objectsplat_scene::nodes::Render,
            &[("scene", &scene), ("frames", &frames)],
            &format!("(appearance: \"{appearance}\")"),
            &tmp.path().join(appearance),
        );
        Image::load(&run.outputs["images"].join("f0.png")).unwrap()
    };
    let (trained, exported) = (render("trained"), render("exported"));
    // Inside one face, away from the shared diagonal.
    let centre = common::pixel_of(&cam, [0.25, 0.0, -0.1]);
    let px = |img: &Image| img.data[((centre.1 * 64 + centre.0) * 3) as usize..][..3].to_vec();
    let off = |p: &[f32]| {
        p.iter()
            .zip(colour)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max)
    };
    assert!(
        off(&px(&trained)) > 0.1,
        "as trained the wall shows through and the SH band tints: {:?}",
        px(&trained)
    );
    // Exactly the flat colour, up to the PNG's 8-bit rounding.
    assert!(
        off(&px(&exported)) <= 0.5 / 255.0 + 1e-6,
        "{:?}",
        px(&exported)
    );
    // Outside the chair the wall, opaque already, is unchanged.
    let wall = common::pixel_of(&cam, [1.2, 3.0, 1.2]);
    let at =
        |img: &Image, (x, y): (u32, u32)| img.data[((y * 64 + x) * 3) as usize..][..3].to_vec();
    assert_eq!(at(&trained, wall), at(&exported, wall));
}
