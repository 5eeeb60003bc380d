//! The flat colours fitted to the training views as the export draws them.
//!
//! The bake (`flat_color.rs`) gives each vertex the constant colour closest to
//! its own SH colours over the training directions, one vertex at a time. What a
//! user sees in the `.glb` is different: opaque, hard-edged faces whose pixels
//! blend their corners' flat colours, where the trained model blended soft,
//! view-dependent ones. At 320×240 the exported scene stayed up to 0.52 dB below the
//! trained one after the bake (docs/benchmarks.md). So the bake is only the
//! start: the exported model (`objectsplat_raster::exported`) then trains on the
//! component's own training loss — its views, masks, random backgrounds and
//! frozen neighbours — with every parameter fixed but the DC band, which at
//! degree 0 is the flat colour. Vertices no view shows get no gradient and keep
//! the bake.

use crate::face_stats::FaceWeights;
use crate::steps::{StepInput, StepRunner, TrainingState};
use anyhow::{Result, bail};
use objectsplat_optim::{LearningRates, Optim};
use objectsplat_raster::exported::exported_model;
use objectsplat_raster::{Model, RenderSettings};
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// How long and how fast the colours move.
#[derive(Debug, Clone, Copy)]
pub struct FlatFit {
    /// Passes over the training views (0: keep the bake).
    pub epochs: u64,
    /// Adam's learning rate of the DC coefficients.
    pub lr: f64,
    pub seed: u64,
    /// A random background colour per step, as in training (else `fixed_background`).
    pub randomize_background: bool,
    pub fixed_background: [f32; 3],
}

/// What the fit did, for the training log.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitReport {
    pub steps: u64,
    /// Mean training loss of the first and of the last pass.
    pub first_pass_loss: f64,
    pub last_pass_loss: f64,
}

impl FlatFit {
    /// Fits `model.flat_dc` (baked already) on `views` through `runner`, which
    /// must not hold a newer model than the loop's (the caller synced it). The
    /// runner is left holding the fit's model: a caller that steps on
    /// afterwards hands it its state again ([`StepRunner::edited`]).
    pub(crate) fn apply(
        &self,
        runner: &mut dyn StepRunner,
        model: &mut Model<f32>,
        views: &[usize],
        world_scale: f64,
    ) -> Result<Option<FitReport>> {
        if self.epochs == 0 || views.is_empty() {
            return Ok(None);
        }
        if !(self.lr.is_finite() && self.lr > 0.0) {
            bail!(
                "the flat-colour fit's learning rate {} is not a positive number",
                self.lr
            );
        }
        let exported = exported_model(model);
        // A run whose final prune was skipped can end with no face opaque enough to
        // draw: the export is empty and there is nothing to fit.
        if exported.face_count() == 0 {
            return Ok(None);
        }
        let nv = exported.vertex_count();
        let rates = LearningRates {
            positions: 0.0,
            sh_dc: self.lr,
            sh_rest: 0.0,
            opacity: 0.0,
        };
        let mut state = TrainingState {
            stats: FaceWeights::new(exported.face_count()),
            optim: Optim::new(rates, nv)?,
            model: exported,
        };
        let render = RenderSettings::for_model(&state.model).with_world_scale(world_scale);
        runner.edited();
        let counted = runner.rendered();
        let mut rng = Pcg64Mcg::seed_from_u64(self.seed ^ 0xf1a7_c010_u64);
        let mut order = views.to_vec();
        let mut step = 0;
        for _ in 0..self.epochs {
            order.shuffle(&mut rng);
            for &view in &order {
                let background = if self.randomize_background {
                    [rng.random(), rng.random(), rng.random()]
                } else {
                    self.fixed_background
                };
                step += 1;
                let input = StepInput {
                    view,
                    background,
                    render: render.clone(),
                    point_depth_weight: 0.0,
                    smoothness_weight: 0.0,
                    normal_agreement_weight: 0.0,
                };
                runner.step(&mut state, step, &input)?;
            }
        }
        let losses = runner.losses(true)?;
        runner.sync(&mut state)?;
        // The fit's renders are not training's share of the frame.
        runner.set_rendered(counted);
        let pass = views.len();
        let mean = |from: usize| {
            let part = &losses[from.min(losses.len())..(from + pass).min(losses.len())];
            part.iter().map(|l| l.loss).sum::<f64>() / part.len().max(1) as f64
        };
        let fitted: Vec<[f32; 3]> = state.model.sh.iter().map(|rows| rows[0]).collect();
        if let Some(v) = fitted.iter().position(|c| !c.iter().all(|x| x.is_finite())) {
            bail!("the flat-colour fit left vertex {v} with a colour that is not finite");
        }
        model.flat_dc = fitted;
        Ok(Some(FitReport {
            steps: step,
            first_pass_loss: mean(0),
            last_pass_loss: mean(losses.len().saturating_sub(pass)),
        }))
    }
}
