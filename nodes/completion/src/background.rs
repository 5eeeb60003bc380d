//! Filling the background where objects stood, for interactive and qualitative use
//! only: these fills are not consistent across views and are never fed to metrics
//! or training (the paper's protocol).
//!
//! For every frame the background component appears in, the pixels it marks OTHER
//! (owned by an object) are filled; ignored pixels are left alone. Every such frame
//! gets a fill image `<frame stem>.png` (unchanged where there was nothing to fill).

use crate::external::{ExternalCommand, FillRequest, composite};
use crate::inpaint::{Method, Options, Raster, inpaint};
use anyhow::{Context, Result, bail};
use objectsplat_core::ComponentFolder;
use objectsplat_core::component::OTHER;
use objectsplat_core::frames::frame_stem;
use objectsplat_core::image::{read_rgb8_sized, write_rgb8};
use objectsplat_core::{ComponentKind, Frames};
use std::path::{Path, PathBuf};

/// Where the fills come from.
#[derive(Debug, Clone, PartialEq)]
pub enum FillSource {
    /// Built-in NS or Telea with this radius.
    Builtin { method: Method, radius: f64 },
    /// An external program (see [`crate::external`]).
    Command(ExternalCommand),
    /// Precomputed fills: `<folder>/<frame stem>.png`, frame-sized.
    Folder(PathBuf),
}

#[derive(Debug, Clone, PartialEq)]
pub struct BackgroundReport {
    pub frames: usize,
    pub frames_with_holes: usize,
    pub pixels_filled: u64,
    /// Set when nothing was written.
    pub skipped: Option<String>,
}

/// Writes one fill per background frame into `out`. `scratch` is a private folder
/// for the external command's files.
pub fn inpaint_background(
    items: &[(String, PathBuf)],
    frames: &Frames,
    source: &FillSource,
    out: &Path,
    scratch: &Path,
) -> Result<BackgroundReport> {
    let components = ComponentFolder::read_items(items)?;
    let Some(background) = components
        .iter()
        .find(|c| c.info.kind == ComponentKind::Background)
    else {
        let skipped = Some("no background component among the inputs".to_string());
        return Ok(BackgroundReport {
            frames: 0,
            frames_with_holes: 0,
            pixels_filled: 0,
            skipped,
        });
    };

    let mut requests = Vec::new();
    for frame in frames
        .frames
        .iter()
        .filter(|f| background.has_frame(&f.name))
    {
        let mask: Vec<u8> = background
            .load_mask(frame)?
            .iter()
            .map(|&v| u8::from(v == OTHER))
            .collect();
        let path = frames.image_path(frame);
        let rgb = read_rgb8_sized(&path, frame.camera.width, frame.camera.height)?;
        requests.push(FillRequest {
            stem: frame_stem(&frame.name).to_string(),
            width: frame.camera.width,
            height: frame.camera.height,
            rgb,
            mask,
        });
    }
    let has_hole = |r: &FillRequest| r.mask.iter().any(|&m| m != 0);
    let mut report = BackgroundReport {
        frames: requests.len(),
        frames_with_holes: requests.iter().filter(|r| has_hole(r)).count(),
        pixels_filled: requests
            .iter()
            .map(|r| r.mask.iter().filter(|&&m| m != 0).count() as u64)
            .sum(),
        skipped: None,
    };
    if report.frames_with_holes == 0 {
        report.skipped = Some(format!(
            "the background has no pixels owned by objects in its {} frames",
            report.frames
        ));
        return Ok(report);
    }

    let to_fill: Vec<FillRequest> = requests.iter().filter(|r| has_hole(r)).cloned().collect();
    let filled: Vec<Vec<u8>> = match source {
        FillSource::Builtin { method, radius } => to_fill
            .iter()
            .map(|r| {
                let image = Raster::new(r.width as usize, r.height as usize, 3, r.rgb.clone())?;
                Ok(inpaint(&image, &r.mask, &Options::new(*method, *radius))?.data)
            })
            .collect::<Result<_>>()?,
        FillSource::Command(command) => command.run(&to_fill, scratch)?,
        FillSource::Folder(dir) => to_fill
            .iter()
            .map(|r| {
                let path = dir.join(format!("{}.png", r.stem));
                if !path.is_file() {
                    bail!(
                        "{}: no precomputed fill for frame {:?}",
                        path.display(),
                        r.stem
                    );
                }
                let rgb = read_rgb8_sized(&path, r.width, r.height)?;
                Ok(composite(&r.rgb, &rgb, &r.mask))
            })
            .collect::<Result<_>>()?,
    };

    let mut filled = to_fill
        .iter()
        .map(|r| &r.stem)
        .zip(filled)
        .collect::<std::collections::HashMap<_, _>>();
    for r in &requests {
        let data = filled.remove(&r.stem).unwrap_or_else(|| r.rgb.clone());
        let path = out.join(format!("{}.png", r.stem));
        write_rgb8(&path, &data, r.width, r.height)
            .with_context(|| format!("writing the fill of frame {:?}", r.stem))?;
    }
    Ok(report)
}
