//! Deterministic completion of flat support surfaces (the paper's "binary
//! hole-filling of the surface's mask ... and Navier–Stokes inpainting").
//!
//! A component is a support surface when its label names one (`labels`, matched
//! case-insensitively against the whole label or any of its words, so "coffee
//! table" matches "table") and, when scene points are given, it passes a planarity
//! test: the points that project into the component's own pixels in at least half
//! of the frames that see them (and in at least two frames, or the only one) must
//! fit one plane, RANSAC inliers within `planarity_tolerance` × the points' extent
//! for at least [`MIN_INLIER_FRACTION`] of them. With fewer than
//! [`MIN_PLANE_POINTS`] such points the label alone decides (and the report says so).
//!
//! In every frame of a surface, its OWN mask is hole-filled; a filled pixel is
//! adopted only if the surface saw it as OTHER and some *object* component owns it
//! in that frame (never background or ignored pixels). The colours of the whole
//! hole are inpainted with NS from the surface's own pixels only (other pixels near
//! the hole are inpainted alongside and discarded, so they never serve as
//! samples), and the adopted pixels get those colours as training targets
//! (`targets/<stem>.png`: the frame with the hole inpainted).

use crate::fill_holes::{Connectivity, fill_holes};
use crate::inpaint::{Method, Options, Raster, inpaint};
use crate::plane::fit_plane;
use anyhow::{Context, Result, bail};
use glam::DVec3;
use objectsplat_core::component::{self, OTHER, OWN};
use objectsplat_core::image::read_rgb8_sized;
use objectsplat_core::visibility::Visibility;
use objectsplat_core::{ComponentFolder, ComponentKind, Frame, Points};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Below this many points on a surface the planarity test is not attempted.
pub const MIN_PLANE_POINTS: usize = 12;
/// Fraction of a surface's points that must lie on the fitted plane. A table is its top
/// *and* its legs (the synthetic room's table keeps ~78% of its points on the top), so the
/// test asks for a dominant plane, not a flat object; chairs and bumpy surfaces stay well
/// below (their best plane holds under half the points).
pub const MIN_INLIER_FRACTION: f64 = 0.6;
pub(crate) const RANSAC_ITERATIONS: usize = 256;

/// The file written into each completed component with what was done.
pub use objectsplat_core::artifact::COMPONENT_COMPLETION_JSON as COMPLETION_JSON;

#[derive(Debug, Clone, PartialEq)]
pub struct SurfaceParams {
    pub labels: Vec<String>,
    /// Relative to the surface points' bounding-box diagonal.
    pub planarity_tolerance: f64,
    /// NS inpainting radius.
    pub radius: f64,
    /// Connectivity of the background flood in hole filling.
    pub connectivity: Connectivity,
}

impl Default for SurfaceParams {
    fn default() -> Self {
        SurfaceParams {
            labels: vec!["table".into(), "desk".into(), "counter".into()],
            planarity_tolerance: 0.02,
            radius: 5.0,
            connectivity: Connectivity::Four,
        }
    }
}

/// The verdict on one candidate surface.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SurfaceOutcome {
    pub component: String,
    pub label: String,
    /// `Some(fraction)` when the planarity test ran.
    pub plane_inlier_fraction: Option<f64>,
    pub plane_points: usize,
    pub accepted: bool,
    pub reason: String,
    pub frames_completed: usize,
    pub pixels_added: u64,
}

/// What `complete_surfaces` did.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct CompletionReport {
    pub surfaces: Vec<SurfaceOutcome>,
    /// Set when nothing was written: why the stage had nothing to do.
    pub skipped: Option<String>,
}

/// One frame of one surface after completion.
pub struct FrameCompletion {
    /// The surface's mask with adopted pixels set to OWN.
    pub mask: Vec<u8>,
    /// The frame image with the whole hole inpainted (RGB, 8-bit).
    pub target: Vec<u8>,
    pub pixels_added: u64,
}

