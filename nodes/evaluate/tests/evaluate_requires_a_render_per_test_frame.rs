//! `evaluate` refuses to score a run with a test frame that has no render, naming it,
//! and reports the mesh F-score as null when no ground-truth mesh is wired.

#[path = "../../scene/tests/common/mod.rs"]
mod common;

use objectsplat_core::Split;
use objectsplat_core::artifact::METRICS_JSON;
use objectsplat_evaluate::Evaluate;

#[test]
fn a_missing_render_is_an_error_and_no_mesh_means_no_fscore() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = common::composed_scene(tmp.path());
    let cam = common::front_camera(24, 24);
    let frames =
        common::write_frames_from(tmp.path(), cam, &[("a", Split::Test), ("b", Split::Test)]);
    let renders = common::rendered(&scene, &frames, &tmp.path().join("r"));
    let inputs = [
        ("images", &*renders),
        ("frames", &frames),
        ("scene", &scene),
    ];

    let run = common::run(&Evaluate, &inputs, "()", &tmp.path().join("e1"));
    let m = common::read_json(&run.outputs["metrics"].join(METRICS_JSON));
    assert!(m["fscore"].is_null() && m["psnr"].is_number());
    assert_eq!(m["images"].as_array().unwrap().len(), 2);

    std::fs::remove_file(renders.join("b.png")).unwrap();
    let err = common::run_error(&Evaluate, &inputs, "()", &tmp.path().join("e2"));
    assert!(
        err.contains("b.png") && err.contains("no render for test frame \"b\""),
        "{err}"
    );
}
