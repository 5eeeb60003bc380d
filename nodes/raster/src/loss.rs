//! Photometric losses with gradients with respect to the rendered image:
//! L1, SSIM (11×11 Gaussian window, σ = 1.5, C1 = 0.01², C2 = 0.03², zero
//! padding, as 3DGS) and `(1 − λ)·L1 + λ·(1 − SSIM)`.
//!
//! Images are row-major, channel-interleaved. Optional per-pixel weights
//! (H×W, finite, ≥ 0; 0 = pixel not supervised) turn every mean into a
//! weighted mean: `L1 = Σ_p w_p Σ_c |x − y| / (C·Σ_p w_p)` and
//! `SSIM = Σ_p w_p Σ_c S_pc / (C·Σ_p w_p)` where `S` is the ordinary SSIM map
//! (only the averaging of the map is weighted). A pixel of weight 0 enters
//! the SSIM windows of its neighbours with its target value in place of the
//! render, so nothing about it is learned: otherwise a supervised pixel's
//! window would pull the unsupervised pixels within 5 px of it toward their
//! targets (the background component learning the edges of the objects in
//! front of it). With all weights zero both losses are 0 with zero gradient.
//!
//! [`PhotometricLoss`] evaluates the loss on a crop of a larger image whose
//! pixels outside the crop render exactly their target (a trainer's view of
//! an object: outside the object's footprint both are the background colour).
//! There `|x − y| = 0` and the SSIM map is exactly 1 as long as the crop
//! reaches [`CROP_MARGIN`] pixels beyond every pixel where `x ≠ y` (then the
//! zero padding at the crop border sees `x = y` too), so the crop's sums plus
//! the outside weight give the full image's loss and gradient. It keeps its
//! planes between calls, runs its row passes on several threads, and skips
//! the gradient when only the value is wanted.

use crate::backend::check_buffer;
use crate::parallel::{run_iter, run_iter_pooled};
use crate::real::Real;
use anyhow::{Result, bail};

pub const SSIM_WINDOW: usize = 11;
pub const SSIM_SIGMA: f64 = 1.5;
pub const SSIM_C1: f64 = 0.01 * 0.01;
pub const SSIM_C2: f64 = 0.03 * 0.03;
/// The reference's D-SSIM weight in `(1 − λ)·L1 + λ·(1 − SSIM)`.
pub const DEFAULT_LAMBDA_DSSIM: f64 = 0.2;
/// How far beyond the pixels where render and target differ a crop must
/// reach for its loss and gradient to equal the full image's: the SSIM map at
/// a pixel reads 5 pixels around it, and its gradient 5 more.
pub const CROP_MARGIN: u32 = 2 * (SSIM_WINDOW as u32 / 2);

const HALF: usize = SSIM_WINDOW / 2;
/// Rows per job of the row passes: fixed, so sums do not depend on the thread count.
const ROWS_PER_JOB: usize = 8;

/// Image shape shared by the rendered image, the target and the gradient.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Dims {
    pub width: usize,
    pub height: usize,
    pub channels: usize,
}

impl Dims {
    pub fn rgb(width: u32, height: u32) -> Self {
        Dims {
            width: width as usize,
            height: height as usize,
            channels: 3,
        }
    }
    fn pixels(&self) -> usize {
        self.width * self.height
    }
}

/// A loss value and its gradient with respect to the rendered image.
#[derive(Debug, Clone, PartialEq)]
pub struct LossGrad<R: Real> {
    pub value: R,
    pub grad: Vec<R>,
}

/// How the crop's sums become means over the whole image.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Normalization {
    /// `Σ w` over the whole image (its pixel count when unweighted).
    pub total_weight: f64,
    /// `Σ w` over the pixels outside the crop, where render and target agree.
    pub outside_weight: f64,
}

impl Normalization {
    /// The crop is the whole image.
    pub fn whole(total_weight: f64) -> Self {
        Normalization {
            total_weight,
            outside_weight: 0.0,
        }
    }
}

