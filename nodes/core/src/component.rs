//! The Component artifact: what one component (an object or the background) is trained on.
//!
//! Encoding (a folder, one item of a `[Component]` collection, named `obj_<id>_<label>`
//! or `background`):
//! - `component.json`: `{"name", "kind": "object" | "background", "object_id", "label"}`
//!   (`object_id`/`label` are null for the background);
//! - `frames.json` + `images/`: the frames it appears in (the Frames encoding);
//! - `masks/<frame stem>.png`: 8-bit grey per frame: [`OWN`] = a pixel this component
//!   owns; [`OTHER`] = owned by another component (an object supervises it toward the
//!   random background colour, the background gives it zero weight); [`IGNORE`] =
//!   never supervised (invalid pixels);
//! - `targets/<frame stem>.png` (optional): replacement target colours, used for owned
//!   pixels instead of the frame image (set by surface completion for filled pixels);
//! - `completion.json` (optional): what surface completion did to a support surface.

use crate::artifact::{
    COMPONENT_COMPLETION_JSON, COMPONENT_JSON, COMPONENT_MASKS_DIR, COMPONENT_TARGETS_DIR,
};
use crate::frames::{Frame, Frames, frame_stem};
use crate::image::{read_gray8, read_rgb8_sized, write_gray8, write_rgb8};
use crate::label_runs::LabelRuns;
use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

pub const OWN: u8 = 255;
pub const OTHER: u8 = 0;
pub const IGNORE: u8 = 128;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ComponentKind {
    Object,
    Background,
}

#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ComponentInfo {
    pub name: String,
    pub kind: ComponentKind,
    pub object_id: Option<u16>,
    pub label: Option<String>,
}

impl ComponentInfo {
    pub fn object(id: u16, label: &str) -> ComponentInfo {
        ComponentInfo {
            name: object_item_name(id, label),
            kind: ComponentKind::Object,
            object_id: Some(id),
            label: Some(label.to_string()),
        }
    }

    pub fn background() -> ComponentInfo {
        ComponentInfo {
            name: "background".into(),
            kind: ComponentKind::Background,
            object_id: None,
            label: None,
        }
    }

    /// Reads `component.json` from a Component folder.
    pub fn read(dir: &Path) -> Result<ComponentInfo> {
        crate::files::read_json(&dir.join(COMPONENT_JSON), "component description")
    }

    /// Writes `component.json` into a Component folder.
    pub fn write(&self, dir: &Path) -> Result<()> {
        let path = dir.join(COMPONENT_JSON);
        std::fs::write(&path, serde_json::to_string_pretty(self)?)
            .with_context(|| format!("{}: cannot write", path.display()))
    }
}

/// A Component folder as its one reader sees it: its description and frames,
/// read once; masks, images and replacement targets read per frame on demand.
#[derive(Debug, Clone)]
pub struct ComponentFolder {
    /// Its item's name in a `[Component]` collection (the component's name).
    pub name: String,
    pub dir: PathBuf,
    pub info: ComponentInfo,
    pub frames: Frames,
}

impl ComponentFolder {
    pub fn read(dir: &Path) -> Result<ComponentFolder> {
        let info = ComponentInfo::read(dir)?;
        Ok(ComponentFolder {
            name: info.name.clone(),
            dir: dir.to_path_buf(),
            info,
            frames: Frames::read(dir)?,
        })
    }

    /// A folder read as item `name` of a collection.
    pub fn read_item(name: &str, dir: &Path) -> Result<ComponentFolder> {
        Ok(ComponentFolder {
            name: name.to_string(),
            ..Self::read(dir)?
        })
    }

    /// Every item of a collection, in its order.
    pub fn read_items(items: &[(String, PathBuf)]) -> Result<Vec<ComponentFolder>> {
        items
            .iter()
            .map(|(name, dir)| Self::read_item(name, dir))
            .collect()
    }

    /// Whether surface completion completed this component as a support surface.
    pub fn is_completed_surface(&self) -> bool {
        self.dir.join(COMPONENT_COMPLETION_JSON).is_file()
    }

    pub fn has_frame(&self, name: &str) -> bool {
        self.frames.frames.iter().any(|f| f.name == name)
    }

    /// The component's OWN/OTHER/IGNORE mask in `frame`, checked against the frame size.
    pub fn load_mask(&self, frame: &Frame) -> Result<Vec<u8>> {
        read_mask(&self.dir, frame)
    }

    /// [`ComponentFolder::load_mask`] as runs.
    pub fn load_labels(&self, frame: &Frame) -> Result<LabelRuns> {
        let mask = self.load_mask(frame)?;
        LabelRuns::from_plane(frame.camera.width, frame.camera.height, &mask)
            .with_context(|| mask_path(&self.dir, frame).display().to_string())
    }

    /// The replacement target colours of `frame` (8-bit RGB), if completion wrote any.
    pub fn load_replacement_target(&self, frame: &Frame) -> Result<Option<Vec<u8>>> {
        let path = target_path(&self.dir, frame);
        if !path.exists() {
            return Ok(None);
        }
        read_rgb8_sized(&path, frame.camera.width, frame.camera.height).map(Some)
    }
}

/// Where a Component folder keeps its ownership mask for `frame`.
pub fn mask_path(dir: &Path, frame: &Frame) -> PathBuf {
    dir.join(COMPONENT_MASKS_DIR)
        .join(format!("{}.png", frame_stem(&frame.name)))
}

/// Where a Component folder keeps its completed target colours for `frame`, if any.
pub fn target_path(dir: &Path, frame: &Frame) -> PathBuf {
    dir.join(COMPONENT_TARGETS_DIR)
        .join(format!("{}.png", frame_stem(&frame.name)))
}

/// The [`OWN`]/[`OTHER`]/[`IGNORE`] mask of `frame`, checked against the frame's size.
pub fn read_mask(dir: &Path, frame: &Frame) -> Result<Vec<u8>> {
    read_gray8(
        &mask_path(dir, frame),
        frame.camera.width,
        frame.camera.height,
    )
}

/// Writes the mask of `frame` (creating `masks/`), replacing any file already there.
pub fn write_mask(dir: &Path, frame: &Frame, mask: &[u8]) -> Result<()> {
    let path = mask_path(dir, frame);
    create_parent(&path)?;
    write_gray8(&path, mask, frame.camera.width, frame.camera.height)
}

/// Writes the completed target colours (8-bit RGB) of `frame` (creating `targets/`),
/// replacing any file already there.
pub fn write_target(dir: &Path, frame: &Frame, rgb: &[u8]) -> Result<()> {
    let path = target_path(dir, frame);
    create_parent(&path)?;
    write_rgb8(&path, rgb, frame.camera.width, frame.camera.height)
}

fn create_parent(path: &Path) -> Result<()> {
    match path.parent() {
        Some(parent) => std::fs::create_dir_all(parent)
            .with_context(|| format!("{}: cannot create folder", parent.display())),
        None => Ok(()),
    }
}

/// `obj_<id>_<label>` with the label reduced to `[a-z0-9_]` so it is a valid item/folder name.
pub fn object_item_name(id: u16, label: &str) -> String {
    let clean: String = label
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect();
    format!("obj_{id}_{clean}")
}
