//! The report counts a node's own run time, not the time it waited for a worker: with
//! one worker, the job that goes second waits for the first, and that wait is reported
//! apart (`queued_seconds`), for whole nodes and for fan-out items alike.

mod common;
use common::*;
use objectsplat_runtime::report::{RunReport, Status};

/// Runs `graph` on the one worker that makes its jobs wait for each other.
fn run_on_one_worker(graph: &str) -> RunReport {
    let ws = Workspace::new();
    run_graph(&ws.graph(graph), &ws.cache(), None, &[], 1)
}

const TWO_READY_NODES: &str = r#"(
  nodes: {
    "x": (kind: "const", params: (value: 1)),
    "p": (kind: "double", inputs: (x: "x.out"), params: (sleep_ms: 600)),
    "q": (kind: "double", inputs: (x: "x.out"), params: (sleep_ms: 610)),
  },
  targets: ["p", "q"],
)"#;

#[test]
fn the_second_of_two_ready_nodes_reports_its_run_and_its_wait_apart() {
    let r = run_on_one_worker(TWO_READY_NODES);
    let (p, q) = (r.node("p").unwrap(), r.node("q").unwrap());
    assert_eq!((p.status, q.status), (Status::Ran, Status::Ran));
    // (Different params: two equal keys would make one a cache hit of the other.)
    // Whichever went second waited about 0.6 s for the only worker; its own time
    // is its 0.6 s sleep, not 1.2 s.
    let (first, second) = if p.queued_seconds < q.queued_seconds {
        (p, q)
    } else {
        (q, p)
    };
    assert!(second.queued_seconds >= 0.5, "{:?}", second);
    assert!(first.queued_seconds < 0.3, "{:?}", first);
    for n in [p, q] {
        assert!(
            (0.55..1.0).contains(&n.seconds),
            "{} ran {} s",
            n.id,
            n.seconds
        );
    }
    assert!(r.render_table().contains("queued"), "{}", r.render_table());
}

/// item0 holds 1 (sleeps 700 ms), item1 holds 0 (no sleep); one worker takes them in
/// name order, so item1 waits behind item0.
const FAST_ITEM_BEHIND_A_SLOW_ONE: &str = r#"(
  nodes: {
    "s": (kind: "split", params: (values: [1, 0])),
    "d": (kind: "double", inputs: (x: each("s.items")), params: (sleep_ms_per_unit: 700)),
  },
  targets: ["d"],
)"#;

#[test]
fn a_fast_item_behind_a_slow_one_reports_its_own_short_run() {
    let r = run_on_one_worker(FAST_ITEM_BEHIND_A_SLOW_ONE);
    let d = r.node("d").unwrap();
    let item = |name: &str| d.items.iter().find(|i| i.name == name).unwrap();
    assert!(item("item1").seconds < 0.3, "{:?}", item("item1"));
    assert!(item("item1").queued_seconds >= 0.6, "{:?}", item("item1"));
    assert!(item("item0").seconds >= 0.65, "{:?}", item("item0"));
    // The node's own time is its items' time.
    let sum = item("item0").seconds + item("item1").seconds;
    assert!((d.seconds - sum).abs() < 1e-9, "{} vs {sum}", d.seconds);
}
