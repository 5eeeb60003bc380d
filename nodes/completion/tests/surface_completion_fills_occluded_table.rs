//! Surface completion on a hand-made partition (tests/common): the table's
//! completed mask covers the footprint of the cup standing inside its silhouette,
//! with table-coloured targets there; the background showing through a gap, the
//! overhanging cup of frame 1 and the other components are left alone; a scene
//! without a support surface is skipped; planarity from points accepts a flat
//! table and rejects a bumpy one.

mod common;

use common::{CUP_RGB, H, Owner, TABLE_RGB, W, owner};
use objectsplat_completion::nodes::SurfaceCompletionNode;
use objectsplat_completion::surface::{ScenePoints, SurfaceParams, complete_surfaces};
use objectsplat_core::component::OWN;
use objectsplat_core::glam::DVec3;
use objectsplat_core::visibility::Visibility;
use objectsplat_core::{Frames, Points};
use objectsplat_runtime::Outcome;

/// The scene's components and frames, as the surface-completion node's inputs.
fn inputs(scene: &common::Scene) -> [(&str, &std::path::Path); 2] {
    [("components", &scene.components), ("frames", &scene.frames)]
}

fn pixels() -> impl Iterator<Item = (u32, u32, usize)> {
    (0..H).flat_map(|y| (0..W).map(move |x| (x, y, (y * W + x) as usize)))
}

#[test]
fn table_mask_covers_the_cup_footprint_and_targets_carry_table_colour() {
    let scene = common::build("table");
    let out = scene.root.path().join("out");
    let report = complete_surfaces(
        &common::items(&scene.components),
        None,
        &SurfaceParams::default(),
        &out,
    )
    .unwrap();
    assert_eq!(report.skipped, None);
    assert_eq!(report.surfaces.len(), 1);
    let cup_pixels = pixels()
        .filter(|&(x, y, _)| owner(0, x, y) == Owner::Cup)
        .count() as u64;
    assert_eq!(report.surfaces[0].pixels_added, cup_pixels);
    assert_eq!(report.surfaces[0].frames_completed, 1);

    let table = out.join("obj_1_table");
    let mask0 = common::read_gray(&table.join("masks/f0.png"));
    let target0 = common::read_rgb(&table.join("targets/f0.png"));
    for (x, y, i) in pixels() {
        let expect_own = matches!(owner(0, x, y), Owner::Table | Owner::Cup);
        assert_eq!(mask0[i] == OWN, expect_own, "frame 0 pixel ({x}, {y})");
        if owner(0, x, y) == Owner::Cup {
            // Inpainted from the table around it, which is one flat colour.
            assert_eq!(
                &target0[i * 3..i * 3 + 3],
                &TABLE_RGB,
                "target at ({x}, {y})"
            );
            assert_ne!(&target0[i * 3..i * 3 + 3], &CUP_RGB);
        }
    }
    // Frame 1: the cup overhangs the table edge, so the table has no hole there.
    let original1 = common::read_gray(&scene.components.join("obj_1_table/masks/f1.png"));
    assert_eq!(common::read_gray(&table.join("masks/f1.png")), original1);
    assert!(!table.join("targets/f1.png").exists());
    assert!(table.join("completion.json").is_file());
    // Other components are passed on unchanged.
    for name in ["obj_2_cup", "obj_3_chair", "background"] {
        for f in ["f0", "f1"] {
            let rel = format!("{name}/masks/{f}.png");
            assert_eq!(
                common::read_gray(&out.join(&rel)),
                common::read_gray(&scene.components.join(&rel)),
                "{rel}"
            );
        }
    }
    // Writing the outputs must not have touched the inputs (files may be hard links).
    let input0 = common::read_gray(&scene.components.join("obj_1_table/masks/f0.png"));
    assert_eq!(
        input0.iter().filter(|&&v| v == OWN).count(),
        pixels()
            .filter(|&(x, y, _)| owner(0, x, y) == Owner::Table)
            .count()
    );
}

#[test]
fn node_is_skipped_without_a_support_surface_and_forwards_its_input() {
    let scene = common::build("sofa");
    let out = scene.root.path().join("run");
    let run = common::run(&SurfaceCompletionNode, &inputs(&scene), "()", &out);
    match run.outcome {
        Outcome::Skipped(reason) => assert!(reason.contains("support surface"), "{reason}"),
        other => panic!("expected a skip, got {other:?}"),
    }
    assert_eq!(run.outputs["components"], scene.components);
}

