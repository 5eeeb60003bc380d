//! nerfstudio / instant-ngp `transforms.json` as posed views.
//!
//! Intrinsics `fl_x, fl_y, cx, cy, w, h` at the top level or per frame (per frame wins;
//! `camera_angle_x` stands in for a missing `fl_x`; `w`/`h` default to the image's
//! size). Distortion must be zero: a distorted model is refused with the step that
//! fixes it. `transform_matrix` is camera-to-world with OpenGL axes; our
//! world-to-camera (OpenCV axes) is `inverse(c2w · diag(1, −1, −1, 1))`. Frames come
//! from `frames` and `test_frames` (ScanNet++), skipping `is_bad` ones. `mask_path`
//! becomes the view's validity mask. `applied_transform`/`applied_scale` describe how
//! the poses were made and are not applied again.

use crate::scene::SourceView;
use anyhow::{Context, Result, bail};
use glam::{DMat3, DMat4, DVec3, DVec4};
use objectsplat_core::Camera;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Where a frame's files are looked up (defaults: the JSON's folder).
#[derive(Debug, Clone, Default)]
pub struct Roots {
    pub images: Option<PathBuf>,
    pub masks: Option<PathBuf>,
}

#[derive(Debug, Clone)]
pub struct NerfstudioFrame {
    /// `file_path` as written in the JSON.
    pub file_path: String,
    pub image: PathBuf,
    pub mask: Option<PathBuf>,
    /// Camera-to-world, OpenGL axes, as stored.
    pub c2w_gl: DMat4,
    pub width: Option<u32>,
    pub height: Option<u32>,
    pub fx: f64,
    pub fy: f64,
    pub cx: Option<f64>,
    pub cy: Option<f64>,
}

#[derive(Debug, Clone)]
pub struct Transforms {
    pub path: PathBuf,
    pub frames: Vec<NerfstudioFrame>,
    /// Frames marked `is_bad`, skipped.
    pub skipped_bad: usize,
}

const DISTORTION_KEYS: [&str; 6] = ["k1", "k2", "k3", "k4", "p1", "p2"];

fn number(obj: &Value, frame: &Value, key: &str) -> Option<f64> {
    frame
        .get(key)
        .or_else(|| obj.get(key))
        .and_then(Value::as_f64)
}

pub fn read(path: &Path, roots: &Roots) -> Result<Transforms> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    let doc: Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let mut frames = Vec::new();
    let mut skipped_bad = 0;
    let lists = ["frames", "test_frames"].map(|k| doc.get(k).and_then(Value::as_array));
    if lists.iter().all(Option::is_none) {
        bail!("{}: has no \"frames\" list", path.display());
    }
    for (i, f) in lists.into_iter().flatten().flatten().enumerate() {
        let at = || format!("{}: frame {i}", path.display());
        if f.get("is_bad").and_then(Value::as_bool) == Some(true) {
            skipped_bad += 1;
            continue;
        }
        let file_path = f
            .get("file_path")
            .and_then(Value::as_str)
            .with_context(|| format!("{}: no file_path", at()))?;
        let model = f
            .get("camera_model")
            .or_else(|| doc.get("camera_model"))
            .and_then(Value::as_str)
            .unwrap_or("PINHOLE");
        for k in DISTORTION_KEYS {
            let v = number(&doc, f, k).unwrap_or(0.0);
            if v != 0.0 {
                bail!(
                    "{} ({file_path}): camera model {model} has distortion {k} = {v}; undistort the images first \
                     (for ScanNet++ use the toolkit's dslr/undistort.py and transforms_undistorted.json) and load the result",
                    at()
                );
            }
        }
        if !matches!(
            model,
            "PINHOLE" | "OPENCV" | "OPENCV_FISHEYE" | "SIMPLE_PINHOLE"
        ) {
            bail!("{} ({file_path}): unsupported camera model {model:?}", at());
        }
        let width = number(&doc, f, "w").map(|v| v as u32);
        let height = number(&doc, f, "h").map(|v| v as u32);
        let fx = match number(&doc, f, "fl_x") {
            Some(v) => v,
            None => {
                let angle = number(&doc, f, "camera_angle_x").with_context(|| {
                    format!("{}: neither fl_x nor camera_angle_x is given", at())
                })?;
                let w = width.with_context(|| format!("{}: camera_angle_x needs w", at()))? as f64;
                0.5 * w / (0.5 * angle).tan()
            }
        };
        let fy = number(&doc, f, "fl_y").unwrap_or(fx);
        let c2w_gl = matrix4(f.get("transform_matrix"))
            .with_context(|| format!("{}: transform_matrix", at()))?;
        // Written on Windows, a path may use `\`; it names the same file here.
        let image = roots
            .images
            .as_deref()
            .unwrap_or(base)
            .join(crate::scene::portable(file_path));
        let mask = f.get("mask_path").and_then(Value::as_str).map(|m| {
            roots
                .masks
                .as_deref()
                .unwrap_or(base)
                .join(crate::scene::portable(m))
        });
        frames.push(NerfstudioFrame {
            file_path: file_path.to_string(),
            image,
            mask,
            c2w_gl,
            width,
            height,
            fx,
            fy,
            cx: number(&doc, f, "cx"),
            cy: number(&doc, f, "cy"),
        });
    }
    Ok(Transforms {
        path: path.to_path_buf(),
        frames,
        skipped_bad,
    })
}

