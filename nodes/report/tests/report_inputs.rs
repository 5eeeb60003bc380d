//! Report inputs: the run's own JSON files deserialise into `ReportData`, and inconsistent
//! input is an error that names the problem (never a panic or a half-drawn page).

mod common;

use objectsplat_report::*;

#[test]
fn run_report_and_metrics_json_deserialise() {
    let run: RunSummary = serde_json::from_str(
        r#"{"nodes": [
            {"id": "scene", "kind": "scannetpp", "status": "cached", "seconds": 0.0, "reason": null, "items": []},
            {"id": "train", "kind": "train", "status": "ran", "seconds": 12.5, "reason": null,
             "items": [{"name": "obj_3_chair", "status": "ran", "seconds": 12.0}]},
            {"id": "complete", "kind": "complete_surfaces", "status": "skipped", "seconds": 0.0, "reason": "no holes"}
        ], "edges": [{"from": "scene", "to": "train"}]}"#,
    )
    .unwrap();
    assert_eq!(run.nodes[1].items[0].seconds, 12.0);
    assert_eq!(run.nodes[2].status, NodeStatus::Skipped);
    assert_eq!(run.nodes[2].reason.as_deref(), Some("no holes"));

    let metrics: MetricsReport = serde_json::from_str(
        r#"{"psnr": 24.1, "ssim": 0.8, "lpips": null, "fscore": 0.6, "precision": 0.7, "recall": 0.5, "tau": 0.05,
            "objects": [{"object_id": 3, "label": "desk lamp", "psnr": 26.0, "ssim": 0.9, "lpips": null,
                         "fscore": 0.7, "precision": 0.8, "recall": 0.6, "tau": 0.05, "extra": 1}]}"#,
    )
    .unwrap();
    assert_eq!(metrics.scene.psnr, Some(24.1));
    assert_eq!(metrics.scene.lpips, None);
    assert_eq!(
        (metrics.objects[0].id, &*metrics.objects[0].label),
        (3, "desk lamp")
    );
    assert_eq!(metrics.objects[0].metrics.recall, Some(0.6));
}

#[test]
fn report_data_roundtrips_through_json() {
    let dir = tempfile::tempdir().unwrap();
    let mut data = common::synthetic_report::report_data(dir.path());
    // serde_json's default float parser may be 1 ulp off, so use dyadic values that print
    // and parse exactly.
    let dyadic = |v: f64| (v * 1024.0).round() / 1024.0;
    for log in data.training.iter_mut().filter_map(|t| t.log.as_mut()) {
        for s in &mut log.steps {
            s.loss = dyadic(s.loss);
        }
        for e in &mut log.evals {
            e.loss = dyadic(e.loss);
        }
    }
    let text = serde_json::to_string(&data).unwrap();
    assert_eq!(serde_json::from_str::<ReportData>(&text).unwrap(), data);
}

/// The error rendering the synthetic report gives after `spoil` changes its data (given
/// the folder the data's images are in).
fn error_of(spoil: impl FnOnce(&mut ReportData, &std::path::Path)) -> String {
    let dir = tempfile::tempdir().unwrap();
    let mut data = common::synthetic_report::report_data(dir.path());
    spoil(&mut data, dir.path());
    let out = tempfile::tempdir().unwrap();
    format!(
        "{:#}",
        render_report(out.path(), &data).expect_err("must be rejected")
    )
}

/// The error for the synthetic report with an extra edge `from` → `to`.
fn error_with_edge(from: &str, to: &str) -> String {
    error_of(|data, _| {
        data.run.edges.push(GraphEdge {
            from: from.into(),
            to: to.into(),
        })
    })
}

#[test]
fn cyclic_graph_is_rejected() {
    let e = error_with_edge("train", "decompose");
    common::assert_mentions(&e, &["cycle", "train", "decompose"]);
}

#[test]
fn edge_to_an_unknown_node_is_rejected() {
    let e = error_with_edge("train", "ghost");
    common::assert_mentions(&e, &["train → ghost", "not in the run report"]);
}

#[test]
fn mismatched_view_sizes_name_both_files() {
    let e = error_of(|data, dir| {
        let small = dir.join("small.png");
        objectsplat_core::Image::new(10, 10, 3)
            .save_png8(&small)
            .unwrap();
        data.views[1].render = small;
    });
    common::assert_mentions(&e, &["DSC01", "small.png is 10×10", "gt_1.png is 64×48"]);
}

#[test]
fn missing_view_image_names_the_file() {
    let e = error_of(|data, dir| data.views[0].ground_truth = dir.join("nowhere.png"));
    assert!(e.contains("nowhere.png"), "{e}");
}

#[test]
fn invalid_node_seconds_are_rejected() {
    let e = error_of(|data, _| data.run.nodes[0].seconds = f64::NAN);
    assert!(e.contains("node scene has invalid seconds NaN"), "{e}");
}

#[test]
fn an_empty_run_still_renders() {
    let dir = tempfile::tempdir().unwrap();
    let data = ReportData {
        title: "empty".into(),
        ..Default::default()
    };
    let path = render_report(dir.path(), &data).unwrap();
    let html = std::fs::read_to_string(path).unwrap();
    assert!(
        html.contains("<p class=\"placeholder\">The run summary"),
        "no run summary: the Run section is the placeholder"
    );
    assert!(html.contains("This run did not evaluate"));
    assert!(html.contains("No trained models were given to the report."));
    assert!(!html.contains("<svg"), "no data, no plots");
}
