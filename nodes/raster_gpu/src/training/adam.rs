//! Adam on the device (`adam.wgsl`): one update of each of a model's three
//! tensors from the backward pass's gradients, with the state, settings and
//! rates of objectsplat-optim's [`Optim`] — the host trainer's own Adam, whose
//! moments live here between host events.

use crate::kernels::{Kernel, Recorder, compile_kernels, groups_for};
use objectsplat_gpu::GpuContext;
use objectsplat_optim::{LearningRates, Optim, SH_VALUES};

pub const ADAM_WGSL: &str = concat!(
    include_str!("../thread_index.wgsl"),
    include_str!("../is_finite.wgsl"),
    include_str!("status.wgsl"),
    include_str!("adam.wgsl")
);

const THREADS: usize = 256;

/// `AdamParams` of adam.wgsl.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(super) struct AdamParams {
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
    active_width: u32,
    _pad: u32,
}

/// Adam's betas and ε, as the host's Adam holds them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct AdamSettings {
    beta1: f64,
    beta2: f64,
    eps: f64,
}

impl AdamSettings {
    pub fn of(optim: &Optim) -> Self {
        AdamSettings {
            beta1: optim.adam.beta1,
            beta2: optim.adam.beta2,
            eps: optim.adam.eps,
        }
    }
}

/// One tensor's update: its values, gradient and moments on the device.
pub(super) struct TensorUpdate<'a> {
    pub values: &'a wgpu::Buffer,
    pub grads: &'a wgpu::Buffer,
    pub first: &'a wgpu::Buffer,
    pub second: &'a wgpu::Buffer,
    /// Updates applied before this one (the bias correction's t − 1).
    pub steps: u64,
}

/// Values per row of each tensor (positions, SH, opacity logits), the values
/// of a row at the first rate, and each tensor's status bit.
const LAYOUT: [(usize, u32, u32); 3] = [(3, 3, 4), (SH_VALUES, 3, 16), (1, 1, 64)];

pub(super) struct AdamKernel {
    kernel: Kernel,
}

impl AdamKernel {
    pub fn new(ctx: &GpuContext) -> Self {
        let [kernel] = compile_kernels(ctx, "adam.wgsl", ADAM_WGSL, ["adam_step"]);
        AdamKernel { kernel }
    }

    /// Records one update of the three tensors of `rows` vertices (only the
    /// first `sh_active` SH values of a row move), raising bits of status slot `slot`.
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &self,
        rec: &mut Recorder<'_>,
        settings: AdamSettings,
        rates: &LearningRates,
        tensors: [TensorUpdate<'_>; 3],
        rows: usize,
        sh_active: usize,
        slot: u32,
        status: &wgpu::Buffer,
    ) {
        let a = settings;
        let rates = [
            (rates.positions, rates.positions),
            (rates.sh_dc, rates.sh_rest),
            (rates.opacity, rates.opacity),
        ];
        for (t, tensor) in tensors.into_iter().enumerate() {
            let (row_width, split, grad_bit) = LAYOUT[t];
            let (lr_first, lr_rest) = rates[t];
            let step = i32::try_from(tensor.steps + 1).unwrap_or(i32::MAX);
            let count = rows * row_width;
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
                bias1: (1.0 - a.beta1.powi(step)) as f32,
                bias2: (1.0 - a.beta2.powi(step)) as f32,
                slot,
                active_width: if t == 1 {
                    sh_active.min(row_width)
                } else {
                    row_width
                } as u32,
                _pad: 0,
            };
            rec.dispatch(
                &self.kernel,
                &params,
                &[
                    (1, tensor.values),
                    (2, tensor.grads),
                    (3, tensor.first),
                    (4, tensor.second),
                    (5, status),
                ],
                groups_for(count, THREADS),
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
    fn adam_params_mirror_the_wgsl_struct() {
        let rust = crate::same_names!(AdamParams; count, row_width, split, grad_bit, lr_first,
            lr_rest, beta1, beta2, complement1, complement2, eps, bias1, bias2, slot, active_width, _pad);
        check_mirrors_wgsl(ADAM_WGSL, "AdamParams", size_of::<AdamParams>(), &rust).unwrap();
    }
}