/// The loss value and its two parts.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LossValue {
    pub l1: f64,
    pub ssim: f64,
    /// `(1 − λ)·L1 + λ·(1 − SSIM)`; 0 when no pixel is supervised.
    pub total: f64,
}

/// `(1 − λ)·L1 + λ·(1 − SSIM)` on a crop, with reusable planes (see the module doc).
#[derive(Debug, Clone, Default)]
pub struct PhotometricLoss<R: Real> {
    /// Row-blurred x, y, x², y², xy of one channel; later the row-blurred gradient maps.
    rows: [Vec<R>; 5],
    /// ∂SSIM/∂(μx, σx², σxy) weighted per pixel, of one channel.
    maps: [Vec<R>; 3],
    /// Per job: (Σ w·|x − y|, Σ w·S) of its rows.
    partials: Vec<(f64, f64)>,
    /// Per worker: rows of x, y and a product (row pass), five blurred rows
    /// and the weighted SSIM map (column passes).
    row_scratch: Vec<[Vec<R>; 3]>,
    column_scratch: Vec<[Vec<R>; 6]>,
    /// dL/d(rendered), filled by [`PhotometricLoss::evaluate`] when asked for.
    pub grad: Vec<R>,
}

fn gaussian_taps<R: Real>() -> [R; SSIM_WINDOW] {
    let half = HALF as f64;
    let raw: Vec<f64> = (0..SSIM_WINDOW)
        .map(|i| (-(i as f64 - half).powi(2) / (2.0 * SSIM_SIGMA * SSIM_SIGMA)).exp())
        .collect();
    let sum: f64 = raw.iter().sum();
    std::array::from_fn(|i| R::of(raw[i] / sum))
}

/// Defines a function whose body is compiled twice: for AVX2 (eight f32
/// lanes per instruction), run on CPUs that have it, and for the baseline
/// target. The loops are written so the compiler vectorizes them; Rust
/// neither fuses nor reorders float operations, so both give the same bits.
macro_rules! widened {
    ($(#[$doc:meta])* fn $name:ident<R: Real>($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $(#[$doc])*
        #[inline]
        #[allow(clippy::too_many_arguments)]
        fn $name<R: Real>($($arg: $ty),*) $(-> $ret)? {
            #[inline(always)]
            #[allow(clippy::too_many_arguments)]
            fn body<R: Real>($($arg: $ty),*) $(-> $ret)? $body
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2")]
                #[allow(clippy::too_many_arguments)]
                fn avx2<R: Real>($($arg: $ty),*) $(-> $ret)? {
                    body($($arg),*)
                }
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU has AVX2.
                    return unsafe { avx2($($arg),*) };
                }
            }
            body($($arg),*)
        }
    };
}

widened! {
    /// One row of the zero-padded horizontal blur: `dst[x] = Σ_t taps[t]·src[x + t − 5]`.
    fn blur_row<R: Real>(src: &[R], taps: &[R; SSIM_WINDOW], dst: &mut [R]) {
        let w = src.len();
        if w > 2 * HALF {
            // Interior: every tap in range, a fixed-length loop the compiler vectorizes.
            let inner = &mut dst[HALF..w - HALF];
            inner.fill(R::zero());
            for (t, &tap) in taps.iter().enumerate() {
                for (d, &s) in inner.iter_mut().zip(&src[t..t + w - 2 * HALF]) {
                    *d += tap * s;
                }
            }
        }
        for x in (0..w.min(HALF)).chain(w.saturating_sub(HALF).max(HALF.min(w))..w) {
            let lo = x.saturating_sub(HALF);
            let hi = (x + HALF).min(w - 1);
            let mut acc = R::zero();
            for xx in lo..=hi {
                acc += taps[xx + HALF - x] * src[xx];
            }
            dst[x] = acc;
        }
    }
}

