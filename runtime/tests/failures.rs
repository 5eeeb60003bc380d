//! A failing node fails only its descendants; failures are never cached.

mod common;
use common::*;
use objectsplat_runtime::report::Status;

fn graph(mode: &str, flag: &std::path::Path) -> String {
    format!(
        r#"(
  nodes: {{
    "a":     (kind: "const", params: (value: 1)),
    "bad":   (kind: "flaky", inputs: (a: "a.out"), params: (mode: "{mode}", flag_file: Some({:?}))),
    "after": (kind: "add", inputs: (a: "bad.out")),
    "other": (kind: "add", inputs: (a: "a.out"), params: (offset: 10)),
  }},
)"#,
        flag.display().to_string()
    )
}

#[test]
fn failure_is_contained_and_retried_next_run() {
    for mode in ["error", "panic"] {
        let ws = Workspace::new();
        let flag = ws.dir.path().join("fail-now");
        std::fs::write(&flag, "").unwrap();
        ws.graph(&graph(mode, &flag));
        let r = ws.run(&[]);
        assert!(!r.ok);
        assert_eq!(status(&r, "bad"), Status::Failed);
        assert!(
            reason(&r, "bad").unwrap().contains("on purpose"),
            "{mode}: {}",
            r.render_table()
        );
        assert_eq!(status(&r, "after"), Status::Failed);
        assert_eq!(reason(&r, "after"), Some("upstream `bad` failed"));
        assert_eq!(status(&r, "other"), Status::Ran);
        // The branch that succeeded is still written out.
        assert_eq!(ws.num("other", "out"), 11);
        // The failure was not cached: the same graph retries it (and fails again).
        let r = ws.run(&[]);
        assert_eq!(ran(&r), Vec::<String>::new());
        assert_eq!(status(&r, "bad"), Status::Failed);
        // Once the cause is gone, exactly the failed part runs.
        std::fs::remove_file(&flag).unwrap();
        let r = ws.run(&[]);
        assert!(r.ok);
        assert_eq!(ran(&r), ["after", "bad"]);
    }
}

#[test]
fn skipped_node_without_outputs_skips_its_consumers_with_a_reason() {
    let ws = Workspace::new();
    let flag = ws.dir.path().join("skip-now");
    std::fs::write(&flag, "").unwrap();
    ws.graph(&graph("skip", &flag));
    let r = ws.run(&[]);
    assert!(r.ok, "{}", r.render_table());
    assert_eq!(status(&r, "bad"), Status::Skipped);
    assert_eq!(reason(&r, "bad"), Some("nothing to do"));
    assert_eq!(status(&r, "after"), Status::Skipped);
    assert!(
        reason(&r, "after")
            .unwrap()
            .contains("upstream `bad` skipped (nothing to do)")
    );
    // A cached skip keeps its reason.
    let r = ws.run(&[]);
    assert_eq!(status(&r, "bad"), Status::Cached);
    assert_eq!(reason(&r, "bad"), Some("skipped: nothing to do"));
}
