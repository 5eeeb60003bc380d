//! `--executor slurm` job options: the graph's `slurm: (...)` defaults, the command
//! line's `--slurm-*` options and a node's own `slurm: (...)` field reach `sbatch`, the
//! most specific one winning (seen from inside the jobs: their CPUs, partition and
//! name); a node with `slurm: (local: true)` stays in the coordinator; Ctrl-C cancels
//! the run's jobs.
//!
//! Needs the local cluster (`scripts/slurm-local-cluster.sh up`); CI starts it.

mod support;

use std::time::Duration;
use support::objectsplat::{assert_ok, objectsplat, read_json, spawn_objectsplat};
use support::slurm::*;

#[test]
fn graph_command_line_and_node_options_reach_sbatch() {
    if !cluster_up("graph_command_line_and_node_options_reach_sbatch") {
        return;
    }
    // Graph: 1 CPU, prefix "graph"; command line: prefix "ostest-cli" (wins over the
    // graph's); node: 2 CPUs (wins over the graph's), extra args naming the partition.
    let (dir, log) = fan_out_dir(
        "job_options",
        "",
        r#", slurm: (cpus: 2, args: ["--partition=debug"])"#,
        r#"slurm: (cpus: 1, job_name: "graph"),"#,
    );
    let out = objectsplat(&dir, &slurm_run_args("ostest-cli"));
    assert_ok(&out, "the run");
    let a = attempts(&log);
    assert_eq!(a.iter().filter(|x| x.event == "done").count(), 7);
    for x in &a {
        assert_eq!(x.cpus, "2", "{x:?}");
        assert_eq!(x.partition, "debug", "{x:?}");
        assert_eq!(x.name, "ostest-cli-items", "{x:?}");
    }
    // Nodes that do not fan out ran in the coordinator.
    let report = read_json(&dir.join("run.json"));
    for node in report["nodes"].as_array().unwrap() {
        if node["id"] != "items" {
            assert_eq!(node["executor"], "local", "{node}");
            assert_eq!(node["job_id"], serde_json::Value::Null, "{node}");
        }
    }
}

#[test]
fn a_node_marked_local_stays_in_the_coordinator() {
    if !cluster_up("a_node_marked_local_stays_in_the_coordinator") {
        return;
    }
    let (dir, log) = fan_out_dir("local_node", "", ", slurm: (local: true)", "");
    let out = objectsplat(&dir, &slurm_run_args("ostest-local"));
    assert_ok(&out, "the run");
    let a = attempts(&log);
    assert_eq!(a.len(), 14);
    assert!(a.iter().all(|x| x.job == "-"), "{a:#?}");
    for item in items(&read_json(&dir.join("run.json")), "items") {
        assert_eq!(item["executor"], "local", "{item}");
    }
}

#[test]
fn ctrl_c_cancels_the_runs_jobs() {
    if !cluster_up("ctrl_c_cancels_the_runs_jobs") {
        return;
    }
    let (dir, log) = fan_out_dir("ctrl_c", "sleep_s: 600.0, ", "", "");
    let child = spawn_objectsplat(
        &dir,
        &[
            "run",
            "g.ron",
            "--cache",
            "cache",
            "--executor",
            "slurm",
            "--slurm-poll",
            "1",
            "--slurm-job-name",
            "ostest-ctrlc",
        ],
    );
    wait_for(&log, Duration::from_secs(120), "an item started", |a| {
        !a.is_empty()
    });
    assert!(!queued_jobs("ostest-ctrlc").is_empty());
    let sent = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let out = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(stderr.contains("interrupted"), "{stderr}");
    // scancel is asynchronous: the jobs leave the queue shortly after.
    let t0 = std::time::Instant::now();
    while !queued_jobs("ostest-ctrlc").is_empty() {
        assert!(
            t0.elapsed() < Duration::from_secs(30),
            "jobs left behind: {:?}",
            queued_jobs("ostest-ctrlc")
        );
        std::thread::sleep(Duration::from_millis(200));
    }
    assert!(attempts(&log).iter().all(|x| x.event == "start"));
}
