//! Files a node declares it reads (`Node::reads`) are part of its cache key:
//! replacing one reruns the node, leaving them alone keeps it cached, and `explain`
//! says which changed.

mod common;
use common::{Workspace, execute, plan_graph, registry_of, status};
use objectsplat_runtime::explain::explain;
use objectsplat_runtime::report::Status;
use objectsplat_runtime::store::Store;
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, ParamType, Params};
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
    let ws = Workspace::new();
    let data = ws.data_file("data.txt", "1");
    let graph = ws.graph(&format!(
        r#"(nodes: {{ "n": (kind: "reads_beside", params: (folder: {:?})) }})"#,
        data.display().to_string()
    ));
    let plan = plan_graph(&graph, &registry_of("Num", Arc::new(ReadsBeside)), &[], &[]);
    let (cache, out) = (ws.cache(), ws.out());
    let run = || execute(&plan, &cache, Some(&out), 1);
    assert_eq!(status(&run(), "n"), Status::Ran);
    assert_eq!(status(&run(), "n"), Status::Cached);

    std::fs::write(data.join("data.txt"), "22").unwrap();
    let why = explain(&plan, &Store::open(&cache).unwrap(), "n").unwrap();
    assert_eq!(
        why,
        "n: will run — a file it reads changed (an image, a script, a folder beside its inputs)"
    );
    assert_eq!(status(&run(), "n"), Status::Ran);
    assert_eq!(
        std::fs::read_to_string(out.join("n/out/value.txt")).unwrap(),
        "22"
    );
}
