//! nerfstudio / instant-ngp `transforms.json` as posed views.
//!
//! Intrinsics `fl_x, fl_y, cx, cy, w, h` at the top level or per frame (per frame wins;
//! `camera_angle_x` stands in for a missing `fl_x`; `w`/`h` default to the image's
//! size). Lens distortion: `camera_model` `OPENCV` (or none: nerfstudio's perspective
//! default) takes `k1, k2, k3, p1, p2`; `OPENCV_FISHEYE` takes `k1..k4`; `PINHOLE` /
//! `SIMPLE_PINHOLE` must have none. Distorted images are undistorted when the frames are
//! written (see `undistort`). `transform_matrix` is camera-to-world with OpenGL axes;
//! our world-to-camera (OpenCV axes) is `inverse(c2w · diag(1, −1, −1, 1))`.
//!
//! Frames come from `frames` and `test_frames` (ScanNet++), skipping `is_bad` ones.
//! The JSON's own split, when it gives one, is kept with each view: `test_frames` are
//! test frames and `frames` then training frames (ScanNet++); otherwise nerfstudio's
//! `train_filenames` / `test_filenames` (or `val_filenames` without a test list), matched
//! against `file_path`. `file_path`s are relative to the JSON's folder unless a root is
//! given ([`Roots`]); so are `mask_path`s (ignored when `has_mask` is false), which
//! become the views' validity masks. `applied_transform`/`applied_scale` describe how
//! the poses were made and are not applied again.

use crate::scene::SourceView;
use crate::undistort::{self, Distortion, Intrinsics};
use anyhow::{Context, Result, bail};
use glam::{DMat3, DMat4, DVec3, DVec4};
use objectsplat_core::{Camera, Split};
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
    /// Lens distortion (`None` when every coefficient is zero).
    pub distortion: Option<Distortion>,
    /// The JSON's own split for this frame, if it gives one.
    pub listed: Option<Split>,
}

#[derive(Debug, Clone)]
pub struct Transforms {
    pub path: PathBuf,
    pub frames: Vec<NerfstudioFrame>,
    /// Frames marked `is_bad`, skipped.
    pub skipped_bad: usize,
    /// Which fields of the JSON give its split (`None`: it gives none).
    pub lists: Option<&'static str>,
}

const DISTORTION_KEYS: [&str; 6] = ["k1", "k2", "k3", "k4", "p1", "p2"];

