//! A step hook sees every iteration of a run, in order, with the view it trained
//! on, its loss and the model; it agrees with the run's own log and can stop it.

mod common;

use objectsplat_core::frames::Split;
use objectsplat_raster::CpuBackend;
use objectsplat_train::trainer::{Step, StepHook, train_component_with_hook};

/// (iteration, total, view, loss, faces of the model shown).
type Seen = (u64, u64, Option<usize>, Option<f64>, Option<usize>);

/// Records what it is shown; stops after `stop_after` steps when set.
#[derive(Default)]
struct Recorder {
    seen: Vec<Seen>,
    stop_after: Option<u64>,
}

impl StepHook for Recorder {
    fn after_step(&mut self, step: &Step) -> bool {
        self.seen.push((
            step.iteration,
            step.total,
            step.view,
            step.loss,
            step.model.map(|m| m.face_count()),
        ));
        self.stop_after.is_none_or(|n| step.iteration < n)
    }
}

#[test]
fn the_hook_sees_every_step_and_matches_the_log() {
    let (_dir, data, points) = common::plate();
    // 400 iterations: the log averages windows of two steps.
    let iterations = 400;
    let settings = common::short_run_settings(iterations, 2, serde_json::json!({}));
    let backend = CpuBackend::new(1);
    let mut hook = Recorder::default();
    let report = train_component_with_hook(&backend, &data, &points, &settings, &mut hook).unwrap();

    // A run whose best model is from before its last iteration finishes that
    // model in more iterations; the total shown grows to their end then.
    let run = report.iterations_run;
    assert!(run >= iterations);
    let iterations_seen: Vec<u64> = hook.seen.iter().map(|s| s.0).collect();
    assert_eq!(iterations_seen, (1..=run).collect::<Vec<_>>());
    assert!(hook.seen.iter().all(|s| s.1 == iterations || s.1 == run));
    assert_eq!(hook.seen.last().unwrap().1, run);
    for &(it, _, view, loss, faces) in &hook.seen {
        let view = view.expect("the host path names the view");
        assert_eq!(
            data.views[view].split,
            Split::Train,
            "iteration {it} trained on a test view"
        );
        assert!(loss.is_some_and(f64::is_finite) && faces.is_some_and(|f| f > 0));
    }
    // The log's loss is the mean over each window of the losses the hook saw.
    let mut window_start = 0;
    for record in &report.log.steps {
        let end = record.iteration as usize;
        let losses: Vec<f64> = hook.seen[window_start..end]
            .iter()
            .map(|s| s.3.unwrap())
            .collect();
        let mean = losses.iter().sum::<f64>() / losses.len() as f64;
        assert!(
            (mean - record.loss).abs() <= 1e-12 * mean.abs().max(1.0),
            "window ending at {end}: hook mean {mean}, log {}",
            record.loss
        );
        assert_eq!(hook.seen[end - 1].4, Some(record.faces));
        window_start = end;
    }
    assert_eq!(window_start, run as usize);
    // The final prune only removes faces from the model the last step showed.
    assert!(report.model.face_count() <= hook.seen.last().unwrap().4.unwrap());
}

#[test]
fn a_hook_that_says_stop_interrupts_the_run() {
    let (_dir, data, points) = common::plate();
    let settings = common::short_run_settings(50, 2, serde_json::json!({}));
    let mut hook = Recorder {
        stop_after: Some(7),
        ..Default::default()
    };
    let err = train_component_with_hook(&CpuBackend::new(1), &data, &points, &settings, &mut hook)
        .err()
        .expect("a stopped run is an error, not a partial model");
    assert!(
        format!("{err}").contains("interrupted at iteration 7"),
        "{err}"
    );
    assert_eq!(hook.seen.len(), 7);
}
