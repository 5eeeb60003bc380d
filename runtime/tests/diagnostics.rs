//! Bad graphs: one clear error naming file:line:column and what was expected.

mod common;
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::{Override, build_plan};

fn errors(text: &str, sets: &[&str]) -> Vec<String> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.ron");
    std::fs::write(&path, text).unwrap();
    let src = GraphSource::read(&path).unwrap();
    let overrides: Vec<Override> = sets.iter().map(|s| Override::parse(s).unwrap()).collect();
    match build_plan(&src, &common::registry(), &overrides, &[]) {
        Ok(_) => vec![],
        Err(d) => {
            d.0.iter()
                .map(|e| e.headline().replace(&path.display().to_string(), "bad.ron"))
                .collect()
        }
    }
}

fn one(text: &str) -> String {
    let e = errors(text, &[]);
    assert_eq!(e.len(), 1, "expected exactly one error, got {e:#?}");
    e[0].clone()
}

fn assert_one_error(text: &str, expected: &str) {
    assert_eq!(one(text), expected);
}

#[test]
fn syntax_error() {
    assert_one_error(
        "(\n  nodes: {\n    \"a\": (kind: \"const\" params: ()),\n  },\n)",
        "bad.ron:3:25: syntax error: expected `,` or `)` after a field, found 'p'",
    );
}

#[test]
fn unknown_kind_suggests_a_close_one() {
    assert_one_error(
        "(nodes: {\n  \"a\": (kind: \"constt\"),\n})",
        "bad.ron:2:15: unknown node kind \"constt\"; did you mean `const`? (`objectsplat nodes` lists every kind)",
    );
}

#[test]
fn unknown_input_port() {
    assert_one_error(
        "(nodes: {\n  \"a\": (kind: \"const\"),\n  \"b\": (kind: \"add\", inputs: (a: \"a.out\", c: \"a.out\")),\n})",
        "bad.ron:3:43: node \"b\" (add) has no input port `c`; did you mean one of `a`, `b`?; its inputs are `a`, `b`",
    );
}

#[test]
fn unknown_output_port() {
    assert_one_error(
        "(nodes: {\n  \"a\": (kind: \"const\"),\n  \"b\": (kind: \"add\", inputs: (a: \"a.ou\")),\n})",
        "bad.ron:3:34: node \"a\" (const) has no output port `ou`; did you mean `out`?; its outputs are `out`",
    );
}

#[test]
fn missing_required_input() {
    let e = one("(nodes: {\n  \"b\": (kind: \"add\"),\n})");
    assert!(
        e.starts_with("bad.ron:2:8: node \"b\" (add) is missing required input `a` (type Num)"),
        "{e}"
    );
}

#[test]
fn type_mismatch_suggests_each() {
    assert_one_error(
        "(nodes: {\n  \"s\": (kind: \"split\", params: (values: [1])),\n  \"d\": (kind: \"double\", inputs: (x: \"s.items\")),\n})",
        "bad.ron:3:37: type mismatch: node \"d\" input `x` expects Num, but \"s.items\" is [Num]; to run once per item write each(\"s.items\")",
    );
    let e = one(
        "(nodes: {\n  \"a\": (kind: \"const\"),\n  \"d\": (kind: \"sum\", inputs: (xs: \"a.out\")),\n})",
    );
    assert!(e.contains("expects [Num], but \"a.out\" is Num"), "{e}");
}

#[test]
fn cycle() {
    let e = one(
        "(nodes: {\n  \"a\": (kind: \"add\", inputs: (a: \"b.out\")),\n  \"b\": (kind: \"add\", inputs: (a: \"a.out\")),\n})",
    );
    assert!(
        e.contains("is part of a cycle; a graph must be acyclic"),
        "{e}"
    );
    assert!(
        e.starts_with("bad.ron:2:3:") || e.starts_with("bad.ron:3:3:"),
        "{e}"
    );
}

#[test]
fn unknown_param() {
    assert_one_error(
        "(nodes: {\n  \"a\": (kind: \"const\", params: (valeu: 1)),\n})",
        "bad.ron:2:33: node \"a\" (const) has no param `valeu`; did you mean `value`?; its params are `value`",
    );
}

