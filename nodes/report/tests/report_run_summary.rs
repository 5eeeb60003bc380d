//! The run summary filled into a `report` node's page after the run: the placeholder the node
//! writes is replaced by the graph and node table, refilling replaces rather than appends, and
//! the page is replaced by a new file so a hard-linked cache copy keeps its placeholder.

mod common;

use common::svg::{section, svg_blocks};
use objectsplat_report::*;
use std::path::Path;

fn node_page(dir: &Path) -> std::path::PathBuf {
    let mut data = common::synthetic_report::report_data(dir);
    data.run = RunSummary::default();
    render_report(&dir.join("report"), &data).unwrap()
}

fn run_summary(dir: &Path) -> RunSummary {
    common::synthetic_report::report_data(dir).run
}

#[test]
fn placeholder_is_replaced_by_every_node_with_its_status() {
    let dir = tempfile::tempdir().unwrap();
    let page = std::fs::read_to_string(node_page(dir.path())).unwrap();
    assert_eq!(page.matches(RUN_SUMMARY_BEGIN).count(), 1);
    assert!(section(&page, "run").contains(
        "comes from <code>run.js</code> beside the outputs of <code>objectsplat run</code>"
    ));

    let run = run_summary(dir.path());
    let filled = inject_run_summary(&page, &run).unwrap();
    let run_html = section(&filled, "run");
    assert!(!run_html.contains("placeholder"));
    for n in &run.nodes {
        assert!(
            run_html.contains(&format!(
                "<tr data-node=\"{}\" data-status=\"{}\"><td>{}</td><td>{}</td>",
                n.id,
                n.status.as_str(),
                n.id,
                n.kind
            )),
            "{} missing from the node table",
            n.id
        );
    }
    let dag = roxmltree::Document::parse(svg_blocks(run_html)[0]).unwrap();
    let drawn: Vec<(&str, &str)> = dag
        .descendants()
        .filter(|n| n.attribute("class") == Some("node"))
        .map(|g| {
            (
                g.attribute("data-id").unwrap(),
                g.attribute("data-status").unwrap(),
            )
        })
        .collect();
    let want: Vec<(&str, &str)> = run
        .nodes
        .iter()
        .map(|n| (n.id.as_str(), n.status.as_str()))
        .collect();
    assert_eq!(drawn, want);
    // Everything outside the run section is untouched.
    let (head, tail) = page.split_at(page.find(RUN_SUMMARY_BEGIN).unwrap());
    assert!(filled.starts_with(head));
    let after = &tail[tail.find(RUN_SUMMARY_END).unwrap() + RUN_SUMMARY_END.len()..];
    assert!(filled.ends_with(after));
}

#[test]
fn filling_again_replaces_the_earlier_summary() {
    let dir = tempfile::tempdir().unwrap();
    let page = std::fs::read_to_string(node_page(dir.path())).unwrap();
    let mut run = run_summary(dir.path());
    let once = inject_run_summary(&page, &run).unwrap();
    for n in &mut run.nodes {
        n.status = NodeStatus::Cached;
    }
    let twice = inject_run_summary(&once, &run).unwrap();
    assert_eq!(twice.matches(RUN_SUMMARY_BEGIN).count(), 1);
    assert_eq!(twice.matches("<section id=\"run\">").count(), 1);
    assert!(twice.contains("9 nodes: 0 ran, 9 cached, 0 skipped, 0 failed"));
    assert_eq!(twice, inject_run_summary(&page, &run).unwrap());
}

#[test]
fn the_page_is_replaced_and_a_hard_linked_copy_keeps_the_placeholder() {
    let dir = tempfile::tempdir().unwrap();
    let page = node_page(dir.path());
    let blob = dir.path().join("blob");
    std::fs::hard_link(&page, &blob).unwrap();
    let before = std::fs::read(&blob).unwrap();
    write_with_run_summary(&page, &run_summary(dir.path()), &page).unwrap();
    assert_eq!(
        std::fs::read(&blob).unwrap(),
        before,
        "the linked copy is untouched"
    );
    let filled = std::fs::read_to_string(&page).unwrap();
    assert!(filled.contains("<tr data-node=\"train\" data-status=\"ran\">"));
    // No temporary file is left beside the page.
    let names: Vec<_> = std::fs::read_dir(page.parent().unwrap())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, [REPORT_FILE]);
    // Readable like any other output, not private like the temporary file it was.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(&page).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o644, "mode {mode:o}");
    }
}

/// A saved run report, with fields the summary does not read (ok, jobs, outputs, notes...).
const SAVED_RUN_JSON: &str = r#"{"graph": "g.ron", "ok": true, "seconds": 1.5, "jobs": 2, "warnings": [], "out": "out/g",
            "nodes": [
              {"id": "a", "kind": "load_image", "status": "cached", "seconds": 0.0, "reason": null, "items": [],
               "outputs": {"image": "ab12"}},
              {"id": "r", "kind": "report", "status": "ran", "seconds": 0.25, "reason": null,
               "items": [{"name": "x", "status": "ran", "seconds": 0.25, "reason": "why"}],
               "notes": {"views": "0"}}
            ],
            "edges": [{"from": "a", "to": "r"}]}"#;

#[test]
fn a_saved_run_report_is_read_with_its_edges_and_extra_fields_ignored() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("run.json");
    std::fs::write(&json, SAVED_RUN_JSON).unwrap();
    let run = read_run_summary(&json).unwrap();
    assert_eq!(run.nodes.len(), 2);
    assert_eq!(run.nodes[0].status, NodeStatus::Cached);
    assert_eq!(
        run.edges,
        [GraphEdge {
            from: "a".into(),
            to: "r".into()
        }]
    );
    assert_eq!(
        (run.graph.as_deref(), run.seconds),
        (Some("g.ron"), Some(1.5))
    );

    std::fs::write(&json, "{\"nodes\": 3}").unwrap();
    let e = format!("{:#}", read_run_summary(&json).unwrap_err());
    common::assert_mentions(&e, &["run.json", "not a run report"]);
}

#[test]
fn a_page_without_the_marker_is_an_error_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let page = dir.path().join("other.html");
    std::fs::write(&page, "<html><body>hand-made</body></html>").unwrap();
    let out = dir.path().join("filled.html");
    let e = format!(
        "{:#}",
        write_with_run_summary(&page, &run_summary(dir.path()), &out).unwrap_err()
    );
    common::assert_mentions(&e, &["other.html", "no run-summary marker"]);
    assert!(!out.exists(), "nothing is written on error");
}
