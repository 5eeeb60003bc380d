//! [`DeviceTrainer`]: training iterations and evaluations that stay on the
//! device. The parameters, Adam's moments, the per-face weight statistics and
//! every view's target live in device buffers; one step renders (the forward
//! of [`WgpuBackend`]), computes the photometric loss and its image gradient
//! (`train_loss.wgsl`), runs the backward pass and applies Adam
//! (`train_adam.wgsl`), with no image or gradient crossing to the host.
//!
//! A step whose settings ask for [`Region::Footprint`] renders, scores and
//! back-propagates only the footprint of the drawn faces and of the view's
//! own supervision (the pixels whose target is not the background colour),
//! grown by the loss's crop margin: the loss and the gradient equal the whole
//! frame's (see train_loss.wgsl).
//!
//! Per step the host writes a few uniform blocks and reads back one record,
//! the tile-entry count and the rendered region, which size the entry buffers
//! and the dispatches. Every buffer is pooled: once the pools have grown to
//! the model and the images, a step creates none. Losses and divergence flags
//! collect in device slots and come back in batches
//! ([`DeviceTrainer::results`]); the parameters come back only when the host
//! needs the model ([`DeviceTrainer::store`]). An evaluation
//! ([`DeviceTrainer::evaluate`]) renders and scores several views with one
//! readback, and the running per-face weight maxima
//! ([`DeviceTrainer::face_weights`]) come back only when asked for.

use crate::kernels::{Kernel, Pooled, Recorder, UniformArena, groups_for, shader, storage};
use crate::raster::{BackgroundSource, GradPool, ModelBuffers, RasterPool, WgpuBackend};
use anyhow::{Context, Result, bail};
use objectsplat_core::Camera;
use objectsplat_gpu::{Readback, read_values};
use objectsplat_raster::backend::{PixelRect, Region};
use objectsplat_raster::loss::{CROP_MARGIN, SSIM_SIGMA, SSIM_WINDOW};
use objectsplat_raster::{Model, RenderSettings, SH_COEFFS};

pub const TRAIN_LOSS_WGSL: &str = concat!(
    include_str!("frame_record.wgsl"),
    include_str!("thread_index.wgsl"),
    include_str!("is_finite.wgsl"),
    include_str!("train_loss.wgsl")
);
pub const TRAIN_ADAM_WGSL: &str = concat!(
    include_str!("is_finite.wgsl"),
    include_str!("train_adam.wgsl")
);
pub const TRAIN_FACES_WGSL: &str = include_str!("train_faces.wgsl");

const THREADS_1D: usize = 256;
/// Steps whose losses and flags the device holds before the host collects them.
const SLOTS: usize = 256;
const ROW_MAPS: usize = 15;
const PARTIAL_MAPS: usize = 9;
const IMAGE_STRIDE: usize = 6;
const SH_VALUES: usize = SH_COEFFS * 3;

/// What a set bit of a step's status means (bits of train_loss.wgsl and train_adam.wgsl).
const STATUS_BITS: [(u32, &str); 8] = [
    (1, "the render"),
    (2, "the loss"),
    (4, "the gradient of the vertex positions"),
    (8, "the vertex positions"),
    (16, "the gradient of the SH coefficients"),
    (32, "the SH coefficients"),
    (64, "the gradient of the opacity logits"),
    (128, "the opacity logits"),
];

/// One training view: its camera and supervision. `target` is RGB per pixel,
/// `weights` the per-pixel loss weight (0 = not supervised), and where
/// `from_background` is set the target is the step's background colour instead.
#[derive(Debug, Clone)]
pub struct TrainingView {
    pub camera: Camera,
    pub target: Vec<f32>,
    pub weights: Vec<f32>,
    pub from_background: Vec<bool>,
}

/// Adam's state of one parameter tensor, in the device layout of its values.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Moments {
    pub first: Vec<f32>,
    pub second: Vec<f32>,
    /// Updates applied so far (for the bias correction).
    pub steps: u64,
}

/// Adam's state of the three tensors: positions (3 per vertex), SH (16×3 per
/// vertex, coefficient-major), opacity logits (1 per vertex).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OptimizerState {
    pub positions: Moments,
    pub sh: Moments,
    pub opacity_logits: Moments,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdamSettings {
    pub beta1: f64,
    pub beta2: f64,
    pub eps: f64,
}

impl Default for AdamSettings {
    /// The reference trainer's: β = (0.9, 0.999), ε = 1e-15.
    fn default() -> Self {
        AdamSettings {
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-15,
        }
    }
}

