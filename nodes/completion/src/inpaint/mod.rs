//! Image inpainting with OpenCV's semantics (`cv::inpaint`, 4.10 and later).
//!
//! Both methods fill the hole in fast-marching order and compute every hole pixel
//! exactly once, as a weighted average of the known pixels within `radius`:
//! - [`Method::Ns`] ("Navier–Stokes" in OpenCV's naming) weights samples by
//!   `1/(|r|⁴+1)` and by how well `r` follows the isophote at the sample;
//! - [`Method::Telea`] weights by `1/|r|³`, by level-set closeness and by direction
//!   along the front's normal, and adds a normalised gradient correction.
//!
//! The fill order depends only on the mask (`march`), so it is computed once and
//! then replayed; channels are independent given the order, and so are groups of
//! holes farther apart than the sampling reach, so either can run on separate
//! threads with bit-identical results. Pixels outside the mask are copied unchanged.
//!
//! Known deviations from OpenCV, both outside what OpenCV defines: on images one
//! pixel tall or wide OpenCV reads outside the image for gradients (those reads are
//! clamped here), and multi-channel images other than 3-channel 8-bit (which OpenCV
//! rejects) are filled channel by channel with the 1-channel code.

mod kernels;
mod march;
mod partition;
mod sample;
mod window;

pub use sample::Sample;

use kernels::Geometry;
use serde::{Deserialize, Serialize};

/// Which weighting to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// OpenCV's `INPAINT_NS`.
    Ns,
    /// OpenCV's `INPAINT_TELEA`.
    Telea,
}

impl std::str::FromStr for Method {
    type Err = String;
    fn from_str(s: &str) -> Result<Method, String> {
        match s {
            "ns" => Ok(Method::Ns),
            "telea" => Ok(Method::Telea),
            other => Err(format!(
                "unknown inpainting method {other:?}: expected \"ns\" or \"telea\""
            )),
        }
    }
}

/// An interleaved image buffer of `width × height × channels` samples.
#[derive(Debug, Clone, PartialEq)]
pub struct Raster<T> {
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub data: Vec<T>,
}

impl<T: Sample> Raster<T> {
    pub fn new(
        width: usize,
        height: usize,
        channels: usize,
        data: Vec<T>,
    ) -> Result<Raster<T>, InpaintError> {
        let expected = width
            .checked_mul(height)
            .and_then(|n| n.checked_mul(channels));
        if expected != Some(data.len()) {
            return Err(InpaintError::ImageSize {
                width,
                height,
                channels,
                len: data.len(),
            });
        }
        Ok(Raster {
            width,
            height,
            channels,
            data,
        })
    }
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum InpaintError {
    #[error("image buffer holds {len} samples, but {width}×{height}×{channels} were declared")]
    ImageSize {
        width: usize,
        height: usize,
        channels: usize,
        len: usize,
    },
    #[error("mask is {mask_width}×{mask_height} but the image is {width}×{height}")]
    MaskSize {
        mask_width: usize,
        mask_height: usize,
        width: usize,
        height: usize,
    },
    #[error("image has {0} channels; 1 to 4 are supported")]
    Channels(usize),
    #[error("inpainting radius {0} is not a finite number")]
    Radius(f64),
    #[error("image sample at pixel ({x}, {y}), channel {channel} is not finite")]
    NonFinite { x: usize, y: usize, channel: usize },
    #[error("image {width}×{height} is too large to inpaint (at most 2³¹ padded pixels)")]
    TooLarge { width: usize, height: usize },
}

/// How to inpaint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Options {
    pub method: Method,
    /// Neighbourhood radius in pixels; rounded half to even and clamped to 1..=100
    /// like OpenCV's.
    pub radius: f64,
    /// Worker threads (channels are filled in parallel); 0 = all available.
    pub threads: usize,
}

impl Options {
    pub fn new(method: Method, radius: f64) -> Options {
        Options {
            method,
            radius,
            threads: 0,
        }
    }
}

