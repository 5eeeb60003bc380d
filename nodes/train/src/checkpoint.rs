//! Saving a training run's whole state between iterations, so that a run killed
//! half-way resumes where it stopped and ends with the very same model.
//!
//! The state lives in a folder (the engine's per-action resume folder): the
//! model and the best snapshot as Model folders (exact f32 PLY), Adam's moments
//! and the face statistics as little-endian f32 files, and everything else —
//! the iteration, the random generator, the epoch order, the logs — in
//! `progress.json`. A new state is written beside the old one and swapped in
//! by renames, so a kill while saving leaves the previous state readable.

use crate::adam::Adam;
use crate::face_stats::FaceWeights;
use anyhow::{Context, Result, bail};
use objectsplat_core::{EvalRecord, StepRecord, TrainingTimes};
use objectsplat_raster::{Model, load_model, save_model};
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

const STATE: &str = "state";
const PROGRESS: &str = "progress.json";

/// Scalars and small lists of the loop, saved as JSON.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Progress {
    /// What the state belongs to; a state of another run is ignored.
    pub identity: String,
    /// Iterations done.
    pub iteration: u64,
    pub rng: Pcg64Mcg,
    pub order: Vec<usize>,
    pub order_next: usize,
    pub stats_epochs: u32,
    pub best: Option<(f64, u64, bool)>,
    pub steps: Vec<StepRecord>,
    pub evals: Vec<EvalRecord>,
    /// When the run so far reached its steps and evaluations; its `seconds` are the
    /// run's wall time so far, which the resumed run's clock continues from. (A saved
    /// state is no artifact: it may hold the clock.)
    pub times: TrainingTimes,
    pub notes: Vec<String>,
    pub cleanup_pending: bool,
    /// The finishing window, once the run is in it.
    #[serde(default)]
    pub finish: Option<crate::trainer::Finish>,
    #[serde(default)]
    pub stopped_early: bool,
    /// Per Adam group: learning rate, rest rate, column split and step count.
    pub adam: Vec<(f64, f64, usize, u64)>,
    /// Training steps rendered and the share of frames they rendered, summed.
    pub rendered: (u64, f64),
}

/// Everything a resumed run continues from.
pub struct TrainerState {
    pub progress: Progress,
    pub model: Model<f32>,
    pub adam: Adam,
    pub stats: FaceWeights,
    /// The best snapshot's model and (when recorded) its face weights.
    pub best: Option<(Model<f32>, Option<Vec<f32>>)>,
}

fn write_f32(path: &Path, values: &[f32]) -> Result<()> {
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    std::fs::write(path, bytes).with_context(|| format!("cannot write {}", path.display()))
}

fn read_f32(path: &Path) -> Result<Vec<f32>> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    if bytes.len() % 4 != 0 {
        bail!(
            "{}: {} bytes is not a list of f32",
            path.display(),
            bytes.len()
        );
    }
    Ok(bytes
        .chunks_exact(4)
        .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect())
}

impl TrainerState {
    /// Writes the state into `dir`, replacing the one there.
    pub fn save(&self, dir: &Path) -> Result<()> {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
        let fresh = dir.join(format!("{STATE}.new"));
        if fresh.exists() {
            std::fs::remove_dir_all(&fresh)?;
        }
        std::fs::create_dir_all(&fresh)?;
        save_model(&self.model, &fresh.join("model"))?;
        for (g, group) in self.adam.groups.iter().enumerate() {
            write_f32(&fresh.join(format!("adam_{g}_m.f32")), group.first_moment())?;
            write_f32(
                &fresh.join(format!("adam_{g}_v.f32")),
                group.second_moment(),
            )?;
        }
        let (current, previous) = self.stats.parts();
        write_f32(&fresh.join("stats_current.f32"), current)?;
        write_f32(&fresh.join("stats_previous.f32"), previous)?;
        if let Some((model, weights)) = &self.best {
            save_model(model, &fresh.join("best"))?;
            if let Some(w) = weights {
                write_f32(&fresh.join("best_weights.f32"), w)?;
            }
        }
        std::fs::write(
            fresh.join(PROGRESS),
            serde_json::to_string(&self.progress).context("serialising the training progress")?,
        )?;
        // Swap: the old state stays readable until the new one is complete.
        let (current_dir, old) = (dir.join(STATE), dir.join(format!("{STATE}.old")));
        if old.exists() {
            std::fs::remove_dir_all(&old)?;
        }
        if current_dir.exists() {
            std::fs::rename(&current_dir, &old)?;
        }
        std::fs::rename(&fresh, &current_dir)?;
        if old.exists() {
            std::fs::remove_dir_all(&old)?;
        }
        Ok(())
    }

    /// The state saved in `dir` for the run `identity`, if any (a swap cut
    /// short leaves it in `state.old`). `template` gives Adam's group layout.
    pub fn load(dir: &Path, identity: &str, template: &Adam) -> Result<Option<TrainerState>> {
        let candidates: [PathBuf; 2] = [dir.join(STATE), dir.join(format!("{STATE}.old"))];
        let Some(state) = candidates.iter().find(|p| p.join(PROGRESS).is_file()) else {
            return Ok(None);
        };
        let text = std::fs::read_to_string(state.join(PROGRESS))?;
        let progress: Progress = serde_json::from_str(&text)
            .with_context(|| format!("{}: not a training progress file", state.display()))?;
        if progress.identity != identity {
            return Ok(None);
        }
        let model = load_model(&state.join("model"))?;
        let mut adam = template.clone();
        if adam.groups.len() != progress.adam.len() {
            bail!("{}: the saved optimizer has other groups", state.display());
        }
        adam.resize_rows(model.vertex_count());
        for (g, (group, &(lr, lr_rest, split, steps))) in
            adam.groups.iter_mut().zip(&progress.adam).enumerate()
        {
            group.lr = lr;
            group.lr_rest = lr_rest;
            group.split = split;
            let m = read_f32(&state.join(format!("adam_{g}_m.f32")))?;
            let v = read_f32(&state.join(format!("adam_{g}_v.f32")))?;
            group
                .set_moments(m, v, steps)
                .with_context(|| format!("{}", state.display()))?;
        }
        let stats = FaceWeights::from_parts(
            read_f32(&state.join("stats_current.f32"))?,
            read_f32(&state.join("stats_previous.f32"))?,
            progress.stats_epochs,
        )?;
        if stats.len() != model.face_count() {
            bail!("{}: face statistics for another model", state.display());
        }
        let best = match progress.best {
            Some((_, _, with_weights)) => {
                let weights = if with_weights {
                    Some(read_f32(&state.join("best_weights.f32"))?)
                } else {
                    None
                };
                Some((load_model(&state.join("best"))?, weights))
            }
            None => None,
        };
        Ok(Some(TrainerState {
            progress,
            model,
            adam,
            stats,
            best,
        }))
    }
}
