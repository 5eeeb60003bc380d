//! Reading and writing the pieces of Component folders this crate touches (see
//! `objectsplat_core::component` for the encoding), with errors that name the file.

use anyhow::{Context, Result};
use objectsplat_core::component;
use objectsplat_core::{ComponentInfo, Frame, Frames};
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
        Ok(ComponentDir {
            name: name.to_string(),
            dir: dir.to_path_buf(),
            info: ComponentInfo::read(dir)?,
            frames: Frames::read(dir)?,
        })
    }

    pub fn has_frame(&self, name: &str) -> bool {
        self.frames.frames.iter().any(|f| f.name == name)
    }

    /// The component's OWN/OTHER/IGNORE mask in `frame`, checked against the frame size.
    pub fn load_mask(&self, frame: &Frame) -> Result<Vec<u8>> {
        component::read_mask(&self.dir, frame)
    }
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
