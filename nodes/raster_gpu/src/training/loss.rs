//! The photometric loss of a training pass and its image gradient
//! (`loss.wgsl`): `(1 − λ)·L1 + λ·(1 − SSIM)` of the render in the raster
//! pool against a view's target, per-pixel weighted, with the gradient written
//! as the backward pass's upstream buffer.

use super::views::ViewBuffers;
use crate::kernels::{Kernel, Recorder, compile_kernels};
use objectsplat_gpu::GpuContext;
use objectsplat_raster::loss::{SSIM_SIGMA, SSIM_WINDOW};

pub const LOSS_WGSL: &str = concat!(
    include_str!("../frame_record.wgsl"),
    include_str!("../thread_index.wgsl"),
    include_str!("../is_finite.wgsl"),
    include_str!("status.wgsl"),
    include_str!("loss.wgsl")
);

/// Scratch planes of the separable blurs per pixel, and of the partial maps.
pub const ROW_MAPS: usize = 15;
pub const PARTIAL_MAPS: usize = 9;

/// `LossParams` of loss.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct LossParams {
    pub width: u32,
    pub slot: u32,
    pub partial_count: u32,
    pub gradient: u32,
    pub background: [f32; 4],
    pub norm: f32,
    pub l1_weight: f32,
    pub ssim_weight: f32,
    pub supervised: u32,
    pub entry_capacity: u32,
    pub _pad: [u32; 3],
    pub taps: [f32; 12],
}

/// The SSIM window's taps as objectsplat_raster::loss computes them (in f64,
/// rounded to f32), padded to whole vec4s.
pub(super) fn gaussian_taps() -> [f32; 12] {
    let half = (SSIM_WINDOW / 2) as f64;
    let raw: Vec<f64> = (0..SSIM_WINDOW)
        .map(|i| (-(i as f64 - half).powi(2) / (2.0 * SSIM_SIGMA * SSIM_SIGMA)).exp())
        .collect();
    let sum: f64 = raw.iter().sum();
    std::array::from_fn(|i| raw.get(i).map_or(0.0, |r| (r / sum) as f32))
}

/// The loss kernels and their scratch buffers.
pub(super) struct LossKernels {
    ssim_rows: Kernel,
    ssim_maps: Kernel,
    ssim_grad_rows: Kernel,
    loss_grad: Kernel,
    loss_total: Kernel,
    taps: [f32; 12],
}

/// Where a pass's loss goes and what it reads.
pub(super) struct LossPass<'a> {
    pub view: &'a ViewBuffers,
    pub background: [f32; 3],
    pub lambda_dssim: f64,
    /// Result slot of `results`/`status`.
    pub slot: u32,
    /// Workgroups of 256 pixels covering the region (or the whole image).
    pub groups: u32,
    /// Write the image gradient into `scratch.upstream`.
    pub gradient: bool,
    pub entry_capacity: u32,
}

/// The buffers a loss pass reads and writes besides the view's.
pub(super) struct LossBuffers<'a> {
    pub image: &'a wgpu::Buffer,
    pub frame: &'a wgpu::Buffer,
    pub rows: &'a wgpu::Buffer,
    pub maps: &'a wgpu::Buffer,
    pub upstream: &'a wgpu::Buffer,
    pub partials: &'a wgpu::Buffer,
    pub results: &'a wgpu::Buffer,
    pub status: &'a wgpu::Buffer,
}

impl LossKernels {
    pub fn new(ctx: &GpuContext) -> Self {
        let [ssim_rows, ssim_maps, ssim_grad_rows, loss_grad, loss_total] = compile_kernels(
            ctx,
            "loss.wgsl",
            LOSS_WGSL,
            [
                "ssim_rows",
                "ssim_maps",
                "ssim_grad_rows",
                "loss_grad",
                "loss_total",
            ],
        );
        LossKernels {
            ssim_rows,
            ssim_maps,
            ssim_grad_rows,
            loss_grad,
            loss_total,
            taps: gaussian_taps(),
        }
    }

    /// Records the loss of a pass whose render is in `b.image`.
    pub fn encode(&self, rec: &mut Recorder<'_>, pass: &LossPass<'_>, b: &LossBuffers<'_>) {
        let v = pass.view;
        let params = LossParams {
            width: v.camera.width,
            slot: pass.slot,
            partial_count: pass.groups,
            gradient: pass.gradient as u32,
            background: [
                pass.background[0],
                pass.background[1],
                pass.background[2],
                0.0,
            ],
            norm: v.norm,
            l1_weight: (1.0 - pass.lambda_dssim) as f32,
            ssim_weight: pass.lambda_dssim as f32,
            supervised: v.supervised as u32,
            entry_capacity: pass.entry_capacity,
            _pad: [0; 3],
            taps: self.taps,
        };
        let groups = pass.groups;
        rec.dispatch(
            &self.ssim_rows,
            &params,
            &[
                (1, b.image),
                (2, &v.targets),
                (3, &v.flags),
                (4, b.rows),
                (10, b.frame),
            ],
            groups,
        );
        rec.dispatch(
            &self.ssim_maps,
            &params,
            &[
                (1, b.image),
                (2, &v.targets),
                (3, &v.flags),
                (4, b.rows),
                (5, b.maps),
                (7, b.partials),
                (9, b.status),
                (10, b.frame),
            ],
            groups,
        );
        if pass.gradient {
            rec.dispatch(
                &self.ssim_grad_rows,
                &params,
                &[(4, b.rows), (5, b.maps), (10, b.frame)],
                groups,
            );
            rec.dispatch(
                &self.loss_grad,
                &params,
                &[
                    (1, b.image),
                    (2, &v.targets),
                    (3, &v.flags),
                    (4, b.rows),
                    (6, b.upstream),
                    (10, b.frame),
                ],
                groups,
            );
        }
        rec.dispatch(
            &self.loss_total,
            &params,
            &[
                (7, b.partials),
                (8, b.results),
                (9, b.status),
                (10, b.frame),
            ],
            1,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use objectsplat_gpu::check_mirrors_wgsl;
    use std::mem::{offset_of, size_of};

    #[test]
    fn loss_params_mirror_the_wgsl_struct() {
        let pad = offset_of!(LossParams, _pad);
        let mut rust = crate::same_names!(LossParams; width, slot, partial_count, gradient,
            background, norm, l1_weight, ssim_weight, supervised, entry_capacity, taps)
        .to_vec();
        rust.extend([("_pad0", pad), ("_pad1", pad + 4), ("_pad2", pad + 8)]);
        check_mirrors_wgsl(LOSS_WGSL, "LossParams", size_of::<LossParams>(), &rust).unwrap();
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