/// The integer radius OpenCV uses for `radius`.
pub fn effective_range(radius: f64) -> Result<usize, InpaintError> {
    if !radius.is_finite() {
        return Err(InpaintError::Radius(radius));
    }
    Ok(radius.round_ties_even().clamp(1.0, 100.0) as usize)
}

/// Fills the pixels where `mask` (`width × height`, row-major) is non-zero.
pub fn inpaint<T: Sample>(
    image: &Raster<T>,
    mask: &[u8],
    options: &Options,
) -> Result<Raster<T>, InpaintError> {
    let Raster {
        width,
        height,
        channels,
        ..
    } = *image;
    if image.data.len() != width * height * channels {
        return Err(InpaintError::ImageSize {
            width,
            height,
            channels,
            len: image.data.len(),
        });
    }
    if mask.len() != width * height {
        // Only the length is known here; report it as one row so the message is true.
        return Err(InpaintError::MaskSize {
            mask_width: mask.len(),
            mask_height: 1,
            width,
            height,
        });
    }
    if !(1..=4).contains(&channels) {
        return Err(InpaintError::Channels(channels));
    }
    let range = effective_range(options.radius)?;
    if (width + 2)
        .checked_mul(height + 2)
        .is_none_or(|n| n > i32::MAX as usize)
    {
        return Err(InpaintError::TooLarge { width, height });
    }
    if let Some(i) = image.data.iter().position(|v| !v.is_finite()) {
        let pixel = i / channels;
        return Err(InpaintError::NonFinite {
            x: pixel % width,
            y: pixel / width,
            channel: i % channels,
        });
    }

    let mut out = image.clone();
    if width == 0 || height == 0 || mask.iter().all(|&m| m == 0) {
        return Ok(out);
    }
    let order = march::fill_order(
        mask,
        width,
        height,
        (options.method == Method::Telea).then_some(range),
    );
    if order.order.is_empty() {
        return Ok(out);
    }
    let disc = window::Disc::new(range);
    let row_taps = window::taps(height);
    let col_taps = window::taps(width);
    let geo = Geometry {
        width,
        height,
        order: &order,
        disc: &disc,
        row_taps: &row_taps,
        col_taps: &col_taps,
    };
    let job = Job {
        geo: &geo,
        method: options.method,
        wide_distance: T::NAME == "u8" && channels == 3,
    };
    let threads = match options.threads {
        0 => std::thread::available_parallelism().map_or(1, |n| n.get()),
        n => n,
    };
    if threads <= 1 {
        job.run(&mut out.data, channels, &order.order);
        return Ok(out);
    }

    // Two ways to split the work: independent groups of holes (all channels
    // together), or channels (all holes together). Take the one whose largest
    // share of the work is smaller.
    let bins = partition::balanced_bins(&order, height + 2, range, threads);
    let total = order.order.len() as f64;
    let hole_share = bins.iter().map(Vec::len).max().unwrap_or(0) as f64 / total;
    let channel_share = channels.div_ceil(threads.min(channels)) as f64 / channels as f64;
    if bins.len() > 1 && hole_share <= channel_share {
        run_hole_groups(&job, &mut out, &bins);
    } else if channels > 1 {
        run_channel_groups(&job, &mut out, threads.min(channels));
    } else {
        job.run(&mut out.data, channels, &order.order);
    }
    Ok(out)
}

/// One inpainting pass over a given set of pixels.
struct Job<'a> {
    geo: &'a Geometry<'a>,
    method: Method,
    wide_distance: bool,
}

impl Job<'_> {
    /// Fills `pixels` (padded cells, in fill order) in an interleaved buffer.
    fn run<T: Sample>(&self, data: &mut [T], channels: usize, pixels: &[u32]) {
        macro_rules! with_channels {
            ($c:literal) => {
                match self.method {
                    Method::Ns => kernels::fill_ns::<T, $c>(data, pixels, self.geo),
                    Method::Telea => {
                        kernels::fill_telea::<T, $c>(data, pixels, self.geo, self.wide_distance)
                    }
                }
            };
        }
        match channels {
            1 => with_channels!(1),
            2 => with_channels!(2),
            3 => with_channels!(3),
            // Validated to be 1..=4 by `inpaint`.
            _ => with_channels!(4),
        }
    }
}