impl OptimizerState {
    /// Fresh state (zero moments, no steps) for a model of `vertices` vertices.
    pub fn zeros(vertices: usize) -> Self {
        let moments = |n: usize| Moments {
            first: vec![0.0; n],
            second: vec![0.0; n],
            steps: 0,
        };
        OptimizerState {
            positions: moments(vertices * 3),
            sh: moments(vertices * SH_VALUES),
            opacity_logits: moments(vertices),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LearningRates {
    pub positions: f64,
    pub sh_dc: f64,
    pub sh_rest: f64,
    pub opacity: f64,
}

/// One iteration: which view, over which background colour, rendered how.
/// With `render.region` = [`Region::Footprint`], the view's own supervision
/// rectangle is added to `include` and the margin must be at least
/// [`CROP_MARGIN`] (what keeps the cropped loss equal to the whole frame's).
#[derive(Debug, Clone)]
pub struct Step {
    pub view: usize,
    pub background: [f32; 3],
    pub render: RenderSettings,
    pub learning_rates: LearningRates,
    /// λ of `(1 − λ)·L1 + λ·(1 − SSIM)`.
    pub lambda_dssim: f64,
}

/// A finished step as the host learns of it.
#[derive(Debug, Clone, PartialEq)]
pub struct StepResult {
    pub loss: f32,
    /// What turned non-finite in this step (render, loss, a gradient or a
    /// parameter tensor); empty when all is finite.
    pub non_finite: Vec<&'static str>,
}

/// Per face, the running maximum of the blending weight over the training
/// renders of the current epoch and of the previous one.
pub type FaceWeightArrays = (Vec<f32>, Vec<f32>);

/// A view's score in an evaluation (over a black background, no gradient).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewScore {
    /// `(1 − λ)·L1 + λ·(1 − SSIM)` over the whole view (0 when nothing is supervised).
    pub loss: f64,
    /// `Σ w·(rendered − target)²` over the supervised pixels and channels.
    pub squared_error: f64,
    /// `Σ w` over the whole view.
    pub total_weight: f64,
}

/// `LossParams` of train_loss.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct LossParams {
    width: u32,
    slot: u32,
    partial_count: u32,
    gradient: u32,
    background: [f32; 4],
    norm: f32,
    l1_weight: f32,
    ssim_weight: f32,
    supervised: u32,
    taps: [f32; 12],
}

/// `AdamParams` of train_adam.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct AdamParams {
    count: u32,
    row_width: u32,
    split: u32,
    grad_bit: u32,
    lr_first: f32,
    lr_rest: f32,
    beta1: f32,
    beta2: f32,
    complement1: f32,
    complement2: f32,
    eps: f32,
    bias1: f32,
    bias2: f32,
    slot: u32,
    pad: [u32; 2],
}

/// `FaceParams` of train_faces.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct FaceParams {
    face_count: u32,
    pad: [u32; 3],
}

struct ViewBuffers {
    camera: Camera,
    targets: wgpu::Buffer,
    from_background: wgpu::Buffer,
    /// 1 / (3·Σ weights), 0 without supervised pixels.
    norm: f32,
    supervised: bool,
    /// `Σ` weights over the view.
    total_weight: f64,
    /// Bounding box of the pixels whose target is not the background colour.
    include: PixelRect,
}

/// The parameters and Adam's moments on the device (pooled buffers, grown to the largest model).
struct Resident {
    params: ModelBuffers,
    first: [wgpu::Buffer; 3],
    second: [wgpu::Buffer; 3],
    steps: [u64; 3],
}

struct Kernels {
    ssim_rows: Kernel,
    ssim_maps: Kernel,
    ssim_grad_rows: Kernel,
    loss_grad: Kernel,
    loss_total: Kernel,
    adam: Kernel,
    fold_face_weights: Kernel,
}

/// Grow-only storage of the trainer beyond the raster pools.
struct TrainerPools {
    /// Positions, SH, opacity logits, face indices.
    model: [Pooled; 4],
    first: [Pooled; 3],
    second: [Pooled; 3],
    /// Running per-face maxima of the blending weight: current and previous epoch.
    face_weights: [Pooled; 2],
    eval_results: Pooled,
    eval_status: Pooled,
    created: u64,
}

/// Training steps on the device (see the module documentation).
pub struct DeviceTrainer {
    backend: WgpuBackend,
    kernels: Kernels,
    adam: AdamSettings,
    taps: [f32; 12],
    views: Vec<ViewBuffers>,
    resident: Option<Resident>,
    uniforms: UniformArena,
    raster: RasterPool,
    grads: GradPool,
    pools: TrainerPools,
    /// Faces the face-weight arrays describe (those of the loaded model).
    face_weight_faces: usize,
    rows: wgpu::Buffer,
    maps: wgpu::Buffer,
    upstream: wgpu::Buffer,
    partials: wgpu::Buffer,
    results: wgpu::Buffer,
    status: wgpu::Buffer,
    readback: Readback,
    pending: usize,
    collected: Vec<StepResult>,
    /// View and region of the last step (for [`DeviceTrainer::last_image_gradient`]).
    last_step: Option<(usize, PixelRect)>,
    /// Host waits for the device outside the raster pool's.
    syncs: u64,
    created: u64,
}

/// The SSIM window's taps as objectsplat_raster::loss computes them (in f64,
/// rounded to f32), padded to whole vec4s.
fn gaussian_taps() -> [f32; 12] {
    let half = (SSIM_WINDOW / 2) as f64;
    let raw: Vec<f64> = (0..SSIM_WINDOW)
        .map(|i| (-(i as f64 - half).powi(2) / (2.0 * SSIM_SIGMA * SSIM_SIGMA)).exp())
        .collect();
    let sum: f64 = raw.iter().sum();
    std::array::from_fn(|i| raw.get(i).map_or(0.0, |r| (r / sum) as f32))
}

