//! `--executor slurm`: an item that fails every time fails its node with the Slurm job
//! id and the end of the job's stderr; the other items succeed, are cached, and a rerun
//! submits only the failing item again (a cached item never gets a job). An item's
//! `seconds` is its own run on the node, from its action record (a cached item keeps
//! the producing run's); the wait for Slurm to start its job is `queued_seconds`.
//!
//! Needs the local cluster (`scripts/slurm-local-cluster.sh up`); CI starts it.

mod support;

use support::objectsplat::{objectsplat, read_json, report_node};
use support::slurm::*;

#[test]
fn a_failing_item_names_its_job_and_stderr_and_spares_the_others() {
    if !cluster_up("a_failing_item_names_its_job_and_stderr_and_spares_the_others") {
        return;
    }
    let (dir, log) = fan_out_dir(
        "failing_item",
        r#"fail_item: "obj_9_cup", sleep_s: 0.3, "#,
        "",
        "",
    );
    let args = slurm_run_args("ostest-fail");
    let out = objectsplat(&dir, &args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "the run should fail:\n{stderr}");

    let a = attempts(&log);
    let cup: Vec<&Attempt> = a.iter().filter(|x| x.item == "obj_9_cup").collect();
    assert_eq!(
        cup.len(),
        1,
        "a failure is not a lost job: no retry: {a:#?}"
    );
    let job = &cup[0].job;
    let report = read_json(&dir.join("run.json"));
    assert_eq!(report_node(&report, "items")["status"], "failed");
    let all = items(&report, "items");
    assert_eq!(all.len(), 7);
    for item in &all {
        assert_eq!(item["executor"], "slurm", "{item}");
        assert!(
            item["host"].as_str().is_some_and(|h| !h.is_empty()),
            "{item}"
        );
        if item["name"] == "obj_9_cup" {
            assert_eq!(item["status"], "failed");
            assert_eq!(item["job_id"], job.as_str());
            let reason = item["reason"].as_str().unwrap();
            assert!(reason.contains(&format!("Slurm job {job}")), "{reason}");
            // The node's own failure, then the end of the job's stderr log (which the
            // job starts with the line saying what it computes).
            assert!(
                reason.contains("injected failure: faulty_item refused item obj_9_cup"),
                "{reason}"
            );
            let tail = reason
                .split_once("end of the job's stderr")
                .unwrap_or_else(|| panic!("no stderr tail: {reason}"))
                .1;
            assert!(
                tail.contains("computing items[obj_9_cup]") && tail.contains(job.as_str()),
                "{tail}"
            );
        } else {
            assert_eq!(item["status"], "ran", "{item}");
            // Its own run holds its sleep; starting a Slurm job takes a while, which
            // is waiting, not run time.
            assert!(item["seconds"].as_f64().unwrap() >= 0.3, "{item}");
            assert!(item["queued_seconds"].as_f64().unwrap() > 0.05, "{item}");
        }
    }
    let ran_seconds: std::collections::BTreeMap<String, f64> = all
        .iter()
        .filter(|i| i["status"] == "ran")
        .map(|i| (i["name"].to_string(), i["seconds"].as_f64().unwrap()))
        .collect();
    assert!(
        stderr.contains(&format!("Slurm job {job}")),
        "the one-line cause names the job:\n{stderr}"
    );

    // Rerun: the six good items are cached, only the cup gets a job (and fails again).
    let before = attempts(&log).len();
    let out = objectsplat(&dir, &args);
    assert!(!out.status.success());
    let again: Vec<Attempt> = attempts(&log)[before..].to_vec();
    assert_eq!(
        again.len(),
        1,
        "only the failing item ran again: {again:#?}"
    );
    assert_eq!(again[0].item, "obj_9_cup");
    let report = read_json(&dir.join("run.json"));
    for item in items(&report, "items") {
        let expected = if item["name"] == "obj_9_cup" {
            "failed"
        } else {
            "cached"
        };
        assert_eq!(item["status"], expected, "{item}");
        // A cache hit still says where it was computed, and how long that took.
        assert_eq!(item["executor"], "slurm", "{item}");
        if expected == "cached" {
            assert_eq!(
                item["seconds"].as_f64(),
                ran_seconds.get(&item["name"].to_string()).copied(),
                "{item}"
            );
        }
    }
}
