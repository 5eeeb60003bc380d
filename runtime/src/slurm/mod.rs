//! `--executor slurm`: fan-out items (and nodes that ask for it) become Slurm jobs.
//!
//! The coordinator (`objectsplat run` on a login node) keeps everything that needs the
//! whole graph — planning, cache checks, early cutoff, the report — and hands each
//! action that misses the cache to Slurm: one job array per node, one task per item.
//! A task runs the embedding program again on a compute node (for the CLI,
//! `objectsplat run-action SPEC.json`), which computes exactly that action against the
//! shared cache ([`worker`]) and exits. The cache already makes this safe: keys are
//! content addresses, every write is atomic, and a key is locked while computed.
//!
//! ```text
//! <cache>/slurm/runs/<run>/<node>-<n>/job.sh             the batch script of one array
//! <cache>/slurm/runs/<run>/<node>-<n>/tasks/<i>.json     what task i computes (ActionSpec)
//! <cache>/slurm/runs/<run>/<node>-<n>/results/<i>.json   how it ended (ActionResult)
//! <cache>/slurm/runs/<run>/<node>-<n>/logs/<job>_<i>.err its stderr (quoted when it fails)
//! <cache>/slurm/claims/<aa>/<key>.json                    which run's job computes a key
//! ```
//!
//! What counts as done is the sealed action record in the cache, never the job's exit
//! status: a task's result file says *why* it ended (an error to report, or "ran"), and
//! `squeue` (then `sacct`, where accounting is on) says whether a job without a result
//! is still alive. A job that ends without one (preempted, node lost, killed, cancelled
//! by someone else) is resubmitted, up to [`SlurmConfig::retries`] times; a job whose
//! node failed reports that failure with the job id and the end of its stderr.
//!
//! Claims keep two coordinators on one cache from both queueing the same item: the
//! second waits for the first one's job (and takes over when that job dies). Even when
//! two jobs do start for one key, the key lock and the cache check inside the job mean
//! it is computed once.

mod claims;
mod commands;
pub(crate) mod executor;
pub mod interrupt;
pub mod settings;
pub mod worker;

pub use settings::SlurmSettings;

use crate::store::Digest;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::ffi::OsString;
use std::path::PathBuf;
use std::time::Duration;

/// How a run uses Slurm (the command line's part; the graph adds its own settings).
#[derive(Debug, Clone)]
pub struct SlurmConfig {
    /// The command line's job options (between the graph's and a node's own).
    pub settings: SlurmSettings,
    /// The program (and leading arguments) that computes one action: the path of its
    /// [`ActionSpec`] is appended. For the CLI: `[objectsplat, "run-action"]`.
    pub worker: Vec<OsString>,
    /// What the worker needs besides the graph file to rebuild the same plan (for the
    /// CLI: its `--set` overrides and `--plugin` libraries), stored in every spec.
    pub plan: serde_json::Value,
    /// How many times a job that ended without a result is resubmitted.
    pub retries: u32,
    /// How often `squeue` is asked about the run's jobs (results are noticed sooner:
    /// the coordinator watches the result folders).
    pub poll: Duration,
}

impl SlurmConfig {
    /// Defaults: no job options, 2 retries, `squeue` every 10 s.
    pub fn new(worker: Vec<OsString>) -> SlurmConfig {
        SlurmConfig {
            settings: SlurmSettings::default(),
            worker,
            plan: serde_json::Value::Null,
            retries: 2,
            poll: Duration::from_secs(10),
        }
    }
}

/// One action for a compute node: everything it needs to compute exactly the action
/// the coordinator planned, and to notice when it would compute something else.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ActionSpec {
    /// The graph file (absolute).
    pub graph: PathBuf,
    /// [`SlurmConfig::plan`], for the embedding program's plan builder.
    pub plan: serde_json::Value,
    /// The shared cache (absolute).
    pub cache: PathBuf,
    pub node: String,
    /// The fan-out item: its name and its digest.
    pub item: Option<(String, Digest)>,
    /// Input digests by port (for an item, its own port holds the item's digest).
    pub inputs: BTreeMap<String, Digest>,
    /// The key the coordinator computed; the worker recomputes it and refuses a mismatch.
    pub key: String,
    /// Where the worker writes its [`ActionResult`].
    pub result: PathBuf,
    /// `host:pid` of the coordinator, for messages.
    pub coordinator: String,
}

/// How a task ended, written by the worker as its last act.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ActionResult {
    /// `ran`, `skipped`, `cached` (another process computed it while this job waited
    /// for the key) or `failed`.
    pub status: String,
    pub error: Option<String>,
    pub host: String,
    pub job_id: Option<String>,
    /// Seconds the worker took, start to finish.
    pub seconds: f64,
    #[serde(default)]
    pub warnings: Vec<String>,
}
