//! Training iterations and evaluations with the host's renderer.
//!
//! Each pass renders only the view's [`Region::Footprint`]: the bounding box
//! of the pixels whose target is not the background colour and of the drawn
//! faces, grown by the loss's [`CROP_MARGIN`]. Everywhere else render and
//! target are both the background colour (for an object among frozen
//! neighbours: what they draw over it), so the loss there is exactly what
//! the crop's normalization adds and no gradient flows (see
//! `objectsplat_raster::loss`). For the background component the region is
//! the whole frame; for an object it is its neighbourhood. On the CPU backend
//! every buffer lives in a workspace reused from step to step.

use crate::composite::Composite;
use crate::depth_smoothness::{self, DepthImage};
use crate::face_stats::FaceWeights;
use crate::neighbours::{NeighbourLayer, render_layer};
use crate::normal_agreement;
use crate::point_depth::PointDepth;
use crate::steps::{HeldOut, StepInput, StepLoss, StepRunner, Subject, TrainingState};
use crate::supervision::{ComponentData, ViewSummary, fill_region};
use anyhow::{Context, Result, bail};
use objectsplat_core::component::OWN;
use objectsplat_core::{Camera, ComponentKind};
use objectsplat_optim::Optim;
use objectsplat_raster::backend::{PixelRect, Region};
use objectsplat_raster::cpu::{Background, CpuWorkspace};
use objectsplat_raster::loss::{
    CROP_MARGIN, DEFAULT_LAMBDA_DSSIM, Dims, Normalization, PhotometricLoss,
};
use objectsplat_raster::supersample;
use objectsplat_raster::{
    CpuBackend, Model, ModelGrads, OutputGrads, RenderBackend, RenderOutput, RenderSettings,
    SavedForward,
};

/// A backend with its reusable buffers.
enum Backend<'a> {
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

impl<'a> Backend<'a> {
    fn new(backend: &'a dyn RenderBackend<f32>) -> Self {
        match backend
            .as_any()
            .and_then(|b| b.downcast_ref::<CpuBackend>())
        {
            Some(cpu) => Backend::Cpu {
                backend: *cpu,
                ws: Box::default(),
            },
            None => Backend::Other(Box::new(OtherRenderer {
                backend,
                saved: None,
                out: RenderOutput::default(),
                grads: ModelGrads::zeros(0, 0),
            })),
        }
    }

    fn output(&self) -> &RenderOutput<f32> {
        match self {
            Backend::Cpu { ws, .. } => &ws.output,
            Backend::Other(r) => &r.out,
        }
    }

    fn forward(
        &mut self,
        model: &Model<f32>,
        camera: &Camera,
        settings: &RenderSettings,
        b: [f32; 3],
    ) -> Result<()> {
        match self {
            Backend::Cpu { backend, ws } => {
                backend.forward_into(ws, model, camera, settings, Background::Uniform(b))
            }
            Backend::Other(r) => {
                let pixels = camera.width as usize * camera.height as usize;
                let bg: Vec<f32> = (0..3 * pixels).map(|i| b[i % 3]).collect();
                let (o, s) = r.backend.forward(model, camera, settings, &bg)?;
                r.out = o;
                r.saved = Some(s);
                Ok(())
            }
        }
    }

    /// Per face, the largest blending weight of a render (the CPU backend
    /// skips colour and what a backward pass needs; another backend renders).
    fn face_max_weight(
        &mut self,
        model: &Model<f32>,
        camera: &Camera,
        settings: &RenderSettings,
    ) -> Result<&[f32]> {
        match self {
            Backend::Cpu { backend, ws } => {
                backend.face_max_weight_into(ws, model, camera, settings)
            }
            Backend::Other(_) => {
                self.forward(model, camera, settings, [0.0; 3])?;
                Ok(&self.output().face_max_weight)
            }
        }
    }

    fn backward(
        &mut self,
        model: &Model<f32>,
        grads: &OutputGrads<'_, f32>,
    ) -> Result<&mut ModelGrads<f32>> {
        match self {
            Backend::Cpu { backend, ws } => {
                backend.backward_into(ws, model, grads)?;
                Ok(&mut ws.grads)
            }
            Backend::Other(r) => {
                let Some(s) = r.saved.as_ref() else {
                    bail!("backward pass before a forward pass");
                };
                r.grads = r.backend.backward(model, s, grads)?;
                Ok(&mut r.grads)
            }
        }
    }
}

/// A backend rendering `supersample²` samples per pixel (see
/// [`objectsplat_raster::supersample`]); its outputs and the gradients it
/// takes are per pixel of the views' cameras.
struct Renderer<'a> {
    backend: Backend<'a>,
    supersample: u32,
    /// The box-filtered outputs (when supersampling).
    coarse: RenderOutput<f32>,
    /// The gradients spread over the samples (when supersampling).
    fine_color: Vec<f32>,
    fine_alpha: Vec<f32>,
    fine_depth: Vec<f32>,
}

