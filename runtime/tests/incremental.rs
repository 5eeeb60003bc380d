//! Execution-log tests: after a change, exactly the invalidated work reruns.

mod common;
use common::*;

const CHAIN: &str = r#"(
  nodes: {
    "a":   (kind: "const", params: (value: 3)),
    "b":   (kind: "const", params: (value: 4)),
    "sum": (kind: "add", inputs: (a: "a.out", b: "b.out")),
    "mod": (kind: "modulo", inputs: (a: "sum.out")),
    "top": (kind: "add", inputs: (a: "mod.out"), params: (offset: 1)),
    "side":(kind: "add", inputs: (a: "b.out")),
  },
  targets: ["top", "side"],
)"#;

/// A workspace holding [`CHAIN`], run once.
fn chain_after_a_run() -> Workspace {
    let ws = Workspace::new();
    ws.graph(CHAIN);
    ws.run(&[]);
    ws
}

#[test]
fn first_run_runs_everything_second_run_nothing() {
    let ws = Workspace::new();
    ws.graph(CHAIN);
    assert_eq!(ran(&ws.run(&[])), ["a", "b", "mod", "side", "sum", "top"]);
    assert_eq!(ws.num("top", "out"), 8);
    assert!(ran(&ws.run(&[])).is_empty());
}

#[test]
fn a_param_change_reruns_exactly_that_node_and_its_descendants() {
    let ws = chain_after_a_run();
    let r = ws.run(&["a.value=5"]);
    assert_eq!(ran(&r), ["a", "mod", "sum", "top"]);
    assert_eq!(ws.num("top", "out"), 10);
    // Going back is a cache hit all the way.
    assert!(ran(&ws.run(&[])).is_empty());
    assert_eq!(ws.num("top", "out"), 8);
}

#[test]
fn identical_output_does_not_invalidate_consumers() {
    let ws = chain_after_a_run();
    // 7 % 1000 == 7 % 100: `mod` reruns, its output bytes are unchanged, `top` stays cached.
    let r = ws.run(&["mod.modulus=100"]);
    assert_eq!(ran(&r), ["mod"]);
    assert_eq!(
        status(&r, "top"),
        objectsplat_runtime::report::Status::Cached
    );
}

const FAN: &str = r#"(
  nodes: {
    "src":   (kind: "split", params: (values: [1, 2, 3])),
    "twice": (kind: "double", inputs: (x: each("src.items"))),
    "total": (kind: "sum", inputs: (xs: "twice.out")),
  },
)"#;

#[test]
fn changing_one_item_reruns_only_that_item() {
    let ws = Workspace::new();
    ws.graph(FAN);
    let r = ws.run(&[]);
    assert_eq!(
        ran(&r),
        [
            "src",
            "total",
            "twice[item0]",
            "twice[item1]",
            "twice[item2]"
        ]
    );
    assert_eq!(ws.num("total", "out"), 12);
    let r = ws.run(&["src.values=[1, 5, 3]"]);
    assert_eq!(ran(&r), ["src", "total", "twice[item1]"]);
    assert_eq!(ws.num("total", "out"), 18);
    // Adding an item runs only the new one.
    let r = ws.run(&["src.values=[1, 5, 3, 4]"]);
    assert_eq!(ran(&r), ["src", "total", "twice[item3]"]);
    let items = &r.node("twice").unwrap().items;
    assert_eq!(items.len(), 4);
}

#[test]
fn a_collection_does_not_depend_on_the_order_its_items_finish() {
    let ws = Workspace::new();
    // item0 sleeps 300 ms, item1 3 ms: with two workers item1 finishes first.
    ws.graph(
        &FAN.replace(
            "(kind: \"double\", inputs: (x: each(\"src.items\")))",
            "(kind: \"double\", inputs: (x: each(\"src.items\")), params: (sleep_ms_per_unit: 10))",
        )
        .replace("values: [1, 2, 3]", "values: [30, 0]"),
    );
    let first = ws.run(&[]);
    let second = ws.run(&[]);
    assert_eq!(
        first.node("twice").unwrap().outputs,
        second.node("twice").unwrap().outputs
    );
    assert!(ran(&second).is_empty(), "{:?}", ran(&second));
}

#[test]
fn fan_out_outputs_are_materialized_one_folder_per_item() {
    let ws = Workspace::new();
    ws.graph(
        &FAN.replace(")\"#", "")
            .replace("  },\n)", "  },\n  targets: [\"twice\"],\n)"),
    );
    ws.run(&[]);
    let mut names: Vec<String> = std::fs::read_dir(ws.out().join("twice").join("out"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["item0", "item1", "item2"]);
}

#[test]
fn only_ancestors_of_the_targets_run() {
    let ws = Workspace::new();
    ws.graph(CHAIN);
    let plan = plan_graph(&ws.dir.path().join("g.ron"), &registry(), &[], &["sum"]);
    let r = execute(&plan, &ws.cache(), None, 2);
    assert_eq!(ran(&r), ["a", "b", "sum"]);
}

#[test]
fn explain_names_the_changed_param() {
    let ws = Workspace::new();
    let g = ws.graph(CHAIN);
    ws.run(&[]);
    let plan = plan_graph(&g, &registry(), &["b.value=9"], &[]);
    let store = objectsplat_runtime::store::Store::open(&ws.cache()).unwrap();
    let text = objectsplat_runtime::explain::explain(&plan, &store, "sum").unwrap();
    assert!(text.contains("a: cached"), "{text}");
    assert!(
        text.contains("b: will run — params changed: value: 4 → 9"),
        "{text}"
    );
    assert!(
        text.contains("sum: will run if `b` produces new outputs"),
        "{text}"
    );
}