impl TrainingView {
    fn validate(&self, index: usize) -> Result<()> {
        self.camera
            .validate()
            .map_err(anyhow::Error::msg)
            .with_context(|| format!("training view {index}"))?;
        let pixels = self.camera.width as usize * self.camera.height as usize;
        if self.target.len() != pixels * 3
            || self.weights.len() != pixels
            || self.from_background.len() != pixels
        {
            bail!(
                "training view {index}: {} target values, {} weights and {} background flags for {pixels} pixels",
                self.target.len(),
                self.weights.len(),
                self.from_background.len()
            );
        }
        if let Some(i) = self.target.iter().position(|v| !v.is_finite()) {
            bail!("training view {index}: target value {i} is not finite");
        }
        if let Some(i) = self
            .weights
            .iter()
            .position(|w| !(w.is_finite() && *w >= 0.0))
        {
            bail!(
                "training view {index}: weight {i} is {} (expected finite and ≥ 0)",
                self.weights[i]
            );
        }
        Ok(())
    }

    /// Bounding box of the pixels whose target is not the background colour
    /// (the supervision a crop must keep; `ViewSummary::include` of the trainer).
    pub fn include(&self) -> PixelRect {
        let w = self.camera.width as usize;
        let mut include = PixelRect::default();
        for (p, _) in self
            .from_background
            .iter()
            .enumerate()
            .filter(|(_, b)| !**b)
        {
            include = include.union(PixelRect::pixel(p, w));
        }
        include
    }
}

impl Moments {
    fn check(&self, what: &str, values: usize) -> Result<()> {
        if self.first.len() != values || self.second.len() != values {
            bail!(
                "Adam state of the {what}: {} first and {} second moments for {values} values",
                self.first.len(),
                self.second.len()
            );
        }
        Ok(())
    }
}

impl DeviceTrainer {
    /// Uploads the views (training and held-out alike) and compiles the kernels.
    pub fn new(
        backend: &WgpuBackend,
        views: &[TrainingView],
        adam: AdamSettings,
    ) -> Result<DeviceTrainer> {
        if views.is_empty() {
            bail!("device training needs at least one training view");
        }
        if !(adam.beta1.is_finite()
            && adam.beta2.is_finite()
            && adam.eps.is_finite()
            && (0.0..1.0).contains(&adam.beta1)
            && (0.0..1.0).contains(&adam.beta2)
            && adam.eps >= 0.0)
        {
            bail!("Adam settings {adam:?}: β1 and β2 must lie in [0, 1) and ε be finite and ≥ 0");
        }
        let ctx = backend.context().clone();
        ctx.check_errors("setup before compiling the training kernels")?;
        let loss = shader(&ctx, "train_loss.wgsl", TRAIN_LOSS_WGSL);
        let adam_module = shader(&ctx, "train_adam.wgsl", TRAIN_ADAM_WGSL);
        let faces_module = shader(&ctx, "train_faces.wgsl", TRAIN_FACES_WGSL);
        let kernels = Kernels {
            ssim_rows: Kernel::new(&ctx, &loss, "ssim_rows"),
            ssim_maps: Kernel::new(&ctx, &loss, "ssim_maps"),
            ssim_grad_rows: Kernel::new(&ctx, &loss, "ssim_grad_rows"),
            loss_grad: Kernel::new(&ctx, &loss, "loss_grad"),
            loss_total: Kernel::new(&ctx, &loss, "loss_total"),
            adam: Kernel::new(&ctx, &adam_module, "adam_step"),
            fold_face_weights: Kernel::new(&ctx, &faces_module, "fold_face_weights"),
        };
        ctx.check_errors("compiling the training kernels")?;
        let mut buffers = Vec::with_capacity(views.len());
        for (i, view) in views.iter().enumerate() {
            view.validate(i)?;
            let targets: Vec<[f32; 4]> = view
                .target
                .chunks_exact(3)
                .zip(&view.weights)
                .map(|(rgb, &w)| [rgb[0], rgb[1], rgb[2], w])
                .collect();
            let flags: Vec<u32> = view.from_background.iter().map(|&b| b as u32).collect();
            let total_weight: f64 = view.weights.iter().map(|&w| w as f64).sum();
            let supervised = total_weight > 0.0;
            buffers.push(ViewBuffers {
                camera: view.camera,
                targets: crate::kernels::storage_from(&ctx, "view targets", &targets),
                from_background: crate::kernels::storage_from(&ctx, "background flags", &flags),
                norm: if supervised {
                    (1.0 / (3.0 * total_weight)) as f32
                } else {
                    0.0
                },
                supervised,
                total_weight,
                include: view.include(),
            });
        }
        let pixels = views
            .iter()
            .map(|v| v.camera.width as usize * v.camera.height as usize)
            .max()
            .unwrap_or(0); // views is not empty (checked above)
        backend.check_binding_size("SSIM planes", (pixels * ROW_MAPS * 4) as u64)?;
        let bytes = |n: usize| (n * 4) as u64;
        let mut created = 0;
        let mut pooled = |label| Pooled::new(&ctx, label, &mut created);
        let pools = TrainerPools {
            model: [
                pooled("positions"),
                pooled("sh"),
                pooled("opacity logits"),
                pooled("face indices"),
            ],
            first: [
                pooled("adam first moment"),
                pooled("adam first moment"),
                pooled("adam first moment"),
            ],
            second: [
                pooled("adam second moment"),
                pooled("adam second moment"),
                pooled("adam second moment"),
            ],
            face_weights: [
                pooled("face weights (current epoch)"),
                pooled("face weights (previous epoch)"),
            ],
            eval_results: pooled("evaluation results"),
            eval_status: pooled("evaluation status"),
            created: 0,
        };
        let results = storage(&ctx, "step results", bytes(4 * SLOTS));
        let status = storage(&ctx, "step status", bytes(SLOTS));
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        enc.clear_buffer(&status, 0, None);
        ctx.queue.submit([enc.finish()]);
        let trainer = DeviceTrainer {
            backend: backend.clone(),
            kernels,
            adam,
            taps: gaussian_taps(),
            views: buffers,
            resident: None,
            uniforms: UniformArena::default(),
            raster: RasterPool::new(&ctx),
            grads: GradPool::new(&ctx),
            pools,
            face_weight_faces: 0,
            rows: storage(&ctx, "ssim rows", bytes(pixels * ROW_MAPS)),
            maps: storage(&ctx, "ssim partial maps", bytes(pixels * PARTIAL_MAPS)),
            upstream: storage(&ctx, "loss gradient", bytes(pixels * IMAGE_STRIDE)),
            partials: storage(
                &ctx,
                "loss partial sums",
                bytes(4 * groups_for(pixels, THREADS_1D) as usize),
            ),
            results,
            status,
            readback: Readback::default(),
            pending: 0,
            collected: Vec::new(),
            last_step: None,
            syncs: 0,
            created: created + 6,
        };
        Ok(trainer)
    }

