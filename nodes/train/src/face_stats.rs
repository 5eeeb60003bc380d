//! Per-face blending-weight statistics kept during training, for pruning,
//! densification and the final prune, instead of re-rendering every training
//! view at each of those events.
//!
//! Views are visited in epochs (a shuffled pass over every training view), so
//! the maximum over the current and the previous epoch covers every training
//! view's latest render at least once: what a re-render of every view would
//! report, up to two epochs of staleness. Until one whole epoch has passed since
//! the faces last changed wholesale the statistics are incomplete, and the
//! trainer renders the views instead. A wholesale change (the connectivity step)
//! lands mid-epoch, so the epoch it lands in does not count: the cleanup after
//! the connectivity step once judged faces on the 12 of 19 views an object's
//! partial epoch had left, and removed faces only the other 7 showed.

use crate::densify::VertexEdit;

#[derive(Debug, Clone, Default)]
pub struct FaceWeights {
    current: Vec<f32>,
    previous: Vec<f32>,
    /// Epoch boundaries passed since the statistics (re)started, counting the
    /// start of training as one: complete from 2 on (see [`FaceWeights::complete`]).
    epochs: u32,
}

impl FaceWeights {
    /// No statistics yet for `faces` faces.
    /// At the start of training, which is also the start of an epoch.
    pub fn new(faces: usize) -> Self {
        FaceWeights {
            epochs: 1,
            ..FaceWeights::restarted(faces)
        }
    }

    fn restarted(faces: usize) -> Self {
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

    /// Epoch boundaries passed since the statistics (re)started (for a saved state).
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

    /// Whether every training view has been seen since the last reset: one
    /// whole epoch has passed.
    pub fn complete(&self) -> bool {
        self.epochs >= 2
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

    /// Forgets everything (the faces were replaced mid-epoch, e.g. by the
    /// connectivity step): complete again after the next whole epoch.
    pub fn reset(&mut self, faces: usize) {
        *self = FaceWeights::restarted(faces);
    }
}

#[cfg(test)]
mod tests {
    use super::FaceWeights;

    #[test]
    fn statistics_are_complete_after_one_whole_epoch() {
        // From the start of training, the first epoch is whole.
        let mut stats = FaceWeights::new(2);
        stats.record(&[0.5, 0.0]);
        assert!(!stats.complete());
        stats.end_epoch();
        assert!(stats.complete());
        assert_eq!(stats.max_weight(), vec![0.5, 0.0]);

        // A reset lands mid-epoch: the rest of that epoch is not a whole one.
        stats.reset(2);
        stats.record(&[0.0, 0.25]);
        stats.end_epoch();
        assert!(!stats.complete());
        stats.record(&[0.125, 0.0]);
        stats.end_epoch();
        assert!(stats.complete());
        // The last whole epoch (and the current one so far).
        assert_eq!(stats.max_weight(), vec![0.125, 0.0]);
    }
}
