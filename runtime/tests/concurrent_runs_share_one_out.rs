//! Two runs writing one `--out` at the same time (a second terminal, a script) both
//! succeed and leave a whole set of outputs: the folder is locked while written and
//! each port is swapped in whole.

mod common;
use common::*;
use std::path::Path;
use std::process::Stdio;

/// Many items, so writing the outputs takes long enough for the runs to overlap.
const GRAPH: &str = r#"(
  nodes: {
    "src":   (kind: "split", params: (values: [VALUES])),
    "twice": (kind: "double", inputs: (x: each("src.items"))),
  },
  targets: ["src", "twice"],
)"#;

const ITEMS: i64 = 30;

/// Not a test: the body of the child processes below (`--ignored --exact`).
#[test]
#[ignore]
fn child_runs_the_graph_into_the_shared_out() {
    run_child_graph_from_env();
}

fn spawn(graph: &Path, cache: &Path, out: &Path) -> std::process::Child {
    let test = "child_runs_the_graph_into_the_shared_out";
    spawn_child(test, graph, cache, out, Stdio::piped())
}

fn count_items(dir: &Path) -> usize {
    std::fs::read_dir(dir).map_or(0, |d| {
        d.flatten()
            .filter(|e| e.path().join("value.txt").is_file())
            .count()
    })
}

#[test]
fn two_runs_on_one_out_both_succeed_and_leave_every_output() {
    let values: Vec<String> = (0..ITEMS).map(|v| v.to_string()).collect();
    for attempt in 0..2 {
        let ws = Workspace::new();
        let g = ws.graph(&GRAPH.replace("VALUES", &values.join(", ")));
        // One cache, as with a second terminal: the second run waits for the first
        // run's keys and reuses them, so both reach the writing of --out together.
        let a = spawn(&g, &ws.cache(), &ws.out());
        let b = spawn(&g, &ws.cache(), &ws.out());
        for (name, child) in [("first", a), ("second", b)] {
            let done = child.wait_with_output().unwrap();
            assert!(
                done.status.success(),
                "attempt {attempt}: the {name} run failed:\n{}",
                String::from_utf8_lossy(&done.stderr)
            );
        }
        assert_eq!(count_items(&ws.out().join("src/items")), ITEMS as usize);
        assert_eq!(count_items(&ws.out().join("twice/out")), ITEMS as usize);
        assert_eq!(
            std::fs::read_to_string(ws.out().join("twice/out/item7/value.txt")).unwrap(),
            "14"
        );
        let leftovers: Vec<String> = std::fs::read_dir(ws.out())
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains("staging"))
            .collect();
        assert!(leftovers.is_empty(), "{leftovers:?}");
    }
}