/// Completes one frame: `support` is the surface's OWN/OTHER/IGNORE mask,
/// `occluded` marks pixels some object component owns, `rgb` is the frame.
/// `None` when no pixel is adopted.
pub fn complete_frame(
    support: &[u8],
    occluded: &[bool],
    rgb: &[u8],
    width: usize,
    height: usize,
    params: &SurfaceParams,
) -> Result<Option<FrameCompletion>> {
    let own: Vec<bool> = support.iter().map(|&v| v == OWN).collect();
    let filled = fill_holes(&own, width, height, params.connectivity);
    let hole: Vec<u8> = filled
        .iter()
        .zip(&own)
        .map(|(&f, &o)| u8::from(f && !o))
        .collect();
    let adopt: Vec<bool> = (0..support.len())
        .map(|i| hole[i] != 0 && support[i] == OTHER && occluded[i])
        .collect();
    let pixels_added = adopt.iter().filter(|&&a| a).count() as u64;
    if pixels_added == 0 {
        return Ok(None);
    }
    let target = inpaint_from_surface(rgb, &own, &hole, width, height, params.radius)?;
    let mask = support
        .iter()
        .zip(&adopt)
        .map(|(&v, &a)| if a { OWN } else { v })
        .collect();
    Ok(Some(FrameCompletion {
        mask,
        target,
        pixels_added,
    }))
}

/// The frame with the hole's colours inpainted (NS) from the surface's own pixels
/// only. Inside a crop around the hole (margin: radius + 2), every pixel that is not
/// the surface's is treated as unknown, so neither the hole nor anything it samples
/// is ever computed from other components' colours; pixels outside the crop do not
/// take part at all.
fn inpaint_from_surface(
    rgb: &[u8],
    own: &[bool],
    hole: &[u8],
    width: usize,
    height: usize,
    radius: f64,
) -> Result<Vec<u8>> {
    let margin = crate::inpaint::effective_range(radius)? + 2;
    let (mut x0, mut y0, mut x1, mut y1) = (usize::MAX, usize::MAX, 0, 0);
    for (p, _) in hole.iter().enumerate().filter(|(_, h)| **h != 0) {
        let (x, y) = (p % width, p / width);
        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x), y1.max(y));
    }
    let (x0, y0) = (x0.saturating_sub(margin), y0.saturating_sub(margin));
    let (x1, y1) = ((x1 + margin).min(width - 1), (y1 + margin).min(height - 1));
    let (cw, ch) = (x1 - x0 + 1, y1 - y0 + 1);
    let mut crop = Vec::with_capacity(cw * ch * 3);
    let mut unknown = Vec::with_capacity(cw * ch);
    for y in y0..=y1 {
        crop.extend_from_slice(&rgb[(y * width + x0) * 3..(y * width + x1 + 1) * 3]);
        unknown.extend(
            own[y * width + x0..=y * width + x1]
                .iter()
                .map(|&o| u8::from(!o)),
        );
    }
    let filled = inpaint(
        &Raster::new(cw, ch, 3, crop)?,
        &unknown,
        &Options::new(Method::Ns, radius),
    )?
    .data;
    let mut target = rgb.to_vec();
    for y in y0..=y1 {
        for x in x0..=x1 {
            let (p, c) = (y * width + x, (y - y0) * cw + (x - x0));
            if hole[p] != 0 {
                target[p * 3..p * 3 + 3].copy_from_slice(&filled[c * 3..c * 3 + 3]);
            }
        }
    }
    Ok(target)
}

/// Whether `label` names one of `labels` (whole label or one of its words).
pub fn label_matches(label: &str, labels: &[String]) -> bool {
    let label = label.to_lowercase();
    labels.iter().map(|l| l.to_lowercase()).any(|wanted| {
        label == wanted
            || label
                .split(|c: char| !c.is_alphanumeric())
                .any(|word| word == wanted)
    })
}

/// The scene's points, and when known which frames see which of them.
#[derive(Debug, Clone, Copy)]
pub struct ScenePoints<'a> {
    pub points: &'a Points,
    /// From `point_visibility`: a point counts in a frame only where that
    /// frame sees it (not hidden behind nearer points). Without it every
    /// point projecting into the frame counts, the floor seen past a table
    /// top among them.
    pub visibility: Option<&'a Visibility>,
}

