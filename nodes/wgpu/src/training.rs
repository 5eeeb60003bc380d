//! [`DeviceTrainer`]: training iterations that stay on the device. The
//! parameters, Adam's moments and every training view's target live in device
//! buffers; one step renders (the forward of [`WgpuBackend`]), computes the
//! photometric loss and its image gradient (`train_loss.wgsl`), runs the
//! backward pass and applies Adam (`train_adam.wgsl`), with no image or
//! gradient crossing to the host. Per step the host sends a few uniforms and
//! reads back one number, the tile-entry count that sizes the entry buffers.
//! Losses and divergence flags collect in device slots and come back in
//! batches ([`DeviceTrainer::results`]); the parameters come back only when
//! the host needs the model ([`DeviceTrainer::store`]).

use crate::device::{read_buffers, read_values};
use crate::kernels::{Kernel, groups_for, shader, storage, storage_from, uniform};
use crate::raster::{ModelBuffers, WgpuBackend};
use anyhow::{Context, Result, bail};
use objectsplat_core::Camera;
use objectsplat_raster::loss::{SSIM_SIGMA, SSIM_WINDOW};
use objectsplat_raster::{Model, RenderSettings, SH_COEFFS};

pub const TRAIN_LOSS_WGSL: &str = include_str!("train_loss.wgsl");
pub const TRAIN_ADAM_WGSL: &str = include_str!("train_adam.wgsl");

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

/// `LossParams` of train_loss.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct LossParams {
    width: u32,
    height: u32,
    slot: u32,
    partial_count: u32,
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

struct ViewBuffers {
    camera: Camera,
    targets: wgpu::Buffer,
    from_background: wgpu::Buffer,
    /// 1 / (3·Σ weights), 0 without supervised pixels.
    norm: f32,
    supervised: bool,
}

struct Resident {
    params: ModelBuffers,
    first: [wgpu::Buffer; 3],
    second: [wgpu::Buffer; 3],
    steps: [u64; 3],
}

struct Kernels {
    fill_background: Kernel,
    ssim_rows: Kernel,
    ssim_maps: Kernel,
    ssim_grad_rows: Kernel,
    loss_grad: Kernel,
    loss_total: Kernel,
    adam: Kernel,
}

