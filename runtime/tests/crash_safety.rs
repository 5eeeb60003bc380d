//! Crash safety: killed runs, corrupted entries and concurrent runs never serve bad data.

mod common;
use common::*;
use objectsplat_runtime::report::RunReport;
use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

const SLOW: &str = r#"(
  nodes: {
    "src":   (kind: "split", params: (values: [1, 2, 3, 4])),
    "twice": (kind: "double", inputs: (x: each("src.items")), params: (sleep_ms: 300)),
    "total": (kind: "sum", inputs: (xs: "twice.out")),
  },
)"#;

/// Not a test: the body of the child processes the tests below start (`--ignored --exact`).
#[test]
#[ignore]
fn child_process_runs_a_graph() {
    run_child_graph_from_env();
}

fn spawn_run(graph: &Path, cache: &Path, out: &Path) -> std::process::Child {
    spawn_child(
        "child_process_runs_a_graph",
        graph,
        cache,
        out,
        Stdio::null(),
    )
}

fn count_files(dir: &Path) -> usize {
    walk(dir).len()
}

fn walk(dir: &Path) -> Vec<std::path::PathBuf> {
    let mut v = Vec::new();
    if let Ok(rd) = std::fs::read_dir(dir) {
        for e in rd.flatten() {
            let p = e.path();
            if p.is_dir() {
                v.extend(walk(&p))
            } else {
                v.push(p)
            }
        }
    }
    v
}

/// A workspace whose [`SLOW`] graph, without the sleep, ran once.
fn ran_once() -> Workspace {
    let ws = Workspace::new();
    ws.graph(SLOW.replace("sleep_ms: 300", "sleep_ms: 0").as_str());
    assert!(ws.run(&[]).ok);
    ws
}

fn assert_warned_of_corruption(r: &RunReport, detail: &str) {
    assert!(
        r.warnings
            .iter()
            .any(|w| w.contains("corrupt") && w.contains(detail)),
        "{:?}",
        r.warnings
    );
}

#[test]
fn a_killed_run_leaves_no_corrupt_entry_and_its_finished_work_is_reused() {
    let ws = Workspace::new();
    let g = ws.graph(SLOW);
    let mut child = spawn_run(&g, &ws.cache(), &ws.out());
    // Wait until `src` and at least one item have finished (three action records: split, item, …).
    let t0 = Instant::now();
    while count_files(&ws.cache().join("actions")) < 2 {
        assert!(
            t0.elapsed() < Duration::from_secs(60),
            "child made no progress"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap(); // SIGKILL
    child.wait().unwrap();
    let finished_before = count_files(&ws.cache().join("actions"));
    assert!(
        finished_before < 6,
        "the child finished everything before it was killed"
    );

    let r = ws.run(&[]);
    assert!(r.ok, "{}", r.render_table());
    assert_eq!(ws.num("total", "out"), 20);
    let log = ran(&r);
    assert!(
        !log.contains(&"src".to_string()),
        "finished work was not reused: {log:?}"
    );
    assert_eq!(log.len(), 6 - finished_before, "{log:?}");
    // The dead run's staging area was cleaned up.
    let leftovers: Vec<_> = std::fs::read_dir(ws.cache().join("tmp"))
        .unwrap()
        .flatten()
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn a_corrupted_blob_is_detected_and_recomputed_with_a_warning() {
    let ws = ran_once();
    for blob in walk(&ws.cache().join("blobs")) {
        let mut bytes = std::fs::read(&blob).unwrap();
        bytes[0] ^= 0x5a;
        std::fs::write(&blob, bytes).unwrap();
    }
    let r = ws.run(&[]);
    assert!(r.ok, "{}", r.render_table());
    assert_warned_of_corruption(&r, "checksum mismatch");
    assert_eq!(ws.num("total", "out"), 20);
    // And the recomputed entries are sound: the next run is a clean cache hit.
    let r = ws.run(&[]);
    assert!(
        r.warnings.is_empty() && ran(&r).is_empty(),
        "{:?} {:?}",
        r.warnings,
        ran(&r)
    );
}

#[test]
fn a_corrupted_action_record_is_detected_and_the_node_reruns() {
    let ws = ran_once();
    for rec in walk(&ws.cache().join("actions")) {
        let text = std::fs::read_to_string(&rec).unwrap();
        std::fs::write(&rec, text.replace("\"ran\"", "\"rab\"")).unwrap();
    }
    let r = ws.run(&[]);
    assert!(r.ok);
    assert_warned_of_corruption(&r, "action record");
    assert_eq!(ran(&r).len(), 6);
    assert_eq!(ws.num("total", "out"), 20);
}

#[test]
fn two_concurrent_runs_on_one_cache_both_succeed_consistently() {
    let ws = Workspace::new();
    let g = ws.graph(SLOW.replace("sleep_ms: 300", "sleep_ms: 50").as_str());
    let out2 = ws.dir.path().join("out2");
    let mut a = spawn_run(&g, &ws.cache(), &ws.out());
    let mut b = spawn_run(&g, &ws.cache(), &out2);
    assert!(a.wait().unwrap().success());
    assert!(b.wait().unwrap().success());
    assert_eq!(ws.num("total", "out"), 20);
    assert_eq!(
        std::fs::read_to_string(out2.join("total/out/value.txt")).unwrap(),
        "20"
    );
    // Whatever interleaving happened, the cache is whole: a third run is all hits.
    let r = ws.run(&[]);
    assert!(ran(&r).is_empty() && r.warnings.is_empty());
}
