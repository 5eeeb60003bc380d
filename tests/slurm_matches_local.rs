//! `--executor slurm` computes what `--executor local` computes: the demo graph at a
//! short training budget (every `train` node at 60 iterations: a few minutes on 2
//! cores) run both ways into two caches gives the same outputs.
//!
//! Not every byte can agree, and not because of the executor: a training log records
//! wall-clock time (`training.json`'s `wall_seconds`), so two *local* runs differ there
//! too. The nodes that carry such logs are found by kind, not by name: every `train`
//! node (the demo trains the objects first, then the background behind them, whose
//! models pass the objects' through) and the `report` page that plots the logs and
//! carries the run summary. Every other node's output digests must agree; the trained
//! models are compared byte for byte and their logs with `wall_seconds` taken out; the
//! report page is left out, and so are the run summaries beside the outputs (`run.json`,
//! `run.js`). Each `train` node's fan-out runs as one Slurm job array.
//!
//! Needs the local cluster (`scripts/slurm-local-cluster.sh up`); CI starts it.

mod support;

use objectsplat_core::artifact::{MODEL_PLY, TRAINING_JSON};
use objectsplat_report::{RUN_DATA_FILE, RUN_SCRIPT_FILE};
use objectsplat_runtime::graph::{GraphSource, parse_graph};
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use support::objectsplat::{assert_ok, file_tree, objectsplat, read_json};
use support::plugin_build::workspace;
use support::slurm::*;

/// The run's own summary beside its outputs: times and executors differ by design.
const RUN_FILES: [&str; 2] = [RUN_DATA_FILE, RUN_SCRIPT_FILE];

/// `v` without the wall-clock fields (`wall_seconds`) anywhere in it.
fn without_times(v: serde_json::Value) -> serde_json::Value {
    match v {
        serde_json::Value::Object(m) => m
            .into_iter()
            .filter(|(k, _)| k != "wall_seconds")
            .map(|(k, v)| (k, without_times(v)))
            .collect(),
        serde_json::Value::Array(a) => a.into_iter().map(without_times).collect(),
        other => other,
    }
}

/// Kinds whose outputs carry wall-clock times (see the module doc).
const TIMED_KINDS: [&str; 2] = ["train", "report"];

/// The ids of the graph's nodes of `kind`.
fn nodes_of_kind(graph: &Path, kind: &str) -> Vec<String> {
    let source = GraphSource::read(graph).expect("the demo graph reads");
    let decl = parse_graph(&source).expect("the demo graph parses");
    decl.nodes
        .into_iter()
        .filter(|n| n.kind == kind)
        .map(|n| n.id)
        .collect()
}

