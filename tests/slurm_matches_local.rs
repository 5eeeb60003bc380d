//! `--executor slurm` computes what `--executor local` computes: the demo graph at a
//! short training budget (`train.iterations=60`: seconds) run both ways into
//! two caches gives byte-identical outputs. Two outputs carry wall-clock times and so
//! differ between *any* two runs, local ones included: the trainer's `training.json`
//! (`wall_seconds`) and the report page that plots it and gets the run summary; the
//! models are compared byte for byte and their logs without those fields, the page is
//! left out. The fan-out (`train`) runs as one Slurm job array.
//!
//! Needs the local cluster (`scripts/slurm-local-cluster.sh up`); CI starts it.

mod support;

use std::collections::BTreeMap;
use std::path::Path;
use support::plugin_build::workspace;
use support::slurm::*;

/// Every file under `root` (relative path → bytes), links read as their targets.
fn files(root: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![root.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let path = e.unwrap().path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let rel = path
                    .strip_prefix(root)
                    .unwrap()
                    .to_string_lossy()
                    .to_string();
                out.insert(rel, std::fs::read(&path).unwrap());
            }
        }
    }
    out
}

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

#[test]
fn the_demo_graph_on_slurm_gives_byte_identical_outputs() {
    if !cluster_up("the_demo_graph_on_slurm_gives_byte_identical_outputs") {
        return;
    }
    let dir = test_dir("matches_local");
    let demo = workspace().join("graphs/demo.ron");
    let demo = demo.to_str().unwrap();
    // The demo as shipped, at a short training budget (seconds on 2 cores).
    let small = ["--set", "train.iterations=60"];
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
        args.extend(small);
        args.extend(["--executor", executor]);
        if executor == "slurm" {
            args.extend(["--slurm-poll", "1", "--slurm-job-name", "ostest-demo"]);
        }
        let result = objectsplat(&args, &dir);
        assert_ok(&result, &format!("the demo with --executor {executor}"));
        read_json(&dir.join(json))
    };
    let (local, slurm) = (run("local"), run("slurm"));

    // Every node's output digest agrees, but for the two that carry wall-clock times:
    // `train` (training.json's `wall_seconds`, different between any two runs) and the
    // `report` that plots them. Those are compared below with the times taken out.
    let timed = ["train", "report"];
    let digests = |r: &serde_json::Value| -> BTreeMap<String, serde_json::Value> {
        r["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|n| !timed.contains(&n["id"].as_str().unwrap()))
            .map(|n| (n["id"].as_str().unwrap().to_string(), n["outputs"].clone()))
            .collect()
    };
    assert_eq!(digests(&local), digests(&slurm));
    assert!(digests(&local).len() >= 10);
    assert!(
        digests(&local)
            .values()
            .all(|o| o.as_object().is_some_and(|o| !o.is_empty()))
    );

    // The trained models themselves, byte for byte; their logs without the times.
    for executor in ["local", "slurm"] {
        let mut args = vec!["run", demo, "--cache"];
        let (cache, out) = (format!("cache-{executor}"), format!("models-{executor}"));
        args.extend([cache.as_str(), "--out", out.as_str(), "--target", "train"]);
        args.extend(small);
        assert_ok(&objectsplat(&args, &dir), "materializing the cached models");
    }
    let (a, b) = (
        files(&dir.join("models-local")),
        files(&dir.join("models-slurm")),
    );
    assert_eq!(a.keys().collect::<Vec<_>>(), b.keys().collect::<Vec<_>>());
    assert!(a.keys().filter(|k| k.ends_with("model.ply")).count() >= 5);
    for (name, bytes) in &a {
        if name.ends_with("training.json") {
            let untimed = |bytes: &[u8]| without_times(serde_json::from_slice(bytes).unwrap());
            assert_eq!(untimed(bytes), untimed(&b[name]), "{name}");
        } else {
            assert!(*bytes == b[name], "{name} differs");
        }
    }

    // Every training item ran as a job of one array; everything else in the coordinator.
    let trained = items(&slurm, "train");
    assert!(trained.len() >= 5, "{trained:?}");
    let arrays: std::collections::BTreeSet<&str> = trained
        .iter()
        .map(|i| {
            // An object no sparse training view sees is skipped, on both executors.
            assert!(
                ["ran", "skipped"].contains(&i["status"].as_str().unwrap()),
                "{i}"
            );
            assert_eq!(i["executor"], "slurm", "{i}");
            assert!(i["host"].as_str().is_some_and(|h| !h.is_empty()), "{i}");
            i["job_id"].as_str().unwrap().split('_').next().unwrap()
        })
        .collect();
    assert_eq!(
        arrays.len(),
        1,
        "one job array for the fan-out: {trained:?}"
    );
    let statuses = |r: &serde_json::Value| -> Vec<(String, String)> {
        items(r, "train")
            .iter()
            .map(|i| (i["name"].to_string(), i["status"].to_string()))
            .collect()
    };
    assert_eq!(statuses(&local), statuses(&slurm));
    for i in items(&local, "train") {
        assert_eq!(i["executor"], "local", "{i}");
        assert_eq!(i["job_id"], serde_json::Value::Null, "{i}");
    }

    let (a, b) = (files(&dir.join("out-local")), files(&dir.join("out-slurm")));
    assert_eq!(
        a.keys().collect::<Vec<_>>(),
        b.keys().collect::<Vec<_>>(),
        "the same files"
    );
    let summary_page = "report/file/index.html";
    assert!(a.contains_key(summary_page));
    let differing: Vec<&String> = a
        .keys()
        .filter(|k| k.as_str() != summary_page && a[*k] != b[*k])
        .collect();
    assert!(differing.is_empty(), "files differ: {differing:?}");
    assert!(a.keys().any(|k| k.ends_with(".glb")));
}
