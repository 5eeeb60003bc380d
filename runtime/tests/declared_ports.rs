//! A node kind whose ports its params declare (`Node::declared_ports`): the graph wires
//! and type-checks them like any ports, the node runs with them, and a bad declaration is
//! an error at the declaring param's file:line:column.

mod common;
use common::{Workspace, ran};
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::build_plan;

fn errors(text: &str) -> Vec<String> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.ron");
    std::fs::write(&path, text).unwrap();
    let src = GraphSource::read(&path).unwrap();
    match build_plan(&src, &common::registry(), &[], &[]) {
        Ok(_) => vec![],
        Err(d) => {
            d.0.iter()
                .map(|e| e.headline().replace(&path.display().to_string(), "bad.ron"))
                .collect()
        }
    }
}

#[test]
fn declared_ports_are_wired_and_run() {
    let ws = Workspace::new();
    ws.graph(
        r#"(nodes: {
  "a": (kind: "const", params: (value: 2)),
  "b": (kind: "const", params: (value: 40)),
  "s": (kind: "sum_of", inputs: (left: "a.out", right: "b.out"), params: (terms: ["left", "right"])),
})"#,
    );
    let r = ws.run(&[]);
    assert_eq!(ws.num("s", "out"), 42);
    assert_eq!(ran(&r), ["a", "b", "s"]);
    // The declaration is part of the key: the same value read through other names reruns.
    let r = ws.run(&["s.terms=[\"right\", \"left\"]"]);
    assert_eq!(ran(&r), ["s"]);
}

#[test]
fn an_undeclared_port_is_an_unknown_port() {
    let e = errors(
        "(nodes: {\n  \"a\": (kind: \"const\"),\n  \"s\": (kind: \"sum_of\", inputs: (x: \"a.out\", y: \"a.out\"), params: (terms: [\"x\"])),\n})",
    );
    assert_eq!(
        e,
        [
            "bad.ron:3:46: node \"s\" (sum_of) has no input port `y`; did you mean `x`?; its inputs are `x`"
        ]
    );
}

#[test]
fn a_missing_declared_input_is_reported() {
    let e = errors(
        "(nodes: {\n  \"a\": (kind: \"const\"),\n  \"s\": (kind: \"sum_of\", inputs: (x: \"a.out\"), params: (terms: [\"x\", \"z\"])),\n})",
    );
    assert_eq!(e.len(), 1, "{e:?}");
    assert!(
        e[0].starts_with(
            "bad.ron:3:8: node \"s\" (sum_of) is missing required input `z` (type Num)"
        ),
        "{e:?}"
    );
}

#[test]
fn bad_declarations_point_at_the_declaring_param() {
    let e = errors(
        "(nodes: {\n  \"a\": (kind: \"const\"),\n  \"s\": (kind: \"sum_of\", inputs: (x: \"a.out\"), params: (terms: [\"x\"], term_type: \"Nun\")),\n})",
    );
    assert_eq!(
        e,
        [
            "bad.ron:3:81: node \"s\" (sum_of) declares port `x` of unknown type `Nun`; did you mean `Num`?"
        ]
    );
    let e = errors("(nodes: {\n  \"s\": (kind: \"sum_of\", params: (terms: [])),\n})");
    assert_eq!(
        e,
        ["bad.ron:2:41: node \"s\" (sum_of) param `terms`: declare at least one term"]
    );
}