impl<'a> Renderer<'a> {
    fn new(backend: &'a dyn RenderBackend<f32>, supersample: u32) -> Result<Self> {
        supersample::validate(supersample)?;
        Ok(Renderer {
            backend: Backend::new(backend),
            supersample,
            coarse: RenderOutput::default(),
            fine_color: Vec::new(),
            fine_alpha: Vec::new(),
            fine_depth: Vec::new(),
        })
    }

    fn threads(&self) -> usize {
        match &self.backend {
            Backend::Cpu { backend, .. } => backend.threads,
            Backend::Other(_) => 1,
        }
    }

    fn set_threads(&mut self, threads: usize) {
        if let Backend::Cpu { backend, .. } = &mut self.backend {
            backend.threads = threads;
        }
    }

    /// The last forward pass's outputs, per pixel.
    fn output(&self) -> &RenderOutput<f32> {
        if self.supersample > 1 {
            &self.coarse
        } else {
            self.backend.output()
        }
    }

    fn forward(
        &mut self,
        model: &Model<f32>,
        camera: &Camera,
        settings: &RenderSettings,
        b: [f32; 3],
    ) -> Result<&RenderOutput<f32>> {
        let s = self.supersample;
        if s == 1 {
            self.backend.forward(model, camera, settings, b)?;
        } else {
            let (camera, settings) = supersample::fine_view(camera, settings, s);
            self.backend.forward(model, &camera, &settings, b)?;
            let threads = self.threads();
            supersample::downsample_into(threads, self.backend.output(), s, &mut self.coarse)?;
        }
        Ok(self.output())
    }

    /// Per face, the largest blending weight over the samples of a render
    /// (as [`Self::forward`]'s `face_max_weight`, without its pixels).
    fn face_max_weight(
        &mut self,
        model: &Model<f32>,
        camera: &Camera,
        settings: &RenderSettings,
    ) -> Result<&[f32]> {
        if self.supersample == 1 {
            return self.backend.face_max_weight(model, camera, settings);
        }
        let (camera, settings) = supersample::fine_view(camera, settings, self.supersample);
        self.backend.face_max_weight(model, &camera, &settings)
    }

    fn backward(
        &mut self,
        model: &Model<f32>,
        grads: &OutputGrads<'_, f32>,
    ) -> Result<&mut ModelGrads<f32>> {
        let s = self.supersample;
        if s == 1 {
            return self.backend.backward(model, grads);
        }
        let (region, threads) = (self.coarse.region, self.threads());
        supersample::spread_into(threads, grads.color, 3, region, s, &mut self.fine_color);
        if let Some(g) = grads.alpha {
            supersample::spread_into(threads, g, 1, region, s, &mut self.fine_alpha);
        }
        if let Some(g) = grads.depth {
            supersample::spread_into(threads, g, 1, region, s, &mut self.fine_depth);
        }
        if grads.median_depth.is_some() {
            bail!("median-depth gradients are not spread over supersamples");
        }
        self.backend.backward(
            model,
            &OutputGrads {
                color: &self.fine_color,
                alpha: grads.alpha.map(|_| &self.fine_alpha[..]),
                depth: grads.depth.map(|_| &self.fine_depth[..]),
                median_depth: None,
            },
        )
    }
}

/// Renders, scores and back-propagates a component's views.
pub(crate) struct HostSteps<'a> {
    data: &'a ComponentData,
    backend: &'a dyn RenderBackend<f32>,
    renderer: Renderer<'a>,
    loss: PhotometricLoss<f32>,
    target: Vec<f32>,
    weights: Vec<f32>,
    /// A row of labels (scratch of `fill_region`).
    labels: Vec<u8>,
    /// Per view of the component data.
    summaries: Vec<ViewSummary>,
    /// Render only each view's footprint (the default); off renders whole frames.
    crop: bool,
    /// Training steps taken and the share of their frames they rendered, summed.
    steps: u64,
    rendered: f64,
    composite: Option<Composite>,
    /// Per view, what an object's frozen neighbours draw there (rendered at
    /// the view's first use; none for the background, whose occluders'
    /// pixels are supervised by the image).
    layers: Vec<Option<NeighbourLayer>>,
    /// Depth supervision at measured points (none kept when it is off).
    point_depth: PointDepth,
    /// Reused dL/ddepth and dL/dalpha planes of the depth loss.
    d_depth: Vec<f32>,
    d_alpha: Vec<f32>,
    /// Losses of the steps not yet taken by the loop.
    losses: Vec<StepLoss>,
}

