//! The training log saved next to a trained model (`training.json` in the
//! Model folder): the curves the report plots and the benchmarks read. It holds
//! no clock reading: a Model must depend only on its inputs, or a recomputed item
//! would change its digest and rerun every stage below it. When training reached
//! its log points is a [`TrainingTimes`], which the `train` node reports as a
//! measurement of its run (the run record, not the artifact).

use crate::artifact::TRAINING_JSON;
use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Loss and size of the model over a window of training steps.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StepRecord {
    /// Last iteration of the window (1-based: the number of steps done).
    pub iteration: u64,
    /// Mean training loss (`0.8·L1 + 0.2·D-SSIM`, weighted) over the window.
    pub loss: f64,
    pub faces: usize,
}

/// A held-out evaluation (the best checkpoint is chosen among these).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EvalRecord {
    pub iteration: u64,
    /// Weighted photometric loss over the held-out views (lower is better; selects the checkpoint).
    pub loss: f64,
    /// PSNR (dB) over the supervised pixels of the held-out views, background black.
    pub psnr: f64,
    pub faces: usize,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainingLog {
    pub component: String,
    /// "object" or "background".
    pub kind: String,
    pub backend: String,
    pub seed: u64,
    pub background_randomization: bool,
    pub iterations_budget: u64,
    pub iterations_run: u64,
    /// The evaluation iteration with the best held-out loss.
    pub best_iteration: u64,
    /// Which model was returned: "best" (that checkpoint) or "last" (the end of the budget).
    #[serde(default)]
    pub checkpoint: String,
    /// True when the patience window ended the run before the budget.
    pub stopped_early: bool,
    /// The iteration after which the returned model — from before the end of the
    /// schedule — was finished (its anneal completed; see the trainer's
    /// `finish_iterations`); absent when the model came from the schedule's end.
    #[serde(default)]
    pub finished_from: Option<u64>,
    /// Held-out PSNR of the returned model (after the final prune).
    pub final_psnr: f64,
    pub final_faces: usize,
    /// Mean share of the frame a training step rendered and scored (1 = whole
    /// frames; an object's steps render only its footprint). Absent in older logs.
    #[serde(default)]
    pub rendered_fraction: Option<f64>,
    /// Which views the evaluations scored: "validation" (held out of training),
    /// "training", or "test" (the paper's protocol; or, with the `last`
    /// checkpoint, only reported). Absent in older logs.
    #[serde(default)]
    pub scored_on: Option<String>,
    pub steps: Vec<StepRecord>,
    pub evals: Vec<EvalRecord>,
    /// Schedule events (connectivity step, final prune, early stop) in words.
    pub notes: Vec<String>,
}

impl TrainingLog {
    pub fn save(&self, model_dir: &Path) -> Result<()> {
        let path = model_dir.join(TRAINING_JSON);
        let text = serde_json::to_string_pretty(self).context("serialising the training log")?;
        std::fs::write(&path, text).with_context(|| format!("cannot write {}", path.display()))
    }

    /// Reads `training.json` from a Model folder; `Ok(None)` when the model has
    /// none (models built by hand or by other tools).
    pub fn load(model_dir: &Path) -> Result<Option<TrainingLog>> {
        let path = model_dir.join(TRAINING_JSON);
        if !path.exists() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let log: TrainingLog = serde_json::from_str(&text)
            .with_context(|| format!("{} is not a valid training log", path.display()))?;
        let losses = log.steps.iter().map(|s| s.loss);
        if losses
            .chain(log.evals.iter().map(|e| e.loss))
            .any(|v| !v.is_finite())
        {
            bail!("{}: a loss is not finite", path.display());
        }
        Ok(Some(log))
    }
}

/// The name under which the `train` node reports its [`TrainingTimes`] as a measurement
/// of each item's run (the run report's `measurements`).
pub const TRAINING_TIMES: &str = "training_times";

/// When a training run reached its loss-log points and evaluations, in seconds since
/// it started (a resumed run counts the time before the interruption too).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct TrainingTimes {
    /// Iterations the run did (the log's `iterations_run`).
    pub iterations: u64,
    /// Seconds of the whole run: its loop, final prune and evaluation; not the loading
    /// of the views before it.
    pub seconds: f64,
    /// (iteration, seconds) at each of the log's `steps`.
    pub steps: Vec<(u64, f64)>,
    /// (iteration, seconds) at each of the log's `evals`.
    pub evals: Vec<(u64, f64)>,
}

impl TrainingTimes {
    /// Reads the measurement as a run report holds it (the value under
    /// [`TRAINING_TIMES`] in an item's `measurements`), checking its times.
    pub fn from_json(value: &serde_json::Value) -> Result<TrainingTimes> {
        let times: TrainingTimes = serde_json::from_value(value.clone())
            .with_context(|| format!("measurement `{TRAINING_TIMES}` is not a TrainingTimes"))?;
        let seconds = times.steps.iter().chain(&times.evals).map(|p| p.1);
        if seconds
            .chain([times.seconds])
            .any(|s| !(s.is_finite() && s >= 0.0))
        {
            bail!("measurement `{TRAINING_TIMES}`: a time is negative or not finite");
        }
        Ok(times)
    }

    /// Iterations per second over the whole run; `None` for a run that took no time.
    pub fn iterations_per_second(&self) -> Option<f64> {
        (self.seconds > 0.0).then(|| self.iterations as f64 / self.seconds)
    }

    /// The seconds at which the evaluation of `iteration` ended.
    pub fn eval_seconds(&self, iteration: u64) -> Option<f64> {
        self.evals
            .iter()
            .find(|(i, _)| *i == iteration)
            .map(|(_, s)| *s)
    }
}
