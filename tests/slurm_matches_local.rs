//! `--executor slurm` computes what `--executor local` computes: the demo graph at a
//! short training budget (every `train` node at 60 iterations: a few minutes on 2
//! cores) run both ways into two caches gives byte-identical outputs, every node's,
//! nothing excluded: the trained models (with their training logs) and the report page
//! that plots them included. No output holds a clock reading, a host or a path; the
//! times of a run are its record, not its outputs.
//!
//! That record is the one thing that differs: the run summary the CLI writes beside the
//! outputs (`run.json`, `run.js`: each item's executor, host, Slurm job and seconds, and
//! the training times each `train` item measured) is no node's output, so it is not
//! compared; the test checks that it and OUT's lock file are all there is outside the
//! nodes' folders.
//! Each `train` node's fan-out runs as one Slurm job array.
//!
//! Needs the local cluster (`scripts/slurm-local-cluster.sh up`); CI starts it.

mod support;

use objectsplat_core::TRAINING_TIMES;
use objectsplat_core::artifact::{MODEL_PLY, TRAINING_JSON};
use objectsplat_report::{RUN_DATA_FILE, RUN_SCRIPT_FILE};
use objectsplat_runtime::graph::{GraphSource, parse_graph};
use objectsplat_runtime::outdir::LOCK_FILE;
use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use support::objectsplat::{assert_ok, file_tree, objectsplat, read_json};
use support::plugin_build::workspace;
use support::slurm::*;

/// What a run keeps in OUT itself besides the nodes' outputs (which are in
/// `OUT/<node>/<port>/`): its record (executors, hosts and times differ by design) and the
/// lock that lets two runs share one OUT.
const RUN_FILES: [&str; 3] = [RUN_DATA_FILE, RUN_SCRIPT_FILE, LOCK_FILE];

/// The files of OUT that nodes wrote (`<node>/<port>/…`), after checking that nothing but
/// the run's own files lies outside the nodes' folders.
fn node_outputs(out: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut files = file_tree(out);
    for run_file in RUN_FILES {
        assert!(
            files.remove(run_file).is_some(),
            "{run_file} in {}",
            out.display()
        );
    }
    for name in files.keys() {
        assert!(name.contains('/'), "{name}: not in a node's folder");
    }
    files
}

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

    // Every node's output digests agree.
    let digests = |r: &serde_json::Value| -> BTreeMap<String, serde_json::Value> {
        r["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .map(|n| (n["id"].as_str().unwrap().to_string(), n["outputs"].clone()))
            .collect()
    };
    let all = digests(&local);
    assert_eq!(all, digests(&slurm));
    assert!(all.len() >= 12, "{:?}", all.keys());
    for id in trainers
        .iter()
        .map(String::as_str)
        .chain(["report", "viewer"])
    {
        assert!(all.contains_key(id), "{id}: {:?}", all.keys());
    }
    assert!(
        all.values()
            .all(|o| o.as_object().is_some_and(|o| !o.is_empty()))
    );

    // The trained models themselves, byte for byte, with their training logs.
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
        node_outputs(&dir.join("models-local")),
        node_outputs(&dir.join("models-slurm")),
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
    let differing: Vec<&String> = a.keys().filter(|k| a[*k] != b[*k]).collect();
    assert!(differing.is_empty(), "models differ: {differing:?}");

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
        // What training took is in the record, whichever executor ran it: every item
        // this node trained measured its times (a Slurm job's come back with its record).
        for report in [&local, &slurm] {
            let trained: Vec<serde_json::Value> = items(report, t)
                .into_iter()
                .filter(|i| i["status"] == "ran" && i["notes"].get("passed through").is_none())
                .collect();
            assert!(!trained.is_empty(), "{t} trained nothing");
            for i in trained {
                let times = &i["measurements"][TRAINING_TIMES];
                let iterations = times["iterations"].to_string();
                assert_eq!(Some(iterations.as_str()), i["notes"]["iterations"].as_str());
                assert!(times["seconds"].as_f64().is_some_and(|s| s > 0.0), "{i}");
            }
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
        node_outputs(&dir.join("out-local")),
        node_outputs(&dir.join("out-slurm")),
    );
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "the same files"
    );
    assert!(a.contains_key("report/file/index.html"));
    let differing: Vec<&String> = a.keys().filter(|k| a[*k] != b[*k]).collect();
    assert!(differing.is_empty(), "files differ: {differing:?}");
    assert!(a.keys().any(|k| k.ends_with(".glb")));
    assert!(a.keys().any(|k| k.starts_with("viewer/")));
}
