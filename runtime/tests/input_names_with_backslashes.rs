//! An input folder may hold names with `\` (made on Windows, or by a careless
//! script): it is fingerprinted like any other and a change to such a file reruns
//! its reader.

mod common;
use objectsplat_runtime::exec::{self, RunOptions, Silent};
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::build_plan;
use objectsplat_runtime::report::Status;
use objectsplat_runtime::store::Store;
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, ParamType, Registry};
use std::sync::Arc;

/// Counts the files of a folder named by a `path` param.
struct CountFiles;
impl Node for CountFiles {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("count_files", "1")
            .output("out", "Num", "")
            .param("dir", ParamType::Path, None, "")
    }
    fn run(&self, ctx: &mut Context) -> anyhow::Result<Outcome> {
        let dir: String = ctx.param("dir")?;
        let mut bytes = 0;
        for e in std::fs::read_dir(dir)? {
            bytes += std::fs::read(e?.path())?.len();
        }
        std::fs::write(ctx.output("out")?.join("value.txt"), bytes.to_string())?;
        Ok(Outcome::Done)
    }
}

#[test]
fn a_file_named_with_backslashes_is_fingerprinted_and_tracked() {
    let ws = tempfile::tempdir().unwrap();
    let data = ws.path().join("data");
    std::fs::create_dir(&data).unwrap();
    std::fs::write(data.join(r"scans\room 1\a.txt"), "abc").unwrap();
    let graph = ws.path().join("g.ron");
    std::fs::write(
        &graph,
        r#"(nodes: { "n": (kind: "count_files", params: (dir: "data")) })"#,
    )
    .unwrap();
    let mut reg = Registry::new();
    reg.add_type("Num", "");
    reg.add_node(Arc::new(CountFiles)).unwrap();
    let run = || {
        let plan = build_plan(&GraphSource::read(&graph).unwrap(), &reg, &[], &[]).unwrap();
        let store = Store::open(&ws.path().join("cache")).unwrap();
        let opts = RunOptions {
            jobs: 1,
            out_dir: Some(ws.path().join("out")),
            observer: Arc::new(Silent),
        };
        exec::run(&plan, &store, &opts).unwrap()
    };
    let r = run();
    assert!(r.ok, "{}", r.render_table());
    assert_eq!(common::status(&r, "n"), Status::Ran);
    assert_eq!(common::status(&run(), "n"), Status::Cached);
    std::fs::write(data.join(r"scans\room 1\a.txt"), "abcdef").unwrap();
    let r = run();
    assert_eq!(common::status(&r, "n"), Status::Ran);
    assert_eq!(
        std::fs::read_to_string(ws.path().join("out/n/out/value.txt")).unwrap(),
        "6"
    );
}
