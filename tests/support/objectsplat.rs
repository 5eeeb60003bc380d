//! The `objectsplat` binary as the end-to-end tests drive it: run in a test folder, its
//! outcome checked, and what it wrote read back (the `--json` run report, the files of a
//! folder).

use serde_json::Value;
use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Output, Stdio};

/// `objectsplat ARGS` in `dir`, ready for more settings before it runs.
pub fn command(dir: &Path, args: &[&str]) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_objectsplat"));
    cmd.current_dir(dir).args(args);
    cmd
}

/// `objectsplat ARGS` in `dir`, run to its end.
pub fn objectsplat(dir: &Path, args: &[&str]) -> Output {
    command(dir, args).output().expect("objectsplat runs")
}

/// `objectsplat ARGS` started in `dir` with its stderr captured, for a test that acts
/// while it runs.
pub fn spawn_objectsplat(dir: &Path, args: &[&str]) -> std::process::Child {
    command(dir, args)
        .stderr(Stdio::piped())
        .spawn()
        .expect("objectsplat starts")
}

/// `run graph.ron` into `cache/` and `out/` with its `--json` report in `report.json`,
/// then `extra`.
pub fn run_graph_ron<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "run",
        "graph.ron",
        "--cache",
        "cache",
        "--out",
        "out",
        "--json",
        "report.json",
    ];
    args.extend(extra);
    args
}

pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Panics with the run's stderr unless it succeeded.
pub fn assert_ok(out: &Output, what: &str) {
    assert!(out.status.success(), "{what} failed:\n{}", stderr(out));
}

/// Asserts that the run failed; returns its stderr, for the test to check the cause.
pub fn failure(out: &Output) -> String {
    assert!(!out.status.success(), "it should fail:\n{}", stderr(out));
    stderr(out)
}

pub fn read_json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The entry of node `id` in a `--json` run report.
pub fn report_node<'a>(report: &'a Value, id: &str) -> &'a Value {
    report["nodes"]
        .as_array()
        .expect("the report lists its nodes")
        .iter()
        .find(|n| n["id"] == id)
        .unwrap_or_else(|| panic!("no node {id} in the report"))
}

/// (node id, status) of every node of a `--json` run report, in its order.
pub fn statuses(report: &Value) -> Vec<(String, String)> {
    report["nodes"]
        .as_array()
        .expect("the report lists its nodes")
        .iter()
        .map(|n| {
            (
                n["id"].as_str().unwrap().to_string(),
                n["status"].as_str().unwrap().to_string(),
            )
        })
        .collect()
}

/// Every file under `root` (path relative to `root` → bytes), links read as their targets.
pub fn file_tree(root: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut files = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let rel = path.strip_prefix(root).unwrap().to_string_lossy();
                files.insert(rel.into_owned(), std::fs::read(&path).unwrap());
            }
        }
    }
    files
}