/// Each thread fills one group of non-interacting holes on its own copy of the
/// image; the filled pixels are then copied back.
fn run_hole_groups<T: Sample>(job: &Job, out: &mut Raster<T>, bins: &[Vec<u32>]) {
    let (channels, width, stride) = (out.channels, out.width, job.geo.order.stride);
    let source = &out.data;
    let filled: Vec<Vec<T>> = std::thread::scope(|scope| {
        let handles: Vec<_> = bins
            .iter()
            .map(|pixels| {
                scope.spawn(move || {
                    let mut copy = source.clone();
                    job.run(&mut copy, channels, pixels);
                    copy
                })
            })
            .collect();
        // A kernel panic would be a bug; re-raise it on this thread.
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
            .collect()
    });
    for (pixels, copy) in bins.iter().zip(&filled) {
        for &cell in pixels {
            let (i, j) = (cell as usize / stride, cell as usize % stride);
            let at = ((i - 1) * width + (j - 1)) * channels;
            out.data[at..at + channels].copy_from_slice(&copy[at..at + channels]);
        }
    }
}

/// Each thread fills every hole in its share of the channels.
fn run_channel_groups<T: Sample>(job: &Job, out: &mut Raster<T>, threads: usize) {
    let channels = out.channels;
    let mut planes: Vec<Vec<T>> = (0..channels)
        .map(|c| out.data.iter().skip(c).step_by(channels).copied().collect())
        .collect();
    let per_thread = channels.div_ceil(threads);
    let pixels = &job.geo.order.order;
    std::thread::scope(|scope| {
        for group in planes.chunks_mut(per_thread) {
            scope.spawn(move || group.iter_mut().for_each(|plane| job.run(plane, 1, pixels)));
        }
    });
    for (c, plane) in planes.iter().enumerate() {
        for (dst, &v) in out.data.iter_mut().skip(c).step_by(channels).zip(plane) {
            *dst = v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn radius_rounds_half_to_even_and_clamps() {
        assert_eq!(effective_range(2.5).unwrap(), 2);
        assert_eq!(effective_range(3.5).unwrap(), 4);
        assert_eq!(effective_range(0.2).unwrap(), 1);
        assert_eq!(effective_range(1e9).unwrap(), 100);
        assert!(effective_range(f64::NAN).is_err());
    }

    #[test]
    fn constant_image_stays_constant_under_ns_and_within_one_level_under_telea() {
        let img = Raster::new(9, 7, 3, vec![77u8; 9 * 7 * 3]).unwrap();
        let mut mask = vec![0u8; 63];
        mask[3 * 9 + 4] = 1;
        mask[0] = 1;
        mask[62] = 1;
        for method in [Method::Ns, Method::Telea] {
            let out = inpaint(&img, &mask, &Options::new(method, 3.0)).unwrap();
            // Telea adds 0.5 and then rounds half to even, so OpenCV itself turns an
            // exact 77 into 78 at some pixels.
            let tolerance = if method == Method::Ns { 0 } else { 1 };
            assert!(
                out.data.iter().all(|&v| v.abs_diff(77) <= tolerance),
                "{method:?}"
            );
        }
    }

    #[test]
    fn rejects_non_finite_samples_with_their_position() {
        let mut data = vec![0.5f32; 12];
        data[7] = f32::NAN;
        let img = Raster::new(2, 3, 2, data).unwrap();
        let err = inpaint(&img, &[1, 0, 0, 0, 0, 0], &Options::new(Method::Ns, 3.0)).unwrap_err();
        assert_eq!(
            err,
            InpaintError::NonFinite {
                x: 1,
                y: 1,
                channel: 1
            }
        );
    }
}
