//! Training iterations and evaluations with the host's renderer.
//!
//! Each pass renders only the view's [`Region::Footprint`]: the bounding box
//! of the pixels whose target is not the background colour and of the drawn
//! faces, grown by the loss's [`CROP_MARGIN`]. Everywhere else render and
//! target are both the background colour, so the loss there is exactly what
//! the crop's normalization adds and no gradient flows (see
//! `objectsplat_raster::loss`). For the background component the region is
//! the whole frame; for an object it is its neighbourhood. On the CPU backend
//! every buffer lives in a workspace reused from step to step.

use crate::face_stats::FaceWeights;
use crate::optim::Optim;
use crate::supervision::{ComponentData, ViewSummary, fill_region};
use anyhow::{Result, bail};
use objectsplat_core::Camera;
use objectsplat_raster::backend::{PixelRect, Region};
use objectsplat_raster::cpu::{Background, CpuWorkspace};
use objectsplat_raster::loss::{
    CROP_MARGIN, DEFAULT_LAMBDA_DSSIM, Dims, Normalization, PhotometricLoss,
};
use objectsplat_raster::{
    CpuBackend, Model, ModelGrads, OutputGrads, RenderBackend, RenderOutput, RenderSettings,
    SavedForward,
};

/// A renderer with its reusable buffers.
enum Renderer<'a> {
    Cpu {
        backend: CpuBackend,
        ws: Box<CpuWorkspace<f32>>,
    },
    /// Any other backend, through the allocating [`RenderBackend`] interface.
    Other(Box<OtherRenderer<'a>>),
}

struct OtherRenderer<'a> {
    backend: &'a dyn RenderBackend<f32>,
    saved: Option<SavedForward>,
    out: RenderOutput<f32>,
    grads: ModelGrads<f32>,
}

impl<'a> Renderer<'a> {
    fn new(backend: &'a dyn RenderBackend<f32>) -> Self {
        match backend
            .as_any()
            .and_then(|b| b.downcast_ref::<CpuBackend>())
        {
            Some(cpu) => Renderer::Cpu {
                backend: *cpu,
                ws: Box::default(),
            },
            None => Renderer::Other(Box::new(OtherRenderer {
                backend,
                saved: None,
                out: RenderOutput::default(),
                grads: ModelGrads::zeros(0, 0),
            })),
        }
    }

    fn threads(&self) -> usize {
        match self {
            Renderer::Cpu { backend, .. } => backend.threads,
            Renderer::Other(_) => 1,
        }
    }

    fn forward(
        &mut self,
        model: &Model<f32>,
        camera: &Camera,
        settings: &RenderSettings,
        b: [f32; 3],
    ) -> Result<&RenderOutput<f32>> {
        match self {
            Renderer::Cpu { backend, ws } => {
                backend.forward_into(ws, model, camera, settings, Background::Uniform(b))?;
                Ok(&ws.output)
            }
            Renderer::Other(r) => {
                let pixels = camera.width as usize * camera.height as usize;
                let bg: Vec<f32> = (0..3 * pixels).map(|i| b[i % 3]).collect();
                let (o, s) = r.backend.forward(model, camera, settings, &bg)?;
                r.out = o;
                r.saved = Some(s);
                Ok(&r.out)
            }
        }
    }

    fn backward(
        &mut self,
        model: &Model<f32>,
        grads: &OutputGrads<'_, f32>,
    ) -> Result<&ModelGrads<f32>> {
        match self {
            Renderer::Cpu { backend, ws } => {
                backend.backward_into(ws, model, grads)?;
                Ok(&ws.grads)
            }
            Renderer::Other(r) => {
                let Some(s) = r.saved.as_ref() else {
                    bail!("backward pass before a forward pass");
                };
                r.grads = r.backend.backward(model, s, grads)?;
                Ok(&r.grads)
            }
        }
    }
}

/// A model's quality on some views of a component.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeldOut {
    /// Mean weighted photometric loss (`0.8·L1 + 0.2·D-SSIM`); selects the checkpoint.
    pub loss: f64,
    /// PSNR (dB) over every supervised pixel of those views (one pooled MSE).
    pub psnr: f64,
}

/// Renders, scores and back-propagates a component's views.
pub(crate) struct HostSteps<'a> {
    renderer: Renderer<'a>,
    loss: PhotometricLoss<f32>,
    target: Vec<f32>,
    weights: Vec<f32>,
    /// Per view of the component data.
    summaries: Vec<ViewSummary>,
    /// Render only each view's footprint (the default); off renders whole frames.
    crop: bool,
    /// Training steps taken and the share of their frames they rendered, summed.
    steps: u64,
    rendered: f64,
}

impl<'a> HostSteps<'a> {
    pub fn new(backend: &'a dyn RenderBackend<f32>, data: &ComponentData, crop: bool) -> Self {
        HostSteps {
            renderer: Renderer::new(backend),
            loss: PhotometricLoss::new(),
            target: Vec::new(),
            weights: Vec::new(),
            summaries: data
                .views
                .iter()
                .map(|v| ViewSummary::of(v, data.kind))
                .collect(),
            crop,
            steps: 0,
            rendered: 0.0,
        }
    }

