//! The scalar type the renderer is generic over: `f32` for speed, `f64` for
//! gradient checks. One code path serves both.

use num_traits::{Float, NumAssign};
use std::fmt::{Debug, Display};

/// Whether every value is finite. The checks on every render's model and
/// every step's gradients use it: scanned without an early exit per value, it
/// vectorizes, and chunks keep the early exit for a bad input (whose culprit
/// the caller then searches for its message).
pub fn all_finite<R: Float>(values: &[R]) -> bool {
    values
        .chunks(256)
        .all(|chunk| chunk.iter().fold(true, |ok, x| ok & x.is_finite()))
}

/// A floating-point scalar usable by the rasterizer.
pub trait Real: Float + NumAssign + Debug + Display + Default + Send + Sync + 'static {
    /// Converts an `f64` constant or parameter (rounding for `f32`).
    fn of(v: f64) -> Self;
    /// Widens to `f64` (exact for both implementors).
    fn f64(self) -> f64;
    /// The slice itself when `Self` is `f32`: lets generic code hand borrowed
    /// data to the f32-only SIMD kernels.
    fn as_f32_slice(_: &[Self]) -> Option<&[f32]> {
        None
    }
}

impl Real for f32 {
    #[inline(always)]
    fn of(v: f64) -> Self {
        v as f32
    }
    #[inline(always)]
    fn f64(self) -> f64 {
        self as f64
    }
    fn as_f32_slice(s: &[f32]) -> Option<&[f32]> {
        Some(s)
    }
}

impl Real for f64 {
    #[inline(always)]
    fn of(v: f64) -> Self {
        v
    }
    #[inline(always)]
    fn f64(self) -> f64 {
        self
    }
}