#[test]
fn node_completes_the_table_with_default_params() {
    let scene = common::build("Dining Table");
    let out = scene.root.path().join("run");
    let run = common::run(
        &SurfaceCompletionNode,
        &inputs(&scene),
        "(radius: 3.0)",
        &out,
    );
    assert_eq!(run.outcome, Outcome::Done);
    let table = run.outputs["components"].join("obj_1_dining_table");
    assert!(table.join("targets/f0.png").is_file());
}

/// Points on the tabletop seen from the scene camera: one per table pixel of
/// frame 0, where its ray meets the plane z = 0 (moved along the ray by up to
/// `bump` of the distance).
fn table_points(bump: f64) -> Points {
    points_on_rays_to(0.0, bump)
}

/// [`table_points`] on the plane z = `height` instead.
fn points_on_rays_to(height: f64, bump: f64) -> Points {
    let camera = common::camera();
    let frames = Frames::read(&common::build("table").frames).unwrap();
    let frame = &frames.frames[0];
    let (rot_t, centre) = (camera.rotation().transpose(), camera.center());
    let mut positions = Vec::new();
    for (x, y, _) in pixels()
        .filter(|&(x, y, _)| owner(0, x, y) == Owner::Table && owner(1, x, y) == Owner::Table)
    {
        let ray = rot_t
            * DVec3::new(
                (x as f64 + 0.5 - frame.camera.cx) / frame.camera.fx,
                (y as f64 + 0.5 - frame.camera.cy) / frame.camera.fy,
                1.0,
            );
        let s = (height - centre.z) / ray.z;
        // A bump moves the point along its own ray, so it still projects to the same pixel.
        let wobble = 1.0 + bump * ((x * 7 + y * 3) % 5) as f64 / 4.0;
        let p = centre + ray * s * wobble;
        positions.push([p.x as f32, p.y as f32, p.z as f32]);
    }
    let colors = vec![[0, 0, 0]; positions.len()];
    Points { positions, colors }
}

#[test]
fn planarity_accepts_a_flat_table_and_rejects_a_bumpy_one() {
    let scene = common::build("table");
    let items = common::items(&scene.components);
    let params = SurfaceParams::default();
    let complete = |bump: f64, out: &str| {
        let points = table_points(bump);
        let points = ScenePoints::new(&points, None).unwrap();
        complete_surfaces(&items, Some(points), &params, &scene.root.path().join(out)).unwrap()
    };
    let flat = complete(0.0, "a");
    assert_eq!(flat.skipped, None);
    assert!(
        flat.surfaces[0].plane_inlier_fraction.unwrap() > 0.99,
        "{:?}",
        flat.surfaces[0]
    );
    let bumpy = complete(0.1, "b");
    assert!(!bumpy.surfaces[0].accepted, "{:?}", bumpy.surfaces[0]);
    assert!(bumpy.skipped.unwrap().contains("not planar"));
    assert!(
        !scene.root.path().join("b").exists(),
        "a skipped run writes nothing"
    );
}

/// The floor seen past the table top (the same rays, 75 cm further) projects
/// onto the table's pixels: counting every point that projects there, half of
/// the table's "points" are the floor's and the flat top is rejected; with the
/// scene's visibility the floor points behind the top are not seen there, and
/// the top is accepted.
#[test]
fn a_flat_table_seen_over_the_floor_is_accepted_with_the_scene_visibility() {
    let scene = common::build("table");
    let items = common::items(&scene.components);
    let params = SurfaceParams::default();
    let mut points = table_points(0.0);
    let floor = points_on_rays_to(-0.75, 0.0);
    points.positions.extend(floor.positions);
    points.colors.extend(floor.colors);
    let frames = Frames::read(&scene.frames).unwrap();
    let visibility = Visibility::compute(&points, &frames.frames, 2).unwrap();
    let run = |visibility: Option<&Visibility>, out: &str| {
        let points = ScenePoints::new(&points, visibility).unwrap();
        complete_surfaces(&items, Some(points), &params, &scene.root.path().join(out)).unwrap()
    };
    let blind = run(None, "blind");
    assert!(!blind.surfaces[0].accepted, "{:?}", blind.surfaces[0]);
    assert!(blind.skipped.unwrap().contains("not planar"));
    let seeing = run(Some(&visibility), "seeing");
    assert_eq!(seeing.skipped, None, "{:?}", seeing.surfaces[0]);
    assert!(
        seeing.surfaces[0].plane_inlier_fraction.unwrap() > 0.99,
        "{:?}",
        seeing.surfaces[0]
    );
    // A visibility of other points is refused, not silently misapplied.
    let other = Visibility::compute(&table_points(0.0), &frames.frames, 1).unwrap();
    assert!(ScenePoints::new(&points, Some(&other)).is_err());
}
