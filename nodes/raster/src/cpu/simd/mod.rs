//! Eight-lane f32 kernels of the CPU backend (x86-64 with AVX2 and FMA).
//!
//! The scalar kernels in [`super::forward`] and [`super::backward`] walk a
//! tile's pixels one at a time. These walk them eight at a time: a 16-px
//! tile row is two lane groups, a face visits the groups its pixel box
//! overlaps and masks the lanes it does not cover. Everything else (culling,
//! binning, the per-face and per-vertex backward) is shared with the scalar
//! path. The one transcendental, the window `G^σ`, is [`math::pow`], with a
//! bounded error (see there).
//!
//! Soundness: AVX2 instructions may only run on a CPU that has them. An
//! [`F32x8`] can only be made from an [`Avx2`] token, and the token only by
//! [`Avx2::detect`], which checks the CPU at run time; so every value of the
//! vector types proves the instructions exist, and their safe methods may
//! execute them. The kernels are compiled with the features enabled
//! (`#[target_feature]`), so the methods inline into straight vector code.

pub mod backward;
pub mod forward;
pub mod math;

use std::arch::x86_64::*;
use std::ops::{Add, BitAnd, BitOr, Mul, Neg, Sub};

/// Proof that the running CPU has AVX2, FMA and POPCNT (every AVX2 CPU has the last).
#[derive(Debug, Clone, Copy)]
pub struct Avx2(());

impl Avx2 {
    /// The token when the CPU has the features (checked once, then cached by std).
    pub fn detect() -> Option<Avx2> {
        (is_x86_feature_detected!("avx2")
            && is_x86_feature_detected!("fma")
            && is_x86_feature_detected!("popcnt"))
        .then_some(Avx2(()))
    }

    /// Asks the CPU to bring `value` into its caches (the tile loops read
    /// faces in tile order, which is scattered in memory).
    #[inline(always)]
    pub fn prefetch<T>(self, value: &T) {
        let start = (value as *const T).cast::<i8>();
        for offset in (0..std::mem::size_of::<T>()).step_by(64) {
            // SAFETY: a prefetch is a hint that never faults; the addresses lie inside `value`.
            unsafe { _mm_prefetch::<_MM_HINT_T0>(start.add(offset)) };
        }
    }
}

/// Number of lanes.
pub const LANES: usize = 8;

/// Arithmetic of one fragment in the eight-lane forward kernel, counted from
/// its code (an add, subtract, multiply or divide is 1, a fused multiply-add
/// 2; compares, selects, min/max, rounding and integer work are not counted):
/// barycentrics 15, window argument 3, `G^σ` 43, α 1, weight 1, colour and
/// depth 20, their accumulation 8, transmittance 2. For a roofline estimate:
/// lanes that blend nothing are not counted, though the kernel pays for them.
pub const FORWARD_FLOPS_PER_FRAGMENT: u32 = 93;

/// The same count for the eight-lane backward kernel: the fragment rebuilt
/// from its record 40, `h` and the running sum behind it 9, dL/dα, dL/dG and
/// the colour, depth and opacity terms 14, and per corner the barycentric
/// gradient and the face partial's sums 27.
pub const BACKWARD_FLOPS_PER_FRAGMENT: u32 = 144;

/// `[f(0), f(1), f(2)]`. Arrays' `map` would run the closure from inside
/// core's generic code, compiled without AVX2, where the vector methods do
/// not inline (each lane operation becomes a call).
#[inline(always)]
pub fn each3<T>(mut f: impl FnMut(usize) -> T) -> [T; 3] {
    [f(0), f(1), f(2)]
}

/// Eight f32 lanes.
#[derive(Debug, Clone, Copy)]
pub struct F32x8(__m256);

/// A per-lane condition (all bits of a lane set or clear).
#[derive(Debug, Clone, Copy)]
pub struct Mask8(__m256);

/// Eight i32 lanes (exponent arithmetic of [`math`]).
#[derive(Debug, Clone, Copy)]
pub struct I32x8(__m256i);

// SAFETY (every `unsafe` block below): the intrinsics are AVX/AVX2/FMA
// instructions; a value of `F32x8`, `Mask8` or `I32x8` exists only once an
// `Avx2` token did (every constructor takes the token or such a value), so the
// CPU has them. Loads and stores go through references to exactly eight f32
// or i32, so the pointers are valid for the 32 bytes accessed (unaligned
// access instructions).

