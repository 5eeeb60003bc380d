//! Photometric losses with gradients with respect to the rendered image:
//! L1, SSIM (11×11 Gaussian window, σ = 1.5, C1 = 0.01², C2 = 0.03², zero
//! padding, as 3DGS) and `(1 − λ)·L1 + λ·(1 − SSIM)`.
//!
//! Images are row-major, channel-interleaved. Optional per-pixel weights
//! (H×W, finite, ≥ 0; 0 = pixel not supervised) turn every mean into a
//! weighted mean: `L1 = Σ_p w_p Σ_c |x − y| / (C·Σ_p w_p)` and
//! `SSIM = Σ_p w_p Σ_c S_pc / (C·Σ_p w_p)` where `S` is the ordinary SSIM map
//! (the window still sees unweighted neighbours; only the averaging of the
//! map is weighted). With all weights zero both losses are 0 with zero gradient.

use crate::backend::check_buffer;
use crate::real::Real;
use anyhow::{Result, bail};

pub const SSIM_WINDOW: usize = 11;
pub const SSIM_SIGMA: f64 = 1.5;
pub const SSIM_C1: f64 = 0.01 * 0.01;
pub const SSIM_C2: f64 = 0.03 * 0.03;
/// The reference's D-SSIM weight in `(1 − λ)·L1 + λ·(1 − SSIM)`.
pub const DEFAULT_LAMBDA_DSSIM: f64 = 0.2;

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

fn check<R: Real>(dims: Dims, rendered: &[R], target: &[R], weights: Option<&[R]>) -> Result<R> {
    if dims.pixels() == 0 || dims.channels == 0 {
        bail!(
            "loss on an empty image ({}×{}×{})",
            dims.width,
            dims.height,
            dims.channels
        );
    }
    let n = dims.pixels() * dims.channels;
    check_buffer("rendered image", rendered, n)?;
    check_buffer("target image", target, n)?;
    match weights {
        None => Ok(R::of(dims.pixels() as f64)),
        Some(w) => {
            check_buffer("loss weights", w, dims.pixels())?;
            if let Some(i) = w.iter().position(|&v| v < R::zero()) {
                bail!("loss weight of pixel {i} is negative ({})", w[i]);
            }
            Ok(w.iter().fold(R::zero(), |a, &b| a + b))
        }
    }
}

/// Weighted mean absolute error and its (sub)gradient (0 where equal).
pub fn l1<R: Real>(
    dims: Dims,
    rendered: &[R],
    target: &[R],
    weights: Option<&[R]>,
) -> Result<LossGrad<R>> {
    let wsum = check(dims, rendered, target, weights)?;
    let mut grad = vec![R::zero(); rendered.len()];
    if wsum <= R::zero() {
        return Ok(LossGrad {
            value: R::zero(),
            grad,
        });
    }
    let norm = R::one() / (wsum * R::of(dims.channels as f64));
    let mut value = R::zero();
    for p in 0..dims.pixels() {
        let w = weights.map_or(R::one(), |w| w[p]) * norm;
        for c in 0..dims.channels {
            let i = p * dims.channels + c;
            let d = rendered[i] - target[i];
            value += w * d.abs();
            grad[i] = if d > R::zero() {
                w
            } else if d < R::zero() {
                -w
            } else {
                R::zero()
            };
        }
    }
    Ok(LossGrad { value, grad })
}

fn gaussian_taps<R: Real>() -> [R; SSIM_WINDOW] {
    let half = (SSIM_WINDOW / 2) as f64;
    let raw: Vec<f64> = (0..SSIM_WINDOW)
        .map(|i| (-(i as f64 - half).powi(2) / (2.0 * SSIM_SIGMA * SSIM_SIGMA)).exp())
        .collect();
    let sum: f64 = raw.iter().sum();
    std::array::from_fn(|i| R::of(raw[i] / sum))
}

/// Separable Gaussian filter of a planar H×W image with zero padding. The
/// kernel is symmetric, so this is also its own adjoint.
fn blur<R: Real>(
    src: &[R],
    width: usize,
    height: usize,
    taps: &[R; SSIM_WINDOW],
    tmp: &mut [R],
    dst: &mut [R],
) {
    let half = SSIM_WINDOW / 2;
    for y in 0..height {
        let row = &src[y * width..(y + 1) * width];
        for x in 0..width {
            let lo = x.saturating_sub(half);
            let hi = (x + half).min(width - 1);
            let mut acc = R::zero();
            for (xx, &v) in row.iter().enumerate().take(hi + 1).skip(lo) {
                acc += taps[xx + half - x] * v;
            }
            tmp[y * width + x] = acc;
        }
    }
    for y in 0..height {
        let lo = y.saturating_sub(half);
        let hi = (y + half).min(height - 1);
        for x in 0..width {
            let mut acc = R::zero();
            for yy in lo..=hi {
                acc += taps[yy + half - y] * tmp[yy * width + x];
            }
            dst[y * width + x] = acc;
        }
    }
}