widened! {
    /// Row `y` of the zero-padded vertical blur of a planar `width`-wide image, into `acc`.
    fn blur_column_into<R: Real>(
        src: &[R],
        width: usize,
        height: usize,
        y: usize,
        taps: &[R; SSIM_WINDOW],
        acc: &mut [R],
    ) {
        acc.fill(R::zero());
        let lo = y.saturating_sub(HALF);
        let hi = (y + HALF).min(height - 1);
        for yy in lo..=hi {
            let tap = taps[yy + HALF - y];
            for (a, &s) in acc.iter_mut().zip(&src[yy * width..(yy + 1) * width]) {
                *a += tap * s;
            }
        }
    }
}

widened! {
    /// `out[x] = a[x]·b[x]`.
    fn multiply<R: Real>(a: &[R], b: &[R], out: &mut [R]) {
        for ((o, &x), &y) in out.iter_mut().zip(a).zip(b) {
            *o = x * y;
        }
    }
}

/// The SSIM of one window, `(a1·a2)/(b1·b2)`, and its factors.
struct SsimTerms<R: Real> {
    a1: R,
    a2: R,
    b1: R,
    b2: R,
    ssim: R,
}

#[inline(always)]
fn ssim_terms<R: Real>(mux: R, muy: R, xx: R, yy: R, xy: R, c1: R, c2: R) -> SsimTerms<R> {
    let two = R::of(2.0);
    let vx = xx - mux * mux;
    let vy = yy - muy * muy;
    let cxy = xy - mux * muy;
    let a1 = two * mux * muy + c1;
    let a2 = two * cxy + c2;
    let b1 = mux * mux + muy * muy + c1;
    let b2 = vx + vy + c2;
    SsimTerms {
        a1,
        a2,
        b1,
        b2,
        ssim: a1 * a2 / (b1 * b2),
    }
}

/// One row of the blurred statistics of a window: E[x], E[y], E[x²], E[y²], E[xy].
struct WindowStats<'a, R: Real> {
    mux: &'a [R],
    muy: &'a [R],
    xx: &'a [R],
    yy: &'a [R],
    xy: &'a [R],
}

widened! {
    /// One row of the weighted SSIM map into `weighted` and, with `partials`,
    /// `u·∂S/∂(μx, σx², σxy)` (u = weight·`u_scale`), μx's own term including
    /// what it enters through σx² = E[x²] − μx² and σxy = E[xy] − μx·μy.
    fn ssim_row<R: Real>(
        s: &WindowStats<'_, R>,
        weights: Option<&[R]>,
        c1: R,
        c2: R,
        u_scale: R,
        weighted: &mut [R],
        partials: Option<[&mut [R]; 3]>,
    ) {
        let two = R::of(2.0);
        // One length for every row, so the loops carry no bounds checks and vectorize.
        let n = weighted.len();
        let (mean_x, mean_y) = (&s.mux[..n], &s.muy[..n]);
        let (xx, yy, xy) = (&s.xx[..n], &s.yy[..n], &s.xy[..n]);
        // Plain code, no closures: a closure would be compiled without AVX2.
        let weights = weights.map(|wt| &wt[..n]);
        match partials {
            None => {
                for x in 0..n {
                    let t = ssim_terms(mean_x[x], mean_y[x], xx[x], yy[x], xy[x], c1, c2);
                    let wp = match weights {
                        Some(wt) => wt[x],
                        None => R::one(),
                    };
                    weighted[x] = wp * t.ssim;
                }
            }
            Some([ga, gb, gc]) => {
                let (ga, gb, gc) = (&mut ga[..n], &mut gb[..n], &mut gc[..n]);
                for x in 0..n {
                    let SsimTerms { a1, a2, b1, b2, ssim } =
                        ssim_terms(mean_x[x], mean_y[x], xx[x], yy[x], xy[x], c1, c2);
                    let wp = match weights {
                        Some(wt) => wt[x],
                        None => R::one(),
                    };
                    weighted[x] = wp * ssim;
                    let u = wp * u_scale;
                    let (mux, muy) = (mean_x[x], mean_y[x]);
                    let ds_dmux = two * muy * a2 / (b1 * b2) - two * mux * ssim / b1;
                    let ds_dvx = -ssim / b2;
                    let ds_dcxy = two * a1 / (b1 * b2);
                    ga[x] = u * (ds_dmux - two * mux * ds_dvx - muy * ds_dcxy);
                    gb[x] = u * ds_dvx;
                    gc[x] = u * ds_dcxy;
                }
            }
        }
    }
}

