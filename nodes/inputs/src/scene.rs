//! Writing what every scene source produces: a Frames artifact (images + frames.json,
//! split and downscaled) and a Points artifact.
//!
//! Resolution: `resolution: n` (integer ≥ 1) divides both sides by `n`, rounding to the
//! nearest pixel (as 3DGS does); `max_width: Some(w)` then caps the width at `w` pixels,
//! keeping the aspect ratio. Intrinsics follow the pixel grid (`Camera::scaled`).
//!
//! Frames are sorted by name before the split is assigned (as COLMAP/3DGS order them);
//! frames the source itself lists as test frames stay test frames under a rule, and
//! `split: "lists"` follows the source's lists alone ([`SplitChoice`]).
//!
//! Distorted views are undistorted first, at full resolution, to the pinhole camera
//! COLMAP's undistorter would choose (see `undistort`); downscaling follows.
//!
//! A source's validity mask (nerfstudio `mask_path`, non-zero = use the pixel) is
//! written beside the image as `valid/<stem>.png` (8-bit, 255 = use, 0 = ignore); an
//! undistorted view gets one too when some of its pixels fall outside the distorted
//! image. After undistortion and downscaling a pixel is valid only when every source
//! pixel under it was.

use crate::undistort::{self, Distortion, Intrinsics, UndistortMap};
use anyhow::{Context, Result, bail};
use objectsplat_core::frames::frame_stem;
use objectsplat_core::{Camera, Frame, Frames, Image, Points, Split, SplitPolicy};
use std::path::{Path, PathBuf};

pub const VALID_DIR: &str = "valid";

/// A relative path as written in a dataset, with `\` read as the separator it is on
/// Windows (where it cannot be part of a name). Where it may lead is checked where it
/// becomes an output file name ([`write_frames`]).
pub fn portable(path: &str) -> String {
    path.replace('\\', "/")
}

/// Output size policy shared by the scene sources.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Resolution {
    pub factor: u32,
    pub max_width: Option<u32>,
}

impl Resolution {
    pub const FULL: Resolution = Resolution {
        factor: 1,
        max_width: None,
    };

    pub fn new(factor: i64, max_width: Option<i64>) -> Result<Resolution> {
        let factor = u32::try_from(factor).ok().filter(|&f| f >= 1).with_context(|| {
            format!("resolution {factor} must be a whole downscale factor ≥ 1 (use max_width for a pixel width)")
        })?;
        let max_width = match max_width {
            None => None,
            Some(w) => Some(
                u32::try_from(w)
                    .ok()
                    .filter(|&w| w >= 1)
                    .with_context(|| format!("max_width {w} must be ≥ 1"))?,
            ),
        };
        Ok(Resolution { factor, max_width })
    }

    /// The output size for an input of `width`×`height`.
    pub fn target(&self, width: u32, height: u32) -> (u32, u32) {
        let f = self.factor as f64;
        let mut w = ((width as f64 / f).round() as u32).max(1);
        let mut h = ((height as f64 / f).round() as u32).max(1);
        if let Some(max) = self.max_width
            && w > max
        {
            h = ((h as f64 * max as f64 / w as f64).round() as u32).max(1);
            w = max;
        }
        (w, h)
    }
}

/// One posed input image, before splitting and downscaling.
#[derive(Debug, Clone)]
pub struct SourceView {
    /// Frame name (unique; may contain `/`).
    pub name: String,
    pub image: PathBuf,
    /// The camera at the image file's full resolution (its pinhole part when the lens
    /// is distorted).
    pub camera: Camera,
    pub valid_mask: Option<PathBuf>,
    /// The lens distortion of the image file; `write_frames` undistorts the image.
    pub distortion: Option<Distortion>,
    /// The split the source itself gives this view (ScanNet++ `test_frames`, a
    /// `train_test_lists.json`, nerfstudio `*_filenames`), if any.
    pub listed: Option<Split>,
}

/// How frames are assigned to train and test.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SplitChoice {
    /// A rule over the frames sorted by name. Frames the source lists as test frames
    /// stay test frames under `sparse` and `dense` (the rule splits the others); `all`
    /// trains on every frame.
    Rule(SplitPolicy),
    /// The source's own lists: every view must be listed. The text names where the
    /// lists come from, for errors.
    Lists(String),
}

