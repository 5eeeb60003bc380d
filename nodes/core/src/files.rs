//! Sharing artifact files between folders: artifacts are immutable once
//! written, so a file another artifact holds is hard-linked where the file
//! system allows (no bytes copied, no disk used), else copied.

use anyhow::{Context, Result};
use std::path::Path;

/// Reads the JSON file at `path` as a `what` (named in the error when it does not parse).
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path, what: &str) -> Result<T> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: not a valid {what}", path.display()))
}

/// `dst` holds `src`'s bytes: a hard link, or a copy across file systems.
pub fn link_or_copy(src: &Path, dst: &Path) -> Result<()> {
    if std::fs::hard_link(src, dst).is_err() {
        std::fs::copy(src, dst)
            .with_context(|| format!("{}: cannot copy to {}", src.display(), dst.display()))?;
    }
    Ok(())
}

/// A folder tree shared into `dst` file by file with [`link_or_copy`].
pub fn share_tree(src: &Path, dst: &Path) -> Result<()> {
    tree_file_by_file(src, dst, &link_or_copy)
}

/// `src`'s folders made again under `dst`, each file placed by `place(from, to)` (a link,
/// a writable copy).
pub fn tree_file_by_file(
    src: &Path,
    dst: &Path,
    place: &dyn Fn(&Path, &Path) -> Result<()>,
) -> Result<()> {
    std::fs::create_dir_all(dst)
        .with_context(|| format!("{}: cannot create folder", dst.display()))?;
    for entry in
        std::fs::read_dir(src).with_context(|| format!("{}: cannot list", src.display()))?
    {
        let entry = entry.with_context(|| format!("{}: cannot list", src.display()))?;
        let (from, to) = (entry.path(), dst.join(entry.file_name()));
        if entry.file_type()?.is_dir() {
            tree_file_by_file(&from, &to, place)?;
        } else {
            place(&from, &to)?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_shared_tree_has_the_same_files_and_bytes() {
        let src = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(src.path().join("a/b")).unwrap();
        std::fs::write(src.path().join("top.txt"), b"top").unwrap();
        std::fs::write(src.path().join("a/b/deep.bin"), [0u8, 1, 2, 255]).unwrap();
        let dst = tempfile::tempdir().unwrap();
        let to = dst.path().join("copy");
        share_tree(src.path(), &to).unwrap();
        assert_eq!(std::fs::read(to.join("top.txt")).unwrap(), b"top");
        assert_eq!(
            std::fs::read(to.join("a/b/deep.bin")).unwrap(),
            [0, 1, 2, 255]
        );
        let err = share_tree(&src.path().join("missing"), &to).unwrap_err();
        assert!(format!("{err:#}").contains("missing"), "{err:#}");
    }
}
