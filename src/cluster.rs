//! `run --executor slurm`: the command line's Slurm options, and the hidden
//! `run-action` subcommand a Slurm task runs on its compute node.

use anyhow::{Result, bail};
use clap::{Args, ValueEnum};
use objectsplat_runtime::exec::{Executor, Local};
use objectsplat_runtime::slurm::{ActionSpec, SlurmConfig, SlurmSettings};
use std::path::PathBuf;
use std::time::Duration;

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ExecutorKind {
    /// In this process, on `-j` threads.
    Local,
    /// Fan-out items (and nodes with a `slurm` field) as Slurm jobs, one job array per
    /// node; the cache must be on a filesystem the compute nodes share (docs/cluster.md).
    Slurm,
}

/// Where the actions that miss the cache are computed.
#[derive(Args)]
pub struct ExecutorArgs {
    /// `local` (this process) or `slurm` (job arrays; see docs/cluster.md).
    #[arg(long, value_enum, default_value = "local")]
    executor: ExecutorKind,
    /// Slurm partition of the jobs (`sbatch --partition`).
    #[arg(long = "slurm-partition", value_name = "NAME")]
    partition: Option<String>,
    /// Time limit of each job (`sbatch --time`, e.g. 30 or 02:00:00).
    #[arg(long = "slurm-time", value_name = "TIME")]
    time: Option<String>,
    /// CPUs per job (`sbatch --cpus-per-task`).
    #[arg(long = "slurm-cpus", value_name = "N")]
    cpus: Option<u32>,
    /// Memory per job (`sbatch --mem`, e.g. 16G).
    #[arg(long = "slurm-mem", value_name = "SIZE")]
    mem: Option<String>,
    /// Generic resources per job (`sbatch --gres`, e.g. gpu:1).
    #[arg(long = "slurm-gres", value_name = "GRES")]
    gres: Option<String>,
    /// One more `sbatch` argument, as given (repeatable), e.g. --slurm-arg=--qos=high.
    #[arg(long = "slurm-arg", value_name = "ARG", allow_hyphen_values = true)]
    args: Vec<String>,
    /// Job names are PREFIX-<node id> (default: objectsplat).
    #[arg(long = "slurm-job-name", value_name = "PREFIX")]
    job_name: Option<String>,
    /// At most N tasks of one job array run at once (`--array=…%N`).
    #[arg(long = "slurm-array-limit", value_name = "N")]
    array_limit: Option<u32>,
    /// How many times a job lost to preemption, a node failure or a kill is resubmitted.
    #[arg(long = "slurm-retries", value_name = "N", default_value_t = 2)]
    retries: u32,
    /// Seconds between two `squeue` queries (results are noticed sooner).
    #[arg(long = "slurm-poll", value_name = "SECONDS", default_value_t = 10.0)]
    poll: f64,
}

/// What a task needs besides the graph file to rebuild the coordinator's plan.
pub struct PlanArgs {
    pub sets: Vec<String>,
    /// Absolute: the task starts elsewhere.
    pub plugins: Vec<PathBuf>,
}

impl ExecutorArgs {
    pub fn executor(&self, sets: &[String], plugins: &[PathBuf]) -> Result<Box<dyn Executor>> {
        let settings = SlurmSettings {
            partition: self.partition.clone(),
            time: self.time.clone(),
            cpus: self.cpus,
            mem: self.mem.clone(),
            gres: self.gres.clone(),
            args: self.args.clone(),
            job_name: self.job_name.clone(),
            array_limit: self.array_limit,
            local: None,
        };
        if self.executor == ExecutorKind::Local {
            if settings != SlurmSettings::default() {
                bail!("--slurm-* options need --executor slurm");
            }
            return Ok(Box::new(Local));
        }
        if settings.cpus == Some(0) || settings.array_limit == Some(0) {
            bail!("--slurm-cpus and --slurm-array-limit must be at least 1");
        }
        if !(self.poll.is_finite() && self.poll > 0.0) {
            bail!("--slurm-poll must be a positive number of seconds");
        }
        if let Some(bad) = settings.args.iter().find(|a| !a.starts_with('-')) {
            bail!("--slurm-arg {bad:?} is not an sbatch option (options start with `-`)");
        }
        let program = std::env::current_exe()
            .map_err(|e| anyhow::anyhow!("cannot find this program's path for the jobs: {e}"))?;
        let mut absolute = Vec::new();
        for p in plugins {
            let p = std::path::absolute(p).unwrap_or_else(|_| p.clone());
            match p.to_str() {
                Some(text) => absolute.push(text.to_string()),
                None => bail!(
                    "--plugin {}: --executor slurm needs plugin paths in UTF-8",
                    p.display()
                ),
            }
        }
        let plugins = absolute;
        let plan = serde_json::json!({ "sets": sets, "plugins": plugins });
        let mut cfg = SlurmConfig::new(vec![program.into(), "run-action".into()]);
        cfg.settings = settings;
        cfg.plan = plan;
        cfg.retries = self.retries;
        cfg.poll = Duration::from_secs_f64(self.poll);
        Ok(Box::new(cfg))
    }
}

/// The plan arguments a coordinator stored in a task's spec.
pub fn plan_args(spec: &ActionSpec) -> Result<PlanArgs> {
    let strings = |field: &str| -> Option<Vec<String>> {
        spec.plan
            .get(field)?
            .as_array()?
            .iter()
            .map(|v| v.as_str().map(str::to_string))
            .collect()
    };
    match (strings("sets"), strings("plugins")) {
        (Some(sets), Some(plugins)) => Ok(PlanArgs {
            sets,
            plugins: plugins.into_iter().map(PathBuf::from).collect(),
        }),
        _ => bail!(
            "the action spec's `plan` is not {{\"sets\": [...], \"plugins\": [...]}}; was it written by another objectsplat build?"
        ),
    }
}
