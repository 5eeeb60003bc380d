//! The normal-agreement prior in a training run: off by default, on at its
//! object weight it leaves a flat plate's connected mesh flatter than the
//! same run without it, and a device run asks for the host instead of
//! silently dropping it.

mod common;

use objectsplat_raster::{CpuBackend, Model, RenderBackend};
use objectsplat_train::normal_agreement::add_gradient;
use objectsplat_train::trainer::{TrainReport, train_component};

fn run(backend: &dyn RenderBackend<f32>, weight: Option<f64>) -> anyhow::Result<TrainReport> {
    let (_dir, data, points) = common::plate();
    let mut extra = serde_json::json!({});
    if let Some(w) = weight {
        extra["object_normal_agreement_weight"] = w.into();
    }
    let settings = common::short_run_settings(60, 1, extra);
    train_component(backend, &data, &points, &settings, |_, _| true)
}

/// Mean `1 − (n₁·n₂)²` over the model's pairs of faces sharing an edge.
fn mean_bend(model: &Model<f32>) -> f64 {
    let mut scratch = vec![[0.0f32; 3]; model.vertices.len()];
    add_gradient(&model.vertices, &model.faces, 1.0, &mut scratch)
}

fn note(report: &TrainReport) -> Option<&str> {
    report
        .notes
        .iter()
        .find(|n| n.starts_with("normal agreement"))
        .map(String::as_str)
}

#[test]
fn a_plate_trained_with_the_prior_is_flatter_than_without() {
    let cpu = CpuBackend::new(2);
    let without = run(&cpu, None).unwrap();
    let with = run(&cpu, Some(0.05)).unwrap();
    without.model.validate().unwrap();
    with.model.validate().unwrap();
    assert_eq!(note(&without), None);
    assert_eq!(
        note(&with),
        Some("normal agreement of faces sharing an edge, weight 0.05")
    );
    let (flat, rough) = (mean_bend(&with.model), mean_bend(&without.model));
    assert!(
        rough > 0.0 && flat < 0.8 * rough,
        "mean 1 − cos² over shared edges: {flat} with the prior, {rough} without"
    );
}

#[test]
fn a_device_run_with_the_prior_asks_for_the_host() {
    let Some(gpu) = common::wgpu_backend() else {
        return;
    };
    let err = match run(&gpu, Some(0.05)) {
        Ok(_) => panic!("a device run with the prior trained without it"),
        Err(err) => format!("{err:#}"),
    };
    assert!(err.contains("runs on the host only"), "{err}");
}
