//! A file name written by a node (as a plugin, or a node naming files after a
//! dataset's entries, may write it) is checked as it is, on every platform's
//! separators: a name holding `..\` components fails the node and nothing is read,
//! moved or written outside `--out`, the cache and the node's staging folder.

mod common;
use common::{Workspace, execute, fn_kind, plan_graph, registry_of};
use objectsplat_runtime::{Context, NodeSpec, Outcome, ParamType};
use std::path::Path;

/// Writes one file, named by its param verbatim, into its output folder.
fn write_named(ctx: &mut Context) -> anyhow::Result<Outcome> {
    let name: String = ctx.param("name")?;
    std::fs::write(ctx.output("file")?.join(name), "written by the node")?;
    Ok(Outcome::Done)
}

fn run(graph: &Path, cache: &Path, out: &Path) -> objectsplat_runtime::report::RunReport {
    let spec = NodeSpec::new("write_named", "1")
        .output("file", "Blob", "")
        .param("name", ParamType::Str, None, "");
    let reg = registry_of("Blob", fn_kind(spec, write_named));
    execute(&plan_graph(graph, &reg, &[], &[]), cache, Some(out), 1)
}

#[test]
fn a_backslash_name_climbing_out_fails_its_node_and_touches_nothing_outside() {
    let ws = tempfile::tempdir().unwrap();
    let root = ws.path();
    // Six `..` from the node's staging output folder (root/cache/tmp/<run>/<job>/out/file)
    // reach `root`; from OUT/w/file (OUT = root/a/b/c/d/out) they reach root/a.
    let name = r"..\..\..\..\..\..\victim.txt";
    std::fs::write(root.join("victim.txt"), "precious").unwrap();
    let graph = root.join("g.ron");
    std::fs::write(
        &graph,
        format!(r#"(nodes: {{ "w": (kind: "write_named", params: (name: {name:?})) }})"#),
    )
    .unwrap();
    let out = root.join("a/b/c/d/out");
    let r = run(&graph, &root.join("cache"), &out);

    assert_eq!(
        std::fs::read_to_string(root.join("victim.txt"))
            .ok()
            .as_deref(),
        Some("precious"),
        "a file outside the staging folder was moved into the cache"
    );
    assert!(
        !root.join("a/victim.txt").exists(),
        "a file was written outside --out"
    );
    assert!(!r.ok, "the node must fail");
    let reason = r.node("w").unwrap().reason.clone().unwrap_or_default();
    assert!(
        reason.contains("contains a path separator"),
        "the reason names the bad file name: {reason}"
    );
    assert!(!out.join("w").exists(), "the failed node has no outputs");
}

#[test]
fn plain_names_with_spaces_and_dots_are_kept() {
    let ws = Workspace::new();
    let graph =
        ws.graph(r#"(nodes: { "w": (kind: "write_named", params: (name: "frame 1..2.png")) })"#);
    let out = ws.out();
    let r = run(&graph, &ws.cache(), &out);
    assert!(r.ok, "{}", r.render_table());
    assert_eq!(
        std::fs::read_to_string(out.join("w/file/frame 1..2.png")).unwrap(),
        "written by the node"
    );
}
