//! Supersampled steps on the device (`supersample.wgsl`): the render of the
//! view's camera scaled by the factor box-filtered to the view's pixels for
//! the loss and the depth terms, and their gradient spread back over the
//! samples for the backward pass (objectsplat_raster::supersample's).

use crate::kernels::{Kernel, Recorder, compile_kernels, groups_for};
use objectsplat_gpu::GpuContext;

pub const SUPERSAMPLE_WGSL: &str = concat!(
    include_str!("../thread_index.wgsl"),
    include_str!("../frame_record.wgsl"),
    include_str!("supersample.wgsl")
);

/// `SampleParams` of supersample.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct SampleParams {
    factor: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

pub(super) struct SampleKernels {
    filter: Kernel,
    spread: Kernel,
}

impl SampleKernels {
    pub fn new(ctx: &GpuContext) -> Self {
        let [filter, spread] = compile_kernels(
            ctx,
            "supersample.wgsl",
            SUPERSAMPLE_WGSL,
            ["box_filter", "spread"],
        );
        SampleKernels { filter, spread }
    }

    fn params(factor: u32) -> SampleParams {
        SampleParams {
            factor,
            _pad0: 0,
            _pad1: 0,
            _pad2: 0,
        }
    }

    /// Records the box filter of the render in `fine` (its frame record
    /// `fine_frame`) into `coarse` and `coarse_frame`, for a view of `pixels` pixels.
    #[allow(clippy::too_many_arguments)]
    pub fn encode_filter(
        &self,
        rec: &mut Recorder<'_>,
        factor: u32,
        pixels: usize,
        fine_frame: &wgpu::Buffer,
        fine: &wgpu::Buffer,
        coarse_frame: &wgpu::Buffer,
        coarse: &wgpu::Buffer,
    ) {
        rec.dispatch(
            &self.filter,
            &Self::params(factor),
            &[(1, fine_frame), (2, fine), (3, coarse_frame), (4, coarse)],
            groups_for(pixels, 256),
        );
    }

    /// Records the spread of `coarse_upstream` over the samples of the render
    /// whose frame record is `fine_frame` (a view of `pixels` pixels).
    pub fn encode_spread(
        &self,
        rec: &mut Recorder<'_>,
        factor: u32,
        pixels: usize,
        fine_frame: &wgpu::Buffer,
        coarse_upstream: &wgpu::Buffer,
        fine_upstream: &wgpu::Buffer,
    ) {
        let samples = pixels * (factor * factor) as usize;
        rec.dispatch(
            &self.spread,
            &Self::params(factor),
            &[(1, fine_frame), (5, coarse_upstream), (6, fine_upstream)],
            groups_for(samples, 256),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use objectsplat_gpu::check_mirrors_wgsl;
    use std::mem::size_of;

    #[test]
    fn sample_params_mirror_the_wgsl_struct() {
        let rust = crate::same_names!(SampleParams; factor, _pad0, _pad1, _pad2);
        check_mirrors_wgsl(
            SUPERSAMPLE_WGSL,
            "SampleParams",
            size_of::<SampleParams>(),
            &rust,
        )
        .unwrap();
    }
}
