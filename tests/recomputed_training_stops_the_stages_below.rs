//! Early cutoff through training: a `train` item evicted from the cache is recomputed on
//! the next run and writes the very same model (a Model holds no clock reading), so the
//! stages below it — compose, render, evaluate — keep their keys and are served from the
//! cache. Asserted from what the run report records as ran and cached.

mod support;

use objectsplat_runtime::store::Store;
use serde_json::Value;
use std::path::Path;
use support::objectsplat::{assert_ok, objectsplat, read_json, report_node, run_graph_ron};
use support::tiny_room;

/// The tiny trained room composed, rendered and evaluated.
fn graph() -> String {
    tiny_room::graph(
        r#"    "composed": (kind: "compose", inputs: (models: "train.model")),
    "renders":  (kind: "render", inputs: (scene: "composed.scene", frames: "scene.frames"), params: (views: "test")),
    "metrics":  (kind: "evaluate", inputs: (images: "renders.images", frames: "scene.frames", scene: "composed.scene",
                 mesh: "scene.mesh", masks: "masks.masks")),"#,
        r#"["metrics"]"#,
    )
}

const BELOW_TRAINING: [&str; 3] = ["composed", "renders", "metrics"];

fn run(dir: &Path) -> Value {
    assert_ok(&objectsplat(dir, &run_graph_ron(&[])), "the run");
    read_json(&dir.join("report.json"))
}

/// (item name, status) of every item of `train`.
fn train_items(report: &Value) -> Vec<(String, String)> {
    report_node(report, "train")["items"]
        .as_array()
        .unwrap()
        .iter()
        .map(|i| {
            (
                i["name"].as_str().unwrap().into(),
                i["status"].as_str().unwrap().into(),
            )
        })
        .collect()
}

/// Deletes the action record of `train`'s item `item`, as a cache eviction would: its key
/// then misses (the layout is `actions/<first two hex digits>/<key>.json`).
fn evict_train_item(dir: &Path, item: &str) {
    let cache = dir.join("cache");
    let keys = Store::open(&cache)
        .unwrap()
        .head(Path::new("graph.ron"), "train")
        .expect("the graph's last keys of `train`");
    let key = &keys[item];
    let record = cache
        .join("actions")
        .join(&key[..2])
        .join(format!("{key}.json"));
    std::fs::remove_file(&record).unwrap_or_else(|e| panic!("{}: {e}", record.display()));
}

#[test]
fn an_evicted_train_item_is_retrained_and_nothing_below_it_reruns() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(dir.join("graph.ron"), graph()).unwrap();
    let first = run(dir);
    for id in BELOW_TRAINING {
        assert_eq!(report_node(&first, id)["status"], "ran", "{id}");
    }
    let metrics = std::fs::read(dir.join("out/metrics/metrics/metrics.json")).unwrap();

    evict_train_item(dir, "background");
    let again = run(dir);
    let items = train_items(&again);
    assert!(items.len() >= 3, "background, box and ball: {items:?}");
    for (name, status) in &items {
        let want = if name == "background" {
            "ran"
        } else {
            "cached"
        };
        assert_eq!(status, want, "train[{name}]");
    }
    assert_eq!(
        report_node(&again, "train")["outputs"],
        report_node(&first, "train")["outputs"],
        "the retrained item wrote the same bytes"
    );
    for id in BELOW_TRAINING {
        assert_eq!(report_node(&again, id)["status"], "cached", "{id}");
    }
    assert_eq!(
        std::fs::read(dir.join("out/metrics/metrics/metrics.json")).unwrap(),
        metrics
    );
}
