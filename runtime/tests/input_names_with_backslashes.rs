//! An input folder may hold names with `\` (made on Windows, or by a careless
//! script): it is fingerprinted like any other and a change to such a file reruns
//! its reader.

mod common;
use common::{Workspace, execute, fn_kind, plan_graph, registry_of, status};
use objectsplat_runtime::report::Status;
use objectsplat_runtime::{Context, NodeSpec, Outcome, ParamType};

/// Counts the bytes of the files in the folder its `dir` param names.
fn count_bytes(ctx: &mut Context) -> anyhow::Result<Outcome> {
    let dir: String = ctx.param("dir")?;
    let mut bytes = 0;
    for e in std::fs::read_dir(dir)? {
        bytes += std::fs::read(e?.path())?.len();
    }
    std::fs::write(ctx.output("out")?.join("value.txt"), bytes.to_string())?;
    Ok(Outcome::Done)
}

#[test]
fn a_file_named_with_backslashes_is_fingerprinted_and_tracked() {
    let ws = Workspace::new();
    let data = ws.data_file(r"scans\room 1\a.txt", "abc");
    let graph = ws.graph(r#"(nodes: { "n": (kind: "count_files", params: (dir: "data")) })"#);
    let spec = NodeSpec::new("count_files", "1")
        .output("out", "Num", "")
        .param("dir", ParamType::Path, None, "");
    let reg = registry_of("Num", fn_kind(spec, count_bytes));
    let (cache, out) = (ws.cache(), ws.out());
    // Planned afresh for each run, as the command line does.
    let run = || execute(&plan_graph(&graph, &reg, &[], &[]), &cache, Some(&out), 1);
    let r = run();
    assert!(r.ok, "{}", r.render_table());
    assert_eq!(status(&r, "n"), Status::Ran);
    assert_eq!(status(&run(), "n"), Status::Cached);
    std::fs::write(data.join(r"scans\room 1\a.txt"), "abcdef").unwrap();
    let r = run();
    assert_eq!(status(&r, "n"), Status::Ran);
    assert_eq!(
        std::fs::read_to_string(out.join("n/out/value.txt")).unwrap(),
        "6"
    );
}
