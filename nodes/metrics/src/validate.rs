//! Input checks shared by the image metrics.

use anyhow::{Result, bail};
use objectsplat_core::Image;

/// Same size and channel count, non-empty, and every value finite.
pub fn check_pair(a: &Image, b: &Image) -> Result<()> {
    if (a.width, a.height, a.channels) != (b.width, b.height, b.channels) {
        bail!(
            "images differ in shape: {}×{}×{} vs {}×{}×{}",
            a.width,
            a.height,
            a.channels,
            b.width,
            b.height,
            b.channels
        );
    }
    if a.data.is_empty() {
        bail!("images are empty");
    }
    for (name, img) in [("first", a), ("second", b)] {
        if img.data.len() != img.pixel_count() * img.channels as usize {
            bail!(
                "{name} image holds {} values, its shape needs {}",
                img.data.len(),
                img.pixel_count() * img.channels as usize
            );
        }
        img.check_finite(&format!("{name} image"))?;
    }
    Ok(())
}