    /// Buffers created since [`DeviceTrainer::new`] began, pools included: it
    /// stops growing once the pools fit the model and the images.
    pub fn buffers_created(&self) -> u64 {
        self.created
            + self.pools.created
            + self.uniforms.created
            + self.readback.created
            + self.raster.created()
            + self.grads.created()
    }

    /// Pixels of view `view`'s frame (0 for a view that does not exist).
    pub fn view_pixels(&self, view: usize) -> usize {
        self.views
            .get(view)
            .map_or(0, |v| v.camera.width as usize * v.camera.height as usize)
    }

    /// The region the last step rendered (None before any step).
    pub fn last_region(&self) -> Option<PixelRect> {
        self.last_step.map(|(_, region)| region)
    }

    /// Times the host has waited for the device (readbacks) so far.
    pub fn host_syncs(&self) -> u64 {
        self.syncs + self.raster.syncs
    }

    /// Puts `model` and its Adam state on the device, replacing what was
    /// there; the per-face weight statistics start at zero for its faces.
    pub fn load(&mut self, model: &Model<f32>, state: &OptimizerState) -> Result<()> {
        let nv = model.vertex_count();
        state.positions.check("vertex positions", nv * 3)?;
        state.sh.check("SH coefficients", nv * SH_VALUES)?;
        state.opacity_logits.check("opacity logits", nv)?;
        let ctx = self.backend.context().clone();
        let c = &mut self.pools.created;
        let params = self
            .backend
            .upload_model_into(model, &mut self.pools.model, c)?;
        let tensors = [&state.positions, &state.sh, &state.opacity_logits];
        for (t, m) in tensors.iter().enumerate() {
            self.pools.first[t].write(&ctx, &m.first, c);
            self.pools.second[t].write(&ctx, &m.second, c);
        }
        let nf = model.face_count();
        for w in &mut self.pools.face_weights {
            w.ensure(&ctx, (nf * 4) as u64, c);
        }
        if nf > 0 {
            let mut enc = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
            for w in &self.pools.face_weights {
                enc.clear_buffer(w.buffer(), 0, Some((nf * 4) as u64));
            }
            ctx.queue.submit([enc.finish()]);
        }
        self.face_weight_faces = nf;
        self.resident = Some(Resident {
            params,
            first: std::array::from_fn(|t| self.pools.first[t].buffer().clone()),
            second: std::array::from_fn(|t| self.pools.second[t].buffer().clone()),
            steps: tensors.map(|t| t.steps),
        });
        Ok(())
    }

    /// The settings a pass over view `view` renders with: a footprint region
    /// keeps the view's own supervision and the loss's margin.
    fn pass_settings(&self, view: usize, render: &RenderSettings) -> Result<RenderSettings> {
        let region = match render.region {
            Region::Full => Region::Full,
            Region::Footprint { include, margin } => {
                if margin < CROP_MARGIN {
                    bail!(
                        "a cropped pass needs a margin of at least {CROP_MARGIN} px (the SSIM window's reach) for an exact loss, not {margin}"
                    );
                }
                Region::Footprint {
                    include: include.union(self.views[view].include),
                    margin,
                }
            }
        };
        Ok(RenderSettings {
            region,
            ..render.clone()
        })
    }