/// Weighted mean SSIM and its gradient with respect to `rendered` (the target is constant).
pub fn ssim<R: Real>(
    dims: Dims,
    rendered: &[R],
    target: &[R],
    weights: Option<&[R]>,
) -> Result<LossGrad<R>> {
    let wsum = check(dims, rendered, target, weights)?;
    let (w, h, nc) = (dims.width, dims.height, dims.channels);
    let n = w * h;
    let mut grad = vec![R::zero(); rendered.len()];
    if wsum <= R::zero() {
        return Ok(LossGrad {
            value: R::zero(),
            grad,
        });
    }
    let norm = R::one() / (wsum * R::of(nc as f64));
    let taps = gaussian_taps::<R>();
    let (c1, c2) = (R::of(SSIM_C1), R::of(SSIM_C2));
    let two = R::of(2.0);
    let plane = || vec![R::zero(); n];
    let (mut x, mut y, mut prod, mut tmp) = (plane(), plane(), plane(), plane());
    let (mut mx, mut my, mut sxx, mut syy, mut sxy) = (plane(), plane(), plane(), plane(), plane());
    let (mut ga, mut gb, mut gc) = (plane(), plane(), plane());
    let (mut ba, mut bb, mut bc) = (plane(), plane(), plane());
    let mut value = R::zero();
    for ch in 0..nc {
        for p in 0..n {
            x[p] = rendered[p * nc + ch];
            y[p] = target[p * nc + ch];
        }
        blur(&x, w, h, &taps, &mut tmp, &mut mx);
        blur(&y, w, h, &taps, &mut tmp, &mut my);
        for p in 0..n {
            prod[p] = x[p] * x[p];
        }
        blur(&prod, w, h, &taps, &mut tmp, &mut sxx);
        for p in 0..n {
            prod[p] = y[p] * y[p];
        }
        blur(&prod, w, h, &taps, &mut tmp, &mut syy);
        for p in 0..n {
            prod[p] = x[p] * y[p];
        }
        blur(&prod, w, h, &taps, &mut tmp, &mut sxy);
        for p in 0..n {
            let (mux, muy) = (mx[p], my[p]);
            let vx = sxx[p] - mux * mux;
            let vy = syy[p] - muy * muy;
            let cxy = sxy[p] - mux * muy;
            let a1 = two * mux * muy + c1;
            let a2 = two * cxy + c2;
            let b1 = mux * mux + muy * muy + c1;
            let b2 = vx + vy + c2;
            let s = a1 * a2 / (b1 * b2);
            let u = weights.map_or(R::one(), |wt| wt[p]) * norm;
            value += u * s;
            let ds_dmux = two * muy * a2 / (b1 * b2) - two * mux * s / b1;
            let ds_dvx = -s / b2;
            let ds_dcxy = two * a1 / (b1 * b2);
            // μx also enters σx² = E[x²] − μx² and σxy = E[xy] − μx·μy.
            ga[p] = u * (ds_dmux - two * mux * ds_dvx - muy * ds_dcxy);
            gb[p] = u * ds_dvx;
            gc[p] = u * ds_dcxy;
        }
        blur(&ga, w, h, &taps, &mut tmp, &mut ba);
        blur(&gb, w, h, &taps, &mut tmp, &mut bb);
        blur(&gc, w, h, &taps, &mut tmp, &mut bc);
        for p in 0..n {
            grad[p * nc + ch] = ba[p] + two * x[p] * bb[p] + y[p] * bc[p];
        }
    }
    Ok(LossGrad { value, grad })
}

/// `(1 − λ)·L1 + λ·(1 − SSIM)` (λ = 0.2 in the reference) and its gradient.
pub fn photometric<R: Real>(
    dims: Dims,
    rendered: &[R],
    target: &[R],
    weights: Option<&[R]>,
    lambda_dssim: f64,
) -> Result<LossGrad<R>> {
    if !(0.0..=1.0).contains(&lambda_dssim) {
        bail!("lambda_dssim = {lambda_dssim} must lie in [0, 1]");
    }
    let l = l1(dims, rendered, target, weights)?;
    let s = ssim(dims, rendered, target, weights)?;
    let (wl, ws) = (R::of(1.0 - lambda_dssim), R::of(lambda_dssim));
    // With no supervised pixel both parts are 0 and so is the loss (not λ·(1 − 0)).
    let supervised = weights.is_none_or(|w| w.iter().any(|&v| v > R::zero()));
    let value = if supervised {
        wl * l.value + ws * (R::one() - s.value)
    } else {
        R::zero()
    };
    let grad = l
        .grad
        .iter()
        .zip(&s.grad)
        .map(|(&gl, &gs)| wl * gl - ws * gs)
        .collect();
    Ok(LossGrad { value, grad })
}
