//! The compute-node side: one Slurm task computes the one action its [`ActionSpec`]
//! names, against the shared cache, writes an [`ActionResult`] and exits.
//!
//! An embedding program serves this by calling [`run_action`] with a way to rebuild
//! its plan (for the CLI: the `run-action` subcommand, which loads the graph with the
//! coordinator's `--set` and `--plugin` arguments).

use super::{ActionResult, ActionSpec};
use crate::job::{Observer, RunOptions};
use crate::node::ProgressSink;
use crate::plan::Plan;
use crate::report::Status;
use crate::store::{RanOn, Store};
use anyhow::{Context as _, Result};
use std::path::Path;
use std::sync::Arc;
use std::sync::Mutex;
use std::time::Instant;

/// The task's Slurm job id, `<array job>_<task>` for an array task.
pub fn job_id_from_env() -> Option<String> {
    let var = |k: &str| std::env::var(k).ok().filter(|v| !v.is_empty());
    match (var("SLURM_ARRAY_JOB_ID"), var("SLURM_ARRAY_TASK_ID")) {
        (Some(a), Some(t)) => Some(format!("{a}_{t}")),
        _ => var("SLURM_JOB_ID"),
    }
}

/// The CPUs Slurm gave this task (what the node's `ctx.threads()` reports).
fn cpus_from_env() -> usize {
    ["SLURM_CPUS_PER_TASK", "SLURM_CPUS_ON_NODE"]
        .iter()
        .find_map(|k| std::env::var(k).ok()?.parse::<usize>().ok())
        .filter(|&n| n > 0)
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// Progress into the job's stderr log, at most one line per label every 10 s.
struct LogObserver {
    last: Mutex<Option<Instant>>,
}

impl ProgressSink for LogObserver {
    fn progress(&self, job: &str, done: u64, total: u64, message: &str) {
        let Ok(mut last) = self.last.lock() else {
            return;
        };
        if last.is_some_and(|t| t.elapsed().as_secs() < 10) && done < total {
            return;
        }
        *last = Some(Instant::now());
        eprintln!("{job}: {done}/{total} {message}");
    }
}

impl Observer for LogObserver {
    fn warning(&self, message: &str) {
        eprintln!("{message}");
    }
    fn job_finished(&self, job: &str, status: Status, seconds: f64) {
        eprintln!("{job}: {} in {seconds:.2}s", status.as_str());
    }
}

/// Computes the action in `spec_path` and records how it ended; returns the exit
/// code (0 when the action is in the cache afterwards).
pub fn run_action(spec_path: &Path, build_plan: impl FnOnce(&ActionSpec) -> Result<Plan>) -> i32 {
    let t0 = Instant::now();
    let spec: ActionSpec = match std::fs::read(spec_path)
        .with_context(|| format!("{}: cannot read", spec_path.display()))
        .and_then(|b| {
            serde_json::from_slice(&b)
                .with_context(|| format!("{}: not an action spec", spec_path.display()))
        }) {
        Ok(s) => s,
        Err(e) => {
            // Without a spec there is nowhere to write a result: the coordinator sees
            // the job end without one and quotes this from the log.
            eprintln!("error: {e:#}");
            return 2;
        }
    };
    let here = RanOn {
        executor: "slurm".into(),
        host: std::env::var("SLURMD_NODENAME")
            .ok()
            .filter(|h| !h.is_empty())
            .unwrap_or_else(crate::host::host_name),
        job_id: job_id_from_env(),
        pid: std::process::id(),
    };
    eprintln!(
        "objectsplat: computing {}{} (key {}) for {} as job {} on {}",
        spec.node,
        spec.item
            .as_ref()
            .map(|(n, _)| format!("[{n}]"))
            .unwrap_or_default(),
        crate::store::short(&spec.key),
        spec.coordinator,
        here.job_id.as_deref().unwrap_or("?"),
        here.host
    );
    let threads = cpus_from_env();
    let observer = Arc::new(LogObserver {
        last: Mutex::new(None),
    });
    let outcome = (|| {
        let plan = build_plan(&spec)?;
        let store = Store::open(&spec.cache)?;
        let opts = RunOptions {
            jobs: threads,
            threads_per_job: None,
            out_dir: None,
            observer: observer.clone(),
        };
        crate::action::compute_action(&plan, &store, &opts, &spec, &here, threads)
    })();
    let (status, error, warnings) = match outcome {
        Ok((rec, hit, warnings)) => {
            let status = if hit {
                "cached"
            } else if rec.status == "skipped" {
                "skipped"
            } else {
                "ran"
            };
            (status, None, warnings)
        }
        Err(e) => {
            let corrupt = e.downcast_ref::<crate::store::Corrupt>().is_some();
            let msg = crate::diag::bounded(&format!("{e:#}"), crate::job::MAX_FAILURE_TEXT);
            eprintln!("error: {msg}");
            (
                if corrupt { "corrupt" } else { "failed" },
                Some(msg),
                vec![],
            )
        }
    };
    let result = ActionResult {
        status: status.into(),
        error,
        host: here.host.clone(),
        job_id: here.job_id.clone(),
        seconds: t0.elapsed().as_secs_f64(),
        warnings,
    };
    if let Err(e) = write_result(&spec.result, &result) {
        eprintln!("error: {e:#}");
        return 3;
    }
    eprintln!(
        "objectsplat: {status} in {:.2}s",
        t0.elapsed().as_secs_f64()
    );
    i32::from(!matches!(status, "ran" | "skipped" | "cached"))
}

/// Written aside and renamed, so the coordinator never reads half a result.
fn write_result(path: &Path, result: &ActionResult) -> Result<()> {
    let tmp = path.with_extension(format!("{}.tmp", std::process::id()));
    let bytes = serde_json::to_vec_pretty(result)?;
    std::fs::write(&tmp, bytes).with_context(|| format!("{}: cannot write", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("{}: cannot write", path.display()))
}
