//! `x^y` on eight lanes for the window `G^σ` (`0 < G ≲ 1`, `0 < σ ≲ 1` in
//! training, any positive σ accepted), as `2^(y·log₂x)`:
//!
//! - `log₂x = e + log₂m` with `m ∈ [√½, √2)` from the float's bits (a
//!   subnormal `x` is scaled by 2²³ first) and `ln m = 2·atanh(t)`,
//!   `t = (m − 1)/(m + 1)`, `|t| ≤ 0.172`, by its series to `t⁹` (truncation
//!   below 1e-9).
//! - `y·e` is split into a whole number and the rest without rounding loss
//!   (an FMA gives the product's rounding error), so large exponents cost no
//!   precision; the fraction `r ∈ [−½, ½]` goes through the Taylor series of
//!   `e^(r·ln 2)` to degree 7 (truncation below 6e-9) and the whole part into
//!   the exponent bits. Results below 2⁻¹²⁶ are flushed to 0 (a window that
//!   small gives α ≪ 1/255, never blended).
//!
//! Measured bound (the unit test below sweeps `x ∈ [1e-30, 1]`,
//! `y ∈ [1e-4, 4]` against f64 `powf`): relative error ≤ 4e-7 (about 3.5 f32
//! ulp) wherever the result is at least 1e-30, i.e. well inside the f32
//! rounding of the α it scales. The scalar path's `powf` is correctly
//! rounded in f32 (≤ 0.5 ulp), so the two paths' windows differ by a few ulp.

use super::{Avx2, F32x8, I32x8};

const SQRT_2: f32 = std::f32::consts::SQRT_2;
/// 2²³, the scale that makes any positive subnormal f32 normal.
const SUBNORMAL_SCALE: f32 = 8_388_608.0;

/// `x^y` for `x > 0` (subnormal included) and finite `y` with `|y·log₂x| < 2³⁰`.
/// Other lanes give unspecified values (never a trap); callers mask them.
#[inline(always)]
pub fn pow(t: Avx2, x: F32x8, y: F32x8) -> F32x8 {
    let (whole, frac) = log2_parts(t, x);
    // y·log₂x = y·whole + y·frac, with y·whole split exactly into hi + lo.
    let hi = y * whole;
    let lo = y.mul_sub(whole, hi);
    let n = hi.round();
    let r = (hi - n) + y.mul_add(frac, lo);
    // |r| may exceed ½ by up to |y|/2 + ulp: fold it back.
    let m = r.round();
    exp2_split(t, n + m, r - m)
}

/// `log₂x = whole + frac` for `x > 0`: `whole` an integer, `|frac| ≤ ½`.
#[inline(always)]
fn log2_parts(t: Avx2, x: F32x8) -> (F32x8, F32x8) {
    let subnormal = x.lt(F32x8::splat(t, f32::MIN_POSITIVE));
    let x = subnormal.select(x * F32x8::splat(t, SUBNORMAL_SCALE), x);
    let bits = x.to_bits();
    let exponent = bits
        .shr::<23>()
        .and(I32x8::splat(t, 0xff))
        .add(I32x8::splat(t, -127))
        .to_f32();
    let exponent = subnormal.select(exponent - F32x8::splat(t, 23.0), exponent);
    // Mantissa in [1, 2), then folded to [√½, √2) so |t| stays small.
    let one = F32x8::splat(t, 1.0);
    let m = bits
        .and(I32x8::splat(t, 0x007f_ffff))
        .or(I32x8::splat(t, 0x3f80_0000))
        .from_bits_f32();
    let fold = m.gt(F32x8::splat(t, SQRT_2));
    let m = fold.select(m * F32x8::splat(t, 0.5), m);
    let whole = fold.select(exponent + one, exponent);
    let s = (m - one).div(m + one);
    let s2 = s * s;
    // ln m = 2·atanh(s) = 2s·(1 + s²/3 + s⁴/5 + s⁶/7 + s⁸/9).
    let series = F32x8::splat(t, 1.0 / 9.0)
        .mul_add(s2, F32x8::splat(t, 1.0 / 7.0))
        .mul_add(s2, F32x8::splat(t, 1.0 / 5.0))
        .mul_add(s2, F32x8::splat(t, 1.0 / 3.0))
        .mul_add(s2, one);
    let two_log2e = F32x8::splat(t, 2.0 * std::f32::consts::LOG2_E);
    (whole, (s * two_log2e) * series)
}

