//! `--executor slurm`: a job killed mid-run — cancelled with `scancel`, or its
//! `objectsplat run-action` process killed with SIGKILL — is resubmitted and its item
//! computed again; the run succeeds and every other item is computed once.
//!
//! Needs the local cluster (`scripts/slurm-local-cluster.sh up`); CI starts it.

mod support;

use std::collections::BTreeSet;
use std::time::Duration;
use support::objectsplat::{read_json, spawn_objectsplat};
use support::slurm::*;

#[test]
fn killed_jobs_are_resubmitted_and_their_items_recomputed() {
    if !cluster_up("killed_jobs_are_resubmitted_and_their_items_recomputed") {
        return;
    }
    // Items sleep long enough to be killed while they compute.
    let (dir, log) = fan_out_dir("lost_jobs", "sleep_s: 3.0, ", "", "");
    let coordinator = spawn_objectsplat(&dir, &slurm_run_args("ostest-lost"));

    // The first two items to start: cancel one's job, SIGKILL the other's process.
    wait_for(&log, Duration::from_secs(120), "two items started", |a| {
        a.iter().filter(|x| x.event == "start").count() >= 2
    });
    let started = attempts(&log);
    let (cancelled, killed) = (&started[0], &started[1]);
    let scancel = std::process::Command::new("scancel")
        .arg(&cancelled.job)
        .status()
        .unwrap();
    assert!(scancel.success());
    let kill = std::process::Command::new("kill")
        .args(["-9", &killed.ppid.to_string()])
        .status()
        .unwrap();
    assert!(kill.success());

    let out = coordinator.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "the run failed:\n{stderr}");
    for job in [&cancelled.job, &killed.job] {
        assert!(
            stderr.contains(&format!("Slurm job {job}")) && stderr.contains("resubmitting"),
            "no resubmission of {job} reported:\n{stderr}"
        );
    }

    let a = attempts(&log);
    let done: Vec<&Attempt> = a.iter().filter(|x| x.event == "done").collect();
    let names: BTreeSet<&str> = a.iter().map(|x| x.item.as_str()).collect();
    assert_eq!(names.len(), 7, "seven components: {a:#?}");
    for item in &names {
        let finished: Vec<&&Attempt> = done.iter().filter(|x| x.item == *item).collect();
        let starts = a
            .iter()
            .filter(|x| x.event == "start" && x.item == *item)
            .count();
        let killed_here = *item == cancelled.item || *item == killed.item;
        // The killed items ran again, in a new job; the rest ran once.
        assert_eq!(starts, if killed_here { 2 } else { 1 }, "{item}: {a:#?}");
        assert_eq!(finished.len(), 1, "{item} finished more than once: {a:#?}");
        if killed_here {
            let first = a.iter().find(|x| x.item == *item).unwrap();
            assert_ne!(finished[0].job, first.job, "{item} was not resubmitted");
        }
    }
    // The report names the job that computed each item: the last attempt's.
    let report = read_json(&dir.join("run.json"));
    for item in items(&report, "items") {
        let name = item["name"].as_str().unwrap();
        let last = done.iter().find(|x| x.item == name).unwrap();
        assert_eq!(item["status"], "ran", "{item}");
        assert_eq!(item["executor"], "slurm");
        assert_eq!(item["job_id"], last.job.as_str(), "{item}");
    }
    assert!(queued_jobs("ostest-lost").is_empty());
}
