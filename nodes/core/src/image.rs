//! Float images and their PNG encoding (8-bit sRGB or 16-bit).
//!
//! Values are stored as they are encoded (sRGB-encoded colours in [0, 1]); no
//! colour-space conversion happens here. Training and metrics work in this space,
//! like 3DGS; only glTF export converts to linear.

use anyhow::{Context, Result, bail};
use std::path::Path;

/// Writes a PNG, replacing (not modifying) a file already at `path`: an output folder may
/// hold hard links to input artifacts (see the engine's store), and writing
/// through one would change the input.
fn write_png(
    path: &Path,
    raw: &[u8],
    width: u32,
    height: u32,
    color: image::ExtendedColorType,
) -> Result<()> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            return Err(e).with_context(|| format!("{}: cannot replace", path.display()));
        }
        _ => {}
    }
    image::save_buffer_with_format(path, raw, width, height, color, image::ImageFormat::Png)
        .with_context(|| format!("{}: cannot write PNG", path.display()))
}

/// Writes 8-bit grey pixels as a PNG.
pub fn write_gray8(path: &Path, data: &[u8], width: u32, height: u32) -> Result<()> {
    write_png(path, data, width, height, image::ExtendedColorType::L8)
}

/// Writes 8-bit RGB pixels as a PNG.
pub fn write_rgb8(path: &Path, data: &[u8], width: u32, height: u32) -> Result<()> {
    write_png(path, data, width, height, image::ExtendedColorType::Rgb8)
}

/// An 8-bit grey PNG of the given size (other formats are refused: masks are 8-bit grey).
pub fn read_gray8(path: &Path, width: u32, height: u32) -> Result<Vec<u8>> {
    let img = image::open(path).with_context(|| format!("{}: cannot read mask", path.display()))?;
    let (w, h) = (img.width(), img.height());
    let image::DynamicImage::ImageLuma8(buf) = img else {
        bail!(
            "{}: expected an 8-bit grey mask, found {:?}",
            path.display(),
            img.color()
        );
    };
    if (w, h) != (width, height) {
        bail!(
            "{}: mask is {w}×{h} but its frame is {width}×{height}",
            path.display()
        );
    }
    Ok(buf.into_raw())
}

/// An image as 8-bit RGB that must be `width`×`height` (the frame it belongs to).
pub fn read_rgb8_sized(path: &Path, width: u32, height: u32) -> Result<Vec<u8>> {
    let (w, h, rgb) = read_rgb8(path)?;
    if (w, h) != (width, height) {
        bail!(
            "{}: image is {w}×{h} but its frame is {width}×{height}",
            path.display()
        );
    }
    Ok(rgb)
}

/// An image as 8-bit RGB (grey is replicated, alpha dropped, 16-bit reduced).
pub fn read_rgb8(path: &Path) -> Result<(u32, u32, Vec<u8>)> {
    let img =
        image::open(path).with_context(|| format!("{}: cannot read image", path.display()))?;
    let rgb = img.to_rgb8();
    Ok((rgb.width(), rgb.height(), rgb.into_raw()))
}

/// The RGB colours of an image inside a window `[x0, x1) × [y0, y1)` of it:
/// 8-bit samples when the file is 8-bit (so a frame costs 3 bytes a pixel, and
/// [`RgbWindow::get`] gives exactly what [`Image::load`] would: `v / 255`),
/// f32 otherwise.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbWindow {
    pub x0: u32,
    pub y0: u32,
    pub x1: u32,
    pub y1: u32,
    samples: Samples,
}

#[derive(Debug, Clone, PartialEq)]
enum Samples {
    U8(Vec<u8>),
    F32(Vec<f32>),
}

impl RgbWindow {
    /// An empty window (no pixel).
    pub fn empty() -> Self {
        RgbWindow {
            x0: 0,
            y0: 0,
            x1: 0,
            y1: 0,
            samples: Samples::U8(Vec::new()),
        }
    }

