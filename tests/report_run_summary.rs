//! `objectsplat run` writes the run summary (graph, each node's status and time) beside its
//! outputs as data (`run.json`, and `run.js` that the report page loads), and rewrites no
//! output: the materialized page is the cached one, byte for byte; a cached rerun shows the
//! nodes as cached; `objectsplat report` fills a page from a saved `--json` report.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

mod support;
use support::objectsplat::{assert_ok, failure, file_tree, objectsplat, read_json};
use support::tiny_room;

/// The tiny trained room ending in a report of its models.
fn graph() -> String {
    tiny_room::graph(
        r#"    "report":   (kind: "report", inputs: (models: "train.model"), params: (title: "tiny run")),"#,
        r#"["report"]"#,
    )
}

const NODES: [&str; 5] = ["scene", "masks", "parts", "train", "report"];
const PLACEHOLDER: &str = "<p class=\"placeholder\">The run summary";

fn run(dir: &Path, json: &str) {
    // One worker: the runtime lists a fan-out's items in the order they finish on a fresh run
    // but sorted by name on a cached one, so with parallel items the `train.model` collection
    // can change digest between runs and the report reruns (a runtime issue, not the report's).
    let out = objectsplat(
        dir,
        &[
            "run", "g.ron", "--cache", "cache", "--out", "out", "--json", json, "-j", "1",
        ],
    );
    assert_ok(&out, "the run");
}

fn page(dir: &Path) -> PathBuf {
    dir.join("out/report/file/index.html")
}

/// The run section that `out/run.js` hands the page.
fn run_section(dir: &Path) -> String {
    let script = std::fs::read_to_string(dir.join("out/run.js")).unwrap();
    let json = script
        .strip_prefix("window.objectsplatRun = ")
        .and_then(|s| s.strip_suffix(";\n"))
        .unwrap_or_else(|| panic!("run.js is not one assignment: {script}"));
    let value: serde_json::Value = serde_json::from_str(json).unwrap();
    value["section"].as_str().unwrap().to_string()
}

/// `out/run.json` is the report `--json` wrote to `json`.
fn assert_run_json_matches(dir: &Path, json: &str) {
    assert_eq!(
        read_json(&dir.join("out/run.json")),
        read_json(&dir.join(json))
    );
}

/// (node id, status) of each row of the page's node table, in order.
fn node_rows(html: &str) -> Vec<(String, String)> {
    html.match_indices("<tr data-node=\"")
        .map(|(i, m)| {
            let rest = &html[i + m.len()..];
            let (id, rest) = rest.split_once('"').unwrap();
            let status = rest
                .strip_prefix(" data-status=\"")
                .and_then(|r| r.split_once('"'))
                .unwrap()
                .0;
            (id.to_string(), status.to_string())
        })
        .collect()
}

fn all(status: &str) -> Vec<(String, String)> {
    NODES
        .iter()
        .map(|n| (n.to_string(), status.to_string()))
        .collect()
}

/// The cache's copies of the page: each keeps the node's placeholder, none has a summary.
fn assert_cache_pages_are_pure(cache: &BTreeMap<String, Vec<u8>>) {
    let pages: Vec<&String> = cache
        .iter()
        .filter(|(_, bytes)| String::from_utf8_lossy(bytes).contains("<title>tiny run</title>"))
        .map(|(p, _)| p)
        .collect();
    assert_eq!(pages.len(), 1, "one cached page: {pages:?}");
    let cached = String::from_utf8(cache[pages[0]].clone()).unwrap();
    assert!(cached.contains(PLACEHOLDER));
    assert!(node_rows(&cached).is_empty());
}

#[test]
fn run_writes_the_summary_beside_the_outputs_and_rewrites_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("g.ron"), graph()).unwrap();

    run(d, "r1.json");
    let page_text = std::fs::read_to_string(page(d)).unwrap();
    assert!(page_text.contains(PLACEHOLDER));
    assert!(page_text.contains("<script src=\"../../run.js\"></script>"));
    assert_run_json_matches(d, "r1.json");
    let first = run_section(d);
    assert_eq!(node_rows(&first), all("ran"));
    assert!(first.contains("5 nodes: 5 ran, 0 cached, 0 skipped, 0 failed"));
    // The drawing has an arrow per data dependency (scene feeds masks, parts and train).
    for (from, to) in [
        ("scene", "masks"),
        ("scene", "parts"),
        ("masks", "parts"),
        ("parts", "train"),
        ("scene", "train"),
        ("train", "report"),
    ] {
        assert!(
            first.contains(&format!("data-from=\"{from}\" data-to=\"{to}\"")),
            "{from} → {to}"
        );
    }
    // The trainer's logs reach the page: one table row per trained component.
    for component in ["obj_8_box", "obj_10_ball", "background"] {
        assert!(
            page_text.contains(&format!(
                "<tr data-component=\"{component}\"><td>{component}</td><td class=\"num\">40</td>"
            )),
            "{component}"
        );
    }
    let cache_after_first = file_tree(&d.join("cache"));
    assert_cache_pages_are_pure(&cache_after_first);
    // Nothing rewrote the output: the materialized page is the cached one.
    assert!(
        cache_after_first
            .values()
            .any(|bytes| bytes == page_text.as_bytes())
    );

    // A second run is fully cached, and its summary says so; the cache is byte-identical.
    run(d, "r2.json");
    assert_run_json_matches(d, "r2.json");
    let second = run_section(d);
    assert_eq!(node_rows(&second), all("cached"));
    assert!(second.contains("5 nodes: 0 ran, 5 cached"));
    assert_eq!(std::fs::read_to_string(page(d)).unwrap(), page_text);
    assert_eq!(file_tree(&d.join("cache")), cache_after_first);

    // `report` fills a page from the first run's saved report, to a new file and in place,
    // without touching the cache the page is linked to.
    let fill_from_first_run = |extra: &[&str]| {
        let mut args = vec![
            "report",
            "--run",
            "r1.json",
            "--html",
            "out/report/file/index.html",
        ];
        args.extend(extra);
        assert_ok(&objectsplat(d, &args), "objectsplat report");
    };
    fill_from_first_run(&["-o", "first.html"]);
    let filled = std::fs::read_to_string(d.join("first.html")).unwrap();
    assert_eq!(node_rows(&filled), all("ran"));
    assert!(filled.contains(&first));
    assert_eq!(std::fs::read_to_string(page(d)).unwrap(), page_text);
    fill_from_first_run(&[]);
    assert_eq!(std::fs::read_to_string(page(d)).unwrap(), filled);
    assert_eq!(file_tree(&d.join("cache")), cache_after_first);
}

#[test]
fn report_command_names_a_missing_run_report() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("page.html"), "<html></html>").unwrap();
    let out = objectsplat(
        dir.path(),
        &["report", "--run", "nowhere.json", "--html", "page.html"],
    );
    let stderr = failure(&out);
    assert!(
        stderr.contains("nowhere.json") && stderr.contains("cannot read"),
        "{stderr}"
    );
}
