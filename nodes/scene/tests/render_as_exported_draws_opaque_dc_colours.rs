//! `render` with `appearance: "exported"` draws the scene as the `.glb` holds it:
//! a semi-transparent, soft-edged member with view-dependent colour shows, inside
//! its faces, exactly its DC colour over nothing — what a user opening the export sees.

mod common;

use objectsplat_core::{Image, Split};
use objectsplat_raster::save_model;

#[test]
fn a_soft_translucent_member_renders_opaque_in_its_dc_colour() {
    let tmp = tempfile::tempdir().unwrap();
    let models = tmp.path().join("models");
    save_model(
        &common::square([0.0, 3.0, 0.0], 6.0, [0.2, 0.3, 0.8]),
        &models.join("background"),
    )
    .unwrap();
    // Half transparent, soft-edged, with a first SH band that tints it toward the camera.
    let mut chair = common::square([0.0, 0.0, 0.0], 1.0, [0.9, 0.1, 0.1]);
    chair.opacity_logits = vec![0.0; 4];
    chair.sigma = 1.0;
    chair.sh_degree = 1;
    for rows in &mut chair.sh {
        rows[1] = [0.3, 0.3, 0.3];
        rows[2] = [0.3, 0.3, 0.3];
        rows[3] = [0.3, 0.3, 0.3];
    }
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
    let chair_dc = [0.9, 0.1, 0.1];
    let off = |p: &[f32]| {
        p.iter()
            .zip(chair_dc)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max)
    };
    assert!(
        off(&px(&trained)) > 0.1,
        "as trained the wall shows through and the SH band tints: {:?}",
        px(&trained)
    );
    // Exactly the DC colour, up to the PNG's 8-bit rounding.
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
