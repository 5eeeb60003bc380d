//! [`DeviceTrainer`]: training iterations and evaluations that stay on the
//! device. The parameters, Adam's moments (objectsplat-optim's state), the
//! per-face weight statistics and every view's target live in device
//! buffers; one step renders (the forward of [`WgpuBackend`]), scores the
//! render (`loss.rs`), adds the geometric terms (`depth.rs`), folds the face
//! statistics (`faces.rs`), runs the backward pass and applies Adam
//! (`adam.rs`), with no image or gradient crossing to the host.
//!
//! What is rendered may be more than what is trained: the background trains
//! behind frozen occluders (trained objects), appended after the trained
//! model's vertices and faces ([`Trained`]). The composite is rendered and
//! depth-tested as one model, each frozen face with its own window sharpness
//! σ; only the trained prefix moves and has face statistics.
//!
//! A step whose settings ask for [`Region::Footprint`] renders, scores and
//! back-propagates only the footprint of the drawn faces and of the view's
//! own supervision, grown by the loss's crop margin: the loss and the
//! gradient equal the whole frame's (see loss.wgsl).
//!
//! A trainer made [`DeviceTrainer::with_supersample`] renders each pass at
//! the view's camera scaled by the factor, box-filters the render to the
//! view's pixels for the loss and the depth terms, and spreads their gradient
//! back over the samples for the backward pass (`supersample.rs`), as the
//! host's loop does with `objectsplat_raster::supersample`.
//!
//! A step is recorded and submitted without waiting for the device: its
//! tile-entry buffers are sized from the entry counts seen so far (with
//! headroom), and a step whose render needs more entries than they hold is
//! not applied (STATUS_OVERFLOW) but replayed with larger buffers when the
//! host collects the results. Losses and divergence flags collect in device
//! slots and come back in batches ([`DeviceTrainer::results`]); the
//! parameters come back only when the host needs the model
//! ([`DeviceTrainer::store`]). Every buffer is pooled: once the pools have
//! grown to the model and the images, a step creates none.

pub mod adam;
mod depth;
mod faces;
mod loss;
mod supersample;
mod views;

pub use adam::ADAM_WGSL;
pub use depth::{DEPTH_WGSL, DepthWeights};
pub use faces::FACES_WGSL;
pub use loss::LOSS_WGSL;
pub use supersample::SUPERSAMPLE_WGSL;
pub use views::TrainingView;

use crate::kernels::{Pooled, Recorder, UniformArena, groups_for, storage};
use crate::raster::{BackwardCover, GradPool, ModelBuffers, ModelPool, RasterPool, WgpuBackend};
use adam::{AdamKernel, AdamSettings, TensorUpdate};
use anyhow::{Result, bail};
use depth::{DepthBuffers, DepthKernels};
use faces::FoldKernel;
use loss::{LossBuffers, LossKernels, LossPass, PARTIAL_MAPS, ROW_MAPS};
use objectsplat_gpu::GpuContext;
use objectsplat_gpu::{Readback, read_values};
use objectsplat_optim::{LearningRates, Optim, SH_VALUES, active_sh_values};
use objectsplat_raster::backend::{PixelRect, Region};
use objectsplat_raster::loss::CROP_MARGIN;
use objectsplat_raster::{Model, RenderSettings};
use supersample::SampleKernels;
use views::ViewBuffers;

const THREADS_1D: usize = 256;
/// Steps whose losses and flags the device holds before the host collects them.
const SLOTS: usize = 256;
const IMAGE_STRIDE: usize = 6;
/// Tile-entry buffers are sized this much above the largest count seen.
const ENTRY_HEADROOM: f64 = 1.25;

/// What a set bit of a step's status means (status.wgsl's STATUS_* and the
/// bits adam.wgsl raises per tensor).
const STATUS_BITS: [(u32, &str); 9] = [
    (1, "the render"),
    (2, "the loss"),
    (4, "the gradient of the vertex positions"),
    (8, "the vertex positions"),
    (16, "the gradient of the SH coefficients"),
    (32, "the SH coefficients"),
    (64, "the gradient of the opacity logits"),
    (128, "the opacity logits"),
    (256, "the gradient of the depth terms"),
];
/// status.wgsl's STATUS_OVERFLOW: the step was not applied (it is replayed).
const STATUS_OVERFLOW: u32 = 512;

/// How much of a loaded model trains: its first `vertices` vertices and
/// `faces` faces. The rest (frozen occluders) is rendered with it, depth-tested,
/// each frozen face with its own σ, but never moves and has no statistics.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Trained {
    pub vertices: usize,
    pub faces: usize,
}

