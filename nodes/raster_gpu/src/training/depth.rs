//! The geometric losses of a training step on the device (`depth.wgsl`):
//! the depth at the view's measured points and the planar prior on the
//! component's own pixels, as gradients with respect to the rendered depth and
//! coverage added to the upstream buffer (objectsplat_train's `point_depth`
//! and `depth_smoothness` define them; the parity tests hold the two to each other).

use super::views::ViewBuffers;
use crate::kernels::{Kernel, Recorder, compile_kernels};
use objectsplat_gpu::GpuContext;

pub const DEPTH_WGSL: &str = concat!(
    include_str!("../frame_record.wgsl"),
    include_str!("../thread_index.wgsl"),
    include_str!("../is_finite.wgsl"),
    include_str!("status.wgsl"),
    include_str!("depth.wgsl")
);

/// `DepthParams` of depth.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct DepthParams {
    width: u32,
    point_count: u32,
    slot: u32,
    _pad: u32,
    weight: f32,
    _pad1: f32,
    _pad2: f32,
    _pad3: f32,
}

/// The weights of the two terms in one step (0: off).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct DepthWeights {
    /// The depth loss at the view's measured points.
    pub points: f64,
    /// The planar prior on the rendered depth of the component's own pixels.
    pub planar: f64,
}

pub(super) struct DepthKernels {
    point_depth: Kernel,
    planar_inverse: Kernel,
    planar_count: Kernel,
    planar_gradient: Kernel,
}

/// What the depth terms read and write besides the view's buffers.
pub(super) struct DepthBuffers<'a> {
    pub image: &'a wgpu::Buffer,
    pub upstream: &'a wgpu::Buffer,
    pub frame: &'a wgpu::Buffer,
    /// A region-sized plane (the inverse depth).
    pub inverse: &'a wgpu::Buffer,
    /// One word (the run count), cleared here.
    pub runs: &'a wgpu::Buffer,
    pub status: &'a wgpu::Buffer,
}

impl DepthKernels {
    pub fn new(ctx: &GpuContext) -> Self {
        let [point_depth, planar_inverse, planar_count, planar_gradient] = compile_kernels(
            ctx,
            "depth.wgsl",
            DEPTH_WGSL,
            [
                "point_depth",
                "planar_inverse",
                "planar_count",
                "planar_gradient",
            ],
        );
        DepthKernels {
            point_depth,
            planar_inverse,
            planar_count,
            planar_gradient,
        }
    }

    /// Records the terms `weights` turns on for a step on `view` (after the
    /// photometric loss wrote the upstream buffer), over `groups` workgroups of
    /// 256 pixels covering the region.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &self,
        rec: &mut Recorder<'_>,
        view: &ViewBuffers,
        weights: DepthWeights,
        slot: u32,
        groups: u32,
        b: &DepthBuffers<'_>,
    ) {
        let params = |weight: f64| DepthParams {
            width: view.camera.width,
            point_count: view.point_count as u32,
            slot,
            _pad: 0,
            weight: weight as f32,
            _pad1: 0.0,
            _pad2: 0.0,
            _pad3: 0.0,
        };
        if weights.points > 0.0 && view.point_count > 0 {
            rec.dispatch(
                &self.point_depth,
                &params(weights.points),
                &[
                    (1, b.image),
                    (2, b.upstream),
                    (3, b.frame),
                    (4, &view.points),
                    (8, b.status),
                ],
                1,
            );
        }
        if weights.planar > 0.0 {
            let p = params(weights.planar);
            rec.enc.clear_buffer(b.runs, 0, None);
            rec.dispatch(
                &self.planar_inverse,
                &p,
                &[(1, b.image), (3, b.frame), (5, &view.flags), (6, b.inverse)],
                groups,
            );
            rec.dispatch(
                &self.planar_count,
                &p,
                &[(3, b.frame), (6, b.inverse), (7, b.runs)],
                groups,
            );
            rec.dispatch(
                &self.planar_gradient,
                &p,
                &[
                    (1, b.image),
                    (2, b.upstream),
                    (3, b.frame),
                    (6, b.inverse),
                    (7, b.runs),
                    (8, b.status),
                ],
                groups,
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use objectsplat_gpu::check_mirrors_wgsl;
    use std::mem::size_of;

    #[test]
    fn depth_params_mirror_the_wgsl_struct() {
        let rust = crate::same_names!(DepthParams; width, point_count, slot, _pad, weight,
            _pad1, _pad2, _pad3);
        check_mirrors_wgsl(DEPTH_WGSL, "DepthParams", size_of::<DepthParams>(), &rust).unwrap();
    }
}
