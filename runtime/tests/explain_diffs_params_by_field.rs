//! `explain` says which param fields changed, by path (`schedule.rate: 0.5 → 0.25`),
//! not the whole params tuple.

mod common;
use common::*;
use objectsplat_runtime::store::Store;

#[test]
fn explain_lists_each_changed_field() {
    let ws = Workspace::new();
    let g = ws.graph(
        r#"(
  nodes: {
    "x": (kind: "const", params: (value: 8)),
    "t": (kind: "tuned", inputs: (x: "x.out"), params: (schedule: {"rate": 0.5, "steps": 3}, label: "a")),
  },
  targets: ["t"],
)"#,
    );
    ws.run(&[]);
    let sets = [r#"t.schedule={"rate": 0.25, "steps": 3}"#, "t.label=b"];
    let plan = plan_graph(&g, &registry(), &sets, &[]);
    let store = Store::open(&ws.cache()).unwrap();
    let text = objectsplat_runtime::explain::explain(&plan, &store, "t").unwrap();
    let line = text.lines().find(|l| l.starts_with("t:")).unwrap();
    assert_eq!(
        line,
        r#"t: will run — params changed: label: "a" → "b"; schedule.rate: 0.5 → 0.25"#
    );
}
