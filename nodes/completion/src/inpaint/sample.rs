//! Pixel sample types and OpenCV's arithmetic on them.
//!
//! OpenCV computes differences of 8- and 16-bit samples in `int` (exact) and of
//! float samples in `float`, and converts results back with `saturate_cast`, which
//! rounds half to even for integer targets. These methods reproduce those rules so
//! the weights come out bit for bit the same.

/// A channel sample OpenCV's `inpaint` accepts: `u8`, `u16` or `f32`.
pub trait Sample: Copy + Send + Sync + PartialEq + std::fmt::Debug + 'static {
    /// A short name for messages ("u8", "u16", "f32").
    const NAME: &'static str;
    fn as_f32(self) -> f32;
    /// `(float)|a − b|`.
    fn abs_diff(a: Self, b: Self) -> f32;
    /// `(float)(|a − b| + |b − c|)`, summed in the sample's own arithmetic.
    fn abs_diff_sum(a: Self, b: Self, c: Self) -> f32;
    /// `(float)(a − b)`.
    fn diff(a: Self, b: Self) -> f32;
    /// `saturate_cast<T>(double)`: the NS result.
    fn from_f64_saturating(v: f64) -> Self;
    /// Telea's final conversion: integers get `saturate_cast<T>(v + 0.5)` (the +0.5
    /// is applied in double and then rounded half to even, as OpenCV does); floats
    /// are stored as computed.
    fn from_telea(v: f32) -> Self;
    fn is_finite(self) -> bool;
}

fn saturate_int(v: f64, max: f64) -> f64 {
    // cvRound rounds half to even; NaN cannot reach here (inputs are validated and
    // the weight sums are strictly positive), so only the range needs clamping.
    v.round_ties_even().clamp(0.0, max)
}

/// u8 and u16 differ only in name and range.
macro_rules! integer_sample {
    ($t:ty, $max:expr) => {
        impl Sample for $t {
            const NAME: &'static str = stringify!($t);
            #[inline(always)]
            fn as_f32(self) -> f32 {
                self as f32
            }
            #[inline(always)]
            fn abs_diff(a: Self, b: Self) -> f32 {
                a.abs_diff(b) as f32
            }
            #[inline(always)]
            fn abs_diff_sum(a: Self, b: Self, c: Self) -> f32 {
                (a.abs_diff(b) as u32 + b.abs_diff(c) as u32) as f32
            }
            #[inline(always)]
            fn diff(a: Self, b: Self) -> f32 {
                (a as i32 - b as i32) as f32
            }
            #[inline(always)]
            fn from_f64_saturating(v: f64) -> Self {
                saturate_int(v, $max) as $t
            }
            #[inline(always)]
            fn from_telea(v: f32) -> Self {
                saturate_int(v as f64 + 0.5, $max) as $t
            }
            fn is_finite(self) -> bool {
                true
            }
        }
    };
}

integer_sample!(u8, 255.0);
integer_sample!(u16, 65535.0);

impl Sample for f32 {
    const NAME: &'static str = "f32";
    #[inline(always)]
    fn as_f32(self) -> f32 {
        self
    }
    #[inline(always)]
    fn abs_diff(a: Self, b: Self) -> f32 {
        (a - b).abs()
    }
    #[inline(always)]
    fn abs_diff_sum(a: Self, b: Self, c: Self) -> f32 {
        (a - b).abs() + (b - c).abs()
    }
    #[inline(always)]
    fn diff(a: Self, b: Self) -> f32 {
        a - b
    }
    #[inline(always)]
    fn from_f64_saturating(v: f64) -> Self {
        v as f32
    }
    #[inline(always)]
    fn from_telea(v: f32) -> Self {
        v
    }
    fn is_finite(self) -> bool {
        f32::is_finite(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integer_conversions_round_half_to_even_and_saturate() {
        assert_eq!(u8::from_f64_saturating(2.5), 2);
        assert_eq!(u8::from_f64_saturating(3.5), 4);
        assert_eq!(u8::from_f64_saturating(-3.0), 0);
        assert_eq!(u8::from_f64_saturating(300.0), 255);
        assert_eq!(u16::from_f64_saturating(70000.0), 65535);
        // Telea adds 0.5 before rounding half to even: 2.0 → 2.5 → 2, 3.0 → 3.5 → 4.
        assert_eq!(u8::from_telea(2.0), 2);
        assert_eq!(u8::from_telea(3.0), 4);
        assert_eq!(f32::from_telea(3.0), 3.0);
    }

    #[test]
    fn differences_use_exact_integer_arithmetic() {
        assert_eq!(u8::diff(3, 250), -247.0);
        assert_eq!(u8::abs_diff_sum(0, 255, 0), 510.0);
        assert_eq!(<u16 as Sample>::abs_diff(0, 65535), 65535.0);
    }
}
