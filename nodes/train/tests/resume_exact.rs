//! A run interrupted after saving its state resumes from it and ends with
//! exactly the model an uninterrupted run gives (same seed, same bytes).

mod common;

use objectsplat_raster::CpuBackend;
use objectsplat_train::trainer::{TrainSettings, train_component};

#[test]
fn an_interrupted_run_resumes_to_the_same_model() {
    let (_dir, data, points) = common::plate();
    let backend = CpuBackend::new(2);
    let base = common::short_run_settings(200, 4, serde_json::json!({}));
    let whole = train_component(&backend, &data, &points, &base, |_, _| true).unwrap();

    let state = tempfile::tempdir().unwrap();
    let saving = TrainSettings {
        resume_dir: Some(state.path().to_path_buf()),
        save_seconds: 0.0,
        ..base.clone()
    };
    // Interrupted after the connectivity step (iteration 74 at this budget) and a save.
    let err = train_component(&backend, &data, &points, &saving, |done, _| done < 131)
        .err()
        .expect("interrupted");
    assert!(format!("{err}").contains("interrupted"), "{err}");
    assert!(state.path().join("state/progress.json").is_file());
    let mut first = None;
    let resumed = train_component(&backend, &data, &points, &saving, |done, _| {
        first.get_or_insert(done);
        true
    })
    .unwrap();
    assert!(
        first.unwrap() > 100,
        "the resumed run continued from its save, not from 0 (first callback at {first:?})"
    );
    assert!(
        resumed
            .notes
            .iter()
            .any(|n| n.starts_with("resumed at iteration"))
    );
    assert_eq!(resumed.model.faces, whole.model.faces);
    assert_eq!(
        common::parameter_bits(&resumed.model),
        common::parameter_bits(&whole.model)
    );
    assert_eq!(resumed.best_iteration, whole.best_iteration);
    // A state of another run (other seed) is not used.
    let other = TrainSettings {
        seed: 5,
        ..saving.clone()
    };
    let fresh = train_component(&backend, &data, &points, &other, |_, _| true).unwrap();
    assert!(!fresh.notes.iter().any(|n| n.starts_with("resumed")));
}
