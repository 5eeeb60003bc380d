//! Every `docs/<page>.md` that a source file, a graph or a doc names exists in the
//! repository: the code's comments send readers there, and a page that only lived in
//! someone's notes is a dead end.

use std::path::{Path, PathBuf};

const SKIPPED_DIRS: &[&str] = &["target", ".git", "node_modules", "out"];
const SCANNED_EXTENSIONS: &[&str] = &["rs", "md", "ron", "toml", "sh", "py", "wgsl"];

fn scanned_files(dir: &Path, found: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name();
        let name = name.to_string_lossy();
        if path.is_dir() {
            if !SKIPPED_DIRS.contains(&name.as_ref()) {
                scanned_files(&path, found);
            }
        } else if path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| SCANNED_EXTENSIONS.contains(&e))
        {
            found.push(path);
        }
    }
}

/// The `docs/<name>.md` paths mentioned in `text`.
fn doc_references(text: &str) -> Vec<String> {
    let mut refs = Vec::new();
    let mut rest = text;
    while let Some(at) = rest.find("docs/") {
        let tail = &rest[at + "docs/".len()..];
        let len = tail
            .find(|c: char| !(c.is_ascii_alphanumeric() || "_-.".contains(c)))
            .unwrap_or(tail.len());
        let name = tail[..len].trim_end_matches('.');
        // Only a page directly under docs/, named by a word before `.md`.
        if let Some(stem) = name.strip_suffix(".md")
            && !stem.is_empty()
            && !stem.contains('.')
        {
            refs.push(format!("docs/{name}"));
        }
        rest = tail;
    }
    refs
}

#[test]
fn reference_extraction() {
    // Spelled in pieces so that this file names no missing page itself.
    let text = concat!(
        "see docs",
        "/one.md. And `docs",
        "/a-b_c.md`, docs/images/x.png, docs/."
    );
    assert_eq!(
        doc_references(text),
        vec![concat!("docs", "/one.md"), concat!("docs", "/a-b_c.md")]
    );
}

#[test]
fn every_named_doc_page_exists() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    scanned_files(root, &mut files);
    assert!(
        files.len() > 100,
        "scanned only {} files from {}",
        files.len(),
        root.display()
    );
    let mut missing = Vec::new();
    for file in &files {
        let Ok(text) = std::fs::read_to_string(file) else {
            continue;
        };
        for page in doc_references(&text) {
            if !root.join(&page).is_file() {
                let shown = file.strip_prefix(root).unwrap_or(file);
                missing.push(format!("{} names {page}", shown.display()));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "doc pages named but not in the repository:\n{}",
        missing.join("\n")
    );
}
