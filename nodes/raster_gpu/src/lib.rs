//! The wgpu compute backend of the ObjectSplat rasterizer.
//!
//! Devices come from `objectsplat-gpu` (adapter choice, readback, WGSL validation).
//! - [`scan`], [`sort`]: GPU exclusive prefix sum and stable LSD radix sort of
//!   (u32 key, u32 value) pairs.
//! - [`raster`]: [`WgpuBackend`], `RenderBackend<f32>` with the CPU backend's
//!   culling, ordering, compositing and gradients.
//! - [`training`]: [`DeviceTrainer`], training iterations (render, loss, the
//!   geometric terms, backward, Adam) that keep parameters and images on the
//!   device, a trained model rendered with frozen occluders.
//! - [`backend_for`]: picks a backend by name for the train/render nodes.

/// `[(field name, byte offset)]` of a `#[repr(C)]` mirror of a WGSL struct,
/// for `objectsplat_gpu::check_mirrors_wgsl`.
#[cfg(test)]
macro_rules! same_names {
    ($t:ty; $($f:ident),*) => { [$((stringify!($f), std::mem::offset_of!($t, $f))),*] };
}
#[cfg(test)]
pub(crate) use same_names;

pub mod atomics;
pub mod kernels;
pub mod raster;
pub mod scan;
pub mod sort;
pub mod training;

pub use atomics::FloatAtomics;
pub use raster::{KernelConfig, WgpuBackend};
pub use training::DeviceTrainer;

use anyhow::{Result, bail};
use objectsplat_gpu::{AdapterChoice, GpuContext};
use objectsplat_raster::{CpuBackend, RenderBackend};

/// A rendering backend by name, and one line for the run report saying which
/// backend runs and why:
/// - `"cpu"`: the CPU backend on `threads` threads;
/// - `"wgpu"`: wgpu on a hardware GPU, else on lavapipe; an error naming why when neither exists;
/// - `"auto"`: wgpu on a hardware GPU, else the CPU backend. Lavapipe is skipped by
///   `auto` on purpose: on the 2-core CI machine it measured about 10× slower than the
///   CPU backend for the same scene (docs/benchmarks.md, "wgpu backend"), so picking it
///   would make every run slower. Ask for it with `"wgpu"`.
pub fn backend_for(name: &str, threads: usize) -> Result<(Box<dyn RenderBackend<f32>>, String)> {
    let threads = threads.max(1);
    let cpu = || -> Box<dyn RenderBackend<f32>> { Box::new(CpuBackend::new(threads)) };
    let wgpu = |choice| -> Result<(Box<dyn RenderBackend<f32>>, String)> {
        let (ctx, why) = GpuContext::shared(choice)?;
        let backend = WgpuBackend::new(ctx)?;
        Ok((Box::new(backend), why))
    };
    match name {
        "cpu" => Ok((cpu(), format!("cpu backend ({threads} threads): requested"))),
        "wgpu" => wgpu(AdapterChoice::Auto)
            .map_err(|e| e.context("the wgpu backend has no usable adapter")),
        "auto" => match wgpu(AdapterChoice::Gpu) {
            Ok(found) => Ok(found),
            Err(e) => Ok((
                cpu(),
                format!(
                    "cpu backend ({threads} threads): no hardware GPU adapter ({e:#}); \
                     lavapipe is slower than the CPU backend, use backend \"wgpu\" to force it"
                ),
            )),
        },
        other => bail!("unknown render backend {other:?}; expected \"cpu\", \"wgpu\" or \"auto\""),
    }
}