    /// Mean share of the frame the training steps rendered (None before any step).
    pub fn rendered_fraction(&self) -> Option<f64> {
        (self.steps > 0).then(|| self.rendered / self.steps as f64)
    }

    fn region(&self, view: usize) -> Region {
        if self.crop {
            Region::Footprint {
                include: self.summaries[view].include,
                margin: CROP_MARGIN,
            }
        } else {
            Region::Full
        }
    }

    /// Renders view `view` over `b` and scores it; the loss gradient is in
    /// `self.loss.grad` afterwards when `gradient`. Returns the loss and the
    /// sum of weighted squared errors (for PSNR).
    fn render_and_score(
        &mut self,
        model: &Model<f32>,
        data: &ComponentData,
        view: usize,
        b: [f32; 3],
        render: &RenderSettings,
        gradient: bool,
    ) -> Result<(f64, f64)> {
        let v = &data.views[view];
        let settings = RenderSettings {
            region: self.region(view),
            ..render.clone()
        };
        let threads = self.renderer.threads();
        let out = self.renderer.forward(model, &v.camera, &settings, b)?;
        if !out.all_finite() {
            bail!(
                "the render of view {:?} is not finite (parameters overflowed; lower the learning rates)",
                v.name
            );
        }
        let region: PixelRect = out.region;
        let inside = fill_region(v, data.kind, b, region, &mut self.target, &mut self.weights);
        let summary = self.summaries[view];
        let norm = Normalization {
            total_weight: summary.total_weight,
            outside_weight: (summary.total_weight - inside).max(0.0),
        };
        let dims = Dims::rgb(region.width(), region.height());
        let value = self.loss.evaluate(
            dims,
            &out.color,
            &self.target,
            Some(&self.weights),
            norm,
            DEFAULT_LAMBDA_DSSIM,
            gradient,
            threads,
        )?;
        let mut squared = 0.0;
        for (p, &w) in self.weights.iter().enumerate() {
            if w > 0.0 {
                for c in 3 * p..3 * p + 3 {
                    let d = (out.color[c] - self.target[c]) as f64;
                    squared += w as f64 * d * d;
                }
            }
        }
        Ok((value.total, squared))
    }

    /// One iteration: render view `view` over `b`, loss, backward, Adam.
    /// The render's per-face weights go into `stats`. Returns the loss.
    #[allow(clippy::too_many_arguments)]
    pub fn step(
        &mut self,
        model: &mut Model<f32>,
        optim: &mut Optim,
        data: &ComponentData,
        view: usize,
        b: [f32; 3],
        render: &RenderSettings,
        stats: &mut FaceWeights,
    ) -> Result<f64> {
        let (loss, _) = self.render_and_score(model, data, view, b, render, true)?;
        let camera = &data.views[view].camera;
        self.steps += 1;
        self.rendered +=
            self.target.len() as f64 / (3.0 * camera.width as f64 * camera.height as f64);
        if !loss.is_finite() || self.loss.grad.iter().any(|g| !g.is_finite()) {
            bail!("the loss on view {:?} is not finite", data.views[view].name);
        }
        stats.record(match &self.renderer {
            Renderer::Cpu { ws, .. } => &ws.output.face_max_weight,
            Renderer::Other(r) => &r.out.face_max_weight,
        });
        let grads = self
            .renderer
            .backward(model, &OutputGrads::color_only(&self.loss.grad))?;
        optim.step(model, grads)?;
        Ok(loss)
    }

    /// The model's loss and PSNR on `views` over a black background, where
    /// stray coverage of another component's pixels costs (their target is black).
    pub fn evaluate(
        &mut self,
        model: &Model<f32>,
        data: &ComponentData,
        views: &[usize],
        render: &RenderSettings,
    ) -> Result<HeldOut> {
        let (mut loss, mut squared, mut weight) = (0.0, 0.0, 0.0);
        for &view in views {
            let (l, s) = self.render_and_score(model, data, view, [0.0; 3], render, false)?;
            loss += l;
            squared += s;
            weight += 3.0 * self.summaries[view].total_weight;
        }
        let mse = squared / weight.max(1.0);
        Ok(HeldOut {
            loss: loss / views.len().max(1) as f64,
            // A perfect fit is capped at 100 dB rather than reported as infinity.
            psnr: if mse > 1e-10 {
                -10.0 * mse.log10()
            } else {
                100.0
            },
        })
    }

    /// Per face, the largest blending weight over renders of `views` (no loss).
    pub fn face_max_weight(
        &mut self,
        model: &Model<f32>,
        data: &ComponentData,
        views: &[usize],
        render: &RenderSettings,
    ) -> Result<Vec<f32>> {
        let mut max = vec![0.0f32; model.face_count()];
        for &view in views {
            let settings = RenderSettings {
                region: self.region(view),
                ..render.clone()
            };
            let out =
                self.renderer
                    .forward(model, &data.views[view].camera, &settings, [0.0; 3])?;
            for (m, &w) in max.iter_mut().zip(&out.face_max_weight) {
                *m = m.max(w);
            }
        }
        Ok(max)
    }
}
