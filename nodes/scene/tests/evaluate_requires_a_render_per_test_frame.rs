//! `evaluate` refuses to score a run with a test frame that has no render, naming it,
//! and reports the mesh F-score as null when no ground-truth mesh is wired.

mod common;

use objectsplat_core::Split;
use objectsplat_core::artifact::METRICS_JSON;
use objectsplat_runtime::testing::run_node;
use objectsplat_scene::nodes::{Evaluate, Render};

#[test]
fn a_missing_render_is_an_error_and_no_mesh_means_no_fscore() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = common::composed_scene(tmp.path());
    let cam = common::front_camera(24, 24);
    let frames = tmp.path().join("frames");
    common::write_frames(
        &frames,
        &[
            ("a".into(), cam, Split::Test),
            ("b".into(), cam, Split::Test),
        ],
    );
    let renders = run_node(
        &Render,
        &[("scene", &scene), ("frames", &frames)],
        "()",
        &tmp.path().join("r"),
        None,
    )
    .unwrap()
    .outputs["images"]
        .clone();

    let run = run_node(
        &Evaluate,
        &[("images", &renders), ("frames", &frames), ("scene", &scene)],
        "()",
        &tmp.path().join("e1"),
        None,
    )
    .unwrap();
    let text = std::fs::read_to_string(run.outputs["metrics"].join(METRICS_JSON)).unwrap();
    let m: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert!(m["fscore"].is_null() && m["psnr"].is_number());
    assert_eq!(m["images"].as_array().unwrap().len(), 2);

    std::fs::remove_file(renders.join("b.png")).unwrap();
    let err = run_node(
        &Evaluate,
        &[("images", &renders), ("frames", &frames), ("scene", &scene)],
        "()",
        &tmp.path().join("e2"),
        None,
    )
    .err()
    .unwrap();
    let err = format!("{err:#}");
    assert!(
        err.contains("b.png") && err.contains("no render for test frame \"b\""),
        "{err}"
    );
}
