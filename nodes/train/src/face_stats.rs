//! Per-face blending-weight statistics kept during training, for pruning,
//! densification and the final prune, instead of re-rendering every training
//! view at each of those events.
//!
//! Views are visited in epochs (a shuffled pass over every training view), so
//! the maximum over the current and the previous epoch covers every training
//! view's latest render at least once: what a re-render of every view would
//! report, up to two epochs of staleness. Until one epoch has passed since the
//! faces last changed wholesale the statistics are incomplete, and the trainer
//! renders the views instead.

use crate::densify::VertexEdit;

#[derive(Debug, Clone, Default)]
pub struct FaceWeights {
    current: Vec<f32>,
    previous: Vec<f32>,
    /// Epochs finished since the last reset.
    epochs: u32,
}

impl FaceWeights {
    /// No statistics yet for `faces` faces.
    pub fn new(faces: usize) -> Self {
        FaceWeights {
            current: vec![0.0; faces],
            previous: vec![0.0; faces],
            epochs: 0,
        }
    }

    /// Statistics saved earlier (see [`FaceWeights::parts`]).
    pub fn from_parts(current: Vec<f32>, previous: Vec<f32>, epochs: u32) -> anyhow::Result<Self> {
        if current.len() != previous.len() {
            anyhow::bail!(
                "face statistics of {} and {} faces",
                current.len(),
                previous.len()
            );
        }
        Ok(FaceWeights {
            current,
            previous,
            epochs,
        })
    }

    /// The current and previous epoch's maxima.
    pub fn parts(&self) -> (&[f32], &[f32]) {
        (&self.current, &self.previous)
    }

    /// Epochs finished since the last reset.
    pub fn epochs(&self) -> u32 {
        self.epochs
    }

    /// Number of faces.
    pub fn len(&self) -> usize {
        self.current.len()
    }

    pub fn is_empty(&self) -> bool {
        self.current.is_empty()
    }

    /// Folds one training render's per-face maximum blending weights in.
    pub fn record(&mut self, face_max_weight: &[f32]) {
        for (m, &w) in self.current.iter_mut().zip(face_max_weight) {
            *m = m.max(w);
        }
    }

    /// Every training view has been rendered once more.
    pub fn end_epoch(&mut self) {
        std::mem::swap(&mut self.current, &mut self.previous);
        self.current.fill(0.0);
        self.epochs += 1;
    }

    /// Whether every training view has been seen since the last reset.
    pub fn complete(&self) -> bool {
        self.epochs >= 1
    }

    /// Per face, the largest weight of the last one to two epochs.
    pub fn max_weight(&self) -> Vec<f32> {
        self.current
            .iter()
            .zip(&self.previous)
            .map(|(a, b)| a.max(*b))
            .collect()
    }

    /// The per-face maxima of the current and the previous epoch, for a
    /// trainer that keeps them elsewhere (on a device) between edits.
    pub fn arrays(&self) -> (&[f32], &[f32]) {
        (&self.current, &self.previous)
    }

    /// Replaces the two arrays by values kept elsewhere; the epoch count stays.
    pub fn set_arrays(&mut self, current: Vec<f32>, previous: Vec<f32>) {
        self.current = current;
        self.previous = previous;
    }

    /// Follows a pruning or densification: kept faces keep their values, and
    /// the children of a split face inherit their parent's.
    pub fn follow(&mut self, edit: &VertexEdit) {
        let remap =
            |v: &[f32]| -> Vec<f32> { edit.face_origin.iter().map(|&f| v[f as usize]).collect() };
        self.current = remap(&self.current);
        self.previous = remap(&self.previous);
    }

    /// Forgets everything (the faces were replaced, e.g. by the connectivity step).
    pub fn reset(&mut self, faces: usize) {
        *self = FaceWeights::new(faces);
    }
}