/// A 4×4 row-major JSON matrix (the last row may be omitted).
fn matrix4(v: Option<&Value>) -> Result<DMat4> {
    let rows = v
        .and_then(Value::as_array)
        .context("missing or not a list of rows")?;
    if rows.len() != 4 && rows.len() != 3 {
        bail!("has {} rows; expected 4 (or 3)", rows.len());
    }
    let mut m = [[0.0, 0.0, 0.0, 1.0]; 4];
    m[3] = [0.0, 0.0, 0.0, 1.0];
    for (r, row) in rows.iter().enumerate() {
        let row = row
            .as_array()
            .filter(|a| a.len() == 4)
            .with_context(|| format!("row {r} is not 4 numbers"))?;
        for (c, x) in row.iter().enumerate() {
            m[r][c] = x
                .as_f64()
                .filter(|x| x.is_finite())
                .with_context(|| format!("entry [{r}][{c}] is not a finite number"))?;
        }
    }
    if m[3] != [0.0, 0.0, 0.0, 1.0] {
        bail!("last row {:?} is not [0, 0, 0, 1]", m[3]);
    }
    Ok(DMat4::from_cols_array_2d(&m).transpose())
}

/// Nearest rotation to `m` (polar decomposition by Newton iteration); `None` when `m` is
/// not within 1e-3 of a proper rotation, which a pose should be up to printing precision.
pub fn nearest_rotation(m: DMat3) -> Option<DMat3> {
    let err = |r: DMat3| {
        (r.transpose() * r - DMat3::IDENTITY)
            .to_cols_array()
            .iter()
            .fold(0.0f64, |a, v| a.max(v.abs()))
    };
    let e = err(m);
    if e.is_nan() || e >= 1e-3 || m.determinant() <= 0.0 {
        return None;
    }
    let mut r = m;
    for _ in 0..8 {
        r = (r + r.inverse().transpose()) * 0.5;
    }
    Some(r)
}

/// OpenGL camera-to-world → OpenCV world-to-camera (rotation re-orthonormalised).
pub fn world_to_camera_cv(c2w_gl: DMat4) -> Result<DMat4> {
    let flip = DMat4::from_diagonal(DVec4::new(1.0, -1.0, -1.0, 1.0));
    let c2w = c2w_gl * flip;
    let rot = nearest_rotation(DMat3::from_mat4(c2w))
        .context("camera-to-world rotation is not a rotation (scaled, sheared or mirrored)")?;
    let centre: DVec3 = c2w.w_axis.truncate();
    let r_wc = rot.transpose();
    let t = -(r_wc * centre);
    Ok(DMat4::from_cols(
        r_wc.x_axis.extend(0.0),
        r_wc.y_axis.extend(0.0),
        r_wc.z_axis.extend(0.0),
        t.extend(1.0),
    ))
}

impl Transforms {
    /// Posed views; `world_change` maps each stored camera-to-world before the axis change
    /// (identity for plain nerfstudio data; the ScanNet++ frame change for its JSON).
    pub fn views(&self, world_change: DMat4) -> Result<Vec<SourceView>> {
        let mut out = Vec::with_capacity(self.frames.len());
        for f in &self.frames {
            let at = || format!("{} ({})", self.path.display(), f.file_path);
            let (width, height) = match (f.width, f.height) {
                (Some(w), Some(h)) => (w, h),
                _ => {
                    let (w, h) = image::image_dimensions(&f.image).with_context(|| {
                        format!("{}: no w/h given and the image cannot be read", at())
                    })?;
                    (w, h)
                }
            };
            let view = world_to_camera_cv(world_change * f.c2w_gl).with_context(at)?;
            let camera = Camera::from_view(
                width,
                height,
                f.fx,
                f.fy,
                f.cx.unwrap_or(width as f64 / 2.0),
                f.cy.unwrap_or(height as f64 / 2.0),
                view,
            );
            camera
                .validate()
                .map_err(|e| anyhow::anyhow!("{}: {e}", at()))?;
            out.push(SourceView {
                name: f.file_path.clone(),
                image: f.image.clone(),
                camera,
                valid_mask: f.mask.clone(),
            });
        }
        Ok(out)
    }
}
