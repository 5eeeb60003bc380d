//! The report embeds the viewer's 3D view of a composed scene (trained for real on a tiny
//! synthetic room): in headless Chromium the report's view starts, lists the composed
//! members, draws them (the centre of the view picks a member), and the page logs no
//! error and requests nothing but itself and the run summary `objectsplat run` wrote beside
//! the outputs (`run.js`), which the page shows in place of its placeholder.

mod support;

use serde_json::{Value, json};
use std::path::Path;
use std::process::Command;
use support::chromium::Browser;

/// A tiny synthetic room (8 views of 32×24, two objects kept) trained for 40 iterations
/// per component, composed, shown by a viewer and embedded in the report.
const GRAPH: &str = r#"(
  nodes: {
    "scene":    (kind: "synthetic_scene", params: (views: 8, width: 32, height: 24, points: 3000, supersample: 1)),
    "masks":    (kind: "gt_masks", inputs: (frames: "scene.frames", mesh: "scene.mesh"), params: (keep_labels: ["box", "ball"])),
    "parts":    (kind: "partition", inputs: (frames: "scene.frames", masks: "masks.masks")),
    "train":    (kind: "train", inputs: (component: each("parts.components"), points: "scene.points"),
                 params: (iterations: 40, backend: "cpu")),
    "composed": (kind: "compose", inputs: (models: "train.model")),
    "viewer":   (kind: "viewer", inputs: (scene: "composed.scene", frames: "scene.frames")),
    "report":   (kind: "report", inputs: (models: "train.model", viewer: "viewer.file"), params: (title: "tiny run")),
  },
  targets: ["report", "viewer"],
)"#;

#[test]
fn report_shows_the_composed_scene_in_3d() {
    let Some(mut browser) = Browser::launch("report_shows_the_composed_scene_in_3d") else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(dir.join("tiny.ron"), GRAPH).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_objectsplat"))
        .current_dir(dir)
        .args(["run", "tiny.ron", "--cache", "cache", "--out", "out"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let members: Value = serde_json::from_str(
        &std::fs::read_to_string(dir.join("out/viewer/file/viewer.json")).unwrap(),
    )
    .unwrap();
    let expected: Vec<Value> = members["members"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| json!({"name": m["name"], "label": m["label"]}))
        .collect();
    assert_eq!(expected.len(), 3, "background, box and ball: {members}");

    let report = dir.join("out/report/file/index.html");
    let html = std::fs::read_to_string(&report).unwrap();
    assert!(
        html.contains("<section id=\"scene\">"),
        "no 3D view section"
    );
    assert!(
        html.contains("<p class=\"placeholder\">The run summary"),
        "the materialized page is the cached one, placeholder included"
    );
    if let Some(keep) = std::env::var_os("OBJECTSPLAT_KEEP_REPORT") {
        std::fs::copy(&report, keep).unwrap();
    }
    let mut page = browser.open(Path::new(&report), 1200, 1400);
    assert_eq!(page.eval("window.objectsplat.ready"), json!(true));
    assert_eq!(page.eval("window.objectsplat.objects()"), json!(expected));
    let centre = page.eval(
        "(() => { const c = document.querySelector('.osv-canvas'); return window.objectsplat.pick(c.clientWidth / 2, c.clientHeight / 2); })()",
    );
    let names: Vec<&Value> = expected.iter().map(|m| &m["name"]).collect();
    assert!(names.contains(&&centre), "the view's centre picks {centre}");
    // The run section came from run.js: one row per node, no placeholder left.
    assert_eq!(
        page.eval("document.querySelectorAll('#run tr[data-node]').length"),
        json!(7)
    );
    assert_eq!(
        page.eval("document.querySelector('#run .placeholder') === null"),
        json!(true)
    );
    page.eval("1");
    assert!(page.errors().is_empty(), "{:#?}", page.errors());
    let own = format!("file://{}", report.display());
    let run_script = format!("file://{}", dir.join("out/run.js").display());
    for url in page.requests() {
        assert!(
            url == own || url == run_script || url.starts_with("data:"),
            "requested {url}"
        );
    }
}
