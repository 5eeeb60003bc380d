//! `evaluate` measures where the background hangs in front of an object: with the
//! composed scene's own surfaces as ground truth nothing does; with the background
//! wall moved between the camera and one object (but behind the others) exactly that
//! object's pixels are covered, and the scene's share is its share of all object pixels.

#[path = "../../scene/tests/common/mod.rs"]
mod common;

use objectsplat_core::artifact::METRICS_JSON;
use objectsplat_core::{ObjectLabels, Split, write_mesh_artifact};
use objectsplat_evaluate::Evaluate;
use objectsplat_scene::load_scene;

#[test]
fn a_wall_moved_in_front_of_the_lamp_covers_the_lamp_alone() {
    let tmp = tempfile::tempdir().unwrap();
    let scene_dir = common::composed_scene(tmp.path());
    let cam = common::front_camera(64, 64);
    let frames = common::write_frames_from(tmp.path(), cam, &[("t0", Split::Test)]);
    // Ground truth: the composed scene's own surfaces, with object ids.
    let scene = load_scene(&scene_dir).unwrap();
    // The wall keeps an id of its own (1); only the scene's objects are scored.
    let gt = common::surfaces_as_ground_truth(&scene, 1);
    let labels: ObjectLabels = [
        (1, "wall".to_string()),
        (3, "chair".to_string()),
        (4, "lamp".into()),
        (5, "cup".into()),
    ]
    .into();
    let mesh_dir = tmp.path().join("mesh");
    write_mesh_artifact(&mesh_dir, &gt, &labels).unwrap();

    let evaluate = |scene: &std::path::Path, out: &str| {
        let renders = common::rendered(scene, &frames, &tmp.path().join(format!("r_{out}")));
        let run = common::run(
            &Evaluate,
            &[
                ("images", &renders),
                ("frames", &frames),
                ("scene", scene),
                ("mesh", &mesh_dir),
            ],
            "(samples: 1000.0)",
            &tmp.path().join(out),
        );
        common::read_json(&run.outputs["metrics"].join(METRICS_JSON))
    };
    let share = |m: &serde_json::Value, id: u64| {
        m["objects"]
            .as_array()
            .unwrap()
            .iter()
            .find(|o| o["id"] == id)
            .unwrap()["background_in_front"]
            .as_f64()
            .unwrap()
    };
    let m = evaluate(&scene_dir, "same");
    assert_eq!(m["background_in_front"].as_f64(), Some(0.0));
    for id in [3, 4, 5] {
        assert_eq!(share(&m, id), 0.0, "object {id}");
    }

    // The wall (at y = 3) moved to y = 0.1: 0.1 m behind the chair and the cup (y = 0),
    // 0.4 m in front of the lamp (y = 0.5), beyond the 5 cm tolerance either way.
    let moved = common::edited(
        &scene_dir,
        "[Move(target: Name(\"background\"), by: (0, -2.9, 0))]",
        &tmp.path().join("e"),
    )
    .unwrap();
    let m = evaluate(&moved, "moved");
    assert_eq!(share(&m, 3), 0.0);
    assert_eq!(share(&m, 5), 0.0);
    assert_eq!(share(&m, 4), 1.0);
    // The scene's share: the lamp's pixels over every object's.
    let pixels = |label_id: i32| {
        let raster = objectsplat_masks::raster::rasterize(
            &gt.positions,
            &gt.faces,
            &cam,
            &objectsplat_masks::raster::RasterOptions::default(),
        )
        .unwrap();
        let ids = gt.object_ids.as_ref().unwrap();
        (0..64u32)
            .flat_map(|y| (0..64u32).map(move |x| (x, y)))
            .filter(|&(x, y)| {
                raster
                    .face_at(x, y)
                    .is_some_and(|f| ids[gt.faces[f as usize][0] as usize] == label_id)
            })
            .count() as f64
    };
    let expected = pixels(4) / (pixels(3) + pixels(4) + pixels(5));
    let scene_share = m["background_in_front"].as_f64().unwrap();
    assert!(
        (scene_share - expected).abs() < 1e-12,
        "{scene_share} vs {expected}"
    );
}