impl F32x8 {
    #[inline(always)]
    pub fn splat(_: Avx2, v: f32) -> Self {
        F32x8(unsafe { _mm256_set1_ps(v) })
    }

    #[inline(always)]
    pub fn zero(_: Avx2) -> Self {
        F32x8(unsafe { _mm256_setzero_ps() })
    }

    #[inline(always)]
    pub fn load(_: Avx2, a: &[f32; LANES]) -> Self {
        F32x8(unsafe { _mm256_loadu_ps(a.as_ptr()) })
    }

    /// Lanes `start..start + 8` of `s` (panics when `s` is shorter).
    #[inline(always)]
    pub fn load_at(t: Avx2, s: &[f32], start: usize) -> Self {
        let lanes: &[f32; LANES] = s[start..start + LANES]
            .try_into()
            .expect("a slice of LANES elements");
        Self::load(t, lanes)
    }

    #[inline(always)]
    pub fn store(self, a: &mut [f32; LANES]) {
        unsafe { _mm256_storeu_ps(a.as_mut_ptr(), self.0) }
    }

    /// Writes the lanes to `s[start..start + 8]` (panics when `s` is shorter).
    #[inline(always)]
    pub fn store_at(self, s: &mut [f32], start: usize) {
        let lanes: &mut [f32; LANES] = (&mut s[start..start + LANES])
            .try_into()
            .expect("a slice of LANES elements");
        self.store(lanes);
    }

    #[inline(always)]
    pub fn to_array(self) -> [f32; LANES] {
        // SAFETY: `__m256` is 32 bytes of plain f32 data, as `[f32; 8]` (a
        // reinterpretation, no instruction that needs the CPU features).
        unsafe { std::mem::transmute::<__m256, [f32; LANES]>(self.0) }
    }

    /// `0, 1, …, 7`.
    #[inline(always)]
    pub fn lane_index(_: Avx2) -> Self {
        F32x8(unsafe { _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0) })
    }

    /// `self·b + c` with one rounding.
    #[inline(always)]
    pub fn mul_add(self, b: Self, c: Self) -> Self {
        F32x8(unsafe { _mm256_fmadd_ps(self.0, b.0, c.0) })
    }

    /// `self·b − c` with one rounding.
    #[inline(always)]
    pub fn mul_sub(self, b: Self, c: Self) -> Self {
        F32x8(unsafe { _mm256_fmsub_ps(self.0, b.0, c.0) })
    }

    #[inline(always)]
    // A method like its neighbours (mul_add, min, or), not the operator trait: the
    // kernels read as one chain of lane operations.
    #[allow(clippy::should_implement_trait)]
    pub fn div(self, b: Self) -> Self {
        F32x8(unsafe { _mm256_div_ps(self.0, b.0) })
    }

    /// Lane-wise minimum; where either lane is NaN, `b`'s lane.
    #[inline(always)]
    pub fn min(self, b: Self) -> Self {
        F32x8(unsafe { _mm256_min_ps(self.0, b.0) })
    }

    /// Lane-wise maximum; where either lane is NaN, `b`'s lane.
    #[inline(always)]
    pub fn max(self, b: Self) -> Self {
        F32x8(unsafe { _mm256_max_ps(self.0, b.0) })
    }

    /// Rounds to the nearest integer (ties to even).
    #[inline(always)]
    pub fn round(self) -> Self {
        F32x8(unsafe {
            _mm256_round_ps::<{ _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC }>(self.0)
        })
    }

    /// The lanes (already whole numbers within i32 range) as integers.
    #[inline(always)]
    pub fn to_i32(self) -> I32x8 {
        I32x8(unsafe { _mm256_cvtps_epi32(self.0) })
    }

    #[inline(always)]
    pub fn to_bits(self) -> I32x8 {
        I32x8(unsafe { _mm256_castps_si256(self.0) })
    }

    #[inline(always)]
    pub fn lt(self, b: Self) -> Mask8 {
        Mask8(unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(self.0, b.0) })
    }

    #[inline(always)]
    pub fn gt(self, b: Self) -> Mask8 {
        Mask8(unsafe { _mm256_cmp_ps::<_CMP_GT_OQ>(self.0, b.0) })
    }

    #[inline(always)]
    pub fn le(self, b: Self) -> Mask8 {
        Mask8(unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(self.0, b.0) })
    }

    #[inline(always)]
    pub fn ge(self, b: Self) -> Mask8 {
        Mask8(unsafe { _mm256_cmp_ps::<_CMP_GE_OQ>(self.0, b.0) })
    }

    /// `!(self < b)`: true where a lane is NaN, as the scalar kernels' `!(x < y)`.
    #[inline(always)]
    pub fn not_lt(self, b: Self) -> Mask8 {
        Mask8(unsafe { _mm256_cmp_ps::<_CMP_NLT_UQ>(self.0, b.0) })
    }

    /// Lane `i` of the result is the sum of the lanes of `v[i]` (pairwise:
    /// adjacent lanes, then pairs, then halves).
    #[inline(always)]
    pub fn sum_each(v: [F32x8; LANES]) -> F32x8 {
        unsafe {
            let first = _mm256_hadd_ps(
                _mm256_hadd_ps(v[0].0, v[1].0),
                _mm256_hadd_ps(v[2].0, v[3].0),
            );
            let second = _mm256_hadd_ps(
                _mm256_hadd_ps(v[4].0, v[5].0),
                _mm256_hadd_ps(v[6].0, v[7].0),
            );
            // first = [Σ₀³ v0..v3 | Σ₄⁷ v0..v3], second likewise for v4..v7.
            F32x8(_mm256_add_ps(
                _mm256_permute2f128_ps::<0x20>(first, second),
                _mm256_permute2f128_ps::<0x31>(first, second),
            ))
        }
    }

    /// Largest lane, ignoring NaN lanes (as `f32::max`).
    #[inline(always)]
    pub fn max_lane(self) -> f32 {
        self.to_array()
            .into_iter()
            .fold(f32::NEG_INFINITY, f32::max)
    }
}

