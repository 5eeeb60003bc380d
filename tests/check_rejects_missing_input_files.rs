//! `objectsplat check` refuses a graph whose input files do not exist, naming the
//! graph file, line and column of the path param (or the `--set` that gave it) and the
//! path it looked for; `--skip-input-files` checks a template without its data, and a
//! bare word given with `--set` is a path.

mod support;
use support::objectsplat::{assert_ok, objectsplat, stderr};

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
    let err = stderr(&out);
    let col = GRAPH.lines().nth(2).unwrap().find("\"photos/").unwrap() + 1;
    assert!(
        err.starts_with(&format!(
            "error: graph.ron:3:{col}: node \"photo\" (load_image) param `path`: {} does not exist (expected an existing file or folder",
            d.join("photos/missing.png").display()
        )),
        "{err}"
    );
    assert!(!err.contains("panicked"));

    // A template without its data still checks with --skip-input-files.
    let out = objectsplat(d, &["check", "--skip-input-files", "graph.ron"]);
    assert_ok(&out, "check --skip-input-files");

    // An override naming a missing file is pointed at the argument.
    let out = objectsplat(
        d,
        &["check", "graph.ron", "--set", "photo.path=elsewhere.png"],
    );
    let err = stderr(&out);
    assert!(
        err.starts_with(
            "error: --set photo.path=elsewhere.png: node \"photo\" (load_image) param `path`: "
        ),
        "{err}"
    );

    // A bare word is the path; once the file exists, check passes.
    std::fs::write(d.join("there.png"), b"").unwrap();
    let out = objectsplat(d, &["check", "graph.ron", "--set", "photo.path=there.png"]);
    assert_ok(&out, "check with the file there");
}
