//! Pixel validity masks for the masked metric variants.

use anyhow::{Result, bail};
use objectsplat_core::{IdMap, Image};

/// Which pixels of an image take part in a masked metric (`true` = evaluated).
/// Row-major; the constructors guarantee one entry per pixel.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Mask {
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) valid: Vec<bool>,
}

impl Mask {
    pub fn new(width: u32, height: u32, valid: Vec<bool>) -> Result<Mask> {
        if valid.len() != width as usize * height as usize {
            bail!(
                "mask of {width}×{height} needs {} entries, got {}",
                width as usize * height as usize,
                valid.len()
            );
        }
        Ok(Mask {
            width,
            height,
            valid,
        })
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    pub fn valid(&self) -> &[bool] {
        &self.valid
    }

    /// The pixels labelled `id` in an object-id map.
    pub fn from_id_map(map: &IdMap, id: u16) -> Mask {
        Mask {
            width: map.width,
            height: map.height,
            valid: map.data.iter().map(|&v| v == id).collect(),
        }
    }

    /// The pixels whose first channel is at least 0.5 (a white-on-black mask image).
    pub fn from_image(image: &Image) -> Result<Mask> {
        if image.channels == 0 {
            bail!("a mask image needs at least one channel");
        }
        let valid = image
            .data
            .chunks_exact(image.channels as usize)
            .map(|px| px[0] >= 0.5)
            .collect();
        Ok(Mask {
            width: image.width,
            height: image.height,
            valid,
        })
    }

    /// Pixels valid in both masks.
    pub fn intersect(&self, other: &Mask) -> Result<Mask> {
        self.check_size(other.width, other.height)?;
        other.check_size(self.width, self.height)?;
        Ok(Mask {
            width: self.width,
            height: self.height,
            valid: self
                .valid
                .iter()
                .zip(&other.valid)
                .map(|(&a, &b)| a && b)
                .collect(),
        })
    }

    pub fn count(&self) -> usize {
        self.valid.iter().filter(|&&v| v).count()
    }

    /// The mask matches a `width`×`height` image (and holds one entry per pixel).
    pub fn check_size(&self, width: u32, height: u32) -> Result<()> {
        if (self.width, self.height) != (width, height) {
            bail!(
                "mask is {}×{} but the image is {width}×{height}",
                self.width,
                self.height
            );
        }
        if self.valid.len() != width as usize * height as usize {
            bail!(
                "mask of {width}×{height} holds {} entries",
                self.valid.len()
            );
        }
        Ok(())
    }

    /// Pixels whose whole (2·radius+1)² window holds only valid pixels; window
    /// positions outside the image do not count against a pixel (so an all-valid
    /// mask stays all-valid).
    pub fn eroded(&self, radius: u32) -> Mask {
        let (w, h) = (self.width as usize, self.height as usize);
        // Summed-area table of invalid pixels, (w+1)×(h+1), so each window is four look-ups.
        let stride = w + 1;
        let mut table = vec![0u32; stride * (h + 1)];
        for y in 0..h {
            let mut row = 0u32;
            for x in 0..w {
                row += u32::from(!self.valid[y * w + x]);
                table[(y + 1) * stride + x + 1] = table[y * stride + x + 1] + row;
            }
        }
        let r = radius as usize;
        let mut valid = vec![false; w * h];
        for y in 0..h {
            let (y0, y1) = (y.saturating_sub(r), (y + r + 1).min(h));
            for x in 0..w {
                let (x0, x1) = (x.saturating_sub(r), (x + r + 1).min(w));
                let invalid = table[y1 * stride + x1] + table[y0 * stride + x0]
                    - table[y0 * stride + x1]
                    - table[y1 * stride + x0];
                valid[y * w + x] = invalid == 0;
            }
        }
        Mask {
            width: self.width,
            height: self.height,
            valid,
        }
    }
}
