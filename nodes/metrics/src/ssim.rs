//! Structural similarity (Wang et al. 2004) with an 11×11 Gaussian window, σ = 1.5.
//!
//! Both conventions in use share the per-pixel formula — population (co)variances
//! from Gaussian-weighted moments, `C1 = 0.01²`, `C2 = 0.03²` for data range 1,
//! every channel separately, averaged over channels — and differ at the border:
//! - [`SsimMode::Gs3d`] (our default; 3DGS `loss_utils.ssim`): the image is padded
//!   with zeros, so every pixel has an SSIM value (border ones biased), and the
//!   mean runs over all pixels;
//! - [`SsimMode::Cropped`] (scikit-image with `gaussian_weights=True`,
//!   `use_sample_covariance=False`, `data_range=1`): pixels closer than 5 to the
//!   border are dropped before the mean, so padding never matters.
//!
//! Masked variant: a pixel is averaged only when every in-image pixel of its 11×11
//! window is valid (ScanNet++ rule). Window positions outside the image are the
//! mode's own padding and do not disqualify a pixel, so an all-valid mask gives
//! the unmasked value.

use crate::mask::Mask;
use crate::validate::check_pair;
use anyhow::{Result, bail};
use objectsplat_core::Image;
use rayon::prelude::*;

pub const WINDOW_RADIUS: usize = 5;
pub const SIGMA: f64 = 1.5;
const C1: f64 = 0.01 * 0.01;
const C2: f64 = 0.03 * 0.03;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SsimMode {
    /// Zero padding, mean over all pixels (3DGS).
    #[default]
    Gs3d,
    /// Border of 5 pixels cropped before the mean (scikit-image / Wang et al.).
    Cropped,
}

impl SsimMode {
    pub fn describe(self) -> &'static str {
        match self {
            SsimMode::Gs3d => {
                "11x11 Gaussian window (sigma 1.5), zero padding, mean over all pixels and channels (3DGS)"
            }
            SsimMode::Cropped => {
                "11x11 Gaussian window (sigma 1.5), 5-pixel border cropped, mean over channels (scikit-image, Wang et al.)"
            }
        }
    }
}

/// The normalised 11-tap Gaussian, in f64.
pub fn gaussian_kernel() -> [f64; 2 * WINDOW_RADIUS + 1] {
    let mut k = [0.0; 2 * WINDOW_RADIUS + 1];
    for (i, v) in k.iter_mut().enumerate() {
        let x = i as f64 - WINDOW_RADIUS as f64;
        *v = (-0.5 * x * x / (SIGMA * SIGMA)).exp();
    }
    let sum: f64 = k.iter().sum();
    k.iter_mut().for_each(|v| *v /= sum);
    k
}

/// Mean SSIM of two images with values in [0, 1]; see the module docs for the modes and the mask rule.
pub fn ssim(a: &Image, b: &Image, mode: SsimMode, mask: Option<&Mask>) -> Result<f64> {
    check_pair(a, b)?;
    let (w, h) = (a.width as usize, a.height as usize);
    let r = WINDOW_RADIUS;
    let region = match mode {
        SsimMode::Gs3d => Region {
            x0: 0,
            y0: 0,
            width: w,
            height: h,
        },
        SsimMode::Cropped => {
            if w < 2 * r + 1 || h < 2 * r + 1 {
                bail!(
                    "SSIM (cropped) needs images of at least {0}×{0}, got {w}×{h}",
                    2 * r + 1
                );
            }
            Region {
                x0: r,
                y0: r,
                width: w - 2 * r,
                height: h - 2 * r,
            }
        }
    };
    let support = match mask {
        Some(m) => {
            m.check_size(a.width, a.height)?;
            Some(m.eroded(r as u32))
        }
        None => None,
    };
    let averaged = match &support {
        Some(s) => (0..region.height)
            .map(|oy| {
                (0..region.width)
                    .filter(|&ox| s.valid[(oy + region.y0) * w + ox + region.x0])
                    .count()
            })
            .sum(),
        None => region.width * region.height,
    };
    if averaged == 0 {
        bail!("SSIM: the mask leaves no pixel whose whole 11×11 window is valid");
    }
    let kernel = gaussian_kernel();
    let ch = a.channels as usize;
    let mut total = 0.0;
    for c in 0..ch {
        let x: Vec<f64> = a.data.chunks_exact(ch).map(|p| p[c] as f64).collect();
        let y: Vec<f64> = b.data.chunks_exact(ch).map(|p| p[c] as f64).collect();
        total += channel_ssim_sum(&x, &y, w, h, &kernel, region, support.as_ref());
    }
    Ok(total / (averaged * ch) as f64)
}