/// Assigns a split to each view (same order).
pub fn assign_splits(views: &[SourceView], choice: &SplitChoice) -> Result<Vec<Split>> {
    match choice {
        SplitChoice::Rule(SplitPolicy::All) => Ok(vec![Split::Train; views.len()]),
        SplitChoice::Rule(policy) => {
            let free: Vec<usize> = (0..views.len())
                .filter(|&i| views[i].listed != Some(Split::Test))
                .collect();
            let mut splits = vec![Split::Test; views.len()];
            for (&i, s) in free.iter().zip(policy.assign(free.len())) {
                splits[i] = s;
            }
            Ok(splits)
        }
        SplitChoice::Lists(source) => views
            .iter()
            .map(|v| {
                v.listed.with_context(|| {
                    format!(
                        "{source}: frame {:?} is in neither the train nor the test list (split \"lists\" needs every frame listed)",
                        v.name
                    )
                })
            })
            .collect(),
    }
}

/// What `write_frames` wrote.
#[derive(Debug, Clone)]
pub struct WrittenFrames {
    pub frames: Vec<Frame>,
    /// Every distinct distorted camera and the pinhole camera it was undistorted to.
    pub undistorted_cameras: Vec<(Intrinsics, Intrinsics)>,
    /// Frames whose image was undistorted.
    pub undistorted_frames: usize,
}

/// The undistortion of one distorted camera, shared by the frames that use it.
struct Undistortion {
    source: Intrinsics,
    distortion: Distortion,
    map: UndistortMap,
}

/// Writes the Frames artifact into `out`, decoding, undistorting, scaling and
/// encoding the images on up to `threads` threads.
pub fn write_frames(
    out: &Path,
    mut views: Vec<SourceView>,
    split: &SplitChoice,
    res: Resolution,
    threads: usize,
) -> Result<WrittenFrames> {
    if views.is_empty() {
        bail!("the scene has no images");
    }
    // Names become file names below: one check, on every platform's separators.
    for view in &mut views {
        view.name = objectsplat_runtime::paths::normalise_relative(&view.name).map_err(|e| {
            anyhow::anyhow!("frame name {e}: it must be relative and stay inside its folder")
        })?;
    }
    views.sort_by(|a, b| a.name.cmp(&b.name));
    if let Some(w) = views.windows(2).find(|w| w[0].name == w[1].name) {
        bail!("two images are both named {:?}", w[0].name);
    }
    let splits = assign_splits(&views, split)?;
    let mut stems = std::collections::HashSet::new();
    // Every distinct distorted camera's undistortion, from the cameras alone.
    let mut undistortions: Vec<Undistortion> = Vec::new();
    for view in &views {
        view.camera
            .validate()
            .map_err(|e| anyhow::anyhow!("frame {:?}: {e}", view.name))?;
        // Per-frame files downstream are named by stem; two frames sharing one would collide.
        let stem = frame_stem(&view.name).to_string();
        if !stems.insert(stem.clone()) {
            bail!(
                "frames {:?} and another share the file stem {stem:?}; per-frame files would collide",
                view.name
            );
        }
        if let Some(distortion) = &view.distortion {
            let source = intrinsics(&view.camera);
            if !undistortions
                .iter()
                .any(|u| u.source == source && u.distortion == *distortion)
            {
                let target = undistort::undistorted_camera(&source, distortion)
                    .with_context(|| format!("frame {:?}", view.name))?;
                undistortions.push(Undistortion {
                    source,
                    distortion: *distortion,
                    map: UndistortMap::new(source, distortion, target),
                });
            }
        }
    }
    std::fs::create_dir_all(out.join("images"))
        .with_context(|| format!("{}: cannot create", out.display()))?;
    let jobs: Vec<(&SourceView, Split)> = views.iter().zip(splits).collect();
    let threads = threads.clamp(1, jobs.len());
    let per = jobs.len().div_ceil(threads);
    let mut written: Vec<Option<Result<Frame>>> = (0..jobs.len()).map(|_| None).collect();
    std::thread::scope(|scope| {
        for (chunk, slots) in jobs.chunks(per).zip(written.chunks_mut(per)) {
            let undistortions = &undistortions;
            scope.spawn(move || {
                for (&(view, split), slot) in chunk.iter().zip(slots) {
                    *slot = Some(write_frame(out, view, split, res, undistortions));
                }
            });
        }
    });
    let frames = written
        .into_iter()
        .map(|f| f.unwrap_or_else(|| bail!("a frame was not written")))
        .collect::<Result<Vec<Frame>>>()?;
    Frames::write_json(out, &frames)?;
    Ok(WrittenFrames {
        undistorted_frames: views.iter().filter(|v| v.distortion.is_some()).count(),
        frames,
        undistorted_cameras: undistortions
            .iter()
            .map(|u| (u.source, u.map.target))
            .collect(),
    })
}

