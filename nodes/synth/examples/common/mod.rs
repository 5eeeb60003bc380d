//! What the gt_masks benchmarks share: their command line and their mask settings.

use anyhow::{Context, Result};
use objectsplat_masks::{GtMaskParams, RasterOptions};
use std::str::FromStr;

/// The positional argument at `index` (after the program name), or `default` when
/// it is absent; `name` is what a parse error calls it.
pub fn arg_or<T>(index: usize, name: &str, default: T) -> Result<T>
where
    T: FromStr,
    T::Err: std::error::Error + Send + Sync + 'static,
{
    let Some(text) = std::env::args().nth(index + 1) else {
        return Ok(default);
    };
    text.parse().context(name.to_string())
}

/// The default masks, rasterized on `threads` threads with a near plane close
/// enough for the synthetic scene's cameras.
pub fn mask_params(threads: usize) -> GtMaskParams {
    GtMaskParams {
        raster: RasterOptions {
            near: 0.01,
            threads,
        },
        ..GtMaskParams::default()
    }
}