    /// Records the loss kernels of a pass over view `view` whose render is in
    /// the raster pool: into result slot `slot` of `results`/`status`, over
    /// `groups` workgroups of pixels, with the image gradient when `gradient`.
    #[allow(clippy::too_many_arguments)]
    fn encode_loss(
        &self,
        rec: &mut Recorder<'_>,
        view: usize,
        background: [f32; 3],
        lambda_dssim: f64,
        slot: u32,
        groups: u32,
        gradient: bool,
        targets: (&wgpu::Buffer, &wgpu::Buffer),
    ) {
        let k = &self.kernels;
        let v = &self.views[view];
        let params = LossParams {
            width: v.camera.width,
            slot,
            partial_count: groups,
            gradient: gradient as u32,
            background: [background[0], background[1], background[2], 0.0],
            norm: v.norm,
            l1_weight: (1.0 - lambda_dssim) as f32,
            ssim_weight: lambda_dssim as f32,
            supervised: v.supervised as u32,
            taps: self.taps,
        };
        let (results, status) = targets;
        let image = self.raster.image();
        let frame = self.raster.frame();
        rec.dispatch(
            &k.ssim_rows,
            &params,
            &[
                (1, image),
                (2, &v.targets),
                (3, &v.from_background),
                (4, &self.rows),
                (10, frame),
            ],
            groups,
        );
        rec.dispatch(
            &k.ssim_maps,
            &params,
            &[
                (1, image),
                (2, &v.targets),
                (3, &v.from_background),
                (4, &self.rows),
                (5, &self.maps),
                (7, &self.partials),
                (9, status),
                (10, frame),
            ],
            groups,
        );
        if gradient {
            rec.dispatch(
                &k.ssim_grad_rows,
                &params,
                &[(4, &self.rows), (5, &self.maps), (10, frame)],
                groups,
            );
            rec.dispatch(
                &k.loss_grad,
                &params,
                &[
                    (1, image),
                    (2, &v.targets),
                    (3, &v.from_background),
                    (4, &self.rows),
                    (6, &self.upstream),
                    (10, frame),
                ],
                groups,
            );
        }
        rec.dispatch(
            &k.loss_total,
            &params,
            &[(7, &self.partials), (8, results), (9, status), (10, frame)],
            1,
        );
    }

    /// Queues one training iteration on the loaded model.
    pub fn step(&mut self, step: &Step) -> Result<()> {
        if step.view >= self.views.len() {
            bail!(
                "step on training view {} of {}",
                step.view,
                self.views.len()
            );
        }
        if !(0.0..=1.0).contains(&step.lambda_dssim) {
            bail!("lambda_dssim = {} must lie in [0, 1]", step.lambda_dssim);
        }
        if step.background.iter().any(|b| !b.is_finite()) {
            bail!("background colour {:?} is not finite", step.background);
        }
        let lr = step.learning_rates;
        for (name, v) in [
            ("positions", lr.positions),
            ("sh_dc", lr.sh_dc),
            ("sh_rest", lr.sh_rest),
            ("opacity", lr.opacity),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                bail!("learning rate of the {name} is {v} (expected finite and ≥ 0)");
            }
        }
        let settings = self.pass_settings(step.view, &step.render)?;
        if self.pending == SLOTS {
            self.collect()?;
        }
        let Some(resident) = self.resident.as_ref() else {
            bail!("device training step before a model was loaded");
        };
        let ctx = self.backend.context().clone();
        let camera = self.views[step.view].camera;
        let region = self
            .backend
            .render_on(
                &mut self.raster,
                &mut self.uniforms,
                &resident.params,
                &camera,
                &settings,
                BackgroundSource::Uniform(step.background),
            )?
            .region;
        let slot = self.pending as u32;
        let groups = groups_for(region.pixels(), THREADS_1D);
        let nf = resident.params.face_count;
        let mut uniforms = std::mem::take(&mut self.uniforms);
        let mut rec = Recorder::new(&ctx, &mut uniforms);
        rec.dispatch(
            &self.kernels.fold_face_weights,
            &FaceParams {
                face_count: nf as u32,
                pad: [0; 3],
            },
            &[
                (1, self.raster.face_stats()),
                (2, self.pools.face_weights[0].buffer()),
            ],
            groups_for(nf, THREADS_1D),
        );
        self.encode_loss(
            &mut rec,
            step.view,
            step.background,
            step.lambda_dssim,
            slot,
            groups,
            true,
            (&self.results, &self.status),
        );
        rec.submit();
        self.backend
            .backward_on(&self.raster, &mut self.grads, &mut uniforms, &self.upstream)?;

