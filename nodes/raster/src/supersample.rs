//! Rendering at `s × s` samples per pixel and box-filtering down, as a camera
//! integrates light over each pixel's area.
//!
//! Opaque, hard-edged triangles sampled once per pixel alias: an edge or a
//! texture step crosses a pixel and the pixel takes one side's colour, where a
//! photograph (and the synthetic scene, rendered at 2×2 samples) holds the
//! area-weighted mix. On the team's room the true meshes and textures rendered
//! at one sample per pixel score only 19.3 dB on the box's pixels and 21.7 dB
//! on the cup's against the 2×2 frames (docs/benchmarks.md): a ceiling no
//! training can pass at one sample.
//!
//! The fine image is the coarse camera scaled by `s` (pixel centres at
//! `(i + 0.5)/s` of a coarse pixel, so the `s × s` samples are symmetric about
//! the coarse centre). The coarse outputs are means over each pixel's samples,
//! all linear, so the backward pass spreads each coarse gradient evenly over
//! its samples and is exact. Pixel thresholds of [`RenderSettings`] stay in
//! the samples' pixels.

use crate::backend::{PixelRect, Region, RenderOutput, RenderSettings};
use crate::real::Real;
use anyhow::{Result, bail};
use objectsplat_core::Camera;

/// Checks a supersampling factor (1 = one sample per pixel). Footprint
/// regions are whole 16-px tiles of the fine image, so the factor must divide
/// 16 for them to be whole coarse pixels; 8 would cost 64 samples a pixel.
pub fn validate(s: u32) -> Result<()> {
    if !matches!(s, 1 | 2 | 4) {
        bail!("supersample = {s} must be 1, 2 or 4");
    }
    Ok(())
}

/// The camera and settings that render the `s × s` samples of `camera`'s pixels.
pub fn fine_view(camera: &Camera, settings: &RenderSettings, s: u32) -> (Camera, RenderSettings) {
    let fine = camera.scaled(camera.width * s, camera.height * s);
    let region = match settings.region {
        Region::Full => Region::Full,
        Region::Footprint { include, margin } => Region::Footprint {
            include: PixelRect {
                x0: include.x0 * s,
                y0: include.y0 * s,
                x1: include.x1 * s,
                y1: include.y1 * s,
            },
            margin: margin * s,
        },
    };
    (
        fine,
        RenderSettings {
            region,
            ..settings.clone()
        },
    )
}

/// `fine` (a render of [`fine_view`]) box-filtered to the coarse camera's pixels.
/// Per-face maxima are kept; pixel counts become coarse pixels (rounded up).
pub fn downsample_into<R: Real>(
    fine: &RenderOutput<R>,
    s: u32,
    coarse: &mut RenderOutput<R>,
) -> Result<()> {
    let r = fine.region;
    if [fine.width, fine.height, r.x0, r.y0, r.x1, r.y1]
        .iter()
        .any(|v| !v.is_multiple_of(s))
    {
        bail!(
            "a {}×{} render over {r:?} is not whole {s}×{s} blocks of samples",
            fine.width,
            fine.height
        );
    }
    let region = PixelRect {
        x0: r.x0 / s,
        y0: r.y0 / s,
        x1: r.x1 / s,
        y1: r.y1 / s,
    };
    coarse.width = fine.width / s;
    coarse.height = fine.height / s;
    coarse.region = region;
    let (fw, cw, ch) = (
        r.width() as usize,
        region.width() as usize,
        region.height() as usize,
    );
    let s = s as usize;
    let scale = R::of(1.0 / (s * s) as f64);
    // Each coarse pixel sums its block row by row, left to right (the order
    // fixes the rounding); the loops walk whole blocks, no index divisions.
    let mean = |src: &[R], channels: usize, dst: &mut Vec<R>| {
        dst.clear();
        dst.resize(cw * ch * channels, R::of(0.0));
        for (y, out) in dst.chunks_exact_mut(cw * channels).enumerate() {
            for row in
                src[y * s * fw * channels..(y + 1) * s * fw * channels].chunks_exact(fw * channels)
            {
                for (o, block) in out
                    .chunks_exact_mut(channels)
                    .zip(row.chunks_exact(s * channels))
                {
                    for sample in block.chunks_exact(channels) {
                        for (o, &v) in o.iter_mut().zip(sample) {
                            *o += v;
                        }
                    }
                }
            }
        }
        for v in dst.iter_mut() {
            *v *= scale;
        }
    };
    mean(&fine.color, 3, &mut coarse.color);
    mean(&fine.alpha, 1, &mut coarse.alpha);
    mean(&fine.depth, 1, &mut coarse.depth);
    mean(&fine.median_depth, 1, &mut coarse.median_depth);
    coarse.face_max_weight.clone_from(&fine.face_max_weight);
    coarse.face_pixel_count.clear();
    let block = (s * s) as u32;
    if block.is_power_of_two() {
        // A shift instead of a division per face (millions of them per render).
        let shift = block.trailing_zeros();
        coarse.face_pixel_count.extend(
            fine.face_pixel_count
                .iter()
                .map(|&n| (n >> shift) + u32::from(n & (block - 1) != 0)),
        );
    } else {
        coarse
            .face_pixel_count
            .extend(fine.face_pixel_count.iter().map(|&n| n.div_ceil(block)));
    }
    Ok(())
}

/// Each value of a `width`×`height` plane (`channels` per pixel) repeated over
/// its pixel's `s × s` samples, row-major in the fine plane.
pub fn replicate_into<R: Copy>(
    coarse: &[R],
    channels: usize,
    width: usize,
    height: usize,
    s: u32,
    fine: &mut Vec<R>,
) {
    let s = s as usize;
    fine.clear();
    fine.reserve(width * height * s * s * channels);
    for y in 0..height * s {
        let row = &coarse[(y / s) * width * channels..(y / s + 1) * width * channels];
        for pixel in row.chunks_exact(channels) {
            for _ in 0..s {
                fine.extend_from_slice(pixel);
            }
        }
    }
}

/// The gradient of a coarse output plane (`channels` per pixel over
/// `coarse_region`) with respect to its `s × s` samples: each sample carries
/// its pixel's gradient over `s²` (the adjoint of [`downsample_into`]).
pub fn spread_into<R: Real>(
    coarse: &[R],
    channels: usize,
    coarse_region: PixelRect,
    s: u32,
    fine: &mut Vec<R>,
) {
    let (width, height) = (
        coarse_region.width() as usize,
        coarse_region.height() as usize,
    );
    replicate_into(coarse, channels, width, height, s, fine);
    let scale = R::of(1.0 / (s * s) as f64);
    for g in fine.iter_mut() {
        *g *= scale;
    }
}
