//! Reading and writing the pieces of Component folders this crate touches (see
//! `objectsplat_core::component` for the encoding), with errors that name the file.

use anyhow::{Context, Result, bail};
use objectsplat_core::ComponentInfo;
use objectsplat_core::component::COMPONENT_JSON;
use objectsplat_core::frames::frame_stem;
use objectsplat_core::{Frame, Frames};
use std::path::{Path, PathBuf};

/// One component folder, loaded enough to work with its masks.
pub struct ComponentDir {
    pub name: String,
    pub dir: PathBuf,
    pub info: ComponentInfo,
    pub frames: Frames,
}

impl ComponentDir {
    pub fn read(name: &str, dir: &Path) -> Result<ComponentDir> {
        let info_path = dir.join(COMPONENT_JSON);
        let text = std::fs::read_to_string(&info_path)
            .with_context(|| format!("{}: cannot read", info_path.display()))?;
        let info: ComponentInfo = serde_json::from_str(&text).with_context(|| {
            format!("{}: not a valid component description", info_path.display())
        })?;
        let frames = Frames::read(dir)?;
        Ok(ComponentDir {
            name: name.to_string(),
            dir: dir.to_path_buf(),
            info,
            frames,
        })
    }

    pub fn mask_path(&self, frame: &Frame) -> PathBuf {
        mask_path(&self.dir, frame)
    }

    pub fn has_frame(&self, name: &str) -> bool {
        self.frames.frames.iter().any(|f| f.name == name)
    }

    /// The component's OWN/OTHER/IGNORE mask in `frame`, checked against the frame size.
    pub fn load_mask(&self, frame: &Frame) -> Result<Vec<u8>> {
        load_gray8(&self.mask_path(frame), frame.width, frame.height)
    }
}

pub fn mask_path(component_dir: &Path, frame: &Frame) -> PathBuf {
    component_dir
        .join("masks")
        .join(format!("{}.png", frame_stem(&frame.name)))
}

/// An 8-bit grey PNG of the given size.
pub fn load_gray8(path: &Path, width: u32, height: u32) -> Result<Vec<u8>> {
    let img = image::open(path).with_context(|| format!("{}: cannot read mask", path.display()))?;
    let (w, h) = (img.width(), img.height());
    let image::DynamicImage::ImageLuma8(buf) = img else {
        bail!(
            "{}: expected an 8-bit grey mask, found {:?}",
            path.display(),
            img.color()
        );
    };
    if (w, h) != (width, height) {
        bail!(
            "{}: mask is {w}×{h} but its frame is {width}×{height}",
            path.display()
        );
    }
    Ok(buf.into_raw())
}

/// Removes `path` if it exists, so that writing it does not modify a file it may
/// share (via a hard link from [`copy_tree`]) with an input artifact.
fn unlink(path: &Path) -> Result<()> {
    match std::fs::remove_file(path) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
            Err(e).with_context(|| format!("{}: cannot replace", path.display()))
        }
        _ => Ok(()),
    }
}

pub fn save_gray8(path: &Path, data: &[u8], width: u32, height: u32) -> Result<()> {
    unlink(path)?;
    image::save_buffer_with_format(
        path,
        data,
        width,
        height,
        image::ExtendedColorType::L8,
        image::ImageFormat::Png,
    )
    .with_context(|| format!("{}: cannot write PNG", path.display()))
}

/// An image as 8-bit RGB (grey is replicated, alpha dropped, 16-bit reduced).
pub fn load_rgb8(path: &Path) -> Result<(u32, u32, Vec<u8>)> {
    let img =
        image::open(path).with_context(|| format!("{}: cannot read image", path.display()))?;
    let rgb = img.to_rgb8();
    Ok((rgb.width(), rgb.height(), rgb.into_raw()))
}

pub fn save_rgb8(path: &Path, data: &[u8], width: u32, height: u32) -> Result<()> {
    unlink(path)?;
    image::save_buffer_with_format(
        path,
        data,
        width,
        height,
        image::ExtendedColorType::Rgb8,
        image::ImageFormat::Png,
    )
    .with_context(|| format!("{}: cannot write PNG", path.display()))
}

/// Copies a folder tree, hard-linking files where the file system allows (artifacts
/// are immutable once written, so sharing their bytes is safe).
pub fn copy_tree(src: &Path, dst: &Path) -> Result<()> {
    std::fs::create_dir_all(dst)
        .with_context(|| format!("{}: cannot create folder", dst.display()))?;
    for entry in
        std::fs::read_dir(src).with_context(|| format!("{}: cannot list", src.display()))?
    {
        let entry = entry.with_context(|| format!("{}: cannot list", src.display()))?;
        let (from, to) = (entry.path(), dst.join(entry.file_name()));
        if entry.file_type()?.is_dir() {
            copy_tree(&from, &to)?;
        } else if std::fs::hard_link(&from, &to).is_err() {
            std::fs::copy(&from, &to)
                .with_context(|| format!("{}: cannot copy to {}", from.display(), to.display()))?;
        }
    }
    Ok(())
}
