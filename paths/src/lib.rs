//! The one check every relative file name passes before it becomes a path below
//! `--out`, the cache or a staging folder, whoever wrote it (a graph param, a
//! dataset, a node, a plugin).
//!
//! A name is normalised first and checked after, so that what is checked is what
//! is used: `\` becomes `/` (it separates folders on Windows, and a dataset or a
//! plugin may have been written there), `.` and empty components are dropped, and
//! then anything that could leave its folder on any platform is refused: `..`, an
//! absolute path (`/x`, `\\server\x`), a drive (`C:x`), a NUL byte.

/// The `/`-separated form of a relative name that stays inside its folder.
///
/// ```
/// use objectsplat_paths::normalise_relative;
/// assert_eq!(normalise_relative(r".\images\frame 1.png").unwrap(), "images/frame 1.png");
/// assert!(normalise_relative(r"a/..\..\x.png").is_err());
/// ```
pub fn normalise_relative(name: &str) -> Result<String, String> {
    let refuse = |why: &str| Err(format!("{name:?} {why}"));
    if name.contains('\0') {
        return refuse("contains a NUL byte");
    }
    let unified = name.replace('\\', "/");
    if unified.starts_with('/') {
        return refuse("is absolute; it must be relative to its folder");
    }
    let mut parts = Vec::new();
    for part in unified.split('/') {
        match part {
            "" | "." => {}
            ".." => return refuse("climbs out of its folder (`..`)"),
            p => parts.push(p),
        }
    }
    if let Some(first) = parts.first()
        && has_drive_prefix(first)
    {
        return refuse("names a drive; it must be relative to its folder");
    }
    if parts.is_empty() {
        return refuse("names no file");
    }
    Ok(parts.join("/"))
}

/// Checks one component of a path (a file or folder name, a collection item name):
/// non-empty, not `.` or `..`, no separator of any platform, no NUL, no drive.
pub fn check_component(name: &str) -> Result<(), String> {
    let why = if name.is_empty() {
        "is empty"
    } else if name == "." || name == ".." {
        "is not a name"
    } else if name.contains(['/', '\\']) {
        "contains a path separator (`/` or `\\`)"
    } else if name.contains('\0') {
        "contains a NUL byte"
    } else if has_drive_prefix(name) {
        "names a drive"
    } else {
        return Ok(());
    };
    Err(format!("file name {name:?} {why}"))
}

/// `C:` or `C:rest`: a drive-relative path on Windows.
fn has_drive_prefix(component: &str) -> bool {
    let b = component.as_bytes();
    b.len() >= 2 && b[0].is_ascii_alphabetic() && b[1] == b':'
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn separators_of_every_platform_are_normalised_before_the_check() {
        assert_eq!(normalise_relative("a/b.png").unwrap(), "a/b.png");
        assert_eq!(normalise_relative(r"a\b.png").unwrap(), "a/b.png");
        assert_eq!(normalise_relative("./a//b/./c").unwrap(), "a/b/c");
        for bad in [
            "",
            ".",
            "./",
            "..",
            "../x",
            "a/../../x",
            r"a/..\..\..\tmp\victim\x.png",
            r"..\x",
            "/etc/passwd",
            r"\\server\share\x",
            r"\x",
            "C:x",
            r"C:\x",
            "a\0b",
        ] {
            assert!(normalise_relative(bad).is_err(), "{bad:?} was accepted");
        }
    }

    #[test]
    fn components_carry_no_separator() {
        assert!(check_component("frame_001.png").is_ok());
        assert!(check_component("obj 7 (table)").is_ok());
        for bad in ["", ".", "..", "a/b", r"a\b", r"..\..\x", "c:", "a\0"] {
            assert!(check_component(bad).is_err(), "{bad:?} was accepted");
        }
    }
}
