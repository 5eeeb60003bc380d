//! Training a component improves its held-out score and yields a valid model.

mod common;

use objectsplat_raster::CpuBackend;
use objectsplat_train::Schedule;
use objectsplat_train::init::{ComponentMasks, InitSettings, init_model};
use objectsplat_train::trainer::{ComponentData, TrainSettings, held_out_score, train_component};

#[test]
fn training_the_plate_lowers_its_held_out_loss() {
    let dir = tempfile::tempdir().unwrap();
    common::write_component(dir.path());
    let masks = ComponentMasks::read(dir.path()).unwrap();
    let points = masks.component_points(&common::points()).unwrap();
    assert_eq!(
        points.positions.len(),
        25,
        "the grey points off the plate are not selected"
    );
    let data = ComponentData::read(dir.path()).unwrap();
    let settings = TrainSettings {
        // Reference learning rates are tuned for 30k steps; a 200-step test needs larger
        // ones, and densification limited to what 64×48 views can resolve.
        schedule: Schedule::new(
            200,
            serde_json::json!({
                "lr_sh_dc": 0.03,
                "lr_opacity": 0.1,
                "lr_vertices_start": 4e-3,
                "lr_vertices_end": 4e-4,
                "densify_until": 30,
                "densify_always_largest": 0,
            })
            .as_object()
            .unwrap(),
        )
        .unwrap(),
        seed: 2,
        background_randomization: true,
        fixed_background: [0.0; 3],
        init: InitSettings::default(),
        world_scale: 1.0,
        checkpoint: Default::default(),
    };
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