        let Some(resident) = self.resident.as_mut() else {
            bail!("device training step before a model was loaded");
        };
        let nv = resident.params.vertex_count;
        let tensors = [
            (
                &resident.params.positions,
                self.grads.positions(),
                nv * 3,
                3,
                3,
                lr.positions,
                lr.positions,
                4,
            ),
            (
                &resident.params.sh,
                self.grads.sh(),
                nv * SH_VALUES,
                SH_VALUES,
                3,
                lr.sh_dc,
                lr.sh_rest,
                16,
            ),
            (
                &resident.params.opacity_logits,
                self.grads.opacity_logits(),
                nv,
                1,
                1,
                lr.opacity,
                lr.opacity,
                64,
            ),
        ];
        let a = self.adam;
        let mut rec = Recorder::new(&ctx, &mut uniforms);
        for (t, (values, grad, count, row_width, split, lr_first, lr_rest, grad_bit)) in
            tensors.into_iter().enumerate()
        {
            resident.steps[t] += 1;
            let steps = i32::try_from(resident.steps[t]).unwrap_or(i32::MAX);
            let params = AdamParams {
                count: count as u32,
                row_width: row_width as u32,
                split,
                grad_bit,
                lr_first: lr_first as f32,
                lr_rest: lr_rest as f32,
                beta1: a.beta1 as f32,
                beta2: a.beta2 as f32,
                complement1: (1.0 - a.beta1) as f32,
                complement2: (1.0 - a.beta2) as f32,
                eps: a.eps as f32,
                bias1: (1.0 - a.beta1.powi(steps)) as f32,
                bias2: (1.0 - a.beta2.powi(steps)) as f32,
                slot,
                pad: [0; 2],
            };
            rec.dispatch(
                &self.kernels.adam,
                &params,
                &[
                    (1, values),
                    (2, grad),
                    (3, &resident.first[t]),
                    (4, &resident.second[t]),
                    (5, &self.status),
                ],
                groups_for(count, THREADS_1D),
            );
        }
        rec.submit();
        self.uniforms = uniforms;
        ctx.check_errors("a device training step")?;
        self.pending += 1;
        self.last_step = Some((step.view, region));
        Ok(())
    }

    /// Moves the finished steps' losses and flags from the device slots to the host.
    fn collect(&mut self) -> Result<()> {
        if self.pending == 0 {
            return Ok(());
        }
        let ctx = self.backend.context().clone();
        let n = self.pending as u64;
        let [results, status]: [Vec<u8>; 2] = self
            .readback
            .read(&ctx, &[(&self.results, 16 * n), (&self.status, 4 * n)])?
            .try_into()
            .map_err(|_| anyhow::anyhow!("two readbacks were asked for"))?;
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        enc.clear_buffer(&self.status, 0, Some(4 * n));
        ctx.queue.submit([enc.finish()]);
        let results: Vec<u32> = bytemuck::pod_collect_to_vec(&results);
        let status: Vec<u32> = bytemuck::pod_collect_to_vec(&status);
        self.syncs += 1;
        for (result, &bits) in results.chunks_exact(4).zip(&status) {
            let non_finite = STATUS_BITS
                .iter()
                .filter(|(bit, _)| bits & bit != 0)
                .map(|(_, what)| *what)
                .collect();
            self.collected.push(StepResult {
                loss: f32::from_bits(result[0]),
                non_finite,
            });
        }
        self.pending = 0;
        Ok(())
    }

    /// The steps finished since the last call, in order.
    pub fn results(&mut self) -> Result<Vec<StepResult>> {
        self.collect()?;
        Ok(std::mem::take(&mut self.collected))
    }

    /// The last step's loss gradient with respect to the rendered colour (RGB
    /// per pixel of that step's view, 0 outside the rendered region), read
    /// back for checks and diagnostics.
    pub fn last_image_gradient(&mut self, view: usize) -> Result<Vec<f32>> {
        let Some(v) = self.views.get(view) else {
            bail!("no training view {view} (there are {})", self.views.len());
        };
        let Some((last_view, region)) = self.last_step else {
            bail!("no training step was taken yet");
        };
        if last_view != view {
            bail!("the last step was on view {last_view}, not {view}");
        }
        let upstream: Vec<f32> = read_values(
            self.backend.context(),
            &self.upstream,
            region.pixels() * IMAGE_STRIDE,
        )?;
        self.syncs += 1;
        let w = v.camera.width as usize;
        let mut full = vec![0.0; w * v.camera.height as usize * 3];
        for (i, u) in upstream.chunks_exact(IMAGE_STRIDE).enumerate() {
            let (x, y) = (
                region.x0 as usize + i % region.width() as usize,
                region.y0 as usize + i / region.width() as usize,
            );
            full[3 * (y * w + x)..3 * (y * w + x) + 3].copy_from_slice(&u[..3]);
        }
        Ok(full)
    }

    /// Writes the device's parameters into `model` (which must have the loaded
    /// model's shape) and returns Adam's state.
    pub fn store(&mut self, model: &mut Model<f32>) -> Result<OptimizerState> {
        Ok(self.store_with_face_weights(model)?.0)
    }

    /// As [`DeviceTrainer::store`], with the running per-face maxima of
    /// [`DeviceTrainer::face_weights`] in the same readback.
    pub fn store_with_face_weights(
        &mut self,
        model: &mut Model<f32>,
    ) -> Result<(OptimizerState, FaceWeightArrays)> {
        let Some(resident) = &self.resident else {
            bail!("no model on the device to store");
        };
        let nv = resident.params.vertex_count;
        if model.vertex_count() != nv || model.face_count() != resident.params.face_count {
            bail!(
                "storing a device model of {nv} vertices / {} faces into one of {} / {}",
                resident.params.face_count,
                model.vertex_count(),
                model.face_count()
            );
        }
        // One readback for all eleven arrays: parameters, first and second
        // moments, then the face statistics.
        let bytes = [nv * 3, nv * SH_VALUES, nv].map(|n| (n * 4) as u64);
        let params = &resident.params;
        let mut sources = vec![
            (&params.positions, bytes[0]),
            (&params.sh, bytes[1]),
            (&params.opacity_logits, bytes[2]),
        ];
        sources.extend((0..3).map(|t| (&resident.first[t], bytes[t])));
        sources.extend((0..3).map(|t| (&resident.second[t], bytes[t])));
        let face_bytes = (self.face_weight_faces * 4) as u64;
        sources.extend(
            self.pools
                .face_weights
                .iter()
                .map(|w| (w.buffer(), face_bytes)),
        );
        let mut values = self
            .readback
            .read(self.backend.context(), &sources)?
            .into_iter()
            .map(|b| bytemuck::pod_collect_to_vec::<u8, f32>(&b));
        let mut next = || {
            values
                .next()
                .expect("a readback returns one result per buffer, and eleven were asked for")
        };
        let (positions, sh) = (next(), next());
        model.opacity_logits = next();
        for (v, p) in model.vertices.iter_mut().zip(positions.chunks_exact(3)) {
            v.copy_from_slice(p);
        }
        for (row, values) in model.sh.iter_mut().zip(sh.chunks_exact(SH_VALUES)) {
            for (coeff, rgb) in row.iter_mut().zip(values.chunks_exact(3)) {
                coeff.copy_from_slice(rgb);
            }
        }
        let [f0, f1, f2] = [next(), next(), next()];
        let [s0, s1, s2] = [next(), next(), next()];
        let moments = |first, second, t: usize| Moments {
            first,
            second,
            steps: resident.steps[t],
        };
        let state = OptimizerState {
            positions: moments(f0, s0, 0),
            sh: moments(f1, s1, 1),
            opacity_logits: moments(f2, s2, 2),
        };
        let faces = (next(), next());
        self.syncs += 1;
        Ok((state, faces))
    }

    /// Scores the loaded model on `views` over a black background, no
    /// gradient, each pass over the region `render.region` asks for (a
    /// footprint keeps each view's supervision, as in [`DeviceTrainer::step`]).
    /// All views are rendered and scored before one readback; a view that
    /// needs more tile entries than any render before it had makes the
    /// buffers grow and the evaluation run once more (a second readback).
    pub fn evaluate(
        &mut self,
        views: &[usize],
        render: &RenderSettings,
        lambda_dssim: f64,
    ) -> Result<Vec<ViewScore>> {
        if !(0.0..=1.0).contains(&lambda_dssim) {
            bail!("lambda_dssim = {lambda_dssim} must lie in [0, 1]");
        }
        if let Some(&v) = views.iter().find(|&&v| v >= self.views.len()) {
            bail!("evaluation of view {v} of {}", self.views.len());
        }
        if self.resident.is_none() {
            bail!("device evaluation before a model was loaded");
        }
        if views.is_empty() {
            return Ok(Vec::new());
        }
        let settings = views
            .iter()
            .map(|&v| self.pass_settings(v, render))
            .collect::<Result<Vec<_>>>()?;
        let ctx = self.backend.context().clone();
        let n = views.len();
        let c = &mut self.pools.created;
        self.pools.eval_results.ensure(&ctx, (16 * n) as u64, c);
        self.pools.eval_status.ensure(&ctx, (4 * n) as u64, c);
        for attempt in 0..2 {
            let capacity = self.raster.entry_capacity();
            let mut uniforms = std::mem::take(&mut self.uniforms);
            for (k, &v) in views.iter().enumerate() {
                let Some(resident) = self.resident.as_ref() else {
                    bail!("device evaluation before a model was loaded");
                };
                let camera = self.views[v].camera;
                let mut rec = Recorder::new(&ctx, &mut uniforms);
                if k == 0 {
                    rec.enc
                        .clear_buffer(self.pools.eval_status.buffer(), 0, Some((4 * n) as u64));
                }
                self.backend.encode_render(
                    &mut rec,
                    &mut self.raster,
                    &resident.params,
                    &camera,
                    &settings[k],
                    [0.0; 3],
                )?;
                let pixels = camera.width as usize * camera.height as usize;
                self.encode_loss(
                    &mut rec,
                    v,
                    [0.0; 3],
                    lambda_dssim,
                    k as u32,
                    groups_for(pixels, THREADS_1D),
                    false,
                    (
                        self.pools.eval_results.buffer(),
                        self.pools.eval_status.buffer(),
                    ),
                );
                rec.submit();
            }
            self.uniforms = uniforms;
            let [results, status]: [Vec<u8>; 2] = self
                .readback
                .read(
                    &ctx,
                    &[
                        (self.pools.eval_results.buffer(), (16 * n) as u64),
                        (self.pools.eval_status.buffer(), (4 * n) as u64),
                    ],
                )?
                .try_into()
                .map_err(|_| anyhow::anyhow!("two readbacks were asked for"))?;
            self.syncs += 1;
            ctx.check_errors("a device evaluation")?;
            let results: Vec<u32> = bytemuck::pod_collect_to_vec(&results);
            let status: Vec<u32> = bytemuck::pod_collect_to_vec(&status);
            let entries = results
                .chunks_exact(4)
                .map(|r| r[2] as usize)
                .max()
                .unwrap_or(0); // views is not empty
            if entries > capacity {
                if attempt > 0 {
                    bail!(
                        "a device evaluation needed {entries} tile entries after its buffers grew to {capacity}"
                    );
                }
                self.backend
                    .check_binding_size("tile entries", entries as u64 * 4)?;
                self.raster.ensure_entries(&ctx, entries);
                continue;
            }
            if let Some(k) = status.iter().position(|&s| s != 0) {
                bail!(
                    "the evaluation render of view {} is not finite (parameters overflowed)",
                    views[k]
                );
            }
            return Ok(results
                .chunks_exact(4)
                .zip(views)
                .map(|(r, &v)| ViewScore {
                    loss: f32::from_bits(r[0]) as f64,
                    squared_error: f32::from_bits(r[1]) as f64,
                    total_weight: self.views[v].total_weight,
                })
                .collect());
        }
        // Both attempts either returned or continued once; the second cannot continue.
        unreachable!("the evaluation loop returns by its second attempt")
    }

    /// The running per-face maxima of the blending weight over this epoch's
    /// and the previous epoch's training renders (one readback).
    pub fn face_weights(&mut self) -> Result<FaceWeightArrays> {
        if self.resident.is_none() {
            bail!("no model on the device for face statistics");
        }
        let bytes = (self.face_weight_faces * 4) as u64;
        let [current, previous]: [Vec<u8>; 2] = self
            .readback
            .read(
                self.backend.context(),
                &[
                    (self.pools.face_weights[0].buffer(), bytes),
                    (self.pools.face_weights[1].buffer(), bytes),
                ],
            )?
            .try_into()
            .map_err(|_| anyhow::anyhow!("two readbacks were asked for"))?;
        self.syncs += 1;
        Ok((
            bytemuck::pod_collect_to_vec(&current),
            bytemuck::pod_collect_to_vec(&previous),
        ))
    }

    /// Replaces the running per-face maxima (after the host remapped them
    /// through a topology edit); one value per face of the loaded model.
    pub fn set_face_weights(&mut self, current: &[f32], previous: &[f32]) -> Result<()> {
        let Some(resident) = &self.resident else {
            bail!("no model on the device for face statistics");
        };
        let nf = resident.params.face_count;
        if current.len() != nf || previous.len() != nf {
            bail!(
                "face weights for {} and {} faces, but the loaded model has {nf}",
                current.len(),
                previous.len()
            );
        }
        if let Some(w) = current
            .iter()
            .chain(previous)
            .find(|w| !(w.is_finite() && **w >= 0.0))
        {
            bail!("face weight {w} is not finite and ≥ 0");
        }
        let ctx = self.backend.context().clone();
        let c = &mut self.pools.created;
        let [now, before] = &mut self.pools.face_weights;
        now.write(&ctx, current, c);
        before.write(&ctx, previous, c);
        Ok(())
    }

    /// Every training view has been rendered once more: this epoch's maxima
    /// become the previous epoch's, and the current ones start at zero.
    pub fn end_epoch(&mut self) {
        self.pools.face_weights.swap(0, 1);
        let bytes = (self.face_weight_faces * 4) as u64;
        if bytes > 0 {
            let ctx = self.backend.context();
            let mut enc = ctx
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
            enc.clear_buffer(self.pools.face_weights[0].buffer(), 0, Some(bytes));
            ctx.queue.submit([enc.finish()]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use objectsplat_gpu::check_mirrors_wgsl;
    use std::mem::{offset_of, size_of};

    macro_rules! same_names {
        ($t:ty; $($f:ident),*) => { [$((stringify!($f), offset_of!($t, $f))),*] };
    }

    #[test]
    fn loss_params_mirror_the_wgsl_struct() {
        let rust = same_names!(LossParams; width, slot, partial_count, gradient, background,
            norm, l1_weight, ssim_weight, supervised, taps);
        check_mirrors_wgsl(
            TRAIN_LOSS_WGSL,
            "LossParams",
            size_of::<LossParams>(),
            &rust,
        )
        .unwrap();
    }

    #[test]
    fn adam_params_mirror_the_wgsl_struct() {
        let pad = offset_of!(AdamParams, pad);
        let mut rust = same_names!(AdamParams; count, row_width, split, grad_bit, lr_first,
            lr_rest, beta1, beta2, complement1, complement2, eps, bias1, bias2, slot)
        .to_vec();
        rust.extend([("pad0", pad), ("pad1", pad + 4)]);
        check_mirrors_wgsl(
            TRAIN_ADAM_WGSL,
            "AdamParams",
            size_of::<AdamParams>(),
            &rust,
        )
        .unwrap();
    }

    #[test]
    fn face_params_mirror_the_wgsl_struct() {
        let pad = offset_of!(FaceParams, pad);
        let mut rust = same_names!(FaceParams; face_count).to_vec();
        rust.extend([("_pad0", pad), ("_pad1", pad + 4), ("_pad2", pad + 8)]);
        check_mirrors_wgsl(
            TRAIN_FACES_WGSL,
            "FaceParams",
            size_of::<FaceParams>(),
            &rust,
        )
        .unwrap();
    }

    #[test]
    fn taps_equal_the_cpu_loss_window() {
        let taps = gaussian_taps();
        let sum: f32 = taps.iter().sum();
        assert!((sum - 1.0).abs() < 1e-6, "{taps:?}");
        assert_eq!(taps[11], 0.0);
        assert_eq!(taps[5], taps.iter().copied().fold(0.0, f32::max));
    }
}