impl Trained {
    /// All of `model`.
    pub fn all_of(model: &Model<f32>) -> Self {
        Trained {
            vertices: model.vertex_count(),
            faces: model.face_count(),
        }
    }
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
    /// The trained model's SH degree: its higher bands do not move, even
    /// where `render.sh_degree` (raised to the occluders') renders them.
    pub sh_degree: u32,
    /// The geometric terms of this step.
    pub depth: DepthWeights,
}

/// A finished step as the host learns of it.
#[derive(Debug, Clone, PartialEq)]
pub struct StepResult {
    pub loss: f32,
    /// What turned non-finite in this step (render, loss, a gradient or a
    /// parameter tensor); empty when all is finite.
    pub non_finite: Vec<&'static str>,
    /// Pixels the step rendered (its region).
    pub rendered_pixels: usize,
}

/// Per face, the running maximum of the blending weight over the training
/// renders of the current epoch and of the previous one.
pub type FaceWeightArrays = (Vec<f32>, Vec<f32>);

/// A training step's render and backward input as read back by
/// [`DeviceTrainer::last_pass`]: per pixel of `region` (row-major), stride 6.
#[derive(Debug, Clone)]
pub struct LastPass {
    pub view: usize,
    pub region: PixelRect,
    /// Colour (3), coverage α, expected depth Σ w z, median depth.
    pub image: Vec<f32>,
    /// The loss's gradient with respect to each of those.
    pub upstream: Vec<f32>,
}

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

/// The loaded model on the device.
struct Resident {
    params: ModelBuffers,
    trained: Trained,
    /// None: loaded without optimizer state (for evaluation only).
    adam: Option<AdamSettings>,
    /// Adam updates applied so far, per tensor (the bias correction).
    steps: [u64; 3],
}

struct Kernels {
    loss: LossKernels,
    adam: AdamKernel,
    fold: FoldKernel,
    depth: DepthKernels,
}

/// Grow-only storage of the trainer beyond the raster pools.
struct TrainerPools {
    model: ModelPool,
    first: [Pooled; 3],
    second: [Pooled; 3],
    /// Running per-face maxima of the blending weight: current and previous epoch.
    face_weights: [Pooled; 2],
    /// Per-face maxima over an evaluation's renders.
    face_max: Pooled,
    eval_results: Pooled,
    eval_status: Pooled,
    created: u64,
}

/// Per-pixel scratch of the loss and the depth terms (sized to the largest view).
struct Scratch {
    rows: wgpu::Buffer,
    maps: wgpu::Buffer,
    upstream: wgpu::Buffer,
    partials: wgpu::Buffer,
    inverse: wgpu::Buffer,
    runs: wgpu::Buffer,
}

/// What a supersampled trainer renders into beyond the raster pool: the
/// render box-filtered to the view's pixels and its frame record (what the
/// loss and the depth terms read), and the gradient spread over the samples.
struct Sampled {
    factor: u32,
    kernels: SampleKernels,
    image: wgpu::Buffer,
    frame: wgpu::Buffer,
    upstream: wgpu::Buffer,
}

/// The image and frame record the loss and the depth terms read: the box
/// filter's when supersampling, else the render's.
fn scored<'a>(
    sampled: &'a Option<Sampled>,
    raster: &'a RasterPool,
) -> (&'a wgpu::Buffer, &'a wgpu::Buffer) {
    match sampled {
        Some(s) => (&s.image, &s.frame),
        None => (raster.image(), raster.frame()),
    }
}

/// Records the box filter of the render just recorded into `raster` for a
/// view of `pixels` pixels (when supersampling).
fn encode_filter(
    sampled: &Option<Sampled>,
    raster: &RasterPool,
    rec: &mut Recorder<'_>,
    pixels: usize,
) {
    if let Some(s) = sampled {
        s.kernels.encode_filter(
            rec,
            s.factor,
            pixels,
            raster.frame(),
            raster.image(),
            &s.frame,
            &s.image,
        );
    }
}

/// Training steps on the device (see the module documentation).
pub struct DeviceTrainer {
    /// `s × s` samples per pixel (None: one).
    sampled: Option<Sampled>,
    backend: WgpuBackend,
    kernels: Kernels,
    views: Vec<ViewBuffers>,
    resident: Option<Resident>,
    uniforms: UniformArena,
    raster: RasterPool,
    grads: GradPool,
    pools: TrainerPools,
    scratch: Scratch,
    results: wgpu::Buffer,
    status: wgpu::Buffer,
    readback: Readback,
    /// The steps recorded since the last collection, in slot order (kept to
    /// replay one whose render overflowed), with the place of a replay's
    /// result in `collected`.
    queued: Vec<(Step, Option<usize>)>,
    collected: Vec<StepResult>,
    /// View of the last step (for [`DeviceTrainer::last_image_gradient`]).
    last_view: Option<usize>,
    /// The most tile entries a step's render has needed so far.
    max_entries: usize,
    /// Steps replayed because their render overflowed the entry buffers.
    replays: u64,
    /// Host waits for the device outside the raster pool's.
    syncs: u64,
    created: u64,
}

