//! The scalar type the renderer is generic over: `f32` for speed, `f64` for
//! gradient checks. One code path serves both.

use crate::parallel::{chunk_size, run_iter};
use num_traits::{Float, NumAssign};
use std::fmt::{Debug, Display};
use std::sync::atomic::{AtomicBool, Ordering};

/// Whether every value is finite. The checks on every render's model and
/// every step's gradients use it: scanned without an early exit per value, it
/// vectorizes, and chunks keep the early exit for a bad input (whose culprit
/// the caller then searches for its message).
pub fn all_finite<R: Float>(values: &[R]) -> bool {
    values
        .chunks(256)
        .all(|chunk| chunk.iter().fold(true, |ok, x| ok & x.is_finite()))
}

/// [`all_finite`] on up to `threads` threads. A background's model and its
/// SH gradients are megabytes, checked on every render and every step: one
/// core streams them slower than two, and the other core would wait meanwhile.
pub fn all_finite_on<R: Float + Sync>(threads: usize, values: &[R]) -> bool {
    let chunk = chunk_size(values.len(), threads, 1 << 15);
    if threads <= 1 || chunk >= values.len() {
        return all_finite(values);
    }
    let finite = AtomicBool::new(true);
    run_iter(
        threads,
        values.chunks(chunk),
        || (),
        |_, part| {
            if finite.load(Ordering::Relaxed) && !all_finite(part) {
                finite.store(false, Ordering::Relaxed);
            }
        },
    );
    finite.into_inner()
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_value_that_is_not_finite_is_found_on_any_thread_count_wherever_it_is() {
        let mut values = vec![1.5f32; 300_000];
        for threads in [1, 2, 3, 8] {
            assert!(all_finite_on(threads, &values));
            for at in [0, 32_767, 32_768, 150_001, 299_999] {
                for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
                    values[at] = bad;
                    assert!(
                        !all_finite_on(threads, &values),
                        "{bad} at {at}, {threads} threads"
                    );
                    assert!(!all_finite(&values));
                    values[at] = 1.5;
                }
            }
        }
        assert!(all_finite_on::<f64>(2, &[]));
    }
}
