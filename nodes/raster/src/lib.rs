//! The differentiable triangle rasterizer of ObjectSplat (mesh splatting).
//!
//! - [`Model`]: vertices, faces, per-vertex SH (degree ≤ 3) and opacity logits
//!   with the floor activation; its folder encoding lives in [`model_io`]
//!   (documented in the crate README).
//! - [`RenderBackend`]: forward (colour over a per-pixel background, alpha,
//!   expected/median depth, per-face max weight and pixel count) and the full
//!   analytic backward; [`CpuBackend`] is the multi-threaded reference
//!   implementation, generic over [`Real`] (f32 for speed, f64 for checks).
//! - [`loss`]: L1, SSIM and `0.8·L1 + 0.2·(1 − SSIM)` with gradients and
//!   per-pixel weights.
//! - [`supersample`]: `s × s` samples per pixel, box-filtered (forward and adjoint).

// Numerical kernels index several parallel fixed-size arrays with one index,
// and use negated comparisons on purpose so that NaN fails every acceptance test.
#![allow(clippy::needless_range_loop, clippy::neg_cmp_op_on_partial_ord)]

pub mod backend;
pub mod cpu;
pub mod exported;
pub mod loss;
pub mod model;
pub mod model_io;
pub mod parallel;
pub mod real;
pub mod sh;
pub mod supersample;

pub use backend::{OutputGrads, RenderBackend, RenderOutput, RenderSettings, SavedForward};
pub use cpu::{CpuBackend, Kernel, render_model};
pub use model::{FINISHED_SIGMA, Model, ModelGrads, SH_COEFFS};
pub use model_io::{load_model, save_model};
pub use real::Real;