/// Training steps on the device (see the module documentation).
pub struct DeviceTrainer {
    backend: WgpuBackend,
    kernels: Kernels,
    adam: AdamSettings,
    taps: [f32; 12],
    views: Vec<ViewBuffers>,
    resident: Option<Resident>,
    background_image: wgpu::Buffer,
    rows: wgpu::Buffer,
    maps: wgpu::Buffer,
    upstream: wgpu::Buffer,
    partials: wgpu::Buffer,
    losses: wgpu::Buffer,
    status: wgpu::Buffer,
    pending: usize,
    collected: Vec<StepResult>,
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
    /// Uploads the training views and compiles the kernels.
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
        let kernels = Kernels {
            fill_background: Kernel::new(&ctx, &loss, "fill_background"),
            ssim_rows: Kernel::new(&ctx, &loss, "ssim_rows"),
            ssim_maps: Kernel::new(&ctx, &loss, "ssim_maps"),
            ssim_grad_rows: Kernel::new(&ctx, &loss, "ssim_grad_rows"),
            loss_grad: Kernel::new(&ctx, &loss, "loss_grad"),
            loss_total: Kernel::new(&ctx, &loss, "loss_total"),
            adam: Kernel::new(&ctx, &adam_module, "adam_step"),
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
            let weight_sum: f32 = view.weights.iter().sum();
            let supervised = weight_sum > 0.0;
            buffers.push(ViewBuffers {
                camera: view.camera,
                targets: storage_from(&ctx, "training targets", &targets),
                from_background: storage_from(&ctx, "background flags", &flags),
                norm: if supervised {
                    1.0 / (weight_sum * 3.0)
                } else {
                    0.0
                },
                supervised,
            });
        }
        let pixels = views
            .iter()
            .map(|v| v.camera.width as usize * v.camera.height as usize)
            .max()
            .unwrap_or(0); // views is not empty (checked above)
        let bytes = |n: usize| (n * 4) as u64;
        let losses = storage(&ctx, "step losses", bytes(SLOTS));
        let status = storage(&ctx, "step status", bytes(SLOTS));
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        enc.clear_buffer(&status, 0, None);
        ctx.queue.submit([enc.finish()]);
        Ok(DeviceTrainer {
            backend: backend.clone(),
            kernels,
            adam,
            taps: gaussian_taps(),
            views: buffers,
            resident: None,
            background_image: storage(&ctx, "background image", bytes(pixels * 3)),
            rows: storage(&ctx, "ssim rows", bytes(pixels * ROW_MAPS)),
            maps: storage(&ctx, "ssim partial maps", bytes(pixels * PARTIAL_MAPS)),
            upstream: storage(&ctx, "loss gradient", bytes(pixels * IMAGE_STRIDE)),
            partials: storage(
                &ctx,
                "loss partial sums",
                bytes(2 * groups_for(pixels, THREADS_1D) as usize),
            ),
            losses,
            status,
            pending: 0,
            collected: Vec::new(),
        })
    }

    /// Puts `model` and its Adam state on the device, replacing what was there.
    pub fn load(&mut self, model: &Model<f32>, state: &OptimizerState) -> Result<()> {
        let nv = model.vertex_count();
        state.positions.check("vertex positions", nv * 3)?;
        state.sh.check("SH coefficients", nv * SH_VALUES)?;
        state.opacity_logits.check("opacity logits", nv)?;
        let params = self.backend.upload_model(model)?;
        let ctx = self.backend.context();
        let tensors = [&state.positions, &state.sh, &state.opacity_logits];
        self.resident = Some(Resident {
            params,
            first: tensors.map(|t| storage_from(ctx, "adam first moment", &t.first)),
            second: tensors.map(|t| storage_from(ctx, "adam second moment", &t.second)),
            steps: tensors.map(|t| t.steps),
        });
        Ok(())
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
        if self.pending == SLOTS {
            self.collect()?;
        }
        let view = &self.views[step.view];
        let Some(resident) = self.resident.as_mut() else {
            bail!("device training step before a model was loaded");
        };
        let ctx = self.backend.context().clone();
        let k = &self.kernels;
        let slot = self.pending as u32;
        let (w, h) = (view.camera.width, view.camera.height);
        let pixels = w as usize * h as usize;
        let groups = groups_for(pixels, THREADS_1D);
        let loss_params = uniform(
            &ctx,
            "loss params",
            &LossParams {
                width: w,
                height: h,
                slot,
                partial_count: groups,
                background: [
                    step.background[0],
                    step.background[1],
                    step.background[2],
                    0.0,
                ],
                norm: view.norm,
                l1_weight: (1.0 - step.lambda_dssim) as f32,
                ssim_weight: step.lambda_dssim as f32,
                supervised: view.supervised as u32,
                taps: self.taps,
            },
        );
        let encoder = || {
            ctx.device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor::default())
        };
        let mut enc = encoder();
        k.fill_background.dispatch(
            &ctx,
            &mut enc,
            &[(0, &loss_params), (10, &self.background_image)],
            groups,
        );
        ctx.queue.submit([enc.finish()]);
        let saved = self.backend.render_on(
            &resident.params,
            &view.camera,
            &step.render,
            &self.background_image,
        )?;

        let mut enc = encoder();
        k.ssim_rows.dispatch(
            &ctx,
            &mut enc,
            &[
                (0, &loss_params),
                (1, &saved.image),
                (2, &view.targets),
                (3, &view.from_background),
                (4, &self.rows),
            ],
            groups,
        );
        k.ssim_maps.dispatch(
            &ctx,
            &mut enc,
            &[
                (0, &loss_params),
                (1, &saved.image),
                (2, &view.targets),
                (3, &view.from_background),
                (4, &self.rows),
                (5, &self.maps),
                (7, &self.partials),
                (9, &self.status),
            ],
            groups,
        );
        k.ssim_grad_rows.dispatch(
            &ctx,
            &mut enc,
            &[(0, &loss_params), (4, &self.rows), (5, &self.maps)],
            groups,
        );
        k.loss_grad.dispatch(
            &ctx,
            &mut enc,
            &[
                (0, &loss_params),
                (1, &saved.image),
                (2, &view.targets),
                (3, &view.from_background),
                (4, &self.rows),
                (6, &self.upstream),
            ],
            groups,
        );
        k.loss_total.dispatch(
            &ctx,
            &mut enc,
            &[
                (0, &loss_params),
                (7, &self.partials),
                (8, &self.losses),
                (9, &self.status),
            ],
            1,
        );
        ctx.queue.submit([enc.finish()]);
        let grads = self.backend.backward_on(&saved, &self.upstream)?;

        let nv = resident.params.vertex_count;
        let tensors = [
            (
                &resident.params.positions,
                &grads.positions,
                nv * 3,
                3,
                3,
                lr.positions,
                lr.positions,
                4,
            ),
            (
                &resident.params.sh,
                &grads.sh,
                nv * SH_VALUES,
                SH_VALUES,
                3,
                lr.sh_dc,
                lr.sh_rest,
                16,
            ),
            (
                &resident.params.opacity_logits,
                &grads.opacity_logits,
                nv,
                1,
                1,
                lr.opacity,
                lr.opacity,
                64,
            ),
        ];
        let a = self.adam;
        let mut enc = encoder();
        for (t, (values, grad, count, row_width, split, lr_first, lr_rest, grad_bit)) in
            tensors.into_iter().enumerate()
        {
            resident.steps[t] += 1;
            let steps = i32::try_from(resident.steps[t]).unwrap_or(i32::MAX);
            let params = uniform(
                &ctx,
                "adam params",
                &AdamParams {
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
                },
            );
            k.adam.dispatch(
                &ctx,
                &mut enc,
                &[
                    (0, &params),
                    (1, values),
                    (2, grad),
                    (3, &resident.first[t]),
                    (4, &resident.second[t]),
                    (5, &self.status),
                ],
                groups_for(count, THREADS_1D),
            );
        }
        ctx.queue.submit([enc.finish()]);
        ctx.check_errors("a device training step")?;
        self.pending += 1;
        Ok(())
    }

    /// Moves the finished steps' losses and flags from the device slots to the host.
    fn collect(&mut self) -> Result<()> {
        if self.pending == 0 {
            return Ok(());
        }
        let ctx = self.backend.context();
        let losses: Vec<f32> = read_values(ctx, &self.losses, self.pending)?;
        let status: Vec<u32> = read_values(ctx, &self.status, self.pending)?;
        for (loss, bits) in losses.into_iter().zip(status) {
            let non_finite = STATUS_BITS
                .iter()
                .filter(|(bit, _)| bits & bit != 0)
                .map(|(_, what)| *what)
                .collect();
            self.collected.push(StepResult { loss, non_finite });
        }
        let mut enc = ctx
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        enc.clear_buffer(&self.status, 0, None);
        ctx.queue.submit([enc.finish()]);
        self.pending = 0;
        Ok(())
    }

    /// The steps finished since the last call, in order.
    pub fn results(&mut self) -> Result<Vec<StepResult>> {
        self.collect()?;
        Ok(std::mem::take(&mut self.collected))
    }

    /// The last step's loss gradient with respect to the rendered colour (RGB
    /// per pixel of that step's view), read back for checks and diagnostics.
    pub fn last_image_gradient(&self, view: usize) -> Result<Vec<f32>> {
        let Some(v) = self.views.get(view) else {
            bail!("no training view {view} (there are {})", self.views.len());
        };
        let pixels = v.camera.width as usize * v.camera.height as usize;
        let upstream: Vec<f32> = read_values(
            self.backend.context(),
            &self.upstream,
            pixels * IMAGE_STRIDE,
        )?;
        Ok(upstream
            .chunks_exact(IMAGE_STRIDE)
            .flat_map(|u| u[..3].iter().copied())
            .collect())
    }

    /// Writes the device's parameters into `model` (which must have the loaded
    /// model's shape) and returns Adam's state.
    pub fn store(&self, model: &mut Model<f32>) -> Result<OptimizerState> {
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
        // One submission for all nine tensors: parameters, then first and second moments.
        let bytes = [nv * 3, nv * SH_VALUES, nv].map(|n| (n * 4) as u64);
        let params = &resident.params;
        let mut sources = vec![
            (&params.positions, bytes[0]),
            (&params.sh, bytes[1]),
            (&params.opacity_logits, bytes[2]),
        ];
        sources.extend((0..3).map(|t| (&resident.first[t], bytes[t])));
        sources.extend((0..3).map(|t| (&resident.second[t], bytes[t])));
        let mut values = read_buffers(self.backend.context(), &sources)?
            .into_iter()
            .map(|b| bytemuck::pod_collect_to_vec::<u8, f32>(&b));
        let mut next = || {
            values
                .next()
                .expect("read_buffers returns one result per buffer, and nine were asked for")
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
        Ok(OptimizerState {
            positions: moments(f0, s0, 0),
            sh: moments(f1, s1, 1),
            opacity_logits: moments(f2, s2, 2),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::check_mirrors_wgsl;
    use std::mem::{offset_of, size_of};

    macro_rules! same_names {
        ($t:ty; $($f:ident),*) => { [$((stringify!($f), offset_of!($t, $f))),*] };
    }

    #[test]
    fn loss_params_mirror_the_wgsl_struct() {
        let rust = same_names!(LossParams; width, height, slot, partial_count, background,
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
    fn taps_equal_the_cpu_loss_window() {
        let taps = gaussian_taps();
        let sum: f32 = taps.iter().sum();
        assert!((sum - 1.0).abs() < 1e-6, "{taps:?}");
        assert_eq!(taps[11], 0.0);
        assert_eq!(taps[5], taps.iter().copied().fold(0.0, f32::max));
    }
}