/// `2^(n + r)` for an integer `n` and `|r| ≤ ½`; 0 below 2⁻¹²⁶.
#[inline(always)]
fn exp2_split(t: Avx2, n: F32x8, r: F32x8) -> F32x8 {
    // e^(r·ln 2) = Σ (r·ln 2)^k / k!, k ≤ 7.
    const LN2: f64 = std::f64::consts::LN_2;
    let c = |k: i32, fact: f64| F32x8::splat(t, (LN2.powi(k) / fact) as f32);
    let p = c(7, 5040.0)
        .mul_add(r, c(6, 720.0))
        .mul_add(r, c(5, 120.0))
        .mul_add(r, c(4, 24.0))
        .mul_add(r, c(3, 6.0))
        .mul_add(r, c(2, 2.0))
        .mul_add(r, c(1, 1.0))
        .mul_add(r, F32x8::splat(t, 1.0));
    // 2^n from the exponent bits; n ≤ −127 gives the bits of +0.
    let biased = n
        .to_i32()
        .max(I32x8::splat(t, -127))
        .min(I32x8::splat(t, 127))
        .add(I32x8::splat(t, 127));
    p * biased.shl::<23>().from_bits_f32()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sweeps x geometrically over [1e-30, 1] (subnormals and exact powers
    /// of two included) and y over [1e-4, 4], against f64.
    #[test]
    fn pow_is_within_its_stated_bound() {
        let Some(t) = Avx2::detect() else {
            eprintln!("skipped: this CPU has no AVX2/FMA");
            return;
        };
        let mut xs: Vec<f32> = (0..=20_000)
            .map(|i| 10f64.powf(-30.0 * i as f64 / 20_000.0) as f32)
            .collect();
        xs.extend([
            1.0,
            0.5,
            0.25,
            1.0 - f32::EPSILON,
            1.0 + f32::EPSILON,
            SQRT_2,
        ]);
        xs.extend([1e-39, 1e-42, f32::MIN_POSITIVE, f32::MIN_POSITIVE * 0.75]);
        let ys = [
            1e-4f32, 3e-3, 0.05, 0.1, 0.33, 0.5, 0.77, 1.0, 1.5, 2.0, 3.3, 4.0,
        ];
        let mut worst = 0.0f64;
        for &y in &ys {
            for chunk in xs.chunks(8) {
                let mut lanes = [1.0f32; 8];
                lanes[..chunk.len()].copy_from_slice(chunk);
                let got = pow(t, F32x8::load(t, &lanes), F32x8::splat(t, y)).to_array();
                for (&x, &g) in lanes.iter().zip(&got) {
                    let want = (x as f64).powf(y as f64);
                    assert!(g.is_finite() && g >= 0.0, "pow({x}, {y}) = {g}");
                    if want >= 1e-30 {
                        let rel = ((g as f64) - want).abs() / want;
                        worst = worst.max(rel);
                        assert!(
                            rel <= 4e-7,
                            "pow({x}, {y}) = {g}, want {want}: relative {rel:.2e}"
                        );
                    } else if want < f32::MIN_POSITIVE as f64 * 0.5 {
                        assert!(g as f64 <= f32::MIN_POSITIVE as f64, "pow({x}, {y}) = {g}");
                    }
                }
            }
        }
        eprintln!("pow: worst relative error {worst:.3e}");
    }
}