#[test]
fn the_demo_graph_on_slurm_gives_byte_identical_outputs() {
    if !cluster_up("the_demo_graph_on_slurm_gives_byte_identical_outputs") {
        return;
    }
    let dir = test_dir("matches_local");
    let demo_path = workspace().join("graphs/demo.ron");
    let demo = demo_path.to_str().unwrap();
    let trainers = nodes_of_kind(&demo_path, "train");
    assert!(
        trainers.len() >= 2,
        "the demo trains objects, then the background: {trainers:?}"
    );
    // The demo as shipped, at a short training budget.
    let budget: Vec<String> = trainers
        .iter()
        .flat_map(|t| ["--set".to_string(), format!("{t}.iterations=60")])
        .collect();
    let small: Vec<&str> = budget.iter().map(String::as_str).collect();
    let run = |executor: &str| {
        let mut args = vec!["run", demo, "--cache"];
        let (cache, out, json) = (
            format!("cache-{executor}"),
            format!("out-{executor}"),
            format!("{executor}.json"),
        );
        args.extend([
            cache.as_str(),
            "--out",
            out.as_str(),
            "--json",
            json.as_str(),
        ]);
        args.extend(&small);
        args.extend(["--executor", executor]);
        if executor == "slurm" {
            args.extend(["--slurm-poll", "1", "--slurm-job-name", "ostest-demo"]);
        }
        let result = objectsplat(&dir, &args);
        assert_ok(&result, &format!("the demo with --executor {executor}"));
        read_json(&dir.join(json))
    };
    let (local, slurm) = (run("local"), run("slurm"));

    // Every node's output digests agree, but for those of the kinds that carry
    // wall-clock times (compared below with the times taken out).
    let digests = |r: &serde_json::Value| -> BTreeMap<String, serde_json::Value> {
        r["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|n| !TIMED_KINDS.contains(&n["kind"].as_str().unwrap()))
            .map(|n| (n["id"].as_str().unwrap().to_string(), n["outputs"].clone()))
            .collect()
    };
    let untimed = digests(&local);
    assert_eq!(untimed, digests(&slurm));
    assert!(untimed.len() >= 10, "{:?}", untimed.keys());
    assert!(untimed.contains_key("viewer") && untimed.contains_key("composed"));
    assert!(
        untimed
            .values()
            .all(|o| o.as_object().is_some_and(|o| !o.is_empty()))
    );

    // The trained models themselves, byte for byte; their logs without the times.
    for executor in ["local", "slurm"] {
        let mut args = vec!["run", demo, "--cache"];
        let (cache, out) = (format!("cache-{executor}"), format!("models-{executor}"));
        args.extend([cache.as_str(), "--out", out.as_str()]);
        for t in &trainers {
            args.extend(["--target", t.as_str()]);
        }
        args.extend(&small);
        let result = objectsplat(&dir, &args);
        assert_ok(&result, "materializing the cached models");
        assert!(
            String::from_utf8_lossy(&result.stderr).contains(" 0 ran,"),
            "the models come from the cache: {}",
            String::from_utf8_lossy(&result.stderr)
        );
    }
    let (a, b) = (
        file_tree(&dir.join("models-local")),
        file_tree(&dir.join("models-slurm")),
    );
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    for t in &trainers {
        let models = a
            .keys()
            .filter(|k| k.starts_with(&format!("{t}/")) && k.ends_with(MODEL_PLY))
            .count();
        assert!(models >= 1, "no models of {t}: {:?}", a.keys());
    }
    let logs = a.keys().filter(|k| k.ends_with(TRAINING_JSON)).count();
    assert!(logs >= 5, "{:?}", a.keys());
    for (name, bytes) in &a {
        if RUN_FILES.contains(&name.as_str()) {
            continue;
        }
        if name.ends_with(TRAINING_JSON) {
            let untimed = |bytes: &[u8]| without_times(serde_json::from_slice(bytes).unwrap());
            assert_eq!(untimed(bytes), untimed(&b[name]), "{name}");
        } else {
            assert!(*bytes == b[name], "{name} differs");
        }
    }

    // Every training item ran as a job of its node's one array; everything else in
    // the coordinator.
    let mut all_arrays = BTreeSet::new();
    for t in &trainers {
        let trained = items(&slurm, t);
        assert!(!trained.is_empty(), "{t}: no items");
        let arrays: BTreeSet<String> = trained
            .iter()
            .map(|i| {
                // An object no training view sees is skipped, on both executors.
                assert!(
                    ["ran", "skipped"].contains(&i["status"].as_str().unwrap()),
                    "{i}"
                );
                assert_eq!(i["executor"], "slurm", "{i}");
                assert!(i["host"].as_str().is_some_and(|h| !h.is_empty()), "{i}");
                let job = i["job_id"].as_str().unwrap();
                job.split('_').next().unwrap().to_string()
            })
            .collect();
        assert_eq!(arrays.len(), 1, "{t}: one job array: {trained:?}");
        all_arrays.extend(arrays);
        let statuses = |r: &serde_json::Value| -> Vec<(String, String)> {
            items(r, t)
                .iter()
                .map(|i| (i["name"].to_string(), i["status"].to_string()))
                .collect()
        };
        assert_eq!(statuses(&local), statuses(&slurm), "{t}");
        for i in items(&local, t) {
            assert_eq!(i["executor"], "local", "{i}");
            assert_eq!(i["job_id"], serde_json::Value::Null, "{i}");
        }
    }
    assert_eq!(all_arrays.len(), trainers.len(), "an array per train node");
    for n in slurm["nodes"].as_array().unwrap() {
        if n["kind"] != "train" {
            assert_ne!(n["executor"], "slurm", "{}", n["id"]);
            assert!(n["job_id"].is_null(), "{}", n["id"]);
        }
    }

    let (a, b) = (
        file_tree(&dir.join("out-local")),
        file_tree(&dir.join("out-slurm")),
    );
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "the same files"
    );
    let summary_page = "report/file/index.html";
    assert!(a.contains_key(summary_page));
    assert!(RUN_FILES.iter().all(|f| a.contains_key(*f)));
    let differing: Vec<&String> = a
        .keys()
        .filter(|k| {
            k.as_str() != summary_page && !RUN_FILES.contains(&k.as_str()) && a[*k] != b[*k]
        })
        .collect();
    assert!(differing.is_empty(), "files differ: {differing:?}");
    assert!(a.keys().any(|k| k.ends_with(".glb")));
    assert!(a.keys().any(|k| k.starts_with("viewer/")));
}
