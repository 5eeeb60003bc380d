//! A file name written by a node (as a plugin, or a node naming files after a
//! dataset's entries, may write it) is checked as it is, on every platform's
//! separators: a name holding `..\` components fails the node and nothing is read,
//! moved or written outside `--out`, the cache and the node's staging folder.

mod common;
use objectsplat_runtime::exec::{self, RunOptions, Silent};
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::build_plan;
use objectsplat_runtime::store::Store;
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, ParamType, Registry};
use std::path::Path;
use std::sync::Arc;

/// Writes one file, named by its param verbatim, into its output folder.
struct WriteNamed;
impl Node for WriteNamed {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("write_named", "1")
            .output("file", "Blob", "")
            .param("name", ParamType::Str, None, "")
    }
    fn run(&self, ctx: &mut Context) -> anyhow::Result<Outcome> {
        let name: String = ctx.param("name")?;
        std::fs::write(ctx.output("file")?.join(name), "written by the node")?;
        Ok(Outcome::Done)
    }
}

fn run(graph: &Path, cache: &Path, out: &Path) -> objectsplat_runtime::report::RunReport {
    let mut reg = Registry::new();
    reg.add_type("Blob", "files");
    reg.add_node(Arc::new(WriteNamed)).unwrap();
    let src = GraphSource::read(graph).unwrap();
    let plan = build_plan(&src, &reg, &[], &[]).unwrap();
    let store = Store::open(cache).unwrap();
    exec::run(
        &plan,
        &store,
        &RunOptions {
            jobs: 1,
            out_dir: Some(out.to_path_buf()),
            observer: Arc::new(Silent),
        },
    )
    .unwrap()
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
    let ws = tempfile::tempdir().unwrap();
    let graph = ws.path().join("g.ron");
    std::fs::write(
        &graph,
        r#"(nodes: { "w": (kind: "write_named", params: (name: "frame 1..2.png")) })"#,
    )
    .unwrap();
    let out = ws.path().join("out");
    let r = run(&graph, &ws.path().join("cache"), &out);
    assert!(r.ok, "{}", r.render_table());
    assert_eq!(
        std::fs::read_to_string(out.join("w/file/frame 1..2.png")).unwrap(),
        "written by the node"
    );
}
