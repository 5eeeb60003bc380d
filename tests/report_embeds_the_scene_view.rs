//! The report embeds the viewer's 3D view of a composed scene (trained for real on a tiny
//! synthetic room): in headless Chromium the report's view starts, lists the composed
//! members, draws them (the centre of the view picks a member), and the page logs no
//! error and requests nothing but itself and the run summary `objectsplat run` wrote beside
//! the outputs (`run.js`), which the page shows in place of its placeholder.

mod support;

use serde_json::{Value, json};
use std::path::Path;
use support::chromium::Browser;
use support::objectsplat::{assert_ok, objectsplat, read_json};
use support::tiny_room;

/// The tiny trained room composed, shown by a viewer and embedded in the report.
fn graph() -> String {
    tiny_room::graph(
        r#"    "composed": (kind: "compose", inputs: (models: "train.model")),
    "viewer":   (kind: "viewer", inputs: (scene: "composed.scene", frames: "scene.frames")),
    "report":   (kind: "report", inputs: (models: "train.model", viewer: "viewer.file"), params: (title: "tiny run")),"#,
        r#"["report", "viewer"]"#,
    )
}

#[test]
fn report_shows_the_composed_scene_in_3d() {
    let Some(mut browser) = Browser::launch("report_shows_the_composed_scene_in_3d") else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(dir.join("tiny.ron"), graph()).unwrap();
    let out = objectsplat(
        dir,
        &["run", "tiny.ron", "--cache", "cache", "--out", "out"],
    );
    assert_ok(&out, "the run");
    let members = read_json(&dir.join("out/viewer/file/viewer.json"));
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
