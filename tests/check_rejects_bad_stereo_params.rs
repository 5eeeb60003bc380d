//! `objectsplat check` refuses `stereo_points` params that cannot work together before
//! anything runs: an even correlation window, and more agreeing neighbours required than
//! neighbours matched — each named at its param's file, line and column.

mod support;
use support::objectsplat::{assert_ok, objectsplat, stderr};

const GRAPH: &str = r#"(
  nodes: {
    "scene":  (kind: "synthetic_scene", params: (views: 8, width: 32, height: 24)),
    "dense":  (kind: "stereo_points", inputs: (frames: "scene.frames", points: "scene.points"),
               params: (neighbours: 3, min_consistent: 4, window: 6)),
  },
  targets: ["dense"],
)"#;

#[test]
fn stereo_params_that_contradict_each_other_are_named_at_their_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("graph.ron"), GRAPH).unwrap();
    let out = objectsplat(d, &["check", "graph.ron"]);
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    let line = GRAPH.lines().nth(4).unwrap();
    for (param, says) in [
        ("min_consistent", "4 exceeds `neighbours` (3)"),
        ("window", "6 is even"),
    ] {
        // The column of the value.
        let key = format!("{param}: ");
        let col = line.find(&key).unwrap() + key.len() + 1;
        assert!(
            err.contains(&format!(
                "graph.ron:5:{col}: node \"dense\" (stereo_points) param `{param}`: {says}"
            )),
            "{err}"
        );
    }
    assert!(!err.contains("panicked"));

    let fixed = GRAPH.replace(
        "min_consistent: 4, window: 6",
        "min_consistent: 2, window: 7",
    );
    std::fs::write(d.join("graph.ron"), fixed).unwrap();
    assert_ok(
        &objectsplat(d, &["check", "graph.ron"]),
        "check with consistent params",
    );
}
