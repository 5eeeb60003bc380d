//! The one interface the training loop drives its iterations through,
//! implemented once for the host's renderer (`host_steps.rs`) and once for a
//! wgpu device (`device_steps.rs`): a step, the held-out evaluation, per-face
//! weight statistics and the model's synchronization between the two sides.
//! The loop (`trainer.rs`) is written once, with no backend branch.

use crate::face_stats::FaceWeights;
use crate::point_depth::PointDepth;
use anyhow::Result;
use objectsplat_optim::Optim;
use objectsplat_raster::{Model, RenderSettings};

/// What the loop holds and edits between steps: the model, Adam's state and
/// the per-face weight statistics. A device runner may hold newer copies of
/// all three between [`StepRunner::sync`] calls.
pub(crate) struct TrainingState {
    pub model: Model<f32>,
    pub optim: Optim,
    pub stats: FaceWeights,
}

/// Which model an evaluation or a statistic is of.
#[derive(Clone, Copy)]
pub(crate) enum Subject<'a> {
    /// The model being trained (on a device, the device's copy when newer).
    Training(&'a TrainingState),
    /// Another model (a checkpoint, the finally pruned model).
    Other(&'a Model<f32>),
}

impl<'a> Subject<'a> {
    /// The host's copy of the model.
    pub fn model(self) -> &'a Model<f32> {
        match self {
            Subject::Training(state) => &state.model,
            Subject::Other(model) => model,
        }
    }
}

/// One iteration as the loop chose it.
pub(crate) struct StepInput {
    /// The view, an index into `ComponentData::views`.
    pub view: usize,
    pub background: [f32; 3],
    pub render: RenderSettings,
    /// Weight of the depth loss at measured points this step (0: off).
    pub point_depth_weight: f64,
    /// Weight of the planar prior this step (0: off).
    pub smoothness_weight: f64,
    /// Weight of the normal-agreement prior this step (0: off).
    pub normal_agreement_weight: f64,
}

/// A model's quality on some views of a component.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeldOut {
    /// Mean weighted photometric loss (`0.8·L1 + 0.2·D-SSIM`); selects the checkpoint.
    pub loss: f64,
    /// PSNR (dB) over every supervised pixel of those views (one pooled MSE).
    pub psnr: f64,
}

impl HeldOut {
    /// The mean of per-view losses, and the PSNR of the MSE pooled from the
    /// squared errors and weights summed over the views (the weights count
    /// once per channel).
    pub fn pooled(loss_sum: f64, views: usize, squared: f64, channel_weight: f64) -> Self {
        let mse = squared / channel_weight.max(1.0);
        HeldOut {
            loss: loss_sum / views.max(1) as f64,
            // A perfect fit is capped at 100 dB rather than reported as infinity.
            psnr: if mse > 1e-10 {
                -10.0 * mse.log10()
            } else {
                100.0
            },
        }
    }
}

/// A step's photometric loss as it became known.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct StepLoss {
    /// The iteration (1-based) it belongs to.
    pub iteration: u64,
    pub loss: f64,
}

pub(crate) trait StepRunner {
    /// The threads the host's passes may use from now on (results do not
    /// depend on it); a device's steps ignore it.
    fn set_threads(&mut self, _threads: usize) {}

    /// Iteration `iteration` (1-based): render, loss (with the geometric
    /// terms), backward, Adam, the render's face weights into the statistics.
    /// Its loss comes back through [`StepRunner::losses`] (at once on the host).
    fn step(&mut self, state: &mut TrainingState, iteration: u64, input: &StepInput) -> Result<()>;

    /// The losses of the steps finished since the last call, in order: those
    /// known by now, or (with `wait`) all of them.
    fn losses(&mut self, wait: bool) -> Result<Vec<StepLoss>>;

    /// The loss and PSNR of `subject` on `views` over a black background.
    fn evaluate(
        &mut self,
        subject: Subject<'_>,
        views: &[usize],
        render: &RenderSettings,
    ) -> Result<HeldOut>;

    /// Per face of `subject`, the largest blending weight over renders of it
    /// alone (no occluders) of `views` over black.
    fn face_max_weight(
        &mut self,
        subject: Subject<'_>,
        views: &[usize],
        render: &RenderSettings,
    ) -> Result<Vec<f32>>;

    /// Makes `state` (the model, Adam's state, the statistics' arrays) the newest.
    fn sync(&mut self, state: &mut TrainingState) -> Result<()>;

    /// The loop changed `state` (after [`StepRunner::sync`]): the next step uses it.
    fn edited(&mut self);

    /// Whether `state` holds the newest model without a [`StepRunner::sync`].
    fn model_is_current(&self) -> bool;

    /// Every training view was rendered once more; the loop rolled its own
    /// statistics (`FaceWeights::end_epoch`) already.
    fn end_epoch(&mut self);

    /// Steps taken and the summed share of their frames they rendered (saved with a state).
    fn rendered(&self) -> (u64, f64);

    fn set_rendered(&mut self, rendered: (u64, f64));

    /// Where the iterations run: "host" or "device".
    fn place(&self) -> &'static str;

    /// The measured points each view of the component sees (none without depth supervision).
    fn seen_points(&self) -> &PointDepth;

    /// A line for the training log where the runner has more to say than the
    /// backend's name: where the iterations ran, and what moved between host and device.
    fn summary(&self) -> Option<String>;
}

impl dyn StepRunner + '_ {
    /// Mean share of the frame the training steps rendered (None before any step).
    pub fn rendered_fraction(&self) -> Option<f64> {
        let (steps, rendered) = self.rendered();
        (steps > 0).then(|| rendered / steps as f64)
    }
}
