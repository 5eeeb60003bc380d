//! Per-face weight statistics on the device (`faces.wgsl`): the running
//! per-face maxima of the blending weight that pruning and densification
//! judge faces by (objectsplat_train's `FaceWeights`, kept here between host
//! events), folded in from each training render.

use crate::kernels::{Kernel, Recorder, compile_kernels, groups_for};
use objectsplat_gpu::GpuContext;

pub const FACES_WGSL: &str = concat!(
    include_str!("../thread_index.wgsl"),
    include_str!("status.wgsl"),
    include_str!("faces.wgsl")
);

/// `FaceParams` of faces.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct FaceParams {
    face_count: u32,
    slot: u32,
    check_status: u32,
    _pad: u32,
}

pub(super) struct FoldKernel {
    kernel: Kernel,
}

impl FoldKernel {
    pub fn new(ctx: &GpuContext) -> Self {
        let [kernel] = compile_kernels(ctx, "faces.wgsl", FACES_WGSL, ["fold_face_weights"]);
        FoldKernel { kernel }
    }

    /// Records `running_max[f] = max(running_max[f], render's max weight of f)`
    /// for the first `faces` faces; with `slot`, not for a step whose render
    /// overflowed (its status word in `status`).
    pub fn encode(
        &self,
        rec: &mut Recorder<'_>,
        faces: usize,
        face_stats: &wgpu::Buffer,
        running_max: &wgpu::Buffer,
        slot: Option<u32>,
        status: &wgpu::Buffer,
    ) {
        rec.dispatch(
            &self.kernel,
            &FaceParams {
                face_count: faces as u32,
                slot: slot.unwrap_or(0),
                check_status: slot.is_some() as u32,
                _pad: 0,
            },
            &[(1, face_stats), (2, running_max), (3, status)],
            groups_for(faces, 256),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use objectsplat_gpu::check_mirrors_wgsl;
    use std::mem::size_of;

    #[test]
    fn face_params_mirror_the_wgsl_struct() {
        let rust = crate::same_names!(FaceParams; face_count, slot, check_status, _pad);
        check_mirrors_wgsl(FACES_WGSL, "FaceParams", size_of::<FaceParams>(), &rust).unwrap();
    }
}