widened! {
    /// Adds `scale·dS/dx = scale·(B(ga) + 2x·B(gb) + y·B(gc))` of channel `ch`
    /// to one row of the interleaved gradient; an unsupervised pixel's render
    /// is not in the windows, so it gets nothing.
    fn combine_row<R: Real>(
        blurred: [&[R]; 3],
        rendered: &[R],
        target: &[R],
        weights: Option<&[R]>,
        channels: usize,
        ch: usize,
        scale: R,
        grad: &mut [R],
    ) {
        let two = R::of(2.0);
        for x in 0..blurred[0].len() {
            if weights.is_some_and(|wt| wt[x] <= R::zero()) {
                continue;
            }
            let i = x * channels + ch;
            let g = blurred[0][x] + two * rendered[i] * blurred[1][x] + target[i] * blurred[2][x];
            grad[i] += scale * g;
        }
    }
}

/// `Σ w·|x − y|` over a band of pixels and, with `grad`, its (sub)gradient
/// times `scale` (0 where x = y).
fn l1_band<R: Real>(
    rendered: &[R],
    target: &[R],
    weights: Option<&[R]>,
    channels: usize,
    scale: R,
    mut grad: Option<&mut [R]>,
) -> f64 {
    let mut sum = 0.0;
    for (p, (x, y)) in rendered
        .chunks(channels)
        .zip(target.chunks(channels))
        .enumerate()
    {
        let wp = weights.map_or(R::one(), |wt| wt[p]);
        for c in 0..channels {
            let d = x[c] - y[c];
            sum += (wp * d.abs()).f64();
            if let Some(g) = grad.as_deref_mut() {
                g[p * channels + c] = if d > R::zero() {
                    wp * scale
                } else if d < R::zero() {
                    -(wp * scale)
                } else {
                    R::zero()
                };
            }
        }
    }
    sum
}

impl<R: Real> PhotometricLoss<R> {
    pub fn new() -> Self {
        Self::default()
    }

    /// Evaluates `(1 − λ)·L1 + λ·(1 − SSIM)` of `rendered` against `target`
    /// on a crop of shape `dims`, with per-pixel `weights` (None = all 1) and
    /// the whole image's weights in `norm`. With `gradient`, [`Self::grad`]
    /// holds dL/d(rendered) afterwards (else it is left empty).
    #[allow(clippy::too_many_arguments)]
    pub fn evaluate(
        &mut self,
        dims: Dims,
        rendered: &[R],
        target: &[R],
        weights: Option<&[R]>,
        norm: Normalization,
        lambda_dssim: f64,
        gradient: bool,
        threads: usize,
    ) -> Result<LossValue> {
        if !(0.0..=1.0).contains(&lambda_dssim) {
            bail!("lambda_dssim = {lambda_dssim} must lie in [0, 1]");
        }
        self.run(
            dims,
            rendered,
            target,
            weights,
            norm,
            [1.0 - lambda_dssim, -lambda_dssim],
            lambda_dssim > 0.0,
            gradient,
            threads,
        )
        .map(|(l1, ssim, supervised)| LossValue {
            l1,
            ssim,
            total: if supervised {
                (1.0 - lambda_dssim) * l1 + lambda_dssim * (1.0 - ssim)
            } else {
                0.0
            },
        })
    }

