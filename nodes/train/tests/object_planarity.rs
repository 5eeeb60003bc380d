//! The planarity prior reaches an object only at `object_depth_smoothness_weight`
//! (off by default), on the host and on the device alike.

mod common;

use objectsplat_raster::{CpuBackend, RenderBackend};
use objectsplat_train::trainer::train_component;

fn planarity_note(backend: &dyn RenderBackend<f32>, weight: Option<f64>) -> Option<String> {
    let (_dir, data, points) = common::plate();
    let mut extra = serde_json::json!({ "depth_smoothness_start": 0 });
    if let Some(w) = weight {
        extra["object_depth_smoothness_weight"] = w.into();
    }
    let settings = common::short_run_settings(60, 1, extra);
    let report = train_component(backend, &data, &points, &settings, |_, _| true).unwrap();
    report.model.validate().unwrap();
    report
        .notes
        .iter()
        .find(|n| n.starts_with("planarity prior"))
        .cloned()
}

#[test]
fn objects_carry_the_planarity_prior_only_at_their_own_weight() {
    let cpu = CpuBackend::new(2);
    assert_eq!(planarity_note(&cpu, None), None);
    assert_eq!(
        planarity_note(&cpu, Some(0.5)).as_deref(),
        Some("planarity prior on the rendered depth, weight 0.5")
    );
    if let Some(gpu) = common::wgpu_backend() {
        assert_eq!(
            planarity_note(&gpu, Some(0.5)).as_deref(),
            Some("planarity prior on the rendered depth, weight 0.5")
        );
    }
}