impl DeviceTrainer {
    /// Uploads the views (training and held-out alike) and compiles the kernels.
    pub fn new(backend: &WgpuBackend, views: &[TrainingView]) -> Result<DeviceTrainer> {
        Self::streamed(backend, views.len(), |i| Ok(views[i].clone()))
    }

    /// As [`DeviceTrainer::new`] for `count` views made one at a time by
    /// `view(index)` and uploaded as they come, so that the host holds one
    /// view's whole-frame planes at a time however many views there are.
    pub fn streamed(
        backend: &WgpuBackend,
        count: usize,
        mut view: impl FnMut(usize) -> Result<TrainingView>,
    ) -> Result<DeviceTrainer> {
        if count == 0 {
            bail!("device training needs at least one training view");
        }
        let ctx = backend.context().clone();
        ctx.check_errors("setup before compiling the training kernels")?;
        let kernels = Kernels {
            loss: LossKernels::new(&ctx),
            adam: AdamKernel::new(&ctx),
            fold: FoldKernel::new(&ctx),
            depth: DepthKernels::new(&ctx),
        };
        ctx.check_errors("compiling the training kernels")?;
        let views = (0..count)
            .map(|i| ViewBuffers::upload(&ctx, &view(i)?, i))
            .collect::<Result<Vec<_>>>()?;
        let pixels = views.iter().map(ViewBuffers::pixels).max().unwrap_or(0); // views is not empty (checked above)
        backend.check_binding_size("SSIM planes", (pixels * ROW_MAPS * 4) as u64)?;
        let bytes = |n: usize| (n * 4) as u64;
        let mut created = 0;
        let mut pooled = |label| Pooled::new(&ctx, label, &mut created);
        let pools = TrainerPools {
            first: [(); 3].map(|_| pooled("adam first moment")),
            second: [(); 3].map(|_| pooled("adam second moment")),
            face_weights: [
                pooled("face weights (current epoch)"),
                pooled("face weights (previous epoch)"),
            ],
            face_max: pooled("face weights (evaluation)"),
            eval_results: pooled("evaluation results"),
            eval_status: pooled("evaluation status"),
            model: ModelPool::new(&ctx, &mut created),
            created: 0,
        };
        let scratch = Scratch {
            rows: storage(&ctx, "ssim rows", bytes(pixels * ROW_MAPS)),
            maps: storage(&ctx, "ssim partial maps", bytes(pixels * PARTIAL_MAPS)),
            upstream: storage(&ctx, "loss gradient", bytes(pixels * IMAGE_STRIDE)),
            partials: storage(
                &ctx,
                "loss partial sums",
                bytes(4 * groups_for(pixels, THREADS_1D) as usize),
            ),
            inverse: storage(&ctx, "inverse depth", bytes(pixels)),
            runs: storage(&ctx, "planar runs", 4),
        };
        let results = storage(&ctx, "step results", bytes(4 * SLOTS));
        let status = storage(&ctx, "step status", bytes(SLOTS));
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        enc.clear_buffer(&status, 0, None);
        ctx.queue.submit([enc.finish()]);
        Ok(DeviceTrainer {
            sampled: None,
            backend: backend.clone(),
            kernels,
            views,
            resident: None,
            uniforms: UniformArena::default(),
            raster: RasterPool::new(&ctx),
            grads: GradPool::new(&ctx),
            pools,
            scratch,
            results,
            status,
            readback: Readback::default(),
            queued: Vec::new(),
            collected: Vec::new(),
            last_view: None,
            max_entries: 0,
            replays: 0,
            syncs: 0,
            created: created + 8,
        })
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

    /// The trainer rendering `factor × factor` samples per pixel (1, 2 or 4),
    /// box-filtered for the loss as `objectsplat_raster::supersample` does.
    pub fn with_supersample(mut self, factor: u32) -> Result<DeviceTrainer> {
        objectsplat_raster::supersample::validate(factor)?;
        if factor == 1 {
            self.sampled = None;
            return Ok(self);
        }
        let ctx = self.backend.context().clone();
        let pixels = self
            .views
            .iter()
            .map(ViewBuffers::pixels)
            .max()
            .unwrap_or(0); // views is not empty (checked at creation)
        let samples = pixels * (factor * factor) as usize;
        self.backend.check_binding_size(
            "supersampled loss gradient",
            (samples * IMAGE_STRIDE * 4) as u64,
        )?;
        let kernels = SampleKernels::new(&ctx);
        ctx.check_errors("compiling the supersampling kernels")?;
        self.sampled = Some(Sampled {
            factor,
            kernels,
            image: storage(
                &ctx,
                "box-filtered render",
                (pixels * IMAGE_STRIDE * 4) as u64,
            ),
            frame: storage(&ctx, "box-filtered frame record", 64),
            upstream: storage(
                &ctx,
                "loss gradient per sample",
                (samples * IMAGE_STRIDE * 4) as u64,
            ),
        });
        self.created += 3;
        Ok(self)
    }

    /// The camera a pass on view `view` renders: the view's, scaled by the
    /// supersampling factor.
    fn pass_camera(&self, view: usize) -> objectsplat_core::Camera {
        let camera = self.views[view].camera;
        match &self.sampled {
            Some(s) => camera.scaled(camera.width * s.factor, camera.height * s.factor),
            None => camera,
        }
    }

    /// Pixels of view `view`'s frame (0 for a view that does not exist).
    pub fn view_pixels(&self, view: usize) -> usize {
        self.views.get(view).map_or(0, ViewBuffers::pixels)
    }

    /// Times the host has waited for the device (readbacks) so far.
    pub fn host_syncs(&self) -> u64 {
        self.syncs + self.raster.syncs
    }

    /// Steps replayed because their render needed more tile entries than the
    /// buffers held at the time.
    pub fn replays(&self) -> u64 {
        self.replays
    }

    /// Puts `model` on the device, replacing what was there: its first
    /// `trained` vertices and faces train with `optim`'s state (zero moments
    /// when None; rows must match `trained.vertices`), the rest is frozen
    /// (with its per-face σ from `model.face_sigma`). The per-face weight
    /// statistics start at zero. Steps queued before are collected first.
    pub fn load(
        &mut self,
        model: &Model<f32>,
        trained: Trained,
        optim: Option<&Optim>,
    ) -> Result<()> {
        if trained.vertices > model.vertex_count() || trained.faces > model.face_count() {
            bail!(
                "{} trained vertices / {} faces of a model of {} / {}",
                trained.vertices,
                trained.faces,
                model.vertex_count(),
                model.face_count()
            );
        }
        if let Some(o) = optim
            && o.rows() != trained.vertices
        {
            bail!(
                "Adam state of {} vertices for {} trained vertices",
                o.rows(),
                trained.vertices
            );
        }
        self.collect()?;
        let ctx = self.backend.context().clone();
        let c = &mut self.pools.created;
        let previous_faces = self.resident.as_ref().map(|r| r.params.face_count);
        let params =
            self.backend
                .upload_model_into(model, trained.faces, &mut self.pools.model, c)?;
        if let Some(o) = optim {
            for (t, g) in o.groups().iter().enumerate() {
                self.pools.first[t].write(&ctx, g.first_moment(), c);
                self.pools.second[t].write(&ctx, g.second_moment(), c);
            }
        }
        let nf = trained.faces;
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
        // More faces draw more tile entries: scale the sizing with them.
        if let Some(before) = previous_faces.filter(|&f| f > 0 && model.face_count() > f) {
            let grown = self.max_entries as f64 * model.face_count() as f64 / before as f64;
            grow_entries(&mut self.raster, &ctx, grown as usize);
        }
        self.resident = Some(Resident {
            params,
            trained,
            adam: optim.map(AdamSettings::of),
            steps: match optim {
                Some(o) => o.groups().map(|g| g.steps),
                None => [0; 3],
            },
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
        let settings = RenderSettings {
            region,
            ..render.clone()
        };
        Ok(match &self.sampled {
            Some(s) => {
                let camera = &self.views[view].camera;
                objectsplat_raster::supersample::fine_view(camera, &settings, s.factor).1
            }
            None => settings,
        })
    }

    fn check_step(&self, step: &Step) -> Result<()> {
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
            ("depth at measured points (weight)", step.depth.points),
            ("planar prior (weight)", step.depth.planar),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                bail!("learning rate of the {name} is {v} (expected finite and ≥ 0)");
            }
        }
        Ok(())
    }

    /// Queues one training iteration on the loaded model.
    pub fn step(&mut self, step: &Step) -> Result<()> {
        self.check_step(step)?;
        match &self.resident {
            None => bail!("device training step before a model was loaded"),
            Some(r) if r.adam.is_none() => {
                bail!("device training step on a model loaded without optimizer state")
            }
            Some(_) => {}
        }
        if self.queued.len() == SLOTS {
            self.collect()?;
        }
        self.record_step(step, self.queued.len() as u32)?;
        self.queued.push((step.clone(), None));
        Ok(())
    }

    /// Records and submits `step` into result slot `slot`.
    fn record_step(&mut self, step: &Step, slot: u32) -> Result<()> {
        let settings = self.pass_settings(step.view, &step.render)?;
        let Some(resident) = self.resident.as_ref() else {
            bail!("device training step before a model was loaded");
        };
        let ctx = self.backend.context().clone();
        let camera = self.pass_camera(step.view);
        let view = &self.views[step.view];
        if self.max_entries == 0 {
            // Nothing measured yet: size the buffers from this render's count.
            let entries = self.backend.measure_entries(
                &mut self.raster,
                &mut self.uniforms,
                &resident.params,
                &camera,
                &settings,
            )?;
            self.max_entries = entries.max(1);
            grow_entries(&mut self.raster, &ctx, self.max_entries);
        }
        let capacity = self.raster.entry_capacity();
        let pixels = view.pixels();
        let groups = groups_for(pixels, THREADS_1D);
        let mut uniforms = std::mem::take(&mut self.uniforms);
        let mut rec = Recorder::new(&ctx, &mut uniforms);
        let raster_params = self.backend.encode_render(
            &mut rec,
            &mut self.raster,
            &resident.params,
            &camera,
            &settings,
            step.background,
        )?;
        encode_filter(&self.sampled, &self.raster, &mut rec, view.pixels());
        let (image, frame) = scored(&self.sampled, &self.raster);
        self.kernels.loss.encode(
            &mut rec,
            &LossPass {
                view,
                background: step.background,
                lambda_dssim: step.lambda_dssim,
                slot,
                groups,
                gradient: true,
                entry_capacity: capacity as u32,
            },
            &LossBuffers {
                image,
                frame,
                rows: &self.scratch.rows,
                maps: &self.scratch.maps,
                upstream: &self.scratch.upstream,
                partials: &self.scratch.partials,
                results: &self.results,
                status: &self.status,
            },
        );
        self.kernels.fold.encode(
            &mut rec,
            resident.trained.faces,
            self.raster.face_stats(),
            self.pools.face_weights[0].buffer(),
            Some(slot),
            &self.status,
        );
        self.kernels.depth.encode(
            &mut rec,
            view,
            step.depth,
            slot,
            groups,
            &DepthBuffers {
                image,
                upstream: &self.scratch.upstream,
                frame,
                inverse: &self.scratch.inverse,
                runs: &self.scratch.runs,
                status: &self.status,
            },
        );
        let upstream = match &self.sampled {
            Some(s) => {
                s.kernels.encode_spread(
                    &mut rec,
                    s.factor,
                    view.pixels(),
                    self.raster.frame(),
                    &self.scratch.upstream,
                    &s.upstream,
                );
                &s.upstream
            }
            None => &self.scratch.upstream,
        };
        self.backend.encode_backward(
            &mut rec,
            &self.raster,
            &mut self.grads,
            &raster_params,
            &resident.params,
            BackwardCover::whole_image(camera.width, camera.height),
            upstream,
        );
        let Some(resident) = self.resident.as_mut() else {
            bail!("device training step before a model was loaded");
        };
        let Some(adam) = resident.adam else {
            bail!("device training step on a model loaded without optimizer state");
        };
        let params = &resident.params;
        let tensors = [
            (&params.positions, self.grads.positions()),
            (&params.sh, self.grads.sh()),
            (&params.opacity_logits, self.grads.opacity_logits()),
        ];
        let updates: [TensorUpdate; 3] = std::array::from_fn(|t| TensorUpdate {
            values: tensors[t].0,
            grads: tensors[t].1,
            first: self.pools.first[t].buffer(),
            second: self.pools.second[t].buffer(),
            steps: resident.steps[t],
        });
        self.kernels.adam.encode(
            &mut rec,
            adam,
            &step.learning_rates,
            updates,
            resident.trained.vertices,
            active_sh_values(step.sh_degree),
            slot,
            &self.status,
        );
        for s in &mut resident.steps {
            *s += 1;
        }
        rec.submit();
        self.uniforms = uniforms;
        ctx.check_errors("a device training step")?;
        self.last_view = Some(step.view);
        Ok(())
    }

    /// Moves the finished steps' losses and flags from the device slots to
    /// the host. A step whose render overflowed the entry buffers was not
    /// applied: it is replayed with buffers grown to the counts seen, after
    /// the steps queued behind it (a reordering, not a lost step), and its
    /// result takes its place.
    fn collect(&mut self) -> Result<()> {
        for _round in 0..4 {
            if self.queued.is_empty() {
                return Ok(());
            }
            let ctx = self.backend.context().clone();
            let n = self.queued.len() as u64;
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
            self.syncs += 1;
            let results: Vec<u32> = bytemuck::pod_collect_to_vec(&results);
            let status: Vec<u32> = bytemuck::pod_collect_to_vec(&status);
            let queued = std::mem::take(&mut self.queued);
            let mut overflowed = Vec::new();
            for ((result, &bits), (step, place)) in results.chunks_exact(4).zip(&status).zip(queued)
            {
                self.max_entries = self.max_entries.max(result[2] as usize);
                let place = place.unwrap_or_else(|| {
                    self.collected.push(StepResult {
                        loss: f32::NAN,
                        non_finite: Vec::new(),
                        rendered_pixels: 0,
                    });
                    self.collected.len() - 1
                });
                if bits & STATUS_OVERFLOW != 0 {
                    overflowed.push((step, place));
                    continue;
                }
                self.collected[place] = StepResult {
                    loss: f32::from_bits(result[0]),
                    non_finite: STATUS_BITS
                        .iter()
                        .filter(|(bit, _)| bits & bit != 0)
                        .map(|(_, what)| *what)
                        .collect(),
                    rendered_pixels: result[3] as usize,
                };
            }
            if overflowed.is_empty() {
                return Ok(());
            }
            grow_entries(&mut self.raster, &ctx, self.max_entries);
            // The skipped steps spent a bias-correction step each without an update.
            if let Some(resident) = self.resident.as_mut() {
                for s in &mut resident.steps {
                    *s -= overflowed.len() as u64;
                }
            }
            for (slot, (step, place)) in overflowed.into_iter().enumerate() {
                self.replays += 1;
                self.record_step(&step, slot as u32)?;
                self.queued.push((step, Some(place)));
            }
        }
        bail!("device training steps kept overflowing their tile-entry buffers after growing them")
    }

    /// The steps finished since the last call, in the order they were queued
    /// (waiting for the device).
    pub fn results(&mut self) -> Result<Vec<StepResult>> {
        self.collect()?;
        Ok(std::mem::take(&mut self.collected))
    }

    /// The results that came back with an earlier wait (a full set of slots,
    /// an evaluation, a store), without waiting: in queue order, a prefix of
    /// what [`DeviceTrainer::results`] would return.
    pub fn take_collected(&mut self) -> Vec<StepResult> {
        std::mem::take(&mut self.collected)
    }

    /// The last step's render and the gradient its backward pass started
    /// from, read back for checks and diagnostics (after collecting the queued steps).
    pub fn last_pass(&mut self) -> Result<LastPass> {
        let Some(view) = self.last_view else {
            bail!("no training step was taken yet");
        };
        self.collect()?;
        let ctx = self.backend.context().clone();
        let (image, frame) = scored(&self.sampled, &self.raster);
        let frame: Vec<u32> = read_values(&ctx, frame, 5)?;
        let region = PixelRect {
            x0: frame[1],
            y0: frame[2],
            x1: frame[3],
            y1: frame[4],
        };
        let values = region.pixels() * IMAGE_STRIDE;
        let [image, upstream]: [Vec<u8>; 2] = self
            .readback
            .read(
                &ctx,
                &[
                    (image, (values * 4) as u64),
                    (&self.scratch.upstream, (values * 4) as u64),
                ],
            )?
            .try_into()
            .map_err(|_| anyhow::anyhow!("two readbacks were asked for"))?;
        self.syncs += 2;
        Ok(LastPass {
            view,
            region,
            image: bytemuck::pod_collect_to_vec(&image),
            upstream: bytemuck::pod_collect_to_vec(&upstream),
        })
    }

    /// The last step's loss gradient with respect to the rendered colour (RGB
    /// per pixel of that step's view, 0 outside the rendered region).
    pub fn last_image_gradient(&mut self, view: usize) -> Result<Vec<f32>> {
        let Some(v) = self.views.get(view) else {
            bail!("no training view {view} (there are {})", self.views.len());
        };
        let w = v.camera.width as usize;
        let mut full = vec![0.0; w * v.camera.height as usize * 3];
        let pass = self.last_pass()?;
        if pass.view != view {
            bail!("the last step was on view {}, not {view}", pass.view);
        }
        for (i, u) in pass.upstream.chunks_exact(IMAGE_STRIDE).enumerate() {
            let (x, y) = (
                pass.region.x0 as usize + i % pass.region.width() as usize,
                pass.region.y0 as usize + i / pass.region.width() as usize,
            );
            full[3 * (y * w + x)..3 * (y * w + x) + 3].copy_from_slice(&u[..3]);
        }
        Ok(full)
    }

    /// Writes the device's trained parameters into `model` (which must have
    /// the trained part's shape) and Adam's state into `optim`, and returns
    /// the running per-face maxima of [`DeviceTrainer::face_weights`], all
    /// in one readback (after collecting the queued steps).
    pub fn store(&mut self, model: &mut Model<f32>, optim: &mut Optim) -> Result<FaceWeightArrays> {
        self.collect()?;
        let Some(resident) = &self.resident else {
            bail!("no model on the device to store");
        };
        let Trained {
            vertices: nv,
            faces: nf,
        } = resident.trained;
        if model.vertex_count() != nv || model.face_count() != nf || optim.rows() != nv {
            bail!(
                "storing a device model of {nv} vertices / {nf} faces into one of {} / {} \
                 (Adam state of {} rows)",
                model.vertex_count(),
                model.face_count(),
                optim.rows()
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
        sources.extend((0..3).map(|t| (self.pools.first[t].buffer(), bytes[t])));
        sources.extend((0..3).map(|t| (self.pools.second[t].buffer(), bytes[t])));
        let face_bytes = (nf * 4) as u64;
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
        let first = [next(), next(), next()];
        let second = [next(), next(), next()];
        let steps = resident.steps;
        for ((group, (m, v)), steps) in optim
            .groups_mut()
            .into_iter()
            .zip(first.into_iter().zip(second))
            .zip(steps)
        {
            group.set_moments(m, v, steps)?;
        }
        let faces = (next(), next());
        self.syncs += 1;
        Ok(faces)
    }

    /// Scores the loaded model on `views` over a black background, no
    /// gradient, each pass over the region `render.region` asks for (a
    /// footprint keeps each view's supervision, as in [`DeviceTrainer::step`]).
    /// All views are rendered and scored before one readback; a view that
    /// needs more tile entries than the buffers hold makes them grow and the
    /// evaluation run once more (a second readback).
    pub fn evaluate(
        &mut self,
        views: &[usize],
        render: &RenderSettings,
        lambda_dssim: f64,
    ) -> Result<Vec<ViewScore>> {
        if !(0.0..=1.0).contains(&lambda_dssim) {
            bail!("lambda_dssim = {lambda_dssim} must lie in [0, 1]");
        }
        let results = self.render_views(views, render, Some(lambda_dssim))?;
        Ok(results
            .chunks_exact(4)
            .zip(views)
            .map(|(r, &v)| ViewScore {
                loss: f32::from_bits(r[0]) as f64,
                squared_error: f32::from_bits(r[1]) as f64,
                total_weight: self.views[v].total_weight,
            })
            .collect())
    }

    /// Per trained face, the largest blending weight over renders of the
    /// trained faces alone (no occluders) of `views` over black: the host
    /// trainer's `face_max_weight`, with one readback (two when the entry
    /// buffers must grow).
    pub fn face_max_weight(
        &mut self,
        views: &[usize],
        render: &RenderSettings,
    ) -> Result<Vec<f32>> {
        let Some(resident) = &self.resident else {
            bail!("no model on the device for face statistics");
        };
        let nf = resident.trained.faces;
        let ctx = self.backend.context().clone();
        let c = &mut self.pools.created;
        self.pools.face_max.ensure(&ctx, (nf.max(1) * 4) as u64, c);
        self.render_views(views, render, None)?;
        let max: Vec<u32> = bytemuck::pod_collect_to_vec(
            &self
                .readback
                .read(&ctx, &[(self.pools.face_max.buffer(), (nf * 4) as u64)])?
                .pop()
                .unwrap_or_default(),
        );
        self.syncs += 1;
        Ok(max.into_iter().map(f32::from_bits).collect())
    }

    /// Renders `views` over black (each with [`DeviceTrainer::pass_settings`]):
    /// scored with `lambda_dssim`, or (None) the trained faces alone, folded
    /// into the per-face maxima of `pools.face_max`. Returns each view's
    /// result words (loss, squared error, entries, pixels).
    fn render_views(
        &mut self,
        views: &[usize],
        render: &RenderSettings,
        lambda_dssim: Option<f64>,
    ) -> Result<Vec<u32>> {
        if let Some(&v) = views.iter().find(|&&v| v >= self.views.len()) {
            bail!("evaluation of view {v} of {}", self.views.len());
        }
        self.collect()?;
        let Some(resident) = self.resident.as_ref() else {
            bail!("device evaluation before a model was loaded");
        };
        if views.is_empty() {
            return Ok(Vec::new());
        }
        let settings = views
            .iter()
            .map(|&v| self.pass_settings(v, render))
            .collect::<Result<Vec<_>>>()?;
        let model = match lambda_dssim {
            Some(_) => resident.params.clone(),
            None => resident.params.first_faces(resident.trained.faces),
        };
        let trained_faces = resident.trained.faces;
        let ctx = self.backend.context().clone();
        let n = views.len();
        let c = &mut self.pools.created;
        self.pools.eval_results.ensure(&ctx, (16 * n) as u64, c);
        self.pools.eval_status.ensure(&ctx, (4 * n) as u64, c);
        for attempt in 0..2 {
            let capacity = self.raster.entry_capacity();
            let mut uniforms = std::mem::take(&mut self.uniforms);
            for (k, &v) in views.iter().enumerate() {
                let camera = self.pass_camera(v);
                let view = &self.views[v];
                let mut rec = Recorder::new(&ctx, &mut uniforms);
                if k == 0 {
                    rec.enc
                        .clear_buffer(self.pools.eval_status.buffer(), 0, Some((4 * n) as u64));
                    if lambda_dssim.is_none() && trained_faces > 0 {
                        rec.enc.clear_buffer(
                            self.pools.face_max.buffer(),
                            0,
                            Some((trained_faces * 4) as u64),
                        );
                    }
                }
                self.backend.encode_render(
                    &mut rec,
                    &mut self.raster,
                    &model,
                    &camera,
                    &settings[k],
                    [0.0; 3],
                )?;
                encode_filter(&self.sampled, &self.raster, &mut rec, view.pixels());
                let (image, frame) = scored(&self.sampled, &self.raster);
                match lambda_dssim {
                    Some(lambda_dssim) => self.kernels.loss.encode(
                        &mut rec,
                        &LossPass {
                            view,
                            background: [0.0; 3],
                            lambda_dssim,
                            slot: k as u32,
                            groups: groups_for(view.pixels(), THREADS_1D),
                            gradient: false,
                            entry_capacity: u32::MAX,
                        },
                        &LossBuffers {
                            image,
                            frame,
                            rows: &self.scratch.rows,
                            maps: &self.scratch.maps,
                            upstream: &self.scratch.upstream,
                            partials: &self.scratch.partials,
                            results: self.pools.eval_results.buffer(),
                            status: self.pools.eval_status.buffer(),
                        },
                    ),
                    None => {
                        self.kernels.fold.encode(
                            &mut rec,
                            trained_faces,
                            self.raster.face_stats(),
                            self.pools.face_max.buffer(),
                            None,
                            &self.status,
                        );
                        // The entries the render needed, where a loss pass puts them.
                        rec.enc.copy_buffer_to_buffer(
                            self.raster.frame(),
                            0,
                            self.pools.eval_results.buffer(),
                            16 * k as u64 + 8,
                            4,
                        );
                    }
                }
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
                grow_entries(&mut self.raster, &ctx, entries);
                continue;
            }
            if let Some(k) = status.iter().position(|&s| s != 0) {
                bail!(
                    "the evaluation render of view {} is not finite (parameters overflowed)",
                    views[k]
                );
            }
            return Ok(results);
        }
        // Both attempts either returned or continued once; the second cannot continue.
        unreachable!("the evaluation loop returns by its second attempt")
    }

    /// The running per-face maxima of the blending weight over this epoch's
    /// and the previous epoch's training renders (one readback, after
    /// collecting the queued steps).
    pub fn face_weights(&mut self) -> Result<FaceWeightArrays> {
        self.collect()?;
        let Some(resident) = &self.resident else {
            bail!("no model on the device for face statistics");
        };
        let bytes = (resident.trained.faces * 4) as u64;
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
    /// through a topology edit); one value per trained face of the loaded model.
    pub fn set_face_weights(&mut self, current: &[f32], previous: &[f32]) -> Result<()> {
        let Some(resident) = &self.resident else {
            bail!("no model on the device for face statistics");
        };
        let nf = resident.trained.faces;
        if current.len() != nf || previous.len() != nf {
            bail!(
                "face weights for {} and {} faces, but the loaded model trains {nf}",
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
        // Writes follow the submitted steps on the queue: those fold into the old arrays.
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
        let bytes = self
            .resident
            .as_ref()
            .map_or(0, |r| (r.trained.faces * 4) as u64);
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

/// Grows the tile-entry buffers to hold `entries` with headroom, when smaller.
fn grow_entries(raster: &mut RasterPool, ctx: &GpuContext, entries: usize) {
    let wanted = ((entries as f64 * ENTRY_HEADROOM).ceil() as usize).max(1);
    if raster.entry_capacity() < wanted {
        raster.ensure_entries(ctx, wanted);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn status_bits_are_those_of_the_kernels() {
        let wgsl = include_str!("status.wgsl");
        for (bit, name) in [
            (1, "STATUS_RENDER"),
            (2, "STATUS_LOSS"),
            (256, "STATUS_DEPTH"),
        ] {
            assert!(
                wgsl.contains(&format!("const {name}: u32 = {bit}u;")),
                "{name}"
            );
            assert!(STATUS_BITS.iter().any(|(b, _)| *b == bit), "{name}");
        }
        assert!(wgsl.contains(&format!("const STATUS_OVERFLOW: u32 = {STATUS_OVERFLOW}u;")));
    }
}