impl<'a> ScenePoints<'a> {
    pub fn new(points: &'a Points, visibility: Option<&'a Visibility>) -> Result<Self> {
        if let Some(v) = visibility {
            v.check_points(points)?;
        }
        Ok(ScenePoints { points, visibility })
    }
}

/// Points that project into the surface's own pixels in at least half the frames
/// that see them, and in at least two frames (or the only frame the surface has).
pub(crate) fn surface_points(
    surface: &ComponentFolder,
    scene: ScenePoints<'_>,
) -> Result<Vec<DVec3>> {
    let points = scene.points;
    let frames = &surface.frames.frames;
    let mut seen = vec![0u32; points.positions.len()];
    let mut on_surface = vec![0u32; points.positions.len()];
    for frame in frames {
        let mask = surface.load_mask(frame)?;
        let mut count = |i: usize, pixel: usize| {
            seen[i] += 1;
            on_surface[i] += u32::from(mask[pixel] == OWN);
        };
        match scene.visibility {
            Some(vis) => {
                let Some(visible) = vis.of_frame(&frame.name) else {
                    bail!(
                        "the visibility has no frame {:?}: it was computed for another capture",
                        frame.name
                    );
                };
                for s in visible {
                    count(s.point as usize, s.pixel as usize);
                }
            }
            None => {
                let camera = frame.camera();
                for (i, p) in points.positions.iter().enumerate() {
                    let world = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
                    let Some((u, v, _)) = camera.project(world) else {
                        continue;
                    };
                    if u < 0.0
                        || v < 0.0
                        || u >= frame.camera.width as f64
                        || v >= frame.camera.height as f64
                    {
                        continue;
                    }
                    // Pixel (i, j) covers [i, i+1) × [j, j+1) in the COLMAP convention.
                    count(i, v as usize * frame.camera.width as usize + u as usize);
                }
            }
        }
    }
    let needed = if frames.len() == 1 { 1 } else { 2 };
    Ok(points
        .positions
        .iter()
        .enumerate()
        .filter(|(i, _)| on_surface[*i] >= needed && 2 * on_surface[*i] >= seen[*i])
        .map(|(_, p)| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
        .collect())
}

fn judge(
    surface: &ComponentFolder,
    label: &str,
    points: Option<ScenePoints<'_>>,
    params: &SurfaceParams,
) -> Result<SurfaceOutcome> {
    let mut outcome = SurfaceOutcome {
        component: surface.name.clone(),
        label: label.to_string(),
        plane_inlier_fraction: None,
        plane_points: 0,
        accepted: true,
        reason: "label names a support surface; no points to test planarity".into(),
        frames_completed: 0,
        pixels_added: 0,
    };
    let Some(points) = points else {
        return Ok(outcome);
    };
    let selected = surface_points(surface, points)?;
    outcome.plane_points = selected.len();
    if selected.len() < MIN_PLANE_POINTS {
        outcome.reason = format!(
            "label names a support surface; only {} points on it (< {MIN_PLANE_POINTS}), planarity not tested",
            selected.len()
        );
        return Ok(outcome);
    }
    let fraction = fit_plane(&selected, params.planarity_tolerance, RANSAC_ITERATIONS)
        .map_or(0.0, |f| f.inlier_fraction);
    outcome.plane_inlier_fraction = Some(fraction);
    outcome.accepted = fraction >= MIN_INLIER_FRACTION;
    outcome.reason = if outcome.accepted {
        format!(
            "planar: {:.0}% of {} points within tolerance",
            fraction * 100.0,
            selected.len()
        )
    } else {
        format!(
            "not planar: only {:.0}% of {} points within tolerance (need {:.0}%)",
            fraction * 100.0,
            selected.len(),
            MIN_INLIER_FRACTION * 100.0
        )
    };
    Ok(outcome)
}

/// Completes every support surface among `items` (name, folder) and writes the
/// whole collection, completed or not, under `out` (one sub-folder per item).
/// When the report says `skipped`, nothing was written.
pub fn complete_surfaces(
    items: &[(String, PathBuf)],
    points: Option<ScenePoints<'_>>,
    params: &SurfaceParams,
    out: &Path,
) -> Result<CompletionReport> {
    let components = ComponentFolder::read_items(items)?;
    let mut surfaces = Vec::new();
    for c in &components {
        if c.info.kind != ComponentKind::Object {
            continue;
        }
        let label = c.info.label.clone().unwrap_or_default();
        if label_matches(&label, &params.labels) {
            surfaces.push(judge(c, &label, points, params)?);
        }
    }
    if !surfaces.iter().any(|s| s.accepted) {
        let why = if surfaces.is_empty() {
            format!(
                "no component is labelled as a support surface ({})",
                params.labels.join(", ")
            )
        } else {
            surfaces
                .iter()
                .map(|s| format!("{}: {}", s.component, s.reason))
                .collect::<Vec<_>>()
                .join("; ")
        };
        return Ok(CompletionReport {
            surfaces,
            skipped: Some(why),
        });
    }

    // Compute everything before writing, so a skip leaves `out` untouched.
    let mut completed: Vec<(usize, Vec<(Frame, FrameCompletion)>)> = Vec::new();
    for outcome in surfaces.iter_mut().filter(|s| s.accepted) {
        let index = components
            .iter()
            .position(|c| c.name == outcome.component)
            .context("surface vanished")?;
        let surface = &components[index];
        let mut frames_done = Vec::new();
        for frame in &surface.frames.frames {
            if let Some(done) = complete_one(surface, &components, frame, params)? {
                outcome.frames_completed += 1;
                outcome.pixels_added += done.pixels_added;
                frames_done.push((frame.clone(), done));
            }
        }
        if !frames_done.is_empty() {
            completed.push((index, frames_done));
        }
    }
    if completed.is_empty() {
        let names: Vec<&str> = surfaces
            .iter()
            .filter(|s| s.accepted)
            .map(|s| s.component.as_str())
            .collect();
        let why = format!(
            "no object occludes a hole in {} in any frame",
            names.join(", ")
        );
        return Ok(CompletionReport {
            surfaces,
            skipped: Some(why),
        });
    }

    for c in &components {
        objectsplat_core::files::share_tree(&c.dir, &out.join(&c.name))?;
    }
    for (index, frames_done) in &completed {
        let c = &components[*index];
        let dir = out.join(&c.name);
        for (frame, done) in frames_done {
            component::write_mask(&dir, frame, &done.mask)?;
            component::write_target(&dir, frame, &done.target)?;
        }
        let outcome = surfaces.iter().find(|s| s.component == c.name);
        let path = dir.join(COMPLETION_JSON);
        std::fs::write(&path, serde_json::to_string_pretty(&outcome)?)
            .with_context(|| format!("{}: cannot write", path.display()))?;
    }
    Ok(CompletionReport {
        surfaces,
        skipped: None,
    })
}

fn complete_one(
    surface: &ComponentFolder,
    components: &[ComponentFolder],
    frame: &Frame,
    params: &SurfaceParams,
) -> Result<Option<FrameCompletion>> {
    let (w, h) = (frame.camera.width as usize, frame.camera.height as usize);
    let support = surface.load_mask(frame)?;
    let mut occluded = vec![false; w * h];
    for other in components {
        if other.name == surface.name
            || other.info.kind != ComponentKind::Object
            || !other.has_frame(&frame.name)
        {
            continue;
        }
        for (o, &v) in occluded.iter_mut().zip(&other.load_mask(frame)?) {
            *o |= v == OWN;
        }
    }
    let image_path = surface.frames.image_path(frame);
    let rgb = read_rgb8_sized(&image_path, frame.camera.width, frame.camera.height)?;
    complete_frame(&support, &occluded, &rgb, w, h, params).with_context(|| {
        format!(
            "{}: completing frame {:?}",
            surface.dir.display(),
            frame.name
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn labels_match_whole_words_case_insensitively() {
        let labels = SurfaceParams::default().labels;
        assert!(label_matches("Coffee Table", &labels));
        assert!(label_matches("desk", &labels));
        assert!(!label_matches("tablet", &labels));
        assert!(!label_matches("chair", &labels));
    }
}
