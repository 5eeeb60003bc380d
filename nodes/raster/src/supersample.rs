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
use crate::parallel::for_chunks_mut;
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
/// Rows of pixels are spread over up to `threads` threads (the result does
/// not depend on how many).
pub fn downsample_into<R: Real>(
    threads: usize,
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
        let row_len = (cw * channels).max(1);
        let rows = chunk_rows(ch, threads) * row_len;
        for_chunks_mut(threads, dst, rows, |first, part| {
            for (dy, out) in part.chunks_exact_mut(row_len).enumerate() {
                let y = first / row_len + dy;
                for row in src[y * s * fw * channels..(y + 1) * s * fw * channels]
                    .chunks_exact(fw * channels)
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
                for v in out.iter_mut() {
                    *v *= scale;
                }
            }
        });
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
/// its pixel's `s × s` samples, row-major in the fine plane, on up to
/// `threads` threads.
pub fn replicate_into<R: Copy + Send + Sync>(
    threads: usize,
    coarse: &[R],
    channels: usize,
    width: usize,
    height: usize,
    s: u32,
    fine: &mut Vec<R>,
) {
    replicate_mapped(threads, coarse, channels, width, height, s, fine, |v| v);
}

/// Rows per job of a pass over `rows` rows on `threads` threads: a few jobs
/// a thread, none of a handful of rows.
fn chunk_rows(rows: usize, threads: usize) -> usize {
    crate::parallel::chunk_size(rows, threads, 8)
}

/// [`replicate_into`] of `map(value)`: each fine row is built once from its
/// coarse row and copied for the block's other rows, rows of pixels on the
/// job's threads (pushed a sample at a time on one core, the gradients' spread
/// was 1 % of a background's step).
#[allow(clippy::too_many_arguments)]
fn replicate_mapped<R: Copy + Send + Sync>(
    threads: usize,
    coarse: &[R],
    channels: usize,
    width: usize,
    height: usize,
    s: u32,
    fine: &mut Vec<R>,
    map: impl Fn(R) -> R + Sync,
) {
    let s = s as usize;
    let row_len = width * s * channels;
    let (Some(&fill), true) = (coarse.first(), row_len > 0) else {
        fine.clear();
        return;
    };
    // Every value is written below: resizing (keeping old values) is enough.
    fine.resize(row_len * s * height, fill);
    let block_rows = row_len * s;
    for_chunks_mut(
        threads,
        fine,
        chunk_rows(height, threads) * block_rows,
        |first, part| {
            for (dy, block) in part.chunks_exact_mut(block_rows).enumerate() {
                let y = first / block_rows + dy;
                let (head, rest) = block.split_at_mut(row_len);
                let samples = head.chunks_exact_mut(channels * s);
                for (pixel, out) in coarse[y * width * channels..(y + 1) * width * channels]
                    .chunks_exact(channels)
                    .zip(samples)
                {
                    for sample in out.chunks_exact_mut(channels) {
                        for (o, &v) in sample.iter_mut().zip(pixel) {
                            *o = map(v);
                        }
                    }
                }
                for copy in rest.chunks_exact_mut(row_len) {
                    copy.copy_from_slice(head);
                }
            }
        },
    );
}

/// The gradient of a coarse output plane (`channels` per pixel over
/// `coarse_region`) with respect to its `s × s` samples: each sample carries
/// its pixel's gradient over `s²` (the adjoint of [`downsample_into`]).
pub fn spread_into<R: Real>(
    threads: usize,
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
    let scale = R::of(1.0 / (s * s) as f64);
    replicate_mapped(threads, coarse, channels, width, height, s, fine, |g| {
        g * scale
    });
}
