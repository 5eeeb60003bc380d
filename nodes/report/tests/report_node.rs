//! The `report` dataflow node, run through the runtime's `run_node` on artifact folders in
//! their documented encodings (Metrics, Frames, Images).

mod common;

use common::synthetic_report::{ground_truth_image, render_image};
use objectsplat_core::artifact::{METRICS_JSON, PAGE_HTML};
use objectsplat_core::frames::Split;
use objectsplat_core::{Camera, Frame, Frames};
use objectsplat_report::node::ReportNode;
use std::path::{Path, PathBuf};

/// Writes the metrics, frames and renders folders under `root`; returns them in that order.
fn write_inputs(root: &Path) -> [PathBuf; 3] {
    let metrics = root.join("metrics");
    std::fs::create_dir_all(&metrics).unwrap();
    std::fs::write(
        metrics.join(METRICS_JSON),
        r#"{"psnr": 23.5, "ssim": 0.75, "lpips": null, "fscore": 0.5, "precision": 0.6, "recall": 0.4, "tau": 0.05,
            "objects": [{"object_id": 4, "label": "sofa", "psnr": 25.0, "ssim": 0.8, "lpips": null,
                         "fscore": 0.7, "precision": 0.7, "recall": 0.7, "tau": 0.05}]}"#,
    )
    .unwrap();
    let frames_dir = root.join("frames");
    let renders = root.join("renders");
    std::fs::create_dir_all(&frames_dir).unwrap();
    std::fs::create_dir_all(&renders).unwrap();
    let camera = Camera::from_view(
        64,
        48,
        50.0,
        50.0,
        32.0,
        24.0,
        objectsplat_core::glam::DMat4::IDENTITY,
    );
    let mut frames = Vec::new();
    for k in 0..6u32 {
        let name = format!("DSC{k:02}.JPG");
        let image = format!("DSC{k:02}.png");
        ground_truth_image(k)
            .save_png8(&frames_dir.join(&image))
            .unwrap();
        // Frames 0 and 3 are training views; 5 is a test view without a render.
        let split = if k % 3 == 0 {
            Split::Train
        } else {
            Split::Test
        };
        frames.push(Frame::new(name, image, &camera, split));
        if k != 5 {
            render_image(k)
                .save_png8(&renders.join(format!("DSC{k:02}.png")))
                .unwrap();
        }
    }
    Frames::write_json(&frames_dir, &frames).unwrap();
    [metrics, frames_dir, renders]
}

#[test]
fn report_node_writes_metrics_and_the_rendered_test_views() {
    let dir = tempfile::tempdir().unwrap();
    let [m, f, r] = write_inputs(dir.path());
    let (run, html) = common::run_report(
        &[("metrics", &m), ("frames", &f), ("renders", &r)],
        r#"(title: "room 7", max_views: 2)"#,
        &dir.path().join("out"),
    );
    assert!(html.contains("<title>room 7</title>"));
    assert!(html.contains("<td class=\"num\">23.5000</td>") && html.contains("obj_4_sofa"));
    // Test frames with renders are 1, 2, 4; two spread evenly are 1 and 2 (indices 0 and 1 of 3).
    assert!(html.contains("data-view=\"DSC01.JPG\"") && html.contains("data-view=\"DSC02.JPG\""));
    assert!(
        !html.contains("DSC00.JPG") && !html.contains("DSC05.JPG"),
        "train frames and unrendered views are left out"
    );
    assert_eq!(html.matches("src=\"data:image/png;base64,").count(), 6);
    assert_eq!(run.notes, vec![("views".to_string(), "2".to_string())]);
}

#[test]
fn report_node_without_views_still_reports_metrics() {
    let dir = tempfile::tempdir().unwrap();
    let [m, _, _] = write_inputs(dir.path());
    let (_, html) = common::run_report(&[("metrics", &m)], "()", &dir.path().join("out"));
    assert!(html.contains("<title>ObjectSplat run</title>") && html.contains("No test views."));
}

#[test]
fn report_node_output_is_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    let [m, f, r] = write_inputs(dir.path());
    let inputs: [(&str, &Path); 3] = [("metrics", &m), ("frames", &f), ("renders", &r)];
    let a = common::node_result(&ReportNode, &inputs, "()", &dir.path().join("a")).unwrap();
    let b = common::node_result(&ReportNode, &inputs, "()", &dir.path().join("b")).unwrap();
    assert_eq!(
        std::fs::read(a.outputs["file"].join(PAGE_HTML)).unwrap(),
        std::fs::read(b.outputs["file"].join(PAGE_HTML)).unwrap()
    );
}

#[test]
fn unreadable_metrics_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let m = dir.path().join("metrics");
    std::fs::create_dir_all(&m).unwrap();
    std::fs::write(m.join(METRICS_JSON), "{not json").unwrap();
    let e = common::report_error(&[("metrics", &m)], &dir.path().join("out"), "must fail");
    common::assert_mentions(&e, &[METRICS_JSON, "not a valid metrics file"]);
}

#[test]
fn registers_the_report_kind() {
    let mut reg = objectsplat_runtime::Registry::new();
    for (name, doc) in [
        ("Metrics", "m"),
        ("Frames", "f"),
        ("Images", "i"),
        ("File", "f"),
        ("Model", "m"),
    ] {
        reg.add_type(name, doc);
    }
    objectsplat_report::register(&mut reg);
    assert!(reg.get("report").is_some());
}
