//! The graph loader never panics, whatever the bytes.

mod common;
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::build_plan;
use proptest::prelude::*;

const VALID: &str = r#"(
  nodes: {
    "src":   (kind: "split", params: (values: [1, 2, 3])),
    "twice": (kind: "double", inputs: (x: each("src.items")), params: (sleep_ms: 0)),
    "total": (kind: "sum", inputs: (xs: "twice.out")),
    "a":     (kind: "const", params: (value: -4)),
    "m":     (kind: "modulo", inputs: (a: "a.out"), params: (modulus: 3)),
  },
  targets: ["total", "m"],
)"#;

fn load(text: &str) {
    let src = GraphSource {
        path: "fuzz.ron".into(),
        text: text.to_string(),
    };
    let _ = build_plan(&src, &common::registry(), &[], &[]);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, .. ProptestConfig::default() })]

    #[test]
    fn arbitrary_text_never_panics(text in "\\PC{0,200}") {
        load(&text);
    }

    #[test]
    fn mutated_valid_graphs_never_panic(pos in 0usize..VALID.len(), len in 0usize..8, insert in "[(){}\\[\\]\",:.a-z0-9 ]{0,6}") {
        let mut s = VALID.to_string();
        let start = s.floor_char_boundary(pos);
        let end = s.floor_char_boundary((start + len).min(s.len()));
        s.replace_range(start..end, &insert);
        load(&s);
    }
}

#[test]
fn the_valid_graph_loads() {
    let src = GraphSource {
        path: "fuzz.ron".into(),
        text: VALID.to_string(),
    };
    assert!(build_plan(&src, &common::registry(), &[], &[]).is_ok());
}
