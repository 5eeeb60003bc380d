//! Peak signal-to-noise ratio for images in [0, 1] (data range 1).

use crate::mask::Mask;
use crate::validate::check_pair;
use anyhow::{Result, bail};
use objectsplat_core::Image;

/// `10·log10(1 / MSE)`, the MSE taken over all channels of the valid pixels
/// (every pixel when `mask` is `None`; the ScanNet++ convention with a mask).
/// Identical images give `f64::INFINITY`.
pub fn psnr(a: &Image, b: &Image, mask: Option<&Mask>) -> Result<f64> {
    check_pair(a, b)?;
    if let Some(m) = mask {
        m.check_size(a.width, a.height)?;
    }
    let ch = a.channels as usize;
    let mut sum = 0.0f64;
    let mut count = 0usize;
    for (i, (pa, pb)) in a
        .data
        .chunks_exact(ch)
        .zip(b.data.chunks_exact(ch))
        .enumerate()
    {
        if let Some(m) = mask
            && !m.valid[i]
        {
            continue;
        }
        for (&va, &vb) in pa.iter().zip(pb) {
            let d = va as f64 - vb as f64;
            sum += d * d;
        }
        count += ch;
    }
    if count == 0 {
        bail!("PSNR: the mask leaves no valid pixel");
    }
    Ok(psnr_from_mse(sum / count as f64))
}

pub fn psnr_from_mse(mse: f64) -> f64 {
    10.0 * (1.0 / mse).log10()
}