/// The lens model of a frame from `camera_model` and the distortion keys.
fn distortion(model: &str, coeff: impl Fn(&str) -> f64) -> Result<Option<Distortion>, String> {
    let nonzero = |keys: &[&'static str]| keys.iter().copied().find(|k| coeff(k) != 0.0);
    let d = match model {
        "PINHOLE" | "SIMPLE_PINHOLE" => {
            if let Some(k) = nonzero(&DISTORTION_KEYS) {
                return Err(format!(
                    "camera model {model} has distortion {k} = {}; a pinhole camera has none \
                     (say which lens the coefficients belong to with camera_model OPENCV or OPENCV_FISHEYE)",
                    coeff(k)
                ));
            }
            return Ok(None);
        }
        "OPENCV" => {
            if let Some(k) = nonzero(&["k4"]) {
                return Err(format!(
                    "camera model OPENCV has k4 = {}, which its radial–tangential model (k1, k2, k3, p1, p2) does not use",
                    coeff(k)
                ));
            }
            Distortion::Brown {
                k: [coeff("k1"), coeff("k2"), coeff("k3"), 0.0, 0.0, 0.0],
                p: [coeff("p1"), coeff("p2")],
            }
        }
        "OPENCV_FISHEYE" => {
            if let Some(k) = nonzero(&["p1", "p2"]) {
                return Err(format!(
                    "camera model OPENCV_FISHEYE has {k} = {}, which its fisheye model (k1..k4) does not use",
                    coeff(k)
                ));
            }
            Distortion::Fisheye {
                k: [coeff("k1"), coeff("k2"), coeff("k3"), coeff("k4")],
            }
        }
        other => {
            return Err(format!(
                "unsupported camera model {other:?} (expected PINHOLE, SIMPLE_PINHOLE, OPENCV or OPENCV_FISHEYE)"
            ));
        }
    };
    Ok((!d.is_identity()).then_some(d))
}

/// `file_path` without a leading `./`, for matching against nerfstudio's filename lists.
fn normalised(path: &str) -> &str {
    path.trim_start_matches("./")
}

/// The JSON's own split per frame index: `frames` / `test_frames` (ScanNet++) or
/// nerfstudio's `*_filenames` lists.
struct Lists {
    by_name: Option<(Vec<String>, Vec<String>)>,
    has_test_frames: bool,
}

impl Lists {
    fn read(doc: &Value, path: &Path) -> Result<Lists> {
        let names = |key: &str| -> Result<Option<Vec<String>>> {
            let Some(v) = doc.get(key) else {
                return Ok(None);
            };
            let list = v
                .as_array()
                .with_context(|| format!("{}: {key} is not a list", path.display()))?;
            list.iter()
                .enumerate()
                .map(|(i, n)| {
                    n.as_str()
                        .map(|n| normalised(n).to_string())
                        .with_context(|| format!("{}: {key}[{i}] is not a string", path.display()))
                })
                .collect::<Result<Vec<_>>>()
                .map(Some)
        };
        let train = names("train_filenames")?;
        let test = match names("test_filenames")? {
            Some(t) => Some(t),
            None => names("val_filenames")?,
        };
        let by_name = match (train, test) {
            (None, None) => None,
            (train, test) => Some((train.unwrap_or_default(), test.unwrap_or_default())),
        };
        Ok(Lists {
            by_name,
            has_test_frames: doc.get("test_frames").is_some(),
        })
    }

    fn source(&self) -> Option<&'static str> {
        if self.has_test_frames {
            Some("frames / test_frames")
        } else if self.by_name.is_some() {
            Some("train_filenames / test_filenames (or val_filenames)")
        } else {
            None
        }
    }

    fn split(&self, in_test_frames: bool, file_path: &str) -> Option<Split> {
        if self.has_test_frames {
            return Some(if in_test_frames {
                Split::Test
            } else {
                Split::Train
            });
        }
        let (train, test) = self.by_name.as_ref()?;
        let name = normalised(file_path);
        if test.iter().any(|n| n == name) {
            Some(Split::Test)
        } else if train.iter().any(|n| n == name) {
            Some(Split::Train)
        } else {
            None
        }
    }
}

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
    let own_split = Lists::read(&doc, path)?;
    // `has_mask: false` (ScanNet++) says the mask_paths are not to be used.
    let use_masks = doc.get("has_mask").and_then(Value::as_bool) != Some(false);
    let [train_list, test_list] = lists;
    let tagged = train_list
        .into_iter()
        .flatten()
        .map(|f| (f, false))
        .chain(test_list.into_iter().flatten().map(|f| (f, true)));
    for (i, (f, in_test_frames)) in tagged.enumerate() {
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
            .unwrap_or("OPENCV");
        let distortion = distortion(model, |k| number(&doc, f, k).unwrap_or(0.0))
            .map_err(|e| anyhow::anyhow!("{} ({file_path}): {e}", at()))?;
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
        let mask = f
            .get("mask_path")
            .and_then(Value::as_str)
            .filter(|_| use_masks)
            .map(|m| {
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
            distortion,
            listed: own_split.split(in_test_frames, file_path),
        });
    }
    Ok(Transforms {
        path: path.to_path_buf(),
        frames,
        skipped_bad,
        lists: own_split.source(),
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
        let mut checked: Vec<(Intrinsics, Distortion)> = Vec::new();
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
            if let Some(d) = &f.distortion {
                let lens = Intrinsics {
                    width,
                    height,
                    fx: camera.fx,
                    fy: camera.fy,
                    cx: camera.cx,
                    cy: camera.cy,
                };
                // Frames usually share one camera: check each distinct one once.
                if checked.last() != Some(&(lens, *d)) {
                    undistort::undistorted_camera(&lens, d).with_context(at)?;
                    checked.push((lens, *d));
                }
            }
            out.push(SourceView {
                name: f.file_path.clone(),
                image: f.image.clone(),
                camera,
                valid_mask: f.mask.clone(),
                distortion: f.distortion,
                listed: f.listed,
            });
        }
        Ok(out)
    }
}

impl Transforms {
    /// Checks that every frame's image (and mask) exists, naming the JSON, the frame and
    /// the field, and the param that says where the files are, when one does not.
    pub fn check_files(&self) -> Result<()> {
        for (i, f) in self.frames.iter().enumerate() {
            if !f.image.is_file() {
                bail!(
                    "{}: frame {i}: file_path {:?} → {} does not exist; set `images` to the folder the \
                     file_paths are relative to (ScanNet++: dslr/resized_images for transforms.json, \
                     dslr/resized_undistorted_images for transforms_undistorted.json)",
                    self.path.display(),
                    f.file_path,
                    f.image.display()
                );
            }
            if let Some(mask) = &f.mask
                && !mask.is_file()
            {
                bail!(
                    "{}: frame {i} ({}): mask_path → {} does not exist; set `masks` to the folder the \
                     mask_paths are relative to (ScanNet++: dslr/resized_anon_masks or \
                     dslr/resized_undistorted_masks), or `use_masks: false` to load none",
                    self.path.display(),
                    f.file_path,
                    mask.display()
                );
            }
        }
        Ok(())
    }
}
