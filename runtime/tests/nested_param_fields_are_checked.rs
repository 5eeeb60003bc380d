//! A node's own check of a nested param (an unknown key inside a map param, like a
//! typo in a trainer's schedule) fails the plan before anything runs, pointing at the
//! key in the graph file (line and column), or at the `--set` that gave it.

mod common;
use common::*;
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::{Override, build_plan};

const GRAPH: &str = r#"(
  nodes: {
    "x": (kind: "const", params: (value: 8)),
    "t": (kind: "tuned", inputs: (x: "x.out"),
          params: (schedule: {"rate": 0.5, "stpes": 3})),
  },
  targets: ["t"],
)"#;

#[test]
fn an_unknown_key_inside_a_nested_param_is_located() {
    let ws = Workspace::new();
    let g = ws.graph(GRAPH);
    let src = GraphSource::read(&g).unwrap();
    let err = build_plan(&src, &registry(), &[], &[]).err().unwrap();
    let text = err.to_string();
    // Line 5, column of `"stpes"`.
    let col = GRAPH.lines().nth(4).unwrap().find("\"stpes\"").unwrap() + 1;
    assert!(
        text.contains(&format!(
            "g.ron:5:{col}: node \"t\" (tuned) param `schedule.stpes`: unknown setting `stpes`; settings are rate, steps"
        )),
        "{text}"
    );
    // Nothing ran: the cache was never opened.
    assert!(!ws.cache().exists());

    // The same check on a value given by --set points at the argument.
    let fixed = GRAPH.replace("stpes", "steps");
    ws.graph(&fixed);
    let src = GraphSource::read(&g).unwrap();
    let o = Override::parse(r#"t.schedule={"rat": 1}"#).unwrap();
    let err = build_plan(&src, &registry(), &[o], &[]).err().unwrap();
    assert!(
        err.to_string()
            .contains(r#"--set t.schedule={"rat": 1}: node "t" (tuned) param `schedule.rat`: unknown setting `rat`"#),
        "{err}"
    );
    assert!(build_plan(&src, &registry(), &[], &[]).is_ok());
}