    /// The window `[x0, x1) × [y0, y1)` of the image at `path`, which must be
    /// `width`×`height`; grey is replicated and alpha dropped, as [`Image::to_rgb`] does.
    pub fn load(path: &Path, width: u32, height: u32, window: [u32; 4]) -> Result<Self> {
        let img =
            image::open(path).with_context(|| format!("{}: cannot read image", path.display()))?;
        if (img.width(), img.height()) != (width, height) {
            bail!(
                "{}: image is {}×{} but its frame is {width}×{height}",
                path.display(),
                img.width(),
                img.height()
            );
        }
        use image::DynamicImage as D;
        Ok(match img {
            D::ImageLuma8(_) | D::ImageLumaA8(_) | D::ImageRgb8(_) | D::ImageRgba8(_) => {
                Self::from_rgb8(width, &img.to_rgb8().into_raw(), window)
            }
            other => Self::from_rgb_f32(width, &Image::from_dynamic(other).to_rgb().data, window),
        })
    }

    /// The window of a `width`-wide 8-bit RGB image.
    pub fn from_rgb8(width: u32, rgb: &[u8], window: [u32; 4]) -> Self {
        Self::with_samples(window, Samples::U8(window_rows(width, rgb, window)))
    }

    /// The window of a `width`-wide float RGB image.
    pub fn from_rgb_f32(width: u32, rgb: &[f32], window: [u32; 4]) -> Self {
        Self::with_samples(window, Samples::F32(window_rows(width, rgb, window)))
    }

    fn with_samples([x0, y0, x1, y1]: [u32; 4], samples: Samples) -> Self {
        RgbWindow {
            x0,
            y0,
            x1,
            y1,
            samples,
        }
    }

    pub fn contains(&self, x: u32, y: u32) -> bool {
        x >= self.x0 && x < self.x1 && y >= self.y0 && y < self.y1
    }

    fn index(&self, x: u32, y: u32) -> usize {
        3 * ((y - self.y0) * (self.x1 - self.x0) + (x - self.x0)) as usize
    }

    /// The colour at frame pixel `(x, y)`, which must lie in the window.
    #[inline]
    pub fn get(&self, x: u32, y: u32) -> [f32; 3] {
        let i = self.index(x, y);
        match &self.samples {
            Samples::U8(s) => [0, 1, 2].map(|c| s[i + c] as f32 / 255.0),
            Samples::F32(s) => [s[i], s[i + 1], s[i + 2]],
        }
    }

    /// Replaces the colour at frame pixel `(x, y)` (in the window) by an 8-bit one.
    pub fn set_rgb8(&mut self, x: u32, y: u32, rgb: [u8; 3]) {
        let i = self.index(x, y);
        match &mut self.samples {
            Samples::U8(s) => s[i..i + 3].copy_from_slice(&rgb),
            Samples::F32(s) => {
                for c in 0..3 {
                    s[i + c] = rgb[c] as f32 / 255.0;
                }
            }
        }
    }

    /// The first sample that is not finite (8-bit ones always are).
    pub fn first_non_finite(&self) -> Option<usize> {
        match &self.samples {
            Samples::U8(_) => None,
            Samples::F32(s) => s.iter().position(|v| !v.is_finite()),
        }
    }

    /// Bytes held (for memory reports).
    pub fn bytes(&self) -> usize {
        match &self.samples {
            Samples::U8(s) => s.len(),
            Samples::F32(s) => 4 * s.len(),
        }
    }
}

/// A row-major, channel-interleaved float image.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub channels: u32,
    pub data: Vec<f32>,
}

impl Image {
    pub fn new(width: u32, height: u32, channels: u32) -> Self {
        Image {
            width,
            height,
            channels,
            data: vec![0.0; (width * height * channels) as usize],
        }
    }

    pub fn from_fn(
        width: u32,
        height: u32,
        channels: u32,
        f: impl Fn(u32, u32, u32) -> f32,
    ) -> Self {
        let mut img = Image::new(width, height, channels);
        for y in 0..height {
            for x in 0..width {
                for c in 0..channels {
                    img.data[((y * width + x) * channels + c) as usize] = f(x, y, c);
                }
            }
        }
        img
    }

    #[inline]
    pub fn get(&self, x: u32, y: u32, c: u32) -> f32 {
        self.data[((y * self.width + x) * self.channels + c) as usize]
    }