impl Add for F32x8 {
    type Output = Self;
    #[inline(always)]
    fn add(self, b: Self) -> Self {
        F32x8(unsafe { _mm256_add_ps(self.0, b.0) })
    }
}

impl Sub for F32x8 {
    type Output = Self;
    #[inline(always)]
    fn sub(self, b: Self) -> Self {
        F32x8(unsafe { _mm256_sub_ps(self.0, b.0) })
    }
}

impl Mul for F32x8 {
    type Output = Self;
    #[inline(always)]
    fn mul(self, b: Self) -> Self {
        F32x8(unsafe { _mm256_mul_ps(self.0, b.0) })
    }
}

impl Neg for F32x8 {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        F32x8(unsafe { _mm256_xor_ps(self.0, _mm256_set1_ps(-0.0)) })
    }
}

impl Mask8 {
    /// Lane `l` set where bit `l` of `bits` is.
    #[inline(always)]
    pub fn from_bits(_: Avx2, bits: u8) -> Self {
        unsafe {
            let lane_bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
            let b = _mm256_and_si256(_mm256_set1_epi32(bits as i32), lane_bits);
            Mask8(_mm256_castsi256_ps(_mm256_cmpeq_epi32(b, lane_bits)))
        }
    }

    /// Bit `l` set where lane `l` is.
    #[inline(always)]
    pub fn bits(self) -> u8 {
        // movemask sets only the low eight bits of its i32.
        (unsafe { _mm256_movemask_ps(self.0) }) as u8
    }

    #[inline(always)]
    pub fn any(self) -> bool {
        self.bits() != 0
    }

    /// `self ∧ ¬b`.
    #[inline(always)]
    pub fn and_not(self, b: Self) -> Self {
        Mask8(unsafe { _mm256_andnot_ps(b.0, self.0) })
    }

    /// Per lane: `a` where set, else `b`.
    #[inline(always)]
    pub fn select(self, a: F32x8, b: F32x8) -> F32x8 {
        F32x8(unsafe { _mm256_blendv_ps(b.0, a.0, self.0) })
    }

