//! Training a component improves its held-out score and yields a valid model.

mod common;

use objectsplat_raster::CpuBackend;
use objectsplat_train::init::{InitSettings, init_model};
use objectsplat_train::trainer::{ComponentData, held_out_score, train_component};

#[test]
fn training_the_plate_lowers_its_held_out_loss() {
    let dir = tempfile::tempdir().unwrap();
    common::write_component(dir.path());
    let data = ComponentData::read(dir.path(), 2).unwrap();
    let points = data.component_points(&common::points(), None).unwrap();
    assert_eq!(
        points.positions.len(),
        25,
        "the grey points off the plate are not selected"
    );
    let settings = common::short_run_settings(200, 2, serde_json::json!({}));
    let backend = CpuBackend::new(2);
    let initial = init_model(
        &points,
        &InitSettings {
            seed: 2,
            ..Default::default()
        },
    )
    .unwrap();
    let before = held_out_score(&backend, &initial, &data, &settings).unwrap();
    let mut calls = 0;
    let report = train_component(&backend, &data, &points, &settings, |_, _| {
        calls += 1;
        true
    })
    .unwrap();
    report.model.validate().unwrap();
    assert_eq!(calls as u64, report.iterations_run);
    assert!(report.model.face_count() > 0, "{:?}", report.notes);
    assert!(
        report.best_score < 0.5 * before,
        "held-out loss {before} → {} ({:?})",
        report.best_score,
        report.notes
    );
    assert!(
        report
            .notes
            .iter()
            .any(|n| n.starts_with("connectivity step")),
        "{:?}",
        report.notes
    );
    // Interrupting is an error, not a silent partial model.
    let err = train_component(&backend, &data, &points, &settings, |done, _| done < 5)
        .err()
        .unwrap();
    assert!(format!("{err}").contains("interrupted"));
}