    /// Computes L1 and (when `with_ssim`) SSIM, and the gradient of
    /// `coef[0]·L1 + coef[1]·SSIM` into `self.grad` when `gradient`.
    /// Returns (L1, SSIM, whether any pixel is supervised).
    #[allow(clippy::too_many_arguments)]
    fn run(
        &mut self,
        dims: Dims,
        rendered: &[R],
        target: &[R],
        weights: Option<&[R]>,
        norm: Normalization,
        coef: [f64; 2],
        with_ssim: bool,
        gradient: bool,
        threads: usize,
    ) -> Result<(f64, f64, bool)> {
        let (w, h, nc) = (dims.width, dims.height, dims.channels);
        let n = w * h;
        if nc == 0 {
            bail!("loss on an image with no channels");
        }
        check_buffer("rendered image", rendered, n * nc)?;
        check_buffer("target image", target, n * nc)?;
        if let Some(wt) = weights {
            check_buffer("loss weights", wt, n)?;
            if let Some(i) = wt.iter().position(|&v| v < R::zero()) {
                bail!("loss weight of pixel {i} is negative ({})", wt[i]);
            }
        }
        if !(norm.total_weight.is_finite() && norm.outside_weight.is_finite())
            || norm.outside_weight < 0.0
            || norm.outside_weight > norm.total_weight * (1.0 + 1e-9) + 1e-9
        {
            bail!(
                "loss normalization {norm:?}: the weights must be finite, with the outside part within the total"
            );
        }
        self.grad.clear();
        if gradient {
            self.grad.resize(n * nc, R::zero());
        }
        if norm.total_weight <= 0.0 {
            return Ok((0.0, 0.0, false));
        }
        // Outside the crop the SSIM map is exactly 1 and |x − y| = 0.
        let outside_ssim = norm.outside_weight / norm.total_weight;
        if n == 0 {
            return Ok((0.0, outside_ssim, true));
        }
        let inv = 1.0 / (norm.total_weight * nc as f64);
        let weight = |p: usize| weights.map_or(R::one(), |wt| wt[p]);

        // L1 over the crop (and its gradient, written first; SSIM's is added
        // per channel), a band of rows per job, the bands' sums added in order.
        let jobs = h.div_ceil(ROWS_PER_JOB);
        self.partials.clear();
        self.partials.resize(jobs, (0.0, 0.0));
        let l1_scale = R::of(coef[0] * inv);
        let band = ROWS_PER_JOB * w;
        // Empty without the gradient: then every band gets None.
        let mut grad_bands = self.grad.chunks_mut(band * nc);
        let work = self
            .partials
            .iter_mut()
            .map(move |p| (p, grad_bands.next()))
            .enumerate();
        run_iter(
            threads,
            work,
            || (),
            |_, (j, (partial, grad))| {
                let pixels = j * band..((j + 1) * band).min(n);
                partial.0 = l1_band(
                    &rendered[pixels.start * nc..pixels.end * nc],
                    &target[pixels.start * nc..pixels.end * nc],
                    weights.map(|wt| &wt[pixels]),
                    nc,
                    l1_scale,
                    grad,
                );
            },
        );
        let l1 = self.partials.iter().map(|p| p.0).sum::<f64>() * inv;
        if !with_ssim {
            return Ok((l1, outside_ssim, true));
        }

        let taps = gaussian_taps::<R>();
        let (c1, c2) = (R::of(SSIM_C1), R::of(SSIM_C2));
        let u_scale = R::of(inv);
        // Every element of these planes is written before it is read.
        for plane in self.rows.iter_mut().chain(self.maps.iter_mut()) {
            plane.resize(n, R::zero());
        }
        let mut ssim_sum = 0.0;
        for ch in 0..nc {
            // 1. Row blurs of x, y, x², y², xy.
            {
                let [r0, r1, r2, r3, r4] = &mut self.rows;
                let work = r0
                    .chunks_mut(band)
                    .zip(r1.chunks_mut(band))
                    .zip(r2.chunks_mut(band))
                    .zip(r3.chunks_mut(band))
                    .zip(r4.chunks_mut(band))
                    .enumerate();
                run_iter_pooled(
                    threads,
                    work,
                    &mut self.row_scratch,
                    Default::default,
                    |[xs, ys, prod], (j, ((((b0, b1), b2), b3), b4))| {
                        xs.resize(w, R::zero());
                        ys.resize(w, R::zero());
                        prod.resize(w, R::zero());
                        let outs: [&mut [R]; 5] = [b0, b1, b2, b3, b4];
                        let rows_here = outs[0].len() / w.max(1);
                        for r in 0..rows_here {
                            let y = j * ROWS_PER_JOB + r;
                            for x in 0..w {
                                let i = (y * w + x) * nc + ch;
                                ys[x] = target[i];
                                xs[x] = if weight(y * w + x) > R::zero() {
                                    rendered[i]
                                } else {
                                    target[i]
                                };
                            }
                            let row = r * w..(r + 1) * w;
                            blur_row(xs, &taps, &mut outs[0][row.clone()]);
                            blur_row(ys, &taps, &mut outs[1][row.clone()]);
                            multiply(xs, xs, prod);
                            blur_row(prod, &taps, &mut outs[2][row.clone()]);
                            multiply(ys, ys, prod);
                            blur_row(prod, &taps, &mut outs[3][row.clone()]);
                            multiply(xs, ys, prod);
                            blur_row(prod, &taps, &mut outs[4][row]);
                        }
                    },
                );
            }
            // 2. Column blurs, the SSIM map and (for the gradient) its partials.
            {
                let rows = &self.rows;
                let [m0, m1, m2] = &mut self.maps;
                let work = m0
                    .chunks_mut(band)
                    .zip(m1.chunks_mut(band))
                    .zip(m2.chunks_mut(band))
                    .zip(self.partials.iter_mut())
                    .enumerate();
                run_iter_pooled(
                    threads,
                    work,
                    &mut self.column_scratch,
                    Default::default,
                    |acc, (j, (((ga, gb), gc), partial))| {
                        for a in acc.iter_mut() {
                            a.resize(w, R::zero());
                        }
                        let mut sum = 0.0f64;
                        let rows_here = ga.len() / w.max(1);
                        for r in 0..rows_here {
                            let y = j * ROWS_PER_JOB + r;
                            for k in 0..5 {
                                blur_column_into(&rows[k], w, h, y, &taps, &mut acc[k]);
                            }
                            let [mux, muy, xx, yy, xy, weighted] = acc;
                            let row = r * w..(r + 1) * w;
                            let statistics = WindowStats {
                                mux,
                                muy,
                                xx,
                                yy,
                                xy,
                            };
                            let weights_row = weights.map(|wt| &wt[y * w..(y + 1) * w]);
                            if gradient {
                                let partials =
                                    [&mut ga[row.clone()], &mut gb[row.clone()], &mut gc[row]];
                                ssim_row(
                                    &statistics,
                                    weights_row,
                                    c1,
                                    c2,
                                    u_scale,
                                    weighted,
                                    Some(partials),
                                );
                            } else {
                                ssim_row(&statistics, weights_row, c1, c2, u_scale, weighted, None);
                            }
                            // In pixel order, so the sum does not depend on the vector width.
                            for v in weighted.iter() {
                                sum += v.f64();
                            }
                        }
                        partial.1 = sum;
                    },
                );
                ssim_sum += self.partials.iter().map(|p| p.1).sum::<f64>();
            }
            if !gradient {
                continue;
            }
            // 3. The adjoint: blur the partial maps back (the kernel is symmetric)
            //    and combine: dS/dx = B(ga) + 2x·B(gb) + y·B(gc).
            {
                let maps = &self.maps;
                let [r0, r1, r2, _, _] = &mut self.rows;
                let work = r0
                    .chunks_mut(band)
                    .zip(r1.chunks_mut(band))
                    .zip(r2.chunks_mut(band))
                    .enumerate();
                run_iter(
                    threads,
                    work,
                    || (),
                    |_, (j, ((b0, b1), b2))| {
                        let rows_here = b0.len() / w.max(1);
                        for r in 0..rows_here {
                            let y = j * ROWS_PER_JOB + r;
                            let src = y * w..(y + 1) * w;
                            let row = r * w..(r + 1) * w;
                            blur_row(&maps[0][src.clone()], &taps, &mut b0[row.clone()]);
                            blur_row(&maps[1][src.clone()], &taps, &mut b1[row.clone()]);
                            blur_row(&maps[2][src], &taps, &mut b2[row]);
                        }
                    },
                );
            }
            {
                let rows = &self.rows;
                let scale = R::of(coef[1]);
                let work = self.grad.chunks_mut(band * nc).enumerate();
                run_iter_pooled(
                    threads,
                    work,
                    &mut self.column_scratch,
                    Default::default,
                    |acc, (j, grad)| {
                        for a in acc.iter_mut() {
                            a.resize(w, R::zero());
                        }
                        let rows_here = grad.len() / (w * nc).max(1);
                        for r in 0..rows_here {
                            let y = j * ROWS_PER_JOB + r;
                            for k in 0..3 {
                                blur_column_into(&rows[k], w, h, y, &taps, &mut acc[k]);
                            }
                            let pixels = y * w..(y + 1) * w;
                            combine_row(
                                [&acc[0], &acc[1], &acc[2]],
                                &rendered[pixels.start * nc..pixels.end * nc],
                                &target[pixels.start * nc..pixels.end * nc],
                                weights.map(|wt| &wt[pixels]),
                                nc,
                                ch,
                                scale,
                                &mut grad[r * w * nc..(r + 1) * w * nc],
                            );
                        }
                    },
                );
            }
        }
        let ssim = ssim_sum * inv + outside_ssim;
        Ok((l1, ssim, true))
    }
}

