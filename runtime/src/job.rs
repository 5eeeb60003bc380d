//! What the scheduler hands an executor and gets back: the run's options and
//! observer, one job, its outcome and timing; and what counts as a cache hit.

use crate::node::ProgressSink;
use crate::report::Status;
use crate::store::{ActionRecord, Corrupt, Digest, RanOn, Store};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

/// Lifecycle events for displays (progress bars, logs).
pub trait Observer: ProgressSink {
    /// A job of node `node` missed the cache and was handed to an executor; it is later
    /// started and finished. Jobs answered from the cache by the scheduler are not queued.
    fn job_queued(&self, _job: &str, _node: &str) {}
    fn job_started(&self, _job: &str) {}
    /// Where a job stands when that is not progress of its own (a Slurm job queued,
    /// running on a node).
    fn job_state(&self, _job: &str, _state: &str) {}
    fn job_finished(&self, _job: &str, _status: Status, _seconds: f64) {}
    fn warning(&self, _message: &str) {}
}

pub struct Silent;
impl ProgressSink for Silent {
    fn progress(&self, _: &str, _: u64, _: u64, _: &str) {}
}
impl Observer for Silent {}

pub struct RunOptions {
    pub jobs: usize,
    /// Threads each job may use (None: the workers left to it, `jobs` / jobs running).
    /// One job at a time with every core (`jobs: 1, threads_per_job: Some(cores)`) is how
    /// benchmarks time items one by one.
    pub threads_per_job: Option<usize>,
    /// Where to materialize targets' outputs (`OUT/<node>/<port>/`); `None` = don't.
    pub out_dir: Option<PathBuf>,
    pub observer: Arc<dyn Observer>,
}

/// What one job (a node, or one item of a fanned-out node) needs.
pub struct Job {
    pub node: usize,
    pub item: Option<(String, Digest)>,
    pub key: String,
    pub params_key: String,
    pub inputs: BTreeMap<String, Digest>,
    pub label: String,
    /// When the job was handed to the workers (queue waiting is reported apart).
    pub queued_at: Instant,
}

pub struct JobOutcome {
    pub node: usize,
    pub item: Option<String>,
    pub result: Result<ActionRecord, JobError>,
    pub status: Status,
    pub timing: Timing,
    pub warnings: Vec<String>,
    /// Where it was computed (for a cache hit: where the record says).
    pub ran_on: Option<RanOn>,
}

/// One job's time: its own run (the producing run's, for a cache hit) and how long it
/// waited for a worker before that.
#[derive(Clone, Copy, Default)]
pub struct Timing {
    pub seconds: f64,
    pub queued: f64,
    /// When a worker took it up (`None`: answered from the cache by the scheduler).
    pub started: Option<Instant>,
}

pub enum JobError {
    Failed(String),
    Corrupt(String),
}

/// Longest failure message a node's report carries.
pub(crate) const MAX_FAILURE_TEXT: usize = 16 << 10;

/// A cache hit: a record for the key whose outputs are all present.
pub(crate) fn cached(store: &Store, key: &str) -> Result<Option<ActionRecord>, Corrupt> {
    match store.action(key)? {
        Some(rec) if rec.outputs.values().all(|d| store.has_artifact(d)) => Ok(Some(rec)),
        _ => Ok(None),
    }
}
