//! A run that returns a model from before the end of its budget (an early
//! stop, or a best checkpoint before the last iteration) finishes it first:
//! what comes back is opaque and hard-edged — σ and opacity floor at the
//! schedule's end — like every exported model, with its flat colours baked,
//! and a run interrupted inside the finish resumes to the same model. At the
//! budget's end the last state, finished by the schedule itself, competes with
//! the finished best.

mod common;

use objectsplat_core::Points;
use objectsplat_raster::CpuBackend;
use objectsplat_train::trainer::{
    Checkpoint, ComponentData, TrainReport, TrainSettings, train_component,
};

/// The loop iteration the finish started at, read from the run's notes.
fn finish_start(report: &TrainReport) -> Option<u64> {
    let note = report
        .notes
        .iter()
        .find(|n| n.starts_with("finished the model of iteration"))?;
    let over = note.split("over iterations ").nth(1)?;
    let first: u64 = over.split('–').next()?.parse().ok()?;
    Some(first - 1)
}

fn assert_finished(report: &TrainReport, settings: &TrainSettings) {
    let s = &settings.schedule;
    let model = &report.model;
    assert_eq!(model.sigma, s.sigma_end);
    assert_eq!(model.opacity_floor, s.floor_end());
    // Baked for a flat-coloured export: a colour for every vertex.
    assert_eq!(model.flat_dc.len(), model.vertex_count());
    for f in 0..model.face_count() {
        assert!(
            model.face_opacity(f) as f64 >= s.floor_end() - 1e-6,
            "face {f} has opacity {}",
            model.face_opacity(f)
        );
    }
}

/// The run of `settings` interrupted when `stop_at` iterations are done (saving
/// at every log point), then resumed.
fn interrupted_and_resumed(
    data: &ComponentData,
    points: &Points,
    settings: &TrainSettings,
    stop_at: u64,
) -> TrainReport {
    let backend = CpuBackend::new(2);
    let state = tempfile::tempdir().unwrap();
    let saving = TrainSettings {
        resume_dir: Some(state.path().to_path_buf()),
        save_seconds: 0.0,
        ..settings.clone()
    };
    let err = train_component(&backend, data, points, &saving, |done, _| done < stop_at)
        .err()
        .expect("interrupted");
    assert!(format!("{err}").contains("interrupted"), "{err}");
    train_component(&backend, data, points, &saving, |_, _| true).unwrap()
}

#[test]
fn an_early_stopped_run_returns_a_finished_model() {
    let (_dir, data, points) = common::plate();
    let backend = CpuBackend::new(2);
    // Impatient: evaluations every 5 iterations, a stop after 10 without improvement.
    let settings = common::short_run_settings(
        200,
        4,
        // The vertex learning rate grows over the run, so late iterations make it worse.
        serde_json::json!({"eval_every": 5, "patience": 10, "finish_iterations": 40, "lr_vertices_end": 0.05}),
    );
    let report = train_component(&backend, &data, &points, &settings, |_, _| true).unwrap();
    let from = finish_start(&report).unwrap_or_else(|| panic!("no finish: {:?}", report.notes));
    assert!(report.best_iteration < from, "{:?}", report.notes);
    assert_eq!(report.iterations_run, from + 40);
    assert_eq!(report.log.iterations_run, from + 40);
    assert_finished(&report, &settings);

    let stop_at = from + 25;
    let resumed = interrupted_and_resumed(&data, &points, &settings, stop_at);
    assert!(
        resumed
            .notes
            .iter()
            .any(|n| n.starts_with(&format!("resumed at iteration {} ", stop_at - 1))),
        "{:?}",
        resumed.notes
    );
    assert_eq!(resumed.model.faces, report.model.faces);
    assert_eq!(
        common::parameter_bits(&resumed.model),
        common::parameter_bits(&report.model)
    );
    assert_eq!(resumed.best_iteration, report.best_iteration);
    assert_eq!(resumed.iterations_run, report.iterations_run);
}

#[test]
fn a_run_to_the_end_of_its_budget_needs_no_finish() {
    let (_dir, data, points) = common::plate();
    let backend = CpuBackend::new(2);
    let settings = TrainSettings {
        checkpoint: Checkpoint::Last,
        ..common::short_run_settings(120, 4, serde_json::json!({}))
    };
    let report = train_component(&backend, &data, &points, &settings, |_, _| true).unwrap();
    assert_eq!(finish_start(&report), None, "{:?}", report.notes);
    assert_eq!(report.iterations_run, 120);
    assert_finished(&report, &settings);
}

/// A best checkpoint from before the budget's end is finished, and the last state
/// (finished by the schedule's end itself) stays a candidate: the run returns the
/// one with the lower held-out loss, as its notes say — on the plate seed 0 keeps
/// the finished best, seed 3 the last state — and resumes to it when interrupted
/// inside the finish.
#[test]
fn at_the_budget_end_the_finished_best_competes_with_the_last_state() {
    let (_dir, data, points) = common::plate();
    let backend = CpuBackend::new(2);
    for (seed, keeps_last) in [(0, false), (3, true)] {
        // Never impatient; the vertex learning rate grows so late iterations can be worse.
        let settings = common::short_run_settings(
            200,
            seed,
            serde_json::json!({"eval_every": 5, "patience": 1000, "finish_iterations": 40, "lr_vertices_end": 0.05}),
        );
        let report = train_component(&backend, &data, &points, &settings, |_, _| true).unwrap();
        let from = finish_start(&report).unwrap_or_else(|| panic!("no finish: {:?}", report.notes));
        assert_eq!(from, 200, "the finish starts at the budget's end");
        // The verdict's two held-out losses, in the order the note gives them.
        let losses = |note: &str| -> Vec<f64> {
            note.split(|c: char| !(c.is_ascii_digit() || c == '.'))
                .filter(|t| t.contains('.') && t.len() > 1)
                .map(|t| t.trim_end_matches('.').parse().unwrap())
                .collect()
        };
        let kept = report
            .notes
            .iter()
            .find(|n| n.starts_with("kept the last state"));
        let beat = report
            .notes
            .iter()
            .find(|n| n.contains("beat the last state"));
        match (kept, beat, keeps_last) {
            (Some(note), None, true) => {
                let [last, finished] = losses(note)[..] else {
                    panic!("{note}")
                };
                assert!(last <= finished, "{note}");
                assert_eq!(report.best_iteration, 200);
                assert_eq!(report.log.finished_from, None);
            }
            (None, Some(note), false) => {
                let [finished, last] = losses(note)[..] else {
                    panic!("{note}")
                };
                assert!(finished < last, "{note}");
                assert!(report.best_iteration < 200, "{:?}", report.notes);
                assert_eq!(report.log.finished_from, Some(200), "{note}");
            }
            other => panic!("seed {seed}: {other:?} in {:?}", report.notes),
        }
        assert_eq!(report.iterations_run, 240);
        assert_finished(&report, &settings);

        let resumed = interrupted_and_resumed(&data, &points, &settings, 225);
        assert_eq!(
            common::parameter_bits(&resumed.model),
            common::parameter_bits(&report.model),
            "seed {seed}"
        );
        assert_eq!(resumed.best_iteration, report.best_iteration);
    }
}
