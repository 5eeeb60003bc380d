//! Files a node declares it reads (`Node::reads`) are part of its cache key:
//! replacing one reruns the node, leaving them alone keeps it cached, and `explain`
//! says which changed.

mod common;
use objectsplat_runtime::exec::{self, RunOptions, Silent};
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::build_plan;
use objectsplat_runtime::report::Status;
use objectsplat_runtime::store::Store;
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, ParamType, Params, Registry};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Copies `<folder>/data.txt`, a file found through a plain string param (so no
/// `path` param fingerprints it): the node must declare it.
struct ReadsBeside;
impl Node for ReadsBeside {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("reads_beside", "1")
            .output("out", "Num", "")
            .param("folder", ParamType::Str, None, "")
    }
    fn reads(&self, params: &Params) -> anyhow::Result<Vec<PathBuf>> {
        Ok(vec![
            Path::new(&params.get::<String>("folder")?).join("data.txt"),
        ])
    }
    fn run(&self, ctx: &mut Context) -> anyhow::Result<Outcome> {
        let folder: String = ctx.param("folder")?;
        let text = std::fs::read_to_string(Path::new(&folder).join("data.txt"))?;
        std::fs::write(ctx.output("out")?.join("value.txt"), text)?;
        Ok(Outcome::Done)
    }
}

#[test]
fn replacing_a_declared_file_reruns_the_node() {
    let ws = tempfile::tempdir().unwrap();
    let data = ws.path().join("data");
    std::fs::create_dir(&data).unwrap();
    std::fs::write(data.join("data.txt"), "1").unwrap();
    let graph = ws.path().join("g.ron");
    std::fs::write(
        &graph,
        format!(
            r#"(nodes: {{ "n": (kind: "reads_beside", params: (folder: {:?})) }})"#,
            data.display().to_string()
        ),
    )
    .unwrap();
    let mut reg = Registry::new();
    reg.add_type("Num", "");
    reg.add_node(Arc::new(ReadsBeside)).unwrap();
    let plan = build_plan(&GraphSource::read(&graph).unwrap(), &reg, &[], &[]).unwrap();
    let cache = ws.path().join("cache");
    let run = || {
        let store = Store::open(&cache).unwrap();
        let opts = RunOptions {
            jobs: 1,
            out_dir: Some(ws.path().join("out")),
            observer: Arc::new(Silent),
        };
        exec::run(&plan, &store, &opts).unwrap()
    };
    assert_eq!(common::status(&run(), "n"), Status::Ran);
    assert_eq!(common::status(&run(), "n"), Status::Cached);

    std::fs::write(data.join("data.txt"), "22").unwrap();
    let why = exec::explain(&plan, &Store::open(&cache).unwrap(), "n").unwrap();
    assert_eq!(
        why,
        "n: will run — a file it reads changed (an image, a script, a folder beside its inputs)"
    );
    assert_eq!(common::status(&run(), "n"), Status::Ran);
    assert_eq!(
        std::fs::read_to_string(ws.path().join("out/n/out/value.txt")).unwrap(),
        "22"
    );
}
