//! `--set NODE.PARAM=word` takes a bare word (or text that is not RON) as a string
//! where the param takes one (enum, string, path; optional or not); elsewhere the value
//! must be RON and the error says so.

mod common;
use common::*;
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::{Override, build_plan};
use objectsplat_runtime::report::Status;

const GRAPH: &str = r#"(
  nodes: {
    "a": (kind: "const", params: (value: 1)),
    "f": (kind: "flaky", inputs: (a: "a.out")),
  },
  targets: ["f"],
)"#;

#[test]
fn a_bare_word_sets_an_enum_param() {
    let ws = Workspace::new();
    ws.graph(GRAPH);
    // `mode` is enum(ok|error|panic|skip): `skip` without quotes.
    let r = ws.run(&["f.mode=skip"]);
    assert_eq!(status(&r, "f"), Status::Skipped);
    // The quoted spelling is the same value (same cache key: nothing reruns).
    let r = ws.run(&["f.mode=\"skip\""]);
    assert!(ran(&r).is_empty(), "{:?}", ran(&r));
}

#[test]
fn text_that_is_not_ron_is_a_string_for_a_string_param_only() {
    let ws = Workspace::new();
    let g = ws.graph(GRAPH);
    let src = GraphSource::read(&g).unwrap();
    let plan = |set: &str| build_plan(&src, &registry(), &[Override::parse(set).unwrap()], &[]);
    // optional(string): a path-like word is Some("data/flag.txt"); None stays None.
    let p = plan("f.flag_file=data/flag.txt").unwrap();
    let f = &p.nodes[p.index("f").unwrap()];
    assert_eq!(
        f.params.get::<Option<String>>("flag_file").unwrap(),
        Some("data/flag.txt".to_string())
    );
    let p = plan("f.flag_file=None").unwrap();
    let f = &p.nodes[p.index("f").unwrap()];
    assert_eq!(f.params.get::<Option<String>>("flag_file").unwrap(), None);
    // An enum still refuses a word that is not one of its options.
    let err = plan("f.mode=skpi").err().unwrap().to_string();
    assert!(
        err.contains(r#"--set f.mode=skpi: node "f" param `mode`: "skpi" is not one of "ok", "error", "panic", "skip""#),
        "{err}"
    );
    // An int param gets no string: the error says the value is not RON.
    let err = plan("a.value=two/3").err().unwrap().to_string();
    assert!(
        err.contains("--set a.value=two/3: node \"a\" param `value`: value is not RON")
            && err.contains("a bare word is read as a string only where the param takes one"),
        "{err}"
    );
    let err = plan("a.value=two").err().unwrap().to_string();
    assert!(
        err.contains("node \"a\" param `value`: expected an integer, found an identifier"),
        "{err}"
    );
}