impl<'a> HostSteps<'a> {
    pub fn new(
        backend: &'a dyn RenderBackend<f32>,
        data: &'a ComponentData,
        crop: bool,
        depth_supervised: bool,
        supersample: u32,
    ) -> Result<Self> {
        let point_depth = if depth_supervised {
            PointDepth::new(&data.depth_points, data)
        } else {
            PointDepth::default()
        };
        Ok(HostSteps {
            data,
            backend,
            renderer: Renderer::new(backend, supersample)?,
            loss: PhotometricLoss::new(),
            target: Vec::new(),
            weights: Vec::new(),
            labels: Vec::new(),
            summaries: data
                .views
                .iter()
                .map(|v| ViewSummary::of(v, data.rule()))
                .collect(),
            crop,
            steps: 0,
            rendered: 0.0,
            composite: data.occluders.as_ref().map(Composite::new).transpose()?,
            layers: (0..data.views.len()).map(|_| None).collect(),
            point_depth,
            d_depth: Vec::new(),
            d_alpha: Vec::new(),
            losses: Vec::new(),
        })
    }

    /// An object trained among frozen neighbours.
    fn among_neighbours(&self) -> bool {
        self.composite.is_some() && self.data.kind == ComponentKind::Object
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
        view: usize,
        b: [f32; 3],
        render: &RenderSettings,
        gradient: bool,
    ) -> Result<(f64, f64)> {
        let data = self.data;
        let v = &data.views[view];
        let mut settings = RenderSettings {
            region: self.region(view),
            ..render.clone()
        };
        let threads = self.renderer.threads();
        if self.among_neighbours() && self.layers[view].is_none() {
            self.layers[view] = Some(self.neighbour_layer(view, render)?);
        }
        let rendered = match self.composite.as_mut() {
            Some(c) => {
                let merged = c.assemble(model, render.sigma);
                settings.sh_degree = merged.sh_degree;
                merged
            }
            None => model,
        };
        let out = self.renderer.forward(rendered, &v.camera, &settings, b)?;
        if !out.all_finite() {
            bail!(
                "the render of view {:?} is not finite (parameters overflowed; lower the learning rates)",
                v.name
            );
        }
        let region: PixelRect = out.region;
        let inside = fill_region(
            v,
            data.rule(),
            b,
            self.layers[view].as_ref(),
            region,
            &mut self.target,
            &mut self.weights,
            &mut self.labels,
        );
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

    /// The frozen neighbours alone in view `view`, over black, over the pixels
    /// they draw and the view's footprint.
    fn neighbour_layer(&self, view: usize, render: &RenderSettings) -> Result<NeighbourLayer> {
        let Some(frozen) = self.composite.as_ref().map(Composite::frozen) else {
            bail!("no frozen neighbours to render");
        };
        let settings = RenderSettings {
            region: self.region(view),
            ..render.clone()
        };
        render_layer(
            self.backend,
            frozen,
            &self.data.views[view].camera,
            &settings,
            self.renderer.supersample,
        )
    }

    /// One iteration: render the input's view over its background, loss (with
    /// the depth loss and the planarity prior at the input's weights),
    /// backward, Adam. The render's per-face weights go into `stats`. Returns
    /// the photometric loss.
    fn train_step(
        &mut self,
        model: &mut Model<f32>,
        optim: &mut Optim,
        stats: &mut FaceWeights,
        input: &StepInput,
    ) -> Result<f64> {
        let threads = self.renderer.threads();
        let data = self.data;
        let (view, depth_weight, smoothness_weight) = (
            input.view,
            input.point_depth_weight,
            input.smoothness_weight,
        );
        let (loss, _) =
            self.render_and_score(model, view, input.background, &input.render, true)?;
        let camera = &data.views[view].camera;
        self.steps += 1;
        self.rendered +=
            self.target.len() as f64 / (3.0 * camera.width as f64 * camera.height as f64);
        if !loss.is_finite() || self.loss.grad.iter().any(|g| !g.is_finite()) {
            bail!("the loss on view {:?} is not finite", data.views[view].name);
        }
        let faces = model.face_count();
        stats.record(&self.renderer.output().face_max_weight[..faces]);
        let rendered = match &self.composite {
            Some(c) => c.merged(),
            None => &*model,
        };
        let with_points = depth_weight > 0.0 && self.point_depth.count(view) > 0;
        let grads = if with_points || smoothness_weight > 0.0 {
            let out = self.renderer.output();
            let pixels = out.region.pixels();
            self.d_depth.clear();
            self.d_depth.resize(pixels, 0.0);
            self.d_alpha.clear();
            self.d_alpha.resize(pixels, 0.0);
            if with_points {
                self.point_depth.add_gradient(
                    view,
                    out,
                    depth_weight,
                    &mut self.d_depth,
                    &mut self.d_alpha,
                );
            }
            if smoothness_weight > 0.0 {
                let region = out.region;
                let region_width = region.width() as usize;
                let labels = &data.views[view].labels;
                depth_smoothness::add_gradient(
                    &DepthImage {
                        width: region_width,
                        height: region.height() as usize,
                        depth: &out.depth,
                        alpha: &out.alpha,
                    },
                    |i| {
                        let (x, y) = (
                            region.x0 as usize + i % region_width,
                            region.y0 as usize + i / region_width,
                        );
                        labels.get(x as u32, y as u32) == OWN
                    },
                    smoothness_weight,
                    &mut self.d_depth,
                    &mut self.d_alpha,
                );
            }
            self.renderer.backward(
                rendered,
                &OutputGrads {
                    color: &self.loss.grad,
                    alpha: Some(&self.d_alpha),
                    depth: Some(&self.d_depth),
                    median_depth: None,
                },
            )?
        } else {
            self.renderer
                .backward(rendered, &OutputGrads::color_only(&self.loss.grad))?
        };
        if input.normal_agreement_weight > 0.0 {
            normal_agreement::add_gradient(
                &model.vertices,
                &model.faces,
                input.normal_agreement_weight,
                &mut grads.vertices,
            );
        }
        optim.step(model, grads, threads)?;
        Ok(loss)
    }

    /// The model's loss and PSNR on `views` over a black background, where
    /// stray coverage of another component's pixels costs (their target is black).
    pub fn evaluate(
        &mut self,
        model: &Model<f32>,
        views: &[usize],
        render: &RenderSettings,
    ) -> Result<HeldOut> {
        let (mut loss, mut squared, mut weight) = (0.0, 0.0, 0.0);
        for &view in views {
            let (l, s) = self.render_and_score(model, view, [0.0; 3], render, false)?;
            loss += l;
            squared += s;
            weight += 3.0 * self.summaries[view].total_weight;
        }
        Ok(HeldOut::pooled(loss, views.len(), squared, weight))
    }

    /// Per face, the largest blending weight over renders of `views` (no loss).
    pub fn face_max_weight(
        &mut self,
        model: &Model<f32>,
        views: &[usize],
        render: &RenderSettings,
    ) -> Result<Vec<f32>> {
        let data = self.data;
        let mut max = vec![0.0f32; model.face_count()];
        for &view in views {
            let settings = RenderSettings {
                region: self.region(view),
                ..render.clone()
            };
            let weights =
                self.renderer
                    .face_max_weight(model, &data.views[view].camera, &settings)?;
            for (m, &w) in max.iter_mut().zip(weights) {
                *m = m.max(w);
            }
        }
        Ok(max)
    }
}

impl StepRunner for HostSteps<'_> {
    fn set_threads(&mut self, threads: usize) {
        self.renderer.set_threads(threads);
    }

