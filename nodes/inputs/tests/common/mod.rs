//! Fixture paths, registries and error checks shared by the input crate's tests.
#![allow(dead_code)] // each test file uses a different part

use objectsplat_runtime::testing::{NodeRun, run_node};
use objectsplat_runtime::{Node, Registry};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// A path under tests/fixtures.
pub fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// The parsed JSON file at `path`.
pub fn read_json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Writes `doc` as the JSON file at `path`.
pub fn write_json(path: &Path, doc: &Value) {
    std::fs::write(path, doc.to_string()).unwrap();
}

/// A JSON array of numbers.
pub fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// A JSON array of arrays of numbers.
pub fn float_rows(v: &Value) -> Vec<Vec<f64>> {
    v.as_array().unwrap().iter().map(floats).collect()
}

/// A registry with the artifact types the input nodes use and the input nodes.
pub fn registry() -> Registry {
    let mut reg = Registry::new();
    for t in ["Frames", "Points", "Mesh", "Masks", "File", "Images"] {
        reg.add_type(t, "test");
    }
    objectsplat_inputs::register(&mut reg);
    reg
}

/// Copies the folder `from` (with its sub-folders) to `to`.
pub fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        if e.path().is_dir() {
            copy_dir(&e.path(), &to.join(e.file_name()));
        } else {
            std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
        }
    }
}

/// Runs `node` into a fresh folder, expecting it to fail; returns the error with its causes.
pub fn node_error(node: &dyn Node, inputs: &[(&str, &Path)], params: &str) -> String {
    let out = tempfile::tempdir().unwrap();
    match run_node(node, inputs, params, out.path(), None) {
        Ok(_) => panic!("{params} should have been refused"),
        Err(e) => format!("{e:#}"),
    }
}

/// Asserts `text` contains every one of `parts`, showing `text` when it does not.
pub fn assert_mentions(text: &str, parts: &[&str]) {
    for part in parts {
        assert!(text.contains(part), "{text}");
    }
}

/// Scene source params naming the model or JSON at `path` and an `images` folder,
/// followed by `rest` (more `, key: value` pairs, or nothing).
pub fn params_with_images(path: &Path, images: &Path, rest: &str) -> String {
    format!(
        "(path: {:?}, images: Some({:?}){rest})",
        path.display().to_string(),
        images.display().to_string()
    )
}

/// Runs the source `node` (no inputs) into a fresh folder, kept alive with the run.
pub fn run_source(node: &dyn Node, params: &str) -> (tempfile::TempDir, NodeRun) {
    let out = tempfile::tempdir().unwrap();
    let run = run_node(node, &[], params, out.path(), None).unwrap();
    (out, run)
}

/// Whether `notes` hold `key` with a value starting with `prefix`.
pub fn has_note(notes: &[(String, String)], key: &str, prefix: &str) -> bool {
    notes.iter().any(|(k, v)| k == key && v.starts_with(prefix))
}

/// Whether an external program a test needs is there (`version`: what asking it gave).
/// Under CI (`CI=true`, where .ci/run installs COLMAP and ffmpeg) a missing one fails the
/// test; elsewhere the test prints SKIPPED and passes.
pub fn installed(test: &str, version: anyhow::Result<String>) -> bool {
    match version {
        Ok(_) => true,
        Err(e) if std::env::var("CI").is_ok_and(|v| v == "true") => {
            panic!("{test}: CI=true needs it (.ci/run installs it): {e}")
        }
        Err(e) => {
            println!("SKIPPED {test}: {e}");
            false
        }
    }
}