#[test]
fn ill_typed_param() {
    assert_one_error(
        "(nodes: {\n  \"a\": (kind: \"const\", params: (value: \"three\")),\n})",
        "bad.ron:2:40: node \"a\" param `value`: expected an integer, found a string (expected an integer)",
    );
    let e = one(
        "(nodes: {\n  \"a\": (kind: \"const\"),\n  \"m\": (kind: \"modulo\", inputs: (a: \"a.out\"), params: (modulus: 0)),\n})",
    );
    assert!(e.contains("param `modulus`: 0 is out of range ≥ 1"), "{e}");
}

#[test]
fn dangling_reference() {
    assert_one_error(
        "(nodes: {\n  \"b\": (kind: \"add\", inputs: (a: \"nope.out\")),\n})",
        "bad.ron:2:34: node \"b\" input `a` refers to node \"nope\", which does not exist",
    );
    let e = one("(nodes: {\n  \"a\": (kind: \"const\"),\n},\ntargets: [\"z\"])");
    assert!(
        e.starts_with("bad.ron:4:11: target \"z\" is not a node of this graph"),
        "{e}"
    );
}

#[test]
fn bad_override_is_reported_against_the_argument() {
    let e = errors("(nodes: {\n  \"a\": (kind: \"const\"),\n})", &["a.vlue=3"]);
    assert_eq!(
        e,
        ["--set a.vlue=3: node `a` (const) has no param `vlue`; it has `value`"]
    );
    let e = errors(
        "(nodes: {\n  \"a\": (kind: \"const\"),\n})",
        &["a.value=\"x\""],
    );
    assert_eq!(
        e,
        [
            "--set a.value=\"x\": node \"a\" param `value`: expected an integer, found a string (expected an integer)"
        ]
    );
    assert!(Override::parse("a.value").is_err());
}

#[test]
fn independent_problems_are_all_reported() {
    let e = errors(
        "(nodes: {\n  \"a\": (kind: \"nope\"),\n  \"b\": (kind: \"const\", params: (x: 1)),\n})",
        &[],
    );
    assert_eq!(e.len(), 2, "{e:#?}");
}

#[test]
fn a_graph_that_is_not_utf8_is_refused_at_the_offending_byte() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("latin1.ron");
    // "é" in Latin-1 (0xe9) inside a string on line 2, column 17.
    let mut bytes = b"(nodes: {\n  \"a\": (kind: \"caf".to_vec();
    bytes.push(0xe9);
    bytes.extend_from_slice(b"\"),\n})");
    std::fs::write(&path, bytes).unwrap();
    let e = GraphSource::read(&path).unwrap_err();
    assert_eq!(e.0.len(), 1);
    let headline = e.0[0]
        .headline()
        .replace(&path.display().to_string(), "latin1.ron");
    assert_eq!(
        headline,
        "latin1.ron:2:19: the graph file is not UTF-8 text (byte 0xe9 at offset 28); save it as UTF-8"
    );
}

#[test]
fn a_huge_offending_line_is_quoted_around_the_error_only() {
    // A generated graph with every node on one 2 MB line and one mistake near its end.
    let mut text = String::from("(nodes: {");
    let mut i = 0;
    while text.len() < 2_000_000 {
        text.push_str(&format!(
            "\"n{i}\": (kind: \"const\", params: (value: {i})), "
        ));
        i += 1;
    }
    text.push_str("\"bad\": (kind: \"constt\"), \"m\": (kind: \"const\")})");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("wide.ron");
    std::fs::write(&path, &text).unwrap();
    let src = GraphSource::read(&path).unwrap();
    let e = match build_plan(&src, &common::registry(), &[], &[]) {
        Ok(_) => panic!("the mistake must be reported"),
        Err(e) => e,
    };
    let shown = e.to_string();
    assert!(shown.len() < 1000, "{} bytes shown", shown.len());
    assert!(shown.contains("unknown node kind \"constt\""), "{shown}");
    // The caret sits under the kind, inside the quoted window.
    let lines: Vec<&str> = shown.lines().collect();
    let (code, caret) = (lines[1], lines[2]);
    let at = caret.find('^').expect("a caret line"); // spaces before it: chars = bytes
    let under: String = code.chars().skip(at).take(8).collect();
    assert_eq!(under, "\"constt\"", "{code}\n{caret}");
    assert!(code.contains('…'), "{code}");
}
