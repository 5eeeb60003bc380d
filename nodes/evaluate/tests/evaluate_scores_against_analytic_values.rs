//! `evaluate` against analytic answers: a ground truth that differs from the render by a
//! known amount inside one object's mask gives known scene and per-object PSNRs; the
//! scene's own surface as ground-truth mesh scores F = 1, and an object moved far beyond
//! τ scores F = 0 while the others stay at 1 (also at the extra per-object thresholds);
//! LPIPS is reported as skipped.

#[path = "../../scene/tests/common/mod.rs"]
mod common;

use objectsplat_core::artifact::{METRICS_CSV, METRICS_JSON};
use objectsplat_core::masks::{IdMap, write_objects};
use objectsplat_core::{ObjectLabels, Split, write_mesh_artifact};
use objectsplat_evaluate::Evaluate;
use objectsplat_scene::load_scene;

const W: u32 = 48;
const H: u32 = 40;
/// The offset added to the ground truth inside the chair's mask: exactly 20/255.
const OFFSET: u8 = 20;

#[test]
fn psnr_and_fscore_match_their_analytic_values() {
    let tmp = tempfile::tempdir().unwrap();
    let scene_dir = common::composed_scene(tmp.path());
    let cam = common::front_camera(W, H);
    let frames = common::write_frames_from(
        tmp.path(),
        cam,
        &[("t0", Split::Test), ("t1", Split::Train)],
    );
    let renders = common::rendered(&scene_dir, &frames, &tmp.path().join("r"));

    // Ground truth = the render, plus OFFSET/255 in a rectangle labelled as the chair (id 3);
    // id 5 labels a rectangle where nothing differs.
    let rendered = image::open(renders.join("t0.png")).unwrap().to_rgb8();
    let mut truth = rendered.clone();
    let mut ids = IdMap::new(W, H);
    let (x0, x1, y0, y1) = (5u32, 17u32, 8u32, 20u32);
    for y in y0..y1 {
        for x in x0..x1 {
            ids.data[(y * W + x) as usize] = 3;
            for c in truth.get_pixel_mut(x, y).0.iter_mut() {
                *c = c
                    .checked_add(OFFSET)
                    .expect("no saturation in the test image");
            }
        }
    }
    for y in 25..35 {
        for x in 30..40 {
            ids.data[(y * W + x) as usize] = 5;
        }
    }
    truth.save(frames.join("images/t0.png")).unwrap();
    let masks = tmp.path().join("masks");
    std::fs::create_dir_all(&masks).unwrap();
    ids.save(&masks.join("t0.png")).unwrap();
    let labels: ObjectLabels = [
        (3, "chair".to_string()),
        (4, "lamp".into()),
        (5, "cup".into()),
    ]
    .into();
    write_objects(&masks, &labels).unwrap();

    // Ground-truth mesh: the composed scene's own surface with object ids, then the cup
    // moved 2 m away in the prediction.
    let scene = load_scene(&scene_dir).unwrap();
    let gt = common::surfaces_as_ground_truth(&scene, -1);
    let mesh_dir = tmp.path().join("mesh");
    write_mesh_artifact(&mesh_dir, &gt, &labels).unwrap();
    let moved = common::edited(
        &scene_dir,
        "[Move(target: Id(5), by: (0, 2, 0))]",
        &tmp.path().join("e"),
    )
    .unwrap();

    let run = common::run(
        &Evaluate,
        &[
            ("images", &renders),
            ("frames", &frames),
            ("scene", &moved),
            ("mesh", &mesh_dir),
            ("masks", &masks),
        ],
        "(samples: 1000.0, tau: 0.25, object_taus: [0.5, 0.25])",
        &tmp.path().join("eval"),
    );
    let dir = &run.outputs["metrics"];
    let m = common::read_json(&dir.join(METRICS_JSON));
    assert!(dir.join(METRICS_CSV).is_file());

    let d = OFFSET as f64 / 255.0;
    let region = ((x1 - x0) * (y1 - y0)) as f64;
    let scene_psnr = 10.0 * ((W * H) as f64 / (region * d * d)).log10();
    let chair_psnr = -20.0 * d.log10();
    let f = |v: &serde_json::Value| v.as_f64().unwrap();
    assert!(
        (f(&m["psnr"]) - scene_psnr).abs() < 1e-4,
        "{} vs {scene_psnr}",
        m["psnr"]
    );
    assert_eq!(
        m["images"].as_array().unwrap().len(),
        1,
        "only the test frame is scored"
    );
    let object = |id: u64| {
        m["objects"]
            .as_array()
            .unwrap()
            .iter()
            .find(|o| o["id"] == id)
            .unwrap()
            .clone()
    };
    assert!(
        (f(&object(3)["psnr"]) - chair_psnr).abs() < 1e-4,
        "{}",
        object(3)["psnr"]
    );
    assert!(
        object(5)["psnr"].is_null(),
        "identical pixels: infinite PSNR is written as null"
    );
    assert!(m["lpips"].is_null());
    assert!(m["lpips_status"].as_str().unwrap().starts_with("skipped"));

    // Mesh: everything but the moved cup coincides with the ground truth.
    assert!((f(&object(3)["fscore"]) - 1.0).abs() < 1e-12);
    assert!((f(&object(4)["fscore"]) - 1.0).abs() < 1e-12);
    assert_eq!(f(&object(5)["fscore"]), 0.0);
    // Per object also at the extra thresholds (above the samples' spacing): the same verdicts.
    for (id, expected) in [(3, 1.0), (4, 1.0), (5, 0.0)] {
        let at = object(id)["thresholds"].as_array().unwrap().clone();
        let taus: Vec<f64> = at.iter().map(|t| f(&t["tau"])).collect();
        assert_eq!(taus, [0.5, 0.25], "object {id}");
        for t in &at {
            assert_eq!(f(&t["precision"]), expected, "object {id} at {}", t["tau"]);
            assert_eq!(f(&t["recall"]), expected, "object {id} at {}", t["tau"]);
        }
    }
    let scene_f = f(&m["fscore"]);
    assert!(
        scene_f > 0.5 && scene_f < 1.0,
        "the scene loses only the cup: {scene_f}"
    );
}
