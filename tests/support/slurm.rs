//! The `--executor slurm` tests' common ground: the one-node cluster that
//! `scripts/slurm-local-cluster.sh up` starts, a small fan-out graph whose items are
//! `faulty_item` jobs of the fault-injection plugin, and that plugin's attempt log (the
//! record of what ran, as which Slurm job, in which process).

use super::objectsplat::report_node;
use super::plugin_build::{build_plugin, scratch_root};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

/// Whether the local cluster answers. Under `CI=true` a missing cluster fails the test
/// (CI starts it); elsewhere the test says loudly that it skipped and returns early.
///
/// A node still `completing` (cleaning up after the jobs another test cancelled) is up:
/// jobs queue behind the cleanup. Any other state is sampled again for up to 30 s before
/// the cluster counts as missing, since one `sinfo` can catch the node mid-transition.
pub fn cluster_up(test: &str) -> bool {
    let t0 = Instant::now();
    let state = loop {
        let state = sinfo_state();
        let up = state.as_ref().is_ok_and(|s| {
            ["idle", "mixed", "alloc", "completing"]
                .iter()
                .any(|x| s.contains(x))
        });
        if up {
            return true;
        }
        // A cluster that is not installed or not started does not come up by waiting.
        if state.is_err() || t0.elapsed() > Duration::from_secs(30) {
            break state.unwrap_or_else(|e| e);
        }
        std::thread::sleep(Duration::from_millis(500));
    };
    let why = format!(
        "no Slurm cluster answers (sinfo: {}); start one with `sudo scripts/slurm-local-cluster.sh up`",
        state.trim()
    );
    if std::env::var("CI").as_deref() == Ok("true") {
        panic!("{why}; CI requires {test}");
    }
    eprintln!("\n!!!!! SKIPPED {test}: {why} !!!!!\n");
    false
}

/// The node states `sinfo` lists, or why it could not answer.
fn sinfo_state() -> Result<String, String> {
    match Command::new("sinfo").args(["-h", "-o", "%T"]).output() {
        Ok(o) if o.status.success() => Ok(String::from_utf8_lossy(&o.stdout).to_string()),
        Ok(o) => Err(String::from_utf8_lossy(&o.stderr).to_string()),
        Err(e) => Err(e.to_string()),
    }
}

/// A fresh folder for one test, with the fault-injection plugin in it.
pub fn test_dir(name: &str) -> PathBuf {
    let dir = scratch_root().join("slurm").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    build_plugin("fault_injection", &[], &[], &dir.join("fault_injection.so"));
    dir
}

/// The test graph: a tiny synthetic room partitioned into its components (seven: six
/// objects and the background), and `faulty_item` once per component. `item_params`
/// and `extra` are spliced into the `items` node's params and the graph's top level.
pub fn fan_out_graph(item_params: &str, item_fields: &str, extra: &str) -> String {
    format!(
        r#"(
  nodes: {{
    "scene": (kind: "synthetic_scene",
              params: (views: 4, width: 32, height: 24, points: 300, supersample: 1)),
    "masks": (kind: "gt_masks", inputs: (frames: "scene.frames", mesh: "scene.mesh")),
    "parts": (kind: "partition", inputs: (frames: "scene.frames", masks: "masks.masks")),
    "items": (kind: "faulty_item", inputs: (component: each("parts.components")),
              params: ({item_params}){item_fields}),
  }},
  targets: ["items"],
  plugins: ["fault_injection.so"],
  {extra}
)"#
    )
}

/// A fresh [`test_dir`] holding [`fan_out_graph`] as `g.ron`, its items logging their
/// attempts to the returned log (`item_params` come before the log's own param).
pub fn fan_out_dir(
    name: &str,
    item_params: &str,
    item_fields: &str,
    extra: &str,
) -> (PathBuf, PathBuf) {
    let dir = test_dir(name);
    let log = dir.join("attempts.log");
    let params = format!(r#"{item_params}log: "{}""#, log.display());
    std::fs::write(
        dir.join("g.ron"),
        fan_out_graph(&params, item_fields, extra),
    )
    .unwrap();
    (dir, log)
}

/// `run g.ron` on Slurm with a `--json` report in `run.json`, polling every second, its
/// jobs named after `job_name`.
pub fn slurm_run_args(job_name: &str) -> Vec<&str> {
    vec![
        "run",
        "g.ron",
        "--cache",
        "cache",
        "--json",
        "run.json",
        "--executor",
        "slurm",
        "--slurm-poll",
        "1",
        "--slurm-job-name",
        job_name,
    ]
}

/// One line of the plugin's attempt log.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Attempt {
    /// `start` or `done`.
    pub event: String,
    pub item: String,
    /// `<array job>_<task>`, or `-` outside Slurm.
    pub job: String,
    pub pid: u32,
    /// The `objectsplat run-action` process that started the plugin's child.
    pub ppid: u32,
    pub cpus: String,
    pub partition: String,
    pub name: String,
}

pub fn attempts(log: &Path) -> Vec<Attempt> {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    text.lines()
        .map(|line| {
            let f: Vec<&str> = line.split(' ').collect();
            let field = |k: &str| {
                f.iter()
                    .find_map(|x| x.strip_prefix(k).and_then(|x| x.strip_prefix('=')))
                    .unwrap_or_else(|| panic!("no {k} in log line {line:?}"))
                    .to_string()
            };
            Attempt {
                event: f[0].to_string(),
                item: f[1].to_string(),
                job: field("job"),
                pid: field("pid").parse().unwrap(),
                ppid: field("ppid").parse().unwrap(),
                cpus: field("cpus"),
                partition: field("partition"),
                name: field("name"),
            }
        })
        .collect()
}

/// Waits until `pred` holds for the attempt log (panics after `timeout`).
pub fn wait_for(log: &Path, timeout: Duration, what: &str, pred: impl Fn(&[Attempt]) -> bool) {
    let t0 = Instant::now();
    loop {
        let a = attempts(log);
        if pred(&a) {
            return;
        }
        assert!(
            t0.elapsed() < timeout,
            "timed out waiting for {what}; log so far: {a:#?}"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The jobs Slurm still lists (any state) whose name starts with `prefix`.
pub fn queued_jobs(prefix: &str) -> Vec<String> {
    let out = Command::new("squeue")
        .args(["-h", "-r", "-o", "%i %j %T"])
        .output()
        .expect("squeue runs");
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter(|l| l.split(' ').nth(1).is_some_and(|n| n.starts_with(prefix)))
        .map(str::to_string)
        .collect()
}

/// Items of `node` in a `--json` report.
pub fn items(report: &serde_json::Value, node: &str) -> Vec<serde_json::Value> {
    report_node(report, node)["items"]
        .as_array()
        .unwrap()
        .clone()
}
