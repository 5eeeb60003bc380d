//! Reading and writing artifacts in their documented on-disk encodings (the text
//! `objectsplat nodes` prints under "types:"). Thin wrappers over objectsplat-core,
//! so a plugin writes byte-for-byte what a built-in node would.
//!
//! Model, Scene and Metrics are JSON-plus-files encodings owned by their stages;
//! [`read_json`]/[`write_json`] cover their JSON parts.

use anyhow::{Context as _, Result, bail};
pub use objectsplat_core::artifact::{
    COMPONENT_JSON, FRAMES_JSON, IMAGE_PNG, MASK_PNG, METRICS_JSON, MODEL_JSON, MODEL_PLY,
    POINTS_PLY, SCENE_JSON,
};
use objectsplat_core::masks::{read_objects, write_objects};
use objectsplat_core::{ComponentInfo, Frame, Frames, IdMap, Image, Mesh, ObjectLabels, Points};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::path::{Path, PathBuf};

/// Frames: `frames.json` plus the images it names (validated: unique names, sane cameras).
pub fn read_frames(dir: &Path) -> Result<Frames> {
    Frames::read(dir)
}

/// Writes `frames.json`; the images it names must be written into `dir` by the caller.
pub fn write_frames(dir: &Path, frames: &[Frame]) -> Result<()> {
    Frames::write_json(dir, frames)
}

/// Bits per channel of the Image artifact's PNG (8 or 16), from its header.
pub fn image_bit_depth(dir: &Path) -> Result<u8> {
    let path = dir.join(IMAGE_PNG);
    let bytes = std::fs::read(&path).with_context(|| format!("{}: cannot read", path.display()))?;
    // A PNG starts with an 8-byte signature and the IHDR chunk; the bit depth is byte 24.
    if bytes.len() < 25 || &bytes[..8] != b"\x89PNG\r\n\x1a\n" || &bytes[12..16] != b"IHDR" {
        bail!("{}: not a PNG file", path.display());
    }
    match bytes[24] {
        d @ (8 | 16) => Ok(d),
        d => bail!(
            "{}: {d}-bit PNG; the Image encoding is 8- or 16-bit",
            path.display()
        ),
    }
}

/// Image: `image.png`, values in [0, 1] as encoded (no colour conversion).
pub fn read_image(dir: &Path) -> Result<Image> {
    let path = dir.join(IMAGE_PNG);
    let image = Image::load(&path)?;
    image.check_finite(&path.display().to_string())?;
    Ok(image)
}

/// Writes `image.png` at `bit_depth` 8 or 16.
pub fn write_image(dir: &Path, image: &Image, bit_depth: u8) -> Result<()> {
    let path = dir.join(IMAGE_PNG);
    image.check_finite(&path.display().to_string())?;
    match bit_depth {
        8 => image.save_png8(&path),
        16 => image.save_png16(&path),
        d => bail!(
            "{}: cannot write a {d}-bit image; use 8 or 16",
            path.display()
        ),
    }
}

/// A binary mask: `set[y * width + x]`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BinaryMask {
    pub width: u32,
    pub height: u32,
    pub set: Vec<bool>,
}

impl BinaryMask {
    pub fn get(&self, x: u32, y: u32) -> bool {
        self.set[(y * self.width + x) as usize]
    }
}

/// Mask: `mask.png`, 8-bit grey, non-zero = set (any channel of other layouts).
pub fn read_mask(dir: &Path) -> Result<BinaryMask> {
    let image = Image::load(&dir.join(MASK_PNG))?;
    let channels = image.channels as usize;
    let set = image
        .data
        .chunks_exact(channels)
        .map(|px| px.iter().any(|&v| v > 0.0))
        .collect();
    Ok(BinaryMask {
        width: image.width,
        height: image.height,
        set,
    })
}

/// Writes `mask.png` with 255 for set pixels and 0 elsewhere.
pub fn write_mask(dir: &Path, mask: &BinaryMask) -> Result<()> {
    if mask.set.len() != (mask.width as usize) * (mask.height as usize) {
        bail!(
            "mask of {}×{} has {} pixels",
            mask.width,
            mask.height,
            mask.set.len()
        );
    }
    let data = mask
        .set
        .iter()
        .map(|&s| if s { 1.0 } else { 0.0 })
        .collect();
    Image {
        width: mask.width,
        height: mask.height,
        channels: 1,
        data,
    }
    .save_png8(&dir.join(MASK_PNG))
}

/// The per-frame id map file of a Masks artifact: `<frame stem>.png`.
pub fn id_map_path(dir: &Path, frame_name: &str) -> PathBuf {
    dir.join(format!(
        "{}.png",
        objectsplat_core::frames::frame_stem(frame_name)
    ))
}

/// Masks: one frame's id map (16-bit; 0 = no object, 65535 = no surface).
pub fn read_id_map(dir: &Path, frame_name: &str) -> Result<IdMap> {
    IdMap::load(&id_map_path(dir, frame_name))
}

pub fn write_id_map(dir: &Path, frame_name: &str, map: &IdMap) -> Result<()> {
    map.save(&id_map_path(dir, frame_name))
}

/// Masks / Mesh: `objects.json` (object id → label).
pub fn read_labels(dir: &Path) -> Result<ObjectLabels> {
    read_objects(dir)
}

pub fn write_labels(dir: &Path, labels: &ObjectLabels) -> Result<()> {
    write_objects(dir, labels)
}

/// Mesh: `mesh.ply` plus `objects.json` when annotated.
pub fn read_mesh(dir: &Path) -> Result<(Mesh, ObjectLabels)> {
    objectsplat_core::read_mesh_artifact(dir)
}

pub fn write_mesh(dir: &Path, mesh: &Mesh, labels: &ObjectLabels) -> Result<()> {
    objectsplat_core::write_mesh_artifact(dir, mesh, labels)
}

/// Points: `points.ply` (x, y, z + red, green, blue).
pub fn read_points(dir: &Path) -> Result<Points> {
    Points::read_ply(&dir.join(POINTS_PLY))
}

pub fn write_points(dir: &Path, points: &Points) -> Result<()> {
    points.write_ply(&dir.join(POINTS_PLY))
}

/// Component: `component.json` (its frames are a Frames encoding in the same folder,
/// its masks are `masks/<frame stem>.png`).
pub fn read_component_info(dir: &Path) -> Result<ComponentInfo> {
    read_json(&dir.join(COMPONENT_JSON))
}

pub fn write_component_info(dir: &Path, info: &ComponentInfo) -> Result<()> {
    write_json(&dir.join(COMPONENT_JSON), info)
}

/// Images: the `<stem>.png` files of the folder, sorted by name.
pub fn list_images(dir: &Path) -> Result<Vec<(String, PathBuf)>> {
    let mut out = vec![];
    for entry in
        std::fs::read_dir(dir).with_context(|| format!("{}: cannot list", dir.display()))?
    {
        let path = entry
            .with_context(|| format!("{}: cannot list", dir.display()))?
            .path();
        if path.extension().is_some_and(|e| e == "png")
            && let Some(stem) = path.file_stem().and_then(|s| s.to_str())
        {
            out.push((stem.to_string(), path.clone()));
        }
    }
    out.sort();
    Ok(out)
}

pub fn read_json<T: DeserializeOwned>(path: &Path) -> Result<T> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: unexpected content", path.display()))
}

/// Pretty JSON; deterministic for deterministic values (use BTreeMap, not HashMap).
pub fn write_json<T: Serialize + ?Sized>(path: &Path, value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value)?;
    std::fs::write(path, text).with_context(|| format!("{}: cannot write", path.display()))
}
