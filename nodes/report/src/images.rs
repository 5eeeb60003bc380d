//! Test-view triplets: ground truth, render and a per-pixel error heatmap, as inline PNG data URIs.

use anyhow::{Context, Result, ensure};
use base64::Engine;
use objectsplat_core::Image;
use std::path::Path;

/// Widest picture embedded in the report; larger views are box-filtered down to keep the file small.
pub const MAX_THUMBNAIL_WIDTH: u32 = 384;

/// Heatmap control points (error fraction → RGB), dark = small error, bright = large.
const HEAT_STOPS: [(f32, [f32; 3]); 5] = [
    (0.0, [0.0, 0.0, 0.02]),
    (0.25, [0.33, 0.06, 0.42]),
    (0.5, [0.80, 0.22, 0.30]),
    (0.75, [0.98, 0.60, 0.10]),
    (1.0, [0.99, 0.98, 0.65]),
];

/// Maps t ∈ [0, 1] (clamped) to the heatmap colour by piecewise-linear interpolation.
pub fn heat_colour(t: f32) -> [f32; 3] {
    let t = if t.is_nan() { 1.0 } else { t.clamp(0.0, 1.0) };
    for pair in HEAT_STOPS.windows(2) {
        let ((t0, c0), (t1, c1)) = (pair[0], pair[1]);
        if t <= t1 {
            let f = (t - t0) / (t1 - t0);
            return [0, 1, 2].map(|k| c0[k] + f * (c1[k] - c0[k]));
        }
    }
    HEAT_STOPS[HEAT_STOPS.len() - 1].1
}

/// Per-pixel mean absolute difference of two RGB images of equal size (values in [0, 1]).
pub fn error_map(ground_truth: &Image, render: &Image) -> Image {
    debug_assert_eq!(
        (ground_truth.width, ground_truth.height, 3),
        (render.width, render.height, render.channels)
    );
    debug_assert_eq!(ground_truth.channels, 3);
    let data = ground_truth
        .data
        .chunks_exact(3)
        .zip(render.data.chunks_exact(3))
        .map(|(a, b)| ((a[0] - b[0]).abs() + (a[1] - b[1]).abs() + (a[2] - b[2]).abs()) / 3.0)
        .collect();
    Image {
        width: ground_truth.width,
        height: ground_truth.height,
        channels: 1,
        data,
    }
}

/// PSNR in dB of an RGB render against its RGB ground truth in [0, 1]; infinite when identical.
pub fn psnr(ground_truth: &Image, render: &Image) -> f64 {
    let (a, b) = (&ground_truth.data, &render.data);
    let mse = a
        .iter()
        .zip(b)
        .map(|(x, y)| ((x - y) as f64).powi(2))
        .sum::<f64>()
        / a.len() as f64;
    10.0 * (1.0 / mse).log10()
}

/// Colours an error map: `scale` is the error drawn with the hottest colour.
pub fn heatmap(errors: &Image, scale: f32) -> Image {
    Image::from_fn(errors.width, errors.height, 3, |x, y, c| {
        heat_colour(errors.get(x, y, 0) / scale)[c as usize]
    })
}

fn thumbnail(image: &Image) -> Image {
    if image.width <= MAX_THUMBNAIL_WIDTH {
        return image.clone();
    }
    let height =
        ((image.height as u64 * MAX_THUMBNAIL_WIDTH as u64) / image.width as u64).max(1) as u32;
    image.resize_area(MAX_THUMBNAIL_WIDTH, height)
}

/// Encodes an image as an 8-bit PNG `data:` URI.
pub fn png_data_uri(image: &Image) -> Result<String> {
    let rgb = image.to_rgb();
    let bytes: Vec<u8> = rgb
        .data
        .iter()
        .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
        .collect();
    let mut png = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut png),
        &bytes,
        rgb.width,
        rgb.height,
        image::ExtendedColorType::Rgb8,
    )
    .context("cannot encode PNG")?;
    Ok(format!(
        "data:image/png;base64,{}",
        base64::engine::general_purpose::STANDARD.encode(png)
    ))
}

/// The three pictures of one test view, ready to inline.
pub struct RenderedTriplet {
    pub ground_truth: String,
    pub render: String,
    pub error: String,
    pub psnr: f64,
}

fn load_rgb_checked(path: &Path) -> Result<Image> {
    let image = Image::load(path)?.to_rgb();
    ensure!(
        image.width > 0 && image.height > 0,
        "{}: image is empty",
        path.display()
    );
    image.check_finite(&path.display().to_string())?;
    Ok(image)
}

pub fn render_triplet(ground_truth: &Path, render: &Path, scale: f32) -> Result<RenderedTriplet> {
    let gt = load_rgb_checked(ground_truth)?;
    let rendered = load_rgb_checked(render)?;
    ensure!(
        (gt.width, gt.height) == (rendered.width, rendered.height),
        "{} is {}×{} but its ground truth {} is {}×{}",
        render.display(),
        rendered.width,
        rendered.height,
        ground_truth.display(),
        gt.width,
        gt.height
    );
    // Colour after downscaling: the thumbnail shows the mean error of each block.
    let errors = thumbnail(&error_map(&gt, &rendered));
    Ok(RenderedTriplet {
        ground_truth: png_data_uri(&thumbnail(&gt))?,
        render: png_data_uri(&thumbnail(&rendered))?,
        error: png_data_uri(&heatmap(&errors, scale))?,
        psnr: psnr(&gt, &rendered),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn heat_colour_hits_its_stops_and_clamps() {
        assert_eq!(heat_colour(0.0), HEAT_STOPS[0].1);
        assert_eq!(heat_colour(0.5), HEAT_STOPS[2].1);
        assert_eq!(heat_colour(7.0), HEAT_STOPS[4].1);
        assert_eq!(heat_colour(-1.0), HEAT_STOPS[0].1);
        // Halfway between the first two stops is their mean.
        let mid = heat_colour(0.125);
        for (k, value) in mid.iter().enumerate() {
            assert!((value - (HEAT_STOPS[0].1[k] + HEAT_STOPS[1].1[k]) / 2.0).abs() < 1e-6);
        }
    }

    #[test]
    fn psnr_of_a_uniform_offset_is_analytic() {
        let a = Image::from_fn(8, 4, 3, |x, _, _| x as f32 / 10.0);
        let b = Image::from_fn(8, 4, 3, |x, _, _| x as f32 / 10.0 + 0.1);
        // MSE = 0.01 → PSNR = 20 dB.
        assert!((psnr(&a, &b) - 20.0).abs() < 1e-4);
        let e = error_map(&a, &b);
        assert!(e.data.iter().all(|v| (v - 0.1).abs() < 1e-6));
    }
}