    /// Per lane: `a` where set, else `b`.
    #[inline(always)]
    pub fn select_i32(self, a: I32x8, b: I32x8) -> I32x8 {
        I32x8(unsafe {
            _mm256_castps_si256(_mm256_blendv_ps(
                _mm256_castsi256_ps(b.0),
                _mm256_castsi256_ps(a.0),
                self.0,
            ))
        })
    }

    /// `a` where set, else 0.
    #[inline(always)]
    pub fn keep(self, a: F32x8) -> F32x8 {
        F32x8(unsafe { _mm256_and_ps(self.0, a.0) })
    }
}

impl BitAnd for Mask8 {
    type Output = Self;
    #[inline(always)]
    fn bitand(self, b: Self) -> Self {
        Mask8(unsafe { _mm256_and_ps(self.0, b.0) })
    }
}

impl BitOr for Mask8 {
    type Output = Self;
    #[inline(always)]
    fn bitor(self, b: Self) -> Self {
        Mask8(unsafe { _mm256_or_ps(self.0, b.0) })
    }
}

impl I32x8 {
    #[inline(always)]
    pub fn splat(_: Avx2, v: i32) -> Self {
        I32x8(unsafe { _mm256_set1_epi32(v) })
    }

    #[inline(always)]
    pub fn load(_: Avx2, a: &[i32; LANES]) -> Self {
        I32x8(unsafe { _mm256_loadu_si256(a.as_ptr().cast()) })
    }

    /// Lanes `start..start + 8` of `s` (panics when `s` is shorter).
    #[inline(always)]
    pub fn load_at(t: Avx2, s: &[i32], start: usize) -> Self {
        let lanes: &[i32; LANES] = s[start..start + LANES]
            .try_into()
            .expect("a slice of LANES elements");
        Self::load(t, lanes)
    }

    #[inline(always)]
    pub fn store(self, a: &mut [i32; LANES]) {
        unsafe { _mm256_storeu_si256(a.as_mut_ptr().cast(), self.0) }
    }

    /// Writes the lanes to `s[start..start + 8]` (panics when `s` is shorter).
    #[inline(always)]
    pub fn store_at(self, s: &mut [i32], start: usize) {
        let lanes: &mut [i32; LANES] = (&mut s[start..start + LANES])
            .try_into()
            .expect("a slice of LANES elements");
        self.store(lanes);
    }

    #[inline(always)]
    pub fn eq(self, b: Self) -> Mask8 {
        Mask8(unsafe { _mm256_castsi256_ps(_mm256_cmpeq_epi32(self.0, b.0)) })
    }

    #[inline(always)]
    pub fn to_f32(self) -> F32x8 {
        F32x8(unsafe { _mm256_cvtepi32_ps(self.0) })
    }

    /// Reinterprets the bits as f32 lanes.
    #[inline(always)]
    pub fn from_bits_f32(self) -> F32x8 {
        F32x8(unsafe { _mm256_castsi256_ps(self.0) })
    }

    #[inline(always)]
    pub fn and(self, b: Self) -> Self {
        I32x8(unsafe { _mm256_and_si256(self.0, b.0) })
    }

    #[inline(always)]
    pub fn or(self, b: Self) -> Self {
        I32x8(unsafe { _mm256_or_si256(self.0, b.0) })
    }

    #[inline(always)]
    // A method like its neighbours (mul_add, min, or), not the operator trait: the
    // kernels read as one chain of lane operations.
    #[allow(clippy::should_implement_trait)]
    pub fn add(self, b: Self) -> Self {
        I32x8(unsafe { _mm256_add_epi32(self.0, b.0) })
    }

    #[inline(always)]
    pub fn min(self, b: Self) -> Self {
        I32x8(unsafe { _mm256_min_epi32(self.0, b.0) })
    }

    #[inline(always)]
    pub fn max(self, b: Self) -> Self {
        I32x8(unsafe { _mm256_max_epi32(self.0, b.0) })
    }

    /// Logical shift right by `N` bits.
    #[inline(always)]
    pub fn shr<const N: i32>(self) -> Self {
        I32x8(unsafe { _mm256_srli_epi32::<N>(self.0) })
    }

    /// Shift left by `N` bits.
    #[inline(always)]
    pub fn shl<const N: i32>(self) -> Self {
        I32x8(unsafe { _mm256_slli_epi32::<N>(self.0) })
    }
}
