//! A cached rerun reports the time each output took in the run that produced it
//! (stored with the action), marked as cached, not 0 s.

mod common;
use common::*;
use objectsplat_runtime::report::Status;

#[test]
fn a_cached_node_reports_the_producing_runs_time() {
    let ws = Workspace::new();
    ws.graph(
        r#"(
  nodes: {
    "x": (kind: "const", params: (value: 2)),
    "slow": (kind: "double", inputs: (x: "x.out"), params: (sleep_ms: 300)),
    "s": (kind: "split", params: (values: [1, 2])),
    "d": (kind: "double", inputs: (x: each("s.items")), params: (sleep_ms_per_unit: 100)),
  },
  targets: ["slow", "d"],
)"#,
    );
    let first = ws.run(&[]);
    let slow = first.node("slow").unwrap();
    assert_eq!(slow.status, Status::Ran);
    assert!(slow.seconds >= 0.3, "{slow:?}");

    let again = ws.run(&[]);
    let cached = again.node("slow").unwrap();
    assert_eq!(cached.status, Status::Cached);
    assert_eq!(
        cached.seconds, slow.seconds,
        "the producing run's time, as stored"
    );
    assert_eq!(cached.queued_seconds, 0.0);
    let (d1, d2) = (first.node("d").unwrap(), again.node("d").unwrap());
    assert_eq!(d2.status, Status::Cached);
    for (a, b) in d1.items.iter().zip(&d2.items) {
        assert_eq!(
            (b.status, b.seconds),
            (Status::Cached, a.seconds),
            "{}",
            a.name
        );
    }
    assert_eq!(d2.seconds, d1.seconds);
    let table = again.render_table();
    let line = table
        .lines()
        .find(|l| l.trim_start().starts_with("slow"))
        .unwrap();
    assert!(
        line.contains(&format!("cached  {:>8.2}s (when produced)", slow.seconds)),
        "{line}"
    );
}
