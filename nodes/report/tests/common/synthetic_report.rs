//! A synthetic run for report tests: a pipeline graph with every status, metrics, two test
//! views written as PNGs, the training logs of tests/fixtures/models and run-time points.

use objectsplat_core::Image;
use objectsplat_core::TRAINING_TIMES;
use objectsplat_report::*;
use std::path::{Path, PathBuf};

/// Model folders with hand-written `training.json` files (obj_3_chair stops early at 400 of
/// 600 iterations with its best checkpoint at 300; background runs its whole budget).
pub fn fixture_models() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/models")
}

/// The fixture logs plus a model without a log, as the report node would read them.
pub fn fixture_training() -> Vec<ModelTraining> {
    let load = |name: &str| ModelTraining {
        model: name.into(),
        log: Some(
            TrainingLog::load(&fixture_models().join(name))
                .unwrap()
                .expect("the fixture has a training.json"),
        ),
    };
    vec![
        load("obj_3_chair"),
        load("background"),
        ModelTraining {
            model: "obj_5_lamp".into(),
            log: None,
        },
    ]
}

/// Test views are 64×48; the render is the ground truth plus 0.2 in a 16×16 block at (8, 8).
pub const VIEW_W: u32 = 64;
pub const VIEW_H: u32 = 48;

pub fn ground_truth_image(seed: u32) -> Image {
    Image::from_fn(VIEW_W, VIEW_H, 3, |x, y, c| {
        ((x * 4 + y * 3 + c * 40 + seed * 17) % 200) as f32 / 255.0
    })
}

pub fn render_image(seed: u32) -> Image {
    let gt = ground_truth_image(seed);
    Image::from_fn(VIEW_W, VIEW_H, 3, |x, y, c| {
        let inside = (8..24).contains(&x) && (8..24).contains(&y);
        gt.get(x, y, c) + if inside { 51.0 / 255.0 } else { 0.0 }
    })
}

/// When the fixture logs' runs reached their steps and evaluations (iterations, seconds,
/// steps, evals), as the `train` node measures them: the chair stopped early at 400.
pub const CHAIR_TIMES: &str = r#"{"iterations": 400, "seconds": 4.75,
    "steps": [[100, 1.0], [200, 2.0], [300, 3.0], [400, 4.0]],
    "evals": [[100, 1.25], [200, 2.25], [300, 3.25], [400, 4.25]]}"#;
pub const BACKGROUND_TIMES: &str = r#"{"iterations": 600, "seconds": 7.0,
    "steps": [[200, 2.0], [400, 4.0], [600, 6.0]], "evals": [[300, 3.5], [600, 6.5]]}"#;

/// An item's measurements holding `times` (JSON) as its training times.
fn training_times(times: &str) -> serde_json::Map<String, serde_json::Value> {
    let mut m = serde_json::Map::new();
    m.insert(TRAINING_TIMES.into(), serde_json::from_str(times).unwrap());
    m
}

fn node(id: &str, kind: &str, status: NodeStatus, seconds: f64) -> NodeRun {
    NodeRun {
        id: id.into(),
        kind: kind.into(),
        status,
        seconds,
        queued_seconds: 0.0,
        reason: None,
        items: Vec::new(),
    }
}

fn skipped(id: &str, kind: &str, seconds: f64, reason: &str) -> NodeRun {
    NodeRun {
        reason: Some(reason.into()),
        ..node(id, kind, NodeStatus::Skipped, seconds)
    }
}

fn failed(id: &str, kind: &str, seconds: f64, reason: &str) -> NodeRun {
    NodeRun {
        reason: Some(reason.into()),
        ..node(id, kind, NodeStatus::Failed, seconds)
    }
}

fn edge(from: &str, to: &str) -> GraphEdge {
    GraphEdge {
        from: from.into(),
        to: to.into(),
    }
}

pub fn report_data(dir: &Path) -> ReportData {
    let mut views = Vec::new();
    for seed in 0..2 {
        let gt = dir.join(format!("gt_{seed}.png"));
        let render = dir.join(format!("render_{seed}.png"));
        ground_truth_image(seed).save_png8(&gt).unwrap();
        render_image(seed).save_png8(&render).unwrap();
        views.push(ViewTriplet {
            name: format!("DSC0{seed}"),
            ground_truth: gt,
            render,
        });
    }
    let mut train = node("train", "train", NodeStatus::Ran, 120.5);
    train.items = vec![
        ItemRun {
            name: "obj_3_chair".into(),
            status: NodeStatus::Ran,
            seconds: 60.0,
            measurements: training_times(CHAIR_TIMES),
        },
        ItemRun {
            name: "background".into(),
            status: NodeStatus::Cached,
            seconds: 0.0,
            measurements: training_times(BACKGROUND_TIMES),
        },
    ];
    ReportData {
        title: "Synthetic run <0a5c013435>".into(),
        run: RunSummary {
            nodes: vec![
                node("scene", "scannetpp", NodeStatus::Cached, 0.0),
                node("masks", "masks_from_mesh", NodeStatus::Cached, 0.0),
                node("decompose", "decompose", NodeStatus::Ran, 2.25),
                skipped(
                    "complete",
                    "complete_surfaces",
                    0.01,
                    "no planar support surface",
                ),
                train,
                node("compose", "compose", NodeStatus::Ran, 0.5),
                node("export", "export_gltf", NodeStatus::Ran, 0.2),
                failed("evaluate", "evaluate", 3.0, "LPIPS weights missing"),
                node("report", "report", NodeStatus::Ran, 0.1),
            ],
            graph: Some("graphs/synthetic.ron".into()),
            seconds: Some(100.25),
            edges: vec![
                edge("scene", "masks"),
                edge("scene", "decompose"),
                edge("masks", "decompose"),
                edge("decompose", "complete"),
                edge("complete", "train"),
                edge("train", "compose"),
                edge("compose", "export"),
                edge("compose", "evaluate"),
                edge("scene", "evaluate"),
                edge("evaluate", "report"),
            ],
        },
        metrics: Some(MetricsReport {
            scene: ScopeMetrics {
                psnr: Some(24.3125),
                ssim: Some(0.8123),
                lpips: None,
                fscore: Some(0.6543),
                precision: Some(0.7),
                recall: Some(0.61),
                tau: Some(0.05),
                ..Default::default()
            },
            objects: vec![ObjectMetrics {
                id: 3,
                label: "chair".into(),
                metrics: ScopeMetrics {
                    psnr: Some(27.5),
                    fscore: Some(0.81),
                    ..Default::default()
                },
                ..Default::default()
            }],
            ..Default::default()
        }),
        views,
        error_scale: 0.0,
        viewer: None,
        training: fixture_training(),
        runtime_vs_error: vec![
            RuntimePoint {
                series: "cpu".into(),
                label: "5k it".into(),
                seconds: 30.0,
                psnr: 21.0,
            },
            RuntimePoint {
                series: "cpu".into(),
                label: "30k it".into(),
                seconds: 180.0,
                psnr: 24.3,
            },
            RuntimePoint {
                series: "wgpu".into(),
                label: "30k it".into(),
                seconds: 40.0,
                psnr: 24.2,
            },
        ],
    }
}
