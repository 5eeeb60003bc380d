//! What the report tests share: running the `report` node, a synthetic report, SVG probes.
#![allow(dead_code)]

use objectsplat_runtime::Node;
use objectsplat_runtime::testing::run_node;
use std::path::Path;

pub mod svg;
pub mod synthetic_report;

/// Runs `node` outside a graph into `out`: the run, or the error with its causes.
pub fn node_result(
    node: &dyn Node,
    inputs: &[(&str, &Path)],
    params: &str,
    out: &Path,
) -> Result<objectsplat_runtime::testing::NodeRun, String> {
    run_node(node, inputs, params, out, None).map_err(|e| format!("{e:#}"))
}

/// Runs the `report` node into `out`; returns the run and the page it wrote.
pub fn run_report(
    inputs: &[(&str, &Path)],
    params: &str,
    out: &Path,
) -> (objectsplat_runtime::testing::NodeRun, String) {
    let run = node_result(&objectsplat_report::node::ReportNode, inputs, params, out).unwrap();
    let page = run.outputs["file"].join(objectsplat_core::artifact::PAGE_HTML);
    let html = std::fs::read_to_string(page).unwrap();
    (run, html)
}

/// Runs the `report` node into `out`, expecting it to fail (`why` says why it must);
/// returns the error with its causes.
pub fn report_error(inputs: &[(&str, &Path)], out: &Path, why: &str) -> String {
    match node_result(&objectsplat_report::node::ReportNode, inputs, "()", out) {
        Ok(_) => panic!("{why}"),
        Err(e) => e,
    }
}

/// Asserts `text` contains every one of `parts`, showing `text` when it does not.
pub fn assert_mentions(text: &str, parts: &[&str]) {
    for part in parts {
        assert!(text.contains(part), "{text}");
    }
}
