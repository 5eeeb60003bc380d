//! Paths in a graph resolve relative to the graph file; outputs stay inside OUT and the cache.

mod common;
use common::{execute, fn_kind, plan_graph, ran, registry_of};
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::build_plan;
use objectsplat_runtime::{Context, NodeSpec, Outcome, ParamType, Registry};

/// Reads a file named by a `path` param and copies its bytes out; writes a file at a `relpath`.
fn copy(ctx: &mut Context) -> anyhow::Result<Outcome> {
    let from: String = ctx.param("from")?;
    let to: String = ctx.param("to")?;
    std::fs::write(ctx.output("file")?.join(to), std::fs::read(from)?)?;
    Ok(Outcome::Done)
}

fn registry() -> Registry {
    let spec = NodeSpec::new("copy", "1")
        .output("file", "Blob", "")
        .param("from", ParamType::Path, None, "")
        .param("to", ParamType::RelPath, Some("\"copy.txt\""), "");
    registry_of("Blob", fn_kind(spec, copy))
}

#[test]
fn path_params_resolve_against_the_graph_folder_and_their_content_is_in_the_key() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("graphs/data")).unwrap();
    std::fs::write(dir.path().join("graphs/data/in.txt"), "hello").unwrap();
    let g = dir.path().join("graphs/g.ron");
    std::fs::write(
        &g,
        r#"(nodes: { "c": (kind: "copy", params: (from: "data/in.txt")) })"#,
    )
    .unwrap();
    let (cache, out) = (dir.path().join("cache"), dir.path().join("out"));
    // Planned afresh for each run, as the command line does.
    let run = || {
        execute(
            &plan_graph(&g, &registry(), &[], &[]),
            &cache,
            Some(&out),
            1,
        )
    };
    // Run from another working directory: the path still resolves next to the graph.
    let r = run();
    assert!(r.ok, "{}", r.render_table());
    assert_eq!(
        std::fs::read_to_string(dir.path().join("out/c/file/copy.txt")).unwrap(),
        "hello"
    );
    assert_eq!(ran(&run()), Vec::<String>::new());
    std::fs::write(dir.path().join("graphs/data/in.txt"), "changed").unwrap();
    assert_eq!(ran(&run()), ["c"]);
    assert_eq!(
        std::fs::read_to_string(dir.path().join("out/c/file/copy.txt")).unwrap(),
        "changed"
    );
}

#[test]
fn output_paths_cannot_leave_the_output_folder() {
    for bad in [
        "../escape.txt",
        "/tmp/escape.txt",
        "a/../../b.txt",
        "",
        r"a/..\..\..\tmp\victim\x.png",
        r"..\escape.txt",
        r"\\server\share\x.txt",
        r"C:\x.txt",
    ] {
        let src = GraphSource {
            path: "g.ron".into(),
            text: format!(
                r#"(nodes: {{ "c": (kind: "copy", params: (from: "x", to: {bad:?})) }})"#
            ),
        };
        let err = build_plan(&src, &registry(), &[], &[])
            .err()
            .expect("must be refused")
            .to_string();
        assert!(err.contains("param `to`"), "{bad}: {err}");
    }
}

#[test]
fn output_paths_written_with_backslashes_mean_folders() {
    let src = GraphSource {
        path: "g.ron".into(),
        text: r#"(nodes: { "c": (kind: "copy", params: (from: "x", to: "sub\\x.txt")) })"#.into(),
    };
    let plan = build_plan(&src, &registry(), &[], &[]).unwrap_or_else(|d| panic!("{d}"));
    let to: String = plan.nodes[0].params.get("to").unwrap();
    assert_eq!(to, "sub/x.txt");
}