/// One view's image (and validity mask) decoded, undistorted, scaled and written.
fn write_frame(
    out: &Path,
    view: &SourceView,
    split: Split,
    res: Resolution,
    undistortions: &[Undistortion],
) -> Result<Frame> {
    let stem = frame_stem(&view.name).to_string();
    let img = Image::load(&view.image)?.to_rgb();
    let full = &view.camera;
    if (img.width, img.height) != (full.width, full.height) {
        bail!(
            "{}: image is {}×{} but its camera says {}×{}",
            view.image.display(),
            img.width,
            img.height,
            full.width,
            full.height
        );
    }
    let valid = match &view.valid_mask {
        Some(mask) => Some(load_valid_mask(mask, (full.width, full.height))?),
        None => None,
    };
    let (img, cam, valid) = match &view.distortion {
        None => (img, *full, valid),
        Some(distortion) => {
            let source = intrinsics(full);
            let Some(u) = undistortions
                .iter()
                .find(|u| u.source == source && u.distortion == *distortion)
            else {
                bail!(
                    "frame {:?}: its camera's undistortion was not prepared",
                    view.name
                );
            };
            let at = || format!("{}", view.image.display());
            let undistorted = u.map.apply(&img).with_context(at)?;
            let coverage = u.map.coverage(valid.as_ref()).with_context(at)?;
            // Output pixels the distorted image does not cover become invalid pixels.
            let blank = coverage.data.contains(&0.0);
            let t = u.map.target;
            let cam = Camera {
                width: t.width,
                height: t.height,
                fx: t.fx,
                fy: t.fy,
                cx: t.cx,
                cy: t.cy,
                world_to_camera: full.world_to_camera,
            };
            (
                undistorted,
                cam,
                (valid.is_some() || blank).then_some(coverage),
            )
        }
    };
    let (w, h) = res.target(img.width, img.height);
    let scaled = if (w, h) == (img.width, img.height) {
        img
    } else {
        img.resize_area(w, h)
    };
    let rel = format!("images/{stem}.png");
    scaled.save_png8(&out.join(&rel))?;
    if let Some(valid) = valid {
        write_valid_mask(
            &valid,
            &out.join(VALID_DIR).join(format!("{stem}.png")),
            (w, h),
        )?;
    }
    Ok(Frame::new(view.name.clone(), rel, &cam.scaled(w, h), split))
}

fn intrinsics(c: &Camera) -> Intrinsics {
    Intrinsics {
        width: c.width,
        height: c.height,
        fx: c.fx,
        fy: c.fy,
        cx: c.cx,
        cy: c.cy,
    }
}

/// A validity mask at its image's size as 1 (use) / 0 (ignore).
fn load_valid_mask(src: &Path, full: (u32, u32)) -> Result<Image> {
    let m = Image::load(src)?;
    if (m.width, m.height) != full {
        bail!(
            "{}: mask is {}×{} but its image is {}×{}",
            src.display(),
            m.width,
            m.height,
            full.0,
            full.1
        );
    }
    Ok(Image::from_fn(m.width, m.height, 1, |x, y, _| {
        if m.get(x, y, 0) > 0.0 { 1.0 } else { 0.0 }
    }))
}

/// Writes a 0/1 validity mask at `target` size: valid only when every pixel under it was.
fn write_valid_mask(binary: &Image, dst: &Path, target: (u32, u32)) -> Result<()> {
    let scaled = if target == (binary.width, binary.height) {
        binary.clone()
    } else {
        binary.resize_area(target.0, target.1)
    };
    let out = Image::from_fn(target.0, target.1, 1, |x, y, _| {
        if scaled.get(x, y, 0) >= 1.0 - 1e-6 {
            1.0
        } else {
            0.0
        }
    });
    if let Some(parent) = dst.parent() {
        std::fs::create_dir_all(parent)
            .with_context(|| format!("{}: cannot create", parent.display()))?;
    }
    out.save_png8(dst)
}

/// Writes the Points artifact (`points.ply`) into `out`.
pub fn write_points(out: &Path, points: &Points) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("{}: cannot create", out.display()))?;
    points.write_ply(&out.join(objectsplat_core::artifact::POINTS_PLY))
}