/// The part of the image whose SSIM values are averaged.
#[derive(Debug, Clone, Copy)]
struct Region {
    x0: usize,
    y0: usize,
    width: usize,
    height: usize,
}

/// The five Gaussian-filtered moments x, y, x², y², xy, one plane each.
const MOMENTS: usize = 5;

/// Sum of one channel's SSIM map over the region pixels `support` keeps.
///
/// Separable filtering: a horizontal pass writes the five moments of every image
/// row the region needs (zero outside the image); a vertical pass per output row
/// then filters them and turns them into SSIM values at once, so the vertical
/// results are never stored. Both passes use the kernel's symmetry.
fn channel_ssim_sum(
    x: &[f64],
    y: &[f64],
    w: usize,
    h: usize,
    k: &[f64],
    region: Region,
    support: Option<&Mask>,
) -> f64 {
    let r = k.len() / 2;
    let ow = region.width;
    let row_lo = region.y0.saturating_sub(r);
    let row_hi = (region.y0 + region.height + r).min(h);
    // horizontal[row][moment][ox]
    let row_len = MOMENTS * ow;
    let mut horizontal = vec![0.0; (row_hi - row_lo) * row_len];
    horizontal
        .par_chunks_mut(row_len)
        .enumerate()
        .for_each_init(
            || vec![0.0; MOMENTS * (w + 2 * r)],
            |padded, (i, out)| {
                let sy = row_lo + i;
                let (xs, ys) = (&x[sy * w..(sy + 1) * w], &y[sy * w..(sy + 1) * w]);
                let pw = w + 2 * r;
                // Zero-padded source rows of the five moments (padding stays zero).
                for (m, row) in padded.chunks_exact_mut(pw).enumerate() {
                    let row = &mut row[r..r + w];
                    match m {
                        0 => row.copy_from_slice(xs),
                        1 => row.copy_from_slice(ys),
                        2 => row.iter_mut().zip(xs).for_each(|(o, v)| *o = v * v),
                        3 => row.iter_mut().zip(ys).for_each(|(o, v)| *o = v * v),
                        _ => row
                            .iter_mut()
                            .zip(xs.iter().zip(ys))
                            .for_each(|(o, (a, b))| *o = a * b),
                    }
                }
                for (src, dst) in padded.chunks_exact(pw).zip(out.chunks_exact_mut(ow)) {
                    // Output ox reads padded[x0 + ox .. x0 + ox + 2r].
                    let src = &src[region.x0..region.x0 + ow + 2 * r];
                    dst.iter_mut()
                        .zip(&src[r..])
                        .for_each(|(d, s)| *d = k[r] * s);
                    for j in 0..r {
                        let (left, right) = (&src[j..j + ow], &src[2 * r - j..2 * r - j + ow]);
                        dst.iter_mut()
                            .zip(left.iter().zip(right))
                            .for_each(|(d, (a, b))| *d += k[j] * (a + b));
                    }
                }
            },
        );
    let row_sums: Vec<f64> = (0..region.height)
        .into_par_iter()
        .map_init(
            || vec![0.0; row_len],
            |acc, oy| {
                let y = region.y0 + oy;
                acc.iter_mut().for_each(|v| *v = 0.0);
                for (j, &kv) in k.iter().enumerate() {
                    // Rows outside the image are zero padding.
                    let Some(sy) = (y + j).checked_sub(r).filter(|&sy| sy < h) else {
                        continue;
                    };
                    let src = &horizontal[(sy - row_lo) * row_len..(sy - row_lo + 1) * row_len];
                    acc.iter_mut().zip(src).for_each(|(a, s)| *a += kv * s);
                }
                let (mu_x, rest) = acc.split_at(ow);
                let (mu_y, rest) = rest.split_at(ow);
                let (e_xx, rest) = rest.split_at(ow);
                let (e_yy, e_xy) = rest.split_at(ow);
                let mut sum = 0.0;
                for ox in 0..ow {
                    if let Some(s) = support
                        && !s.valid[y * w + region.x0 + ox]
                    {
                        continue;
                    }
                    let (ux, uy) = (mu_x[ox], mu_y[ox]);
                    let vx = e_xx[ox] - ux * ux;
                    let vy = e_yy[ox] - uy * uy;
                    let vxy = e_xy[ox] - ux * uy;
                    let num = (2.0 * ux * uy + C1) * (2.0 * vxy + C2);
                    let den = (ux * ux + uy * uy + C1) * (vx + vy + C2);
                    sum += num / den;
                }
                sum
            },
        )
        .collect();
    // Summed in row order so the result does not depend on thread scheduling.
    row_sums.iter().sum()
}