    fn step(&mut self, state: &mut TrainingState, iteration: u64, input: &StepInput) -> Result<()> {
        let TrainingState {
            model,
            optim,
            stats,
        } = state;
        let loss = self
            .train_step(model, optim, stats, input)
            .with_context(|| {
                format!(
                    "training of {:?} diverged at iteration {iteration} (view {:?}; parameters \
                     overflowed, lower the learning rates)",
                    self.data.name, self.data.views[input.view].name
                )
            })?;
        self.losses.push(StepLoss { iteration, loss });
        Ok(())
    }

    fn losses(&mut self, _wait: bool) -> Result<Vec<StepLoss>> {
        Ok(std::mem::take(&mut self.losses))
    }

    fn evaluate(
        &mut self,
        subject: Subject<'_>,
        views: &[usize],
        render: &RenderSettings,
    ) -> Result<HeldOut> {
        HostSteps::evaluate(self, subject.model(), views, render)
    }

    fn face_max_weight(
        &mut self,
        subject: Subject<'_>,
        views: &[usize],
        render: &RenderSettings,
    ) -> Result<Vec<f32>> {
        HostSteps::face_max_weight(self, subject.model(), views, render)
    }

    /// The host's state is the only one.
    fn sync(&mut self, _state: &mut TrainingState) -> Result<()> {
        Ok(())
    }

    fn edited(&mut self) {}

    fn model_is_current(&self) -> bool {
        true
    }

    fn end_epoch(&mut self) {}

    fn rendered(&self) -> (u64, f64) {
        (self.steps, self.rendered)
    }

    fn set_rendered(&mut self, (steps, rendered): (u64, f64)) {
        self.steps = steps;
        self.rendered = rendered;
    }

    fn place(&self) -> &'static str {
        "host"
    }

    fn seen_points(&self) -> &PointDepth {
        &self.point_depth
    }

    /// None: the run report's backend note already says where host steps ran.
    fn summary(&self) -> Option<String> {
        None
    }
}
