//! `objectsplat check` refuses a graph whose input files do not exist, naming the
//! graph file, line and column of the path param (or the `--set` that gave it) and the
//! path it looked for; `--skip-input-files` checks a template without its data, and a
//! bare word given with `--set` is a path.

use std::path::Path;
use std::process::{Command, Output};

fn objectsplat(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_objectsplat"))
        .current_dir(dir)
        .args(args)
        .output()
        .unwrap()
}

const GRAPH: &str = r#"(
  nodes: {
    "photo": (kind: "load_image", params: (path: "photos/missing.png")),
  },
  targets: ["photo"],
)"#;

#[test]
fn a_missing_input_file_is_an_error_at_its_param() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("graph.ron"), GRAPH).unwrap();
    let out = objectsplat(d, &["check", "graph.ron"]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    let col = GRAPH.lines().nth(2).unwrap().find("\"photos/").unwrap() + 1;
    assert!(
        stderr.starts_with(&format!(
            "error: graph.ron:3:{col}: node \"photo\" (load_image) param `path`: {} does not exist (expected an existing file or folder",
            d.join("photos/missing.png").display()
        )),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"));

    // A template without its data still checks with --skip-input-files.
    let out = objectsplat(d, &["check", "--skip-input-files", "graph.ron"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    // An override naming a missing file is pointed at the argument.
    let out = objectsplat(
        d,
        &["check", "graph.ron", "--set", "photo.path=elsewhere.png"],
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.starts_with(
            "error: --set photo.path=elsewhere.png: node \"photo\" (load_image) param `path`: "
        ),
        "{stderr}"
    );

    // A bare word is the path; once the file exists, check passes.
    std::fs::write(d.join("there.png"), b"").unwrap();
    let out = objectsplat(d, &["check", "graph.ron", "--set", "photo.path=there.png"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}