    #[inline]
    pub fn set(&mut self, x: u32, y: u32, c: u32, v: f32) {
        self.data[((y * self.width + x) * self.channels + c) as usize] = v;
    }

    pub fn pixel_count(&self) -> usize {
        (self.width * self.height) as usize
    }

    /// Loads a PNG or JPEG; 8- and 16-bit grey, grey+alpha, RGB and RGBA are kept with their channel count.
    pub fn load(path: &Path) -> Result<Image> {
        let img = image::ImageReader::open(path)
            .with_context(|| format!("{}: cannot open image", path.display()))?
            .with_guessed_format()
            .with_context(|| format!("{}: cannot read image", path.display()))?
            .decode()
            .with_context(|| format!("{}: not a decodable image", path.display()))?;
        Ok(Self::from_dynamic(img))
    }

    pub fn from_dynamic(img: image::DynamicImage) -> Image {
        use image::DynamicImage as D;
        let (w, h) = (img.width(), img.height());
        let (channels, data): (u32, Vec<f32>) = match img {
            D::ImageLuma8(b) => (1, b.into_raw().iter().map(|&v| v as f32 / 255.0).collect()),
            D::ImageLumaA8(b) => (2, b.into_raw().iter().map(|&v| v as f32 / 255.0).collect()),
            D::ImageRgb8(b) => (3, b.into_raw().iter().map(|&v| v as f32 / 255.0).collect()),
            D::ImageRgba8(b) => (4, b.into_raw().iter().map(|&v| v as f32 / 255.0).collect()),
            D::ImageLuma16(b) => (
                1,
                b.into_raw().iter().map(|&v| v as f32 / 65535.0).collect(),
            ),
            D::ImageLumaA16(b) => (
                2,
                b.into_raw().iter().map(|&v| v as f32 / 65535.0).collect(),
            ),
            D::ImageRgb16(b) => (
                3,
                b.into_raw().iter().map(|&v| v as f32 / 65535.0).collect(),
            ),
            D::ImageRgba16(b) => (
                4,
                b.into_raw().iter().map(|&v| v as f32 / 65535.0).collect(),
            ),
            other => (4, other.to_rgba32f().into_raw()),
        };
        Image {
            width: w,
            height: h,
            channels,
            data,
        }
    }

    /// The RGB part (grey is replicated, alpha dropped).
    pub fn to_rgb(&self) -> Image {
        match self.channels {
            3 => self.clone(),
            1 | 2 => Image::from_fn(self.width, self.height, 3, |x, y, _| self.get(x, y, 0)),
            _ => Image::from_fn(self.width, self.height, 3, |x, y, c| self.get(x, y, c)),
        }
    }

    fn quantize<T: Copy>(&self, max: f32, conv: impl Fn(f32) -> T) -> Vec<T> {
        self.data
            .iter()
            .map(|&v| conv((v.clamp(0.0, 1.0) * max).round()))
            .collect()
    }

    /// Saves as an 8-bit PNG (values clamped to [0, 1] and rounded).
    pub fn save_png8(&self, path: &Path) -> Result<()> {
        let raw = self.to_8bit();
        write_png(path, &raw, self.width, self.height, self.png_color(false)?)
    }

    /// The samples as an 8-bit PNG stores them (clamped to [0, 1], rounded).
    pub fn to_8bit(&self) -> Vec<u8> {
        self.quantize(255.0, |v| v as u8)
    }

    /// [`Image::to_8bit`] of the RGB part ([`Image::to_rgb`]).
    pub fn to_rgb8(&self) -> Vec<u8> {
        if self.channels == 3 {
            self.to_8bit()
        } else {
            self.to_rgb().to_8bit()
        }
    }

    /// Saves as a 16-bit PNG.
    pub fn save_png16(&self, path: &Path) -> Result<()> {
        let raw: Vec<u8> = self
            .quantize(65535.0, |v| v as u16)
            .iter()
            .flat_map(|v| v.to_ne_bytes())
            .collect();
        write_png(path, &raw, self.width, self.height, self.png_color(true)?)
    }