fn whole_image_norm<R: Real>(dims: Dims, weights: Option<&[R]>) -> Result<Normalization> {
    if dims.pixels() == 0 || dims.channels == 0 {
        bail!(
            "loss on an empty image ({}×{}×{})",
            dims.width,
            dims.height,
            dims.channels
        );
    }
    let total = match weights {
        None => dims.pixels() as f64,
        Some(w) => {
            check_buffer("loss weights", w, dims.pixels())?;
            w.iter().map(|v| v.f64()).sum()
        }
    };
    Ok(Normalization::whole(total))
}

/// Weighted mean absolute error and its (sub)gradient (0 where equal).
pub fn l1<R: Real>(
    dims: Dims,
    rendered: &[R],
    target: &[R],
    weights: Option<&[R]>,
) -> Result<LossGrad<R>> {
    one_term(dims, rendered, target, weights, Term::L1)
}

/// Weighted mean SSIM and its gradient with respect to `rendered` (the target is constant).
pub fn ssim<R: Real>(
    dims: Dims,
    rendered: &[R],
    target: &[R],
    weights: Option<&[R]>,
) -> Result<LossGrad<R>> {
    one_term(dims, rendered, target, weights, Term::Ssim)
}

enum Term {
    L1,
    Ssim,
}

/// One term of the photometric loss on its own, over the whole image, single-threaded.
fn one_term<R: Real>(
    dims: Dims,
    rendered: &[R],
    target: &[R],
    weights: Option<&[R]>,
    term: Term,
) -> Result<LossGrad<R>> {
    let norm = whole_image_norm(dims, weights)?;
    let mut loss = PhotometricLoss::new();
    let (coef, with_ssim) = match term {
        Term::L1 => ([1.0, 0.0], false),
        Term::Ssim => ([0.0, 1.0], true),
    };
    let (l1, ssim, _) = loss.run(
        dims, rendered, target, weights, norm, coef, with_ssim, true, 1,
    )?;
    let value = match term {
        Term::L1 => l1,
        Term::Ssim => ssim,
    };
    Ok(LossGrad {
        value: R::of(value),
        grad: loss.grad,
    })
}

/// `(1 − λ)·L1 + λ·(1 − SSIM)` (λ = 0.2 in the reference) and its gradient.
pub fn photometric<R: Real>(
    dims: Dims,
    rendered: &[R],
    target: &[R],
    weights: Option<&[R]>,
    lambda_dssim: f64,
) -> Result<LossGrad<R>> {
    let norm = whole_image_norm(dims, weights)?;
    let mut loss = PhotometricLoss::new();
    let value = loss.evaluate(dims, rendered, target, weights, norm, lambda_dssim, true, 1)?;
    Ok(LossGrad {
        value: R::of(value.total),
        grad: loss.grad,
    })
}
