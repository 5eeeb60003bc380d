//! `--executor slurm`: two coordinators started together on one cache compute every
//! item exactly once between them (claims: the second waits for the first one's jobs),
//! and both succeed with the same outputs.
//!
//! Needs the local cluster (`scripts/slurm-local-cluster.sh up`); CI starts it.

mod support;

use std::collections::BTreeMap;
use support::objectsplat::{assert_ok, objectsplat, read_json, spawn_objectsplat};
use support::slurm::*;

#[test]
fn two_coordinators_never_compute_one_item_twice() {
    if !cluster_up("two_coordinators_never_compute_one_item_twice") {
        return;
    }
    let (dir, log) = fan_out_dir("two_coordinators", "sleep_s: 1.0, ", "", "");
    // The upstream nodes first, so both coordinators reach the fan-out at once.
    let out = objectsplat(
        &dir,
        &["run", "g.ron", "--cache", "cache", "--target", "parts"],
    );
    assert_ok(&out, "the upstream run");

    let spawn = |n: &str| {
        let (out, json, job_name) = (
            format!("out-{n}"),
            format!("run-{n}.json"),
            format!("ostest-two-{n}"),
        );
        // Each its own outputs and report, to compare them.
        let mut args = slurm_run_args(&job_name);
        args.retain(|a| !["--json", "run.json"].contains(a));
        args.extend(["--out", &out, "--json", &json]);
        spawn_objectsplat(&dir, &args)
    };
    let (a, b) = (spawn("a"), spawn("b"));
    for (n, child) in [("a", a), ("b", b)] {
        let out = child.wait_with_output().unwrap();
        assert_ok(&out, &format!("coordinator {n}"));
    }

    let mut computed: BTreeMap<String, usize> = BTreeMap::new();
    for x in attempts(&log).iter().filter(|x| x.event == "start") {
        *computed.entry(x.item.clone()).or_default() += 1;
    }
    assert_eq!(computed.len(), 7, "{computed:?}");
    assert!(
        computed.values().all(|&n| n == 1),
        "an item was computed twice: {computed:?}\n{:#?}",
        attempts(&log)
    );
    // Each item is reported by both runs, with the one job that computed it.
    let (ra, rb) = (
        read_json(&dir.join("run-a.json")),
        read_json(&dir.join("run-b.json")),
    );
    let jobs = |r: &serde_json::Value| -> BTreeMap<String, String> {
        items(r, "items")
            .iter()
            .map(|i| {
                (
                    i["name"].as_str().unwrap().to_string(),
                    i["job_id"].as_str().unwrap().to_string(),
                )
            })
            .collect()
    };
    assert_eq!(jobs(&ra), jobs(&rb));
    for x in attempts(&log).iter().filter(|x| x.event == "done") {
        assert_eq!(jobs(&ra)[&x.item], x.job);
    }
    for item in items(&ra, "items").iter().chain(&items(&rb, "items")) {
        assert!(
            ["ran", "cached"].contains(&item["status"].as_str().unwrap()),
            "{item}"
        );
    }
}
