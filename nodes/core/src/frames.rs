//! The Frames artifact: posed images of one capture.
//!
//! Encoding (a folder): `frames.json`, a JSON list of
//! `{name, image, width, height, fx, fy, cx, cy, world_to_camera, split}` where
//! `image` is a path relative to the folder, `world_to_camera` is 4×4 row-major
//! (OpenCV axes) and `split` is `"train"` or `"test"`; the images sit beside it.

use crate::artifact::FRAMES_JSON;
use crate::{Camera, Image};
use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Split {
    Train,
    Test,
}

/// How a scene source assigns frames to train and test.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SplitPolicy {
    /// The paper's protocol: train on 1 of every 8 frames, spread evenly; test on the other 7.
    Sparse,
    /// Train on 7 of every 8, test on the 8th.
    Dense,
    /// Every frame is a training frame (and none is held out).
    All,
}

impl SplitPolicy {
    /// Split of `n` frames in capture order. Sparse trains on frames 4, 12, 20, … (the
    /// middle of each block of 8, so training views are spread evenly); dense tests
    /// on those same frames and trains on the rest.
    pub fn assign(self, n: usize) -> Vec<Split> {
        (0..n)
            .map(|i| {
                let marked = if n < 8 { i == n / 2 } else { i % 8 == 4 };
                match (self, marked) {
                    (SplitPolicy::All, _) => Split::Train,
                    (SplitPolicy::Sparse, true) | (SplitPolicy::Dense, false) => Split::Train,
                    _ => Split::Test,
                }
            })
            .collect()
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Frame {
    pub name: String,
    pub image: String,
    /// Written as the entry's own `width` … `world_to_camera` fields.
    #[serde(flatten)]
    pub camera: Camera,
    pub split: Split,
}

impl Frame {
    pub fn new(
        name: impl Into<String>,
        image: impl Into<String>,
        camera: &Camera,
        split: Split,
    ) -> Frame {
        Frame {
            name: name.into(),
            image: image.into(),
            camera: *camera,
            split,
        }
    }

    pub fn camera(&self) -> Camera {
        self.camera
    }
}

/// A loaded `frames.json` and the folder it came from.
#[derive(Debug, Clone)]
pub struct Frames {
    pub root: PathBuf,
    pub frames: Vec<Frame>,
}

impl Frames {
    pub fn read(dir: &Path) -> Result<Frames> {
        let path = dir.join(FRAMES_JSON);
        let frames: Vec<Frame> = crate::files::read_json(&path, "frames list")?;
        let mut seen = std::collections::HashSet::new();
        for f in &frames {
            if !seen.insert(&f.name) {
                bail!("{}: frame name {:?} appears twice", path.display(), f.name);
            }
            f.camera()
                .validate()
                .map_err(|e| anyhow::anyhow!("{}: frame {:?}: {e}", path.display(), f.name))?;
            check_relative(&f.image)
                .with_context(|| format!("{}: frame {:?}", path.display(), f.name))?;
        }
        Ok(Frames {
            root: dir.to_path_buf(),
            frames,
        })
    }

    /// Writes `frames.json` into `dir` (the images must be written there by the caller).
    pub fn write_json(dir: &Path, frames: &[Frame]) -> Result<()> {
        let path = dir.join(FRAMES_JSON);
        let text = serde_json::to_string_pretty(frames)?;
        std::fs::write(&path, text).with_context(|| format!("{}: cannot write", path.display()))
    }

    /// The image file of a frame; a `\` in a hand-written `image` is a separator, as
    /// the check in [`Frames::read`] treats it.
    pub fn image_path(&self, frame: &Frame) -> PathBuf {
        self.root.join(frame.image.replace('\\', "/"))
    }

    /// Loads a frame's image as RGB and checks it matches the declared size.
    pub fn load_rgb(&self, frame: &Frame) -> Result<Image> {
        let path = self.image_path(frame);
        let img = Image::load(&path)?.to_rgb();
        if img.width != frame.camera.width || img.height != frame.camera.height {
            bail!(
                "{}: image is {}×{} but frames.json says {}×{}",
                path.display(),
                img.width,
                img.height,
                frame.camera.width,
                frame.camera.height
            );
        }
        Ok(img)
    }

    pub fn by_split(&self, split: Split) -> impl Iterator<Item = &Frame> {
        self.frames.iter().filter(move |f| f.split == split)
    }
}

/// Refuses absolute paths and paths that climb out of their folder, on every
/// platform's separators (the engine's one check, `objectsplat_paths`).
pub fn check_relative(path: &str) -> Result<()> {
    objectsplat_paths::normalise_relative(path)
        .map(drop)
        .map_err(|e| anyhow::anyhow!("path {e}: it must be relative and stay inside its folder"))
}

/// The file stem used to name per-frame files (masks, renders) after a frame: the
/// last component of the name (split at `/` or `\`, whoever wrote it) without its
/// extension, so per-frame files always land in the folder they are written to.
pub fn frame_stem(name: &str) -> &str {
    let last = name.rsplit(['/', '\\']).next().unwrap_or(name);
    match last.rfind('.') {
        Some(dot) if dot > 0 && last != ".." => &last[..dot],
        _ => last,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sparse_and_dense_are_complements() {
        for n in [1, 5, 8, 24, 30] {
            let s = SplitPolicy::Sparse.assign(n);
            let d = SplitPolicy::Dense.assign(n);
            assert!(s.iter().zip(&d).all(|(a, b)| a != b), "n={n}");
            let train = s.iter().filter(|x| **x == Split::Train).count();
            let expected = if n < 8 {
                1
            } else {
                (0..n).filter(|i| i % 8 == 4).count()
            };
            assert_eq!(train, expected, "n={n}");
        }
    }

    #[test]
    fn frame_stems_are_last_components_on_every_separator() {
        assert_eq!(frame_stem("images/frame_001.png"), "frame_001");
        assert_eq!(frame_stem(r"images\frame_001.png"), "frame_001");
        assert_eq!(frame_stem(r"a/..\..\x.png"), "x");
        assert_eq!(frame_stem("r_0"), "r_0");
        assert_eq!(frame_stem(".hidden"), ".hidden");
        assert_eq!(frame_stem("a.b.jpg"), "a.b");
        assert!(check_relative(r"..\x.png").is_err());
        assert!(check_relative(r"images\x.png").is_ok());
    }

    #[test]
    fn frames_roundtrip() {
        let dir = tempfile::tempdir().unwrap();
        let cam = Camera::look_at(
            8,
            6,
            10.0,
            10.0,
            glam::DVec3::new(0.0, -3.0, 1.0),
            glam::DVec3::ZERO,
            glam::DVec3::Z,
        );
        let frames = vec![Frame::new("f0", "images/f0.png", &cam, Split::Train)];
        Frames::write_json(dir.path(), &frames).unwrap();
        let back = Frames::read(dir.path()).unwrap();
        assert_eq!(back.frames, frames);
    }
}
