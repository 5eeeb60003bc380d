//! The versions of the programs a node starts (`Node::tool_versions`) are part of its
//! cache key: another version reruns the node, the same one keeps it cached, and
//! `explain` names both versions.

mod common;
use common::{Workspace, execute, plan_graph, registry_of, status};
use objectsplat_runtime::explain::explain;
use objectsplat_runtime::report::Status;
use objectsplat_runtime::store::Store;
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, Params};
use std::sync::{Arc, Mutex};

/// Writes the version of a pretend program it "starts"; the test installs another.
struct StartsAProgram {
    installed: Arc<Mutex<String>>,
}

impl StartsAProgram {
    fn version(&self) -> String {
        self.installed.lock().unwrap().clone()
    }
}

impl Node for StartsAProgram {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("starts_a_program", "1").output("out", "Num", "")
    }
    fn tool_versions(&self, _params: &Params) -> Vec<String> {
        vec![self.version()]
    }
    fn run(&self, ctx: &mut Context) -> anyhow::Result<Outcome> {
        std::fs::write(ctx.output("out")?.join("value.txt"), self.version())?;
        Ok(Outcome::Done)
    }
}

#[test]
fn another_program_version_reruns_the_node() {
    let ws = Workspace::new();
    let graph = ws.graph(r#"(nodes: { "n": (kind: "starts_a_program") })"#);
    let installed = Arc::new(Mutex::new("tool 1.0".to_string()));
    let node = Arc::new(StartsAProgram {
        installed: installed.clone(),
    });
    let plan = plan_graph(&graph, &registry_of("Num", node), &[], &[]);
    let (cache, out) = (ws.cache(), ws.out());
    let run = || execute(&plan, &cache, Some(&out), 1);
    assert_eq!(status(&run(), "n"), Status::Ran);
    assert_eq!(status(&run(), "n"), Status::Cached);

    *installed.lock().unwrap() = "tool 1.1".into();
    let why = explain(&plan, &Store::open(&cache).unwrap(), "n").unwrap();
    assert_eq!(
        why,
        r#"n: will run — a program it starts changed (["tool 1.0"] → ["tool 1.1"])"#
    );
    assert_eq!(status(&run(), "n"), Status::Ran);
    assert_eq!(
        std::fs::read_to_string(out.join("n/out/value.txt")).unwrap(),
        "tool 1.1"
    );
    assert_eq!(status(&run(), "n"), Status::Cached);
}