    /// The PNG colour type of this image's channels at 8 or 16 bits.
    fn png_color(&self, sixteen_bit: bool) -> Result<image::ExtendedColorType> {
        use image::ExtendedColorType::*;
        let types = if sixteen_bit {
            [L16, La16, Rgb16, Rgba16]
        } else {
            [L8, La8, Rgb8, Rgba8]
        };
        match self.channels {
            c @ 1..=4 => Ok(types[c as usize - 1]),
            c => bail!("cannot save a {c}-channel image as PNG"),
        }
    }

    /// Box-filter (area) downscale to `width`×`height`; exact for integer factors.
    pub fn resize_area(&self, width: u32, height: u32) -> Image {
        let sx = self.width as f64 / width as f64;
        let sy = self.height as f64 / height as f64;
        let ch = self.channels as usize;
        let mut out = Image::new(width, height, self.channels);
        for oy in 0..height {
            let (y0, y1) = (oy as f64 * sy, (oy + 1) as f64 * sy);
            for ox in 0..width {
                let (x0, x1) = (ox as f64 * sx, (ox + 1) as f64 * sx);
                let mut acc = vec![0.0f64; ch];
                let mut wsum = 0.0;
                let mut y = y0.floor() as u32;
                while (y as f64) < y1 && y < self.height {
                    let wy = (y1.min(y as f64 + 1.0) - y0.max(y as f64)).max(0.0);
                    let mut x = x0.floor() as u32;
                    while (x as f64) < x1 && x < self.width {
                        let wx = (x1.min(x as f64 + 1.0) - x0.max(x as f64)).max(0.0);
                        let w = wx * wy;
                        for (c, a) in acc.iter_mut().enumerate() {
                            *a += w * self.get(x, y, c as u32) as f64;
                        }
                        wsum += w;
                        x += 1;
                    }
                    y += 1;
                }
                for (c, a) in acc.iter().enumerate() {
                    out.set(ox, oy, c as u32, (a / wsum.max(1e-12)) as f32);
                }
            }
        }
        out
    }

    /// Fails with a message naming the first non-finite value.
    pub fn check_finite(&self, what: &str) -> Result<()> {
        if let Some(i) = self.data.iter().position(|v| !v.is_finite()) {
            let p = i / self.channels as usize;
            bail!(
                "{what}: non-finite value at pixel ({}, {})",
                p % self.width as usize,
                p / self.width as usize
            );
        }
        Ok(())
    }
}

/// The rows of `window` (`[x0, y0, x1, y1]`) of a `width`-wide RGB image, packed.
fn window_rows<T: Copy>(width: u32, rgb: &[T], [x0, y0, x1, y1]: [u32; 4]) -> Vec<T> {
    let mut samples = Vec::with_capacity(3 * ((x1 - x0) * (y1 - y0)) as usize);
    for y in y0..y1 {
        let row = 3 * (y * width) as usize;
        samples.extend_from_slice(&rgb[row + 3 * x0 as usize..row + 3 * x1 as usize]);
    }
    samples
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png8_and_png16_roundtrip() {
        let dir = tempfile::tempdir().unwrap();
        let img = Image::from_fn(7, 5, 3, |x, y, c| {
            ((x * 31 + y * 17 + c * 5) % 256) as f32 / 255.0
        });
        img.save_png8(&dir.path().join("a.png")).unwrap();
        assert_eq!(Image::load(&dir.path().join("a.png")).unwrap(), img);
        let img16 = Image::from_fn(3, 2, 1, |x, y, _| (x * 1000 + y * 7) as f32 / 65535.0);
        img16.save_png16(&dir.path().join("b.png")).unwrap();
        let back = Image::load(&dir.path().join("b.png")).unwrap();
        assert!(
            back.data
                .iter()
                .zip(&img16.data)
                .all(|(a, b)| (a - b).abs() < 1e-7)
        );
    }

    #[test]
    fn area_downscale_averages_blocks() {
        let img = Image::from_fn(4, 2, 1, |x, _, _| x as f32);
        let small = img.resize_area(2, 1);
        assert_eq!(small.data, vec![0.5, 2.5]);
    }
}
