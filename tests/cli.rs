//! The `objectsplat` command line: the contract outside tools rely on.

use std::path::Path;

mod support;
use support::objectsplat::{assert_ok, failure, objectsplat, read_json, statuses};

fn demo_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    std::fs::create_dir_all(dir.path().join("graphs/assets")).unwrap();
    std::fs::copy(
        root.join("graphs/assets/astronaut.png"),
        dir.path().join("graphs/assets/astronaut.png"),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("graphs/images.ron"),
        r#"(
  nodes: {
    "photo": (kind: "load_image", params: (path: "assets/astronaut.png")),
    "small": (kind: "resize_image", inputs: (image: "photo.image"), params: (factor: 4)),
    "save":  (kind: "save_image", inputs: (image: "small.image"), params: (path: "nested/small.png")),
  },
  targets: ["save"],
)"#,
    )
    .unwrap();
    dir
}

/// The demo graph with `from` replaced by `to`.
fn edit_graph(dir: &Path, from: &str, to: &str) {
    let g = dir.join("graphs/images.ron");
    let text = std::fs::read_to_string(&g).unwrap().replace(from, to);
    std::fs::write(&g, text).unwrap();
}

#[test]
fn run_materializes_targets_and_reports_json_then_reuses_the_cache() {
    let dir = demo_dir();
    let out = objectsplat(
        dir.path(),
        &["run", "graphs/images.ron", "--json", "r1.json", "-j", "2"],
    );
    assert_ok(&out, "the first run");
    // Default folders: cache in .objectsplat-cache/, outputs in out/<graph name>/<node>/<port>/.
    let png = dir.path().join("out/images/save/file/nested/small.png");
    let img = image::open(&png).unwrap();
    assert_eq!((img.width(), img.height()), (64, 64));
    assert!(dir.path().join(".objectsplat-cache/actions").is_dir());
    let r1 = read_json(&dir.path().join("r1.json"));
    assert_eq!(
        statuses(&r1),
        [
            ("photo".into(), "ran".into()),
            ("small".into(), "ran".into()),
            ("save".into(), "ran".into())
        ]
    );
    for n in r1["nodes"].as_array().unwrap() {
        for field in ["id", "kind", "status", "seconds", "reason", "items"] {
            assert!(n.get(field).is_some(), "report node lacks `{field}`: {n}");
        }
    }
    let out = objectsplat(
        dir.path(),
        &["run", "graphs/images.ron", "--json", "r2.json"],
    );
    assert!(out.status.success());
    let r2 = read_json(&dir.path().join("r2.json"));
    assert!(statuses(&r2).iter().all(|(_, s)| s == "cached"), "{r2}");
    // An override reruns the changed node and its consumers, not the loader.
    let out = objectsplat(
        dir.path(),
        &[
            "run",
            "graphs/images.ron",
            "--set",
            "small.factor=2",
            "--json",
            "r3.json",
        ],
    );
    assert!(out.status.success());
    assert_eq!(
        statuses(&read_json(&dir.path().join("r3.json"))),
        [
            ("photo".into(), "cached".into()),
            ("small".into(), "ran".into()),
            ("save".into(), "ran".into())
        ]
    );
    assert_eq!(image::open(&png).unwrap().width(), 128);
}

#[test]
fn a_bad_graph_fails_with_one_located_line_and_no_panic() {
    let dir = demo_dir();
    edit_graph(dir.path(), "\"resize_image\"", "\"resize_imag\"");
    for cmd in ["check", "run"] {
        let err = failure(&objectsplat(dir.path(), &[cmd, "graphs/images.ron"]));
        assert!(err.starts_with("error: graphs/images.ron:4:21: unknown node kind \"resize_imag\"; did you mean `resize_image`?"), "{err}");
        assert!(!err.contains("panicked"));
    }
}

#[test]
fn a_failing_node_exits_non_zero_with_its_cause() {
    let dir = demo_dir();
    edit_graph(dir.path(), "assets/astronaut.png", "assets/missing.png");
    let err = failure(&objectsplat(dir.path(), &["run", "graphs/images.ron"]));
    let last = err.lines().last().unwrap();
    assert!(
        last.starts_with("error: node `photo` (load_image) failed:")
            && last.contains("missing.png"),
        "{err}"
    );
}

#[test]
fn graph_dot_nodes_and_explain() {
    let dir = demo_dir();
    let dot = objectsplat(dir.path(), &["graph", "graphs/images.ron", "--dot"]);
    let dot = String::from_utf8_lossy(&dot.stdout);
    assert!(
        dot.starts_with("digraph") && dot.contains("\"photo\" -> \"small\""),
        "{dot}"
    );
    let nodes = objectsplat(dir.path(), &["nodes"]);
    let nodes = String::from_utf8_lossy(&nodes.stdout);
    assert!(
        nodes.contains("save_image (v1)") && nodes.contains("param path: relpath = \"image.png\""),
        "{nodes}"
    );
    assert!(
        objectsplat(dir.path(), &["run", "graphs/images.ron"])
            .status
            .success()
    );
    let ex = objectsplat(
        dir.path(),
        &[
            "explain",
            "graphs/images.ron",
            "save",
            "--set",
            "small.factor=8",
        ],
    );
    let ex = String::from_utf8_lossy(&ex.stdout);
    assert!(
        ex.contains("photo: cached") && ex.contains("small: will run — params changed"),
        "{ex}"
    );
}
