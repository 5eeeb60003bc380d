//! The coordinator's Slurm thread: turns each node's batch of actions into a job
//! array, notices results as their files appear, asks `squeue` about jobs that have
//! none, resubmits jobs that were lost, and cancels everything on Ctrl-C.
//!
//! A task is done when its result file says so *and* its action record is in the
//! cache; a job that ends without a result was lost (preempted, node failure, killed)
//! and is resubmitted, at most [`SlurmConfig::retries`] times, unless the cache has
//! the record by then. Ending by `TIMEOUT` or `OUT_OF_MEMORY` is not retried: the next
//! attempt would end the same way.

use super::claims::{Claim, Claimed, Claims};
use super::commands::{self, JobState};
use super::{ActionResult, ActionSpec, SlurmConfig, SlurmSettings};
use crate::executor::{Batch, Executor, Pass};
use crate::job::{Job, JobError, JobOutcome, RunOptions, Timing, cached};
use crate::plan::{Plan, PlanNode};
use crate::report::Status;
use crate::store::{ActionRecord, RanOn, Store};
use anyhow::{Context as _, Result};
use crossbeam::channel::{Receiver, RecvTimeoutError, Sender};
use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// How often result folders are looked at.
const TICK: Duration = Duration::from_millis(200);

/// How long a job Slurm calls COMPLETED (or a result saying "ran") may go without its
/// result (or record) showing: clients of a shared filesystem cache directory listings
/// for up to a minute (NFS `acdirmax`), so a file written on a compute node can take
/// that long to appear here. Only then does the job count as lost.
const VISIBILITY_GRACE: Duration = Duration::from_secs(75);

/// How much of a failed job's stderr its error quotes.
const STDERR_TAIL_BYTES: u64 = 4096;
const STDERR_TAIL_LINES: usize = 40;

/// One job array: its folder and the `sbatch` arguments its (re)submissions share.
struct Array {
    dir: PathBuf,
    args: Vec<String>,
    limit: Option<u32>,
    settings: SlurmSettings,
}

/// An action this run has a job for.
struct Task {
    job: Job,
    array: usize,
    index: u32,
    /// The current attempt's job, `<array job>_<task>`.
    job_id: String,
    attempt: u32,
    state: String,
    host: Option<String>,
    /// When Slurm first said the job ended (while its result may still be in flight).
    ended_at: Option<Instant>,
}

/// An action another run's job is computing: wait for it, take over if it dies.
struct Watched {
    job: Job,
    claim: Claim,
    settings: SlurmSettings,
}

/// A task whose result said "ran" before its record was visible here.
struct Unconfirmed {
    task: Task,
    result: ActionResult,
    since: Instant,
}

struct Tracker<'a> {
    plan: &'a Plan,
    store: &'a Store,
    opts: &'a RunOptions,
    cfg: &'a SlurmConfig,
    results: Sender<JobOutcome>,
    run_id: String,
    /// The cache's absolute path.
    cache: PathBuf,
    run_dir: PathBuf,
    claims: Claims,
    arrays: Vec<Array>,
    tasks: BTreeMap<(usize, u32), Task>,
    watched: Vec<Watched>,
    unconfirmed: Vec<Unconfirmed>,
    max_array: Option<usize>,
    last_poll: Instant,
    keep_run_dir: bool,
    squeue_failures: u32,
}

impl SlurmConfig {
    /// The job options for `node` when it runs on Slurm (graph < command line < node);
    /// `None` when it runs in the coordinating process: it neither fans out nor has a
    /// `slurm` field, or that field says `local: true`.
    pub fn settings_for(&self, plan: &Plan, node: &PlanNode) -> Option<SlurmSettings> {
        let own = node.slurm.clone().unwrap_or_default();
        let settings = plan.slurm.overridden_by(&self.settings).overridden_by(&own);
        let asks = node.fans_out || node.slurm.is_some();
        (asks && settings.local != Some(true)).then_some(settings)
    }
}

impl Executor for SlurmConfig {
    fn takes(&self, plan: &Plan, node: &PlanNode) -> bool {
        self.settings_for(plan, node).is_some()
    }

    fn serve(&self, pass: Pass<'_>, batches: Receiver<Batch>, results: Sender<JobOutcome>) {
        track(pass, self, batches, results);
    }

    /// Ctrl-C must cancel the cluster jobs, not orphan them.
    fn hold(&self) -> Option<Box<dyn std::any::Any>> {
        Some(Box::new(super::interrupt::Guard::install()))
    }

    fn interruption(&self) -> Option<String> {
        super::interrupt::interrupted()
            .then(|| "interrupted: this run's Slurm jobs were cancelled".to_string())
    }
}

/// The Slurm thread's body (see the module doc). Ends when the coordinator closes
/// `batches` with nothing outstanding; cancels what is outstanding if it closes early.
fn track(pass: Pass<'_>, cfg: &SlurmConfig, batches: Receiver<Batch>, results: Sender<JobOutcome>) {
    let Pass {
        plan,
        store,
        opts,
        cancel,
    } = pass;
    let run_id = format!(
        "{}-{}-{}",
        crate::host::host_name()
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            })
            .collect::<String>(),
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_nanos() % 1_000_000_000_000)
    );
    // Jobs start elsewhere (`--chdir`, another machine): every path they get is absolute.
    let cache = std::path::absolute(store.root()).unwrap_or_else(|_| store.root().to_path_buf());
    let mut t = Tracker {
        plan,
        store,
        opts,
        cfg,
        results,
        run_dir: cache.join("slurm").join("runs").join(&run_id),
        claims: Claims::new(&cache, &run_id),
        cache,
        run_id,
        arrays: Vec::new(),
        tasks: BTreeMap::new(),
        watched: Vec::new(),
        unconfirmed: Vec::new(),
        max_array: None,
        last_poll: Instant::now(),
        keep_run_dir: false,
        squeue_failures: 0,
    };
    loop {
        if super::interrupt::interrupted() {
            cancel.store(true, Ordering::SeqCst);
            t.cancel_all("interrupted");
            // Batches already on their way fail too; the coordinator closes the
            // channel once every job it counted has an outcome.
            for b in batches.iter() {
                for job in b.jobs {
                    t.send_failure(job, "interrupted before it was submitted".into());
                }
            }
            break;
        }
        match batches.recv_timeout(TICK) {
            Ok(b) => t.accept(b),
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => {
                if !t.idle() {
                    // The coordinator stopped with jobs out (it failed): leave nothing
                    // computing for nobody.
                    t.cancel_all("the run stopped");
                }
                break;
            }
        }
        t.collect_results();
        t.check_unconfirmed();
        if !t.idle() && t.last_poll.elapsed() >= cfg.poll {
            t.poll();
        }
    }
    t.finish();
}

/// `17_3` → `17`.
/// A task's time as the run report counts it: its own run (`own`, the action record's
/// time; unknown for a job that left no record, which then counts whole) and the rest
/// of the time since the coordinator handed it over — Slurm's queue, the job's start,
/// collecting its result — as waiting.
fn task_timing(task: &Task, own: Option<f64>) -> Timing {
    let total = task.job.queued_at.elapsed().as_secs_f64();
    let seconds = own.unwrap_or(total);
    Timing {
        seconds,
        queued: (total - seconds).max(0.0),
        started: Instant::now().checked_sub(Duration::from_secs_f64(seconds.max(0.0))),
    }
}

fn array_of(job_id: &str) -> &str {
    job_id.split('_').next().unwrap_or(job_id)
}

fn shell_quote(s: &str) -> String {
    format!("'{}'", s.replace('\'', r"'\''"))
}

impl Tracker<'_> {
    fn idle(&self) -> bool {
        self.tasks.is_empty() && self.watched.is_empty() && self.unconfirmed.is_empty()
    }

    fn warn(&self, message: String) {
        self.opts.observer.warning(&message);
    }

    /// Claims each action and submits the ones this run holds as one array.
    fn accept(&mut self, batch: Batch) {
        // The scheduler sends only what `takes` accepted, so settings exist; a node
        // without them would be a scheduler bug, reported on each job rather than hidden.
        let Some(settings) = self
            .cfg
            .settings_for(self.plan, &self.plan.nodes[batch.node])
        else {
            for job in batch.jobs {
                self.send_failure(job, "sent to Slurm without Slurm settings".into());
            }
            return;
        };
        let mut mine = Vec::new();
        for job in batch.jobs {
            self.opts.observer.job_started(&job.label);
            match self.claims.claim(&job.key) {
                Ok(Claimed::Mine) => mine.push(job),
                Ok(Claimed::Theirs(claim)) => {
                    self.opts.observer.job_state(
                        &job.label,
                        &format!(
                            "waiting for {} of another run",
                            claim
                                .job
                                .as_deref()
                                .map_or("a job".into(), |j| format!("Slurm job {j}"))
                        ),
                    );
                    self.watched.push(Watched {
                        job,
                        claim,
                        settings: settings.clone(),
                    });
                }
                Err(e) => self.send_failure(job, format!("cannot claim it for this run: {e:#}")),
            }
        }
        self.submit_new(batch.node, &settings, mine);
    }

    fn max_array(&mut self) -> usize {
        if let Some(m) = self.max_array {
            return m;
        }
        let m = commands::max_array_size().unwrap_or_else(|e| {
            self.warn(format!("warning: {e:#}; assuming MaxArraySize=1001"));
            1001
        });
        let m = m.max(1);
        self.max_array = Some(m);
        m
    }

    /// New arrays for `jobs` (as many as MaxArraySize requires).
    fn submit_new(&mut self, node: usize, settings: &SlurmSettings, jobs: Vec<Job>) {
        if jobs.is_empty() {
            return;
        }
        let chunk = self.max_array();
        let mut jobs = jobs.into_iter().peekable();
        while jobs.peek().is_some() {
            let part: Vec<Job> = jobs.by_ref().take(chunk).collect();
            let array = match self.make_array(node, settings, &part) {
                Ok(a) => a,
                Err(e) => {
                    for job in part {
                        self.claims.release(&job.key);
                        self.send_failure(job, format!("cannot prepare its Slurm job: {e:#}"));
                    }
                    continue;
                }
            };
            let indices: Vec<u32> = (0..part.len() as u32).collect();
            match self.submit(array, &indices) {
                Ok(id) => {
                    for (index, job) in (0u32..).zip(part) {
                        let job_id = format!("{id}_{index}");
                        self.claims.set_job(&job.key, &job_id);
                        self.opts
                            .observer
                            .job_state(&job.label, &format!("Slurm job {job_id} queued"));
                        self.tasks.insert(
                            (array, index),
                            Task {
                                job,
                                array,
                                index,
                                job_id,
                                attempt: 1,
                                state: "PENDING".into(),
                                host: None,
                                ended_at: None,
                            },
                        );
                    }
                }
                Err(e) => {
                    for job in part {
                        self.claims.release(&job.key);
                        self.send_failure(job, format!("{e:#}"));
                    }
                }
            }
        }
    }

    /// Writes an array's folder: the batch script and one action spec per task.
    fn make_array(&mut self, node: usize, settings: &SlurmSettings, jobs: &[Job]) -> Result<usize> {
        let node_id = &self.plan.nodes[node].id;
        let n = self.arrays.len();
        let dir = self.run_dir.join(format!("{node_id}-{n}"));
        for sub in ["tasks", "results", "logs"] {
            fs::create_dir_all(dir.join(sub))
                .with_context(|| format!("{}: cannot create", dir.join(sub).display()))?;
        }
        let coordinator = format!("{}:{}", crate::host::host_name(), std::process::id());
        let graph = std::path::absolute(&self.plan.source.path)
            .unwrap_or_else(|_| self.plan.source.path.clone());
        for (index, job) in jobs.iter().enumerate() {
            let spec = ActionSpec {
                graph: graph.clone(),
                plan: self.cfg.plan.clone(),
                cache: self.cache.clone(),
                node: node_id.clone(),
                item: job.item.clone(),
                inputs: job.inputs.clone(),
                key: job.key.clone(),
                result: dir.join("results").join(format!("{index}.json")),
                coordinator: coordinator.clone(),
            };
            let path = dir.join("tasks").join(format!("{index}.json"));
            fs::write(&path, serde_json::to_vec_pretty(&spec)?)
                .with_context(|| format!("{}: cannot write", path.display()))?;
        }
        let worker: Vec<String> = self
            .cfg
            .worker
            .iter()
            .map(|a| shell_quote(&a.to_string_lossy()))
            .collect();
        let script = format!(
            "#!/bin/sh\n# objectsplat run {run}: task N computes the action in tasks/N.json ({node_id})\nexec {worker} {tasks}/\"$SLURM_ARRAY_TASK_ID\".json\n",
            run = self.run_id,
            worker = worker.join(" "),
            tasks = shell_quote(&dir.join("tasks").to_string_lossy()),
        );
        fs::write(dir.join("job.sh"), script)
            .with_context(|| format!("{}: cannot write", dir.join("job.sh").display()))?;
        let prefix = settings.job_name.as_deref().unwrap_or("objectsplat");
        let logs = dir.join("logs");
        let mut args = vec![
            format!("--job-name={prefix}-{node_id}"),
            format!("--output={}", logs.join("%A_%a.out").display()),
            format!("--error={}", logs.join("%A_%a.err").display()),
            // A job Slurm requeues itself appends to its log instead of erasing it.
            "--open-mode=append".into(),
            format!("--chdir={}", dir.display()),
            "--nodes=1".into(),
            "--ntasks=1".into(),
        ];
        args.extend(settings.sbatch_args());
        self.arrays.push(Array {
            dir,
            args,
            limit: settings.array_limit,
            settings: settings.clone(),
        });
        Ok(n)
    }

    /// Submits some tasks of an array; returns the (new) array job id.
    fn submit(&self, array: usize, indices: &[u32]) -> Result<String> {
        let a = &self.arrays[array];
        let mut spec = commands::array_ranges(indices);
        if let Some(limit) = a.limit {
            spec.push_str(&format!("%{limit}"));
        }
        let mut args = a.args.clone();
        args.push(format!("--array={spec}"));
        commands::sbatch(&args, &a.dir.join("job.sh"))
    }

    /// Takes every result file that appeared.
    fn collect_results(&mut self) {
        let arrays: BTreeSet<usize> = self.tasks.keys().map(|k| k.0).collect();
        for a in arrays {
            let dir = self.arrays[a].dir.join("results");
            let Ok(entries) = fs::read_dir(&dir) else {
                continue;
            };
            let mut found = Vec::new();
            for e in entries.flatten() {
                let name = e.file_name();
                let index = name
                    .to_str()
                    .and_then(|n| n.strip_suffix(".json"))
                    .and_then(|n| n.parse::<u32>().ok());
                if let Some(index) = index
                    && self.tasks.contains_key(&(a, index))
                {
                    found.push((index, e.path()));
                }
            }
            for (index, path) in found {
                if let Some(task) = self.tasks.remove(&(a, index)) {
                    self.on_result(task, &path);
                }
            }
        }
        self.resubmit_pending();
    }

    fn on_result(&mut self, task: Task, path: &Path) {
        let parsed: Result<ActionResult> = fs::read(path)
            .with_context(|| format!("{}: cannot read", path.display()))
            .and_then(|b| serde_json::from_slice(&b).context("not a result"));
        // The next attempt (if any) writes its own.
        let _ = fs::remove_file(path);
        let result = match parsed {
            Ok(r) => r,
            Err(e) => {
                return self.lost(
                    task,
                    None,
                    format!("left a result that cannot be read ({e:#})"),
                );
            }
        };
        let job_id = result.job_id.clone().unwrap_or_else(|| task.job_id.clone());
        match result.status.as_str() {
            "failed" => {
                let msg = format!(
                    "Slurm job {job_id} on {} failed: {}{}",
                    result.host,
                    result.error.as_deref().unwrap_or("(no message)"),
                    self.stderr_tail(&task)
                );
                let host = Some(result.host.clone());
                self.fail(task, msg, host);
            }
            "corrupt" => {
                let msg = result.error.unwrap_or_default();
                self.recompute(task, msg, &job_id, result.host);
            }
            _ => self.confirm(task, result),
        }
    }

    /// A result that says the action is in the cache: check the cache.
    fn confirm(&mut self, task: Task, result: ActionResult) {
        match cached(self.store, &task.job.key) {
            Ok(Some(rec)) => {
                let hit = result.status == "cached";
                self.succeed(task, rec, hit, result.warnings);
            }
            Ok(None) => self.unconfirmed.push(Unconfirmed {
                task,
                result,
                since: Instant::now(),
            }),
            Err(c) => {
                let job_id = task.job_id.clone();
                self.recompute(task, c.to_string(), &job_id, result.host);
            }
        }
    }

    /// Looks again for the records of results that came before them; after the grace,
    /// a still-missing record means the job was lost.
    fn check_unconfirmed(&mut self) {
        let waiting = std::mem::take(&mut self.unconfirmed);
        for u in waiting {
            match cached(self.store, &u.task.job.key) {
                Ok(Some(rec)) => {
                    let hit = u.result.status == "cached";
                    self.succeed(u.task, rec, hit, u.result.warnings)
                }
                _ if u.since.elapsed() >= VISIBILITY_GRACE => self.lost(
                    u.task,
                    None,
                    "reported success, but its action record is not in the cache".into(),
                ),
                _ => self.unconfirmed.push(u),
            }
        }
        self.resubmit_pending();
    }

    fn ran_on(&self, job_id: &str, host: Option<String>) -> RanOn {
        RanOn {
            executor: "slurm".into(),
            host: host.unwrap_or_default(),
            job_id: Some(job_id.to_string()),
            pid: 0,
        }
    }

    fn succeed(&mut self, task: Task, rec: ActionRecord, hit: bool, warnings: Vec<String>) {
        self.claims.release(&task.job.key);
        let status = if hit {
            Status::Cached
        } else if rec.status == "skipped" {
            Status::Skipped
        } else {
            Status::Ran
        };
        let ran_on = rec
            .ran_on
            .clone()
            .or_else(|| Some(self.ran_on(&task.job_id, task.host.clone())));
        let timing = task_timing(&task, Some(rec.seconds));
        self.send(task.job, Ok(rec), status, timing, warnings, ran_on);
    }

    fn fail(&mut self, task: Task, message: String, host: Option<String>) {
        self.keep_run_dir = true;
        let ran_on = self.ran_on(&task.job_id, host.or(task.host.clone()));
        self.end_failed(task, JobError::Failed(message), ran_on);
    }

    /// A result or record found corrupt: the coordinator computes the action again.
    fn recompute(&mut self, task: Task, message: String, job_id: &str, host: String) {
        self.warn(format!("warning: {message}; recomputing"));
        let ran_on = self.ran_on(job_id, Some(host));
        self.end_failed(task, JobError::Corrupt(message), ran_on);
    }

    fn end_failed(&mut self, task: Task, error: JobError, ran_on: RanOn) {
        self.claims.release(&task.job.key);
        let timing = task_timing(&task, None);
        self.send(
            task.job,
            Err(error),
            Status::Failed,
            timing,
            vec![],
            Some(ran_on),
        );
    }

    /// Fails an action that no job of this run computed (nothing ran: no time).
    fn send_failure(&self, job: Job, message: String) {
        self.send(
            job,
            Err(JobError::Failed(message)),
            Status::Failed,
            Timing::default(),
            vec![],
            None,
        );
    }

    fn send(
        &self,
        job: Job,
        result: Result<ActionRecord, JobError>,
        status: Status,
        timing: Timing,
        warnings: Vec<String>,
        ran_on: Option<RanOn>,
    ) {
        self.opts
            .observer
            .job_finished(&job.label, status, timing.seconds);
        // The coordinator gone means it failed and reports that itself.
        let _ = self.results.send(JobOutcome {
            node: job.node,
            item: job.item.map(|(n, _)| n),
            result,
            status,
            timing,
            warnings,
            ran_on,
        });
    }

    /// The end of a task's stderr log, for its error message.
    fn stderr_tail(&self, task: &Task) -> String {
        let path = self.arrays[task.array]
            .dir
            .join("logs")
            .join(format!("{}.err", task.job_id));
        let Ok(mut f) = fs::File::open(&path) else {
            return format!("\n(no stderr log at {})", path.display());
        };
        use std::io::{Read, Seek, SeekFrom};
        let len = f.metadata().map_or(0, |m| m.len());
        let _ = f.seek(SeekFrom::Start(len.saturating_sub(STDERR_TAIL_BYTES)));
        let mut bytes = Vec::new();
        let _ = f.read_to_end(&mut bytes);
        let text = String::from_utf8_lossy(&bytes);
        let lines: Vec<&str> = text.lines().collect();
        let tail = lines[lines.len().saturating_sub(STDERR_TAIL_LINES)..].join("\n");
        format!(
            "\n--- end of the job's stderr ({}) ---\n{tail}",
            path.display()
        )
    }

    /// Leaves the task's action to the run holding `claim`, watching for its result.
    fn wait_for_claim(&mut self, task: Task, claim: Claim) {
        let settings = self.arrays[task.array].settings.clone();
        self.watched.push(Watched {
            job: task.job,
            claim,
            settings,
        });
    }

    /// A job ended without a result: done after all, resubmitted, handed to the run
    /// that took its claim, or failed after the last attempt.
    fn lost(&mut self, mut task: Task, state: Option<&JobState>, why: String) {
        let key = task.job.key.clone();
        if let Ok(Some(rec)) = cached(self.store, &key) {
            // Killed after its record was written, or computed by someone else.
            let hit = rec.ran_on.as_ref().and_then(|r| r.job_id.as_deref()) != Some(&task.job_id);
            return self.succeed(task, rec, hit, vec![]);
        }
        if let Some(s) = state {
            task.host = s.node.clone().or(task.host.take());
        }
        if task.attempt > self.cfg.retries {
            let msg = format!(
                "Slurm job {} {why}; gave up after {} attempt{}{}",
                task.job_id,
                task.attempt,
                if task.attempt == 1 { "" } else { "s" },
                self.stderr_tail(&task)
            );
            let host = task.host.clone();
            return self.fail(task, msg, host);
        }
        match self.claims.read(&key) {
            Some(c) if c.run != self.run_id => {
                // Another run took it over (it thought this run's job dead): wait for it.
                return self.wait_for_claim(task, c);
            }
            None => {
                // Our claim vanished (someone cleaned up): claim again or wait.
                if let Ok(Claimed::Theirs(c)) = self.claims.claim(&key) {
                    return self.wait_for_claim(task, c);
                }
            }
            Some(_) => {}
        }
        self.warn(format!(
            "warning: Slurm job {} ({}) {why}; resubmitting (attempt {} of {})",
            task.job_id,
            task.job.label,
            task.attempt + 1,
            self.cfg.retries + 1
        ));
        task.ended_at = None;
        task.state = "RESUBMIT".into();
        self.tasks.insert((task.array, task.index), task);
    }

    /// Submits again the tasks [`Self::lost`] marked, one `sbatch` per array.
    fn resubmit_pending(&mut self) {
        let mut by_array: BTreeMap<usize, Vec<u32>> = BTreeMap::new();
        for t in self.tasks.values().filter(|t| t.state == "RESUBMIT") {
            by_array.entry(t.array).or_default().push(t.index);
        }
        for (array, indices) in by_array {
            match self.submit(array, &indices) {
                Ok(id) => {
                    for index in indices {
                        let Some(t) = self.tasks.get_mut(&(array, index)) else {
                            continue;
                        };
                        t.job_id = format!("{id}_{index}");
                        t.attempt += 1;
                        t.state = "PENDING".into();
                        t.host = None;
                        self.claims.set_job(&t.job.key, &t.job_id);
                        self.opts
                            .observer
                            .job_state(&t.job.label, &format!("Slurm job {} queued", t.job_id));
                    }
                }
                Err(e) => {
                    for index in indices {
                        if let Some(t) = self.tasks.remove(&(array, index)) {
                            let msg = format!("resubmitting it failed: {e:#}");
                            self.fail(t, msg, None);
                        }
                    }
                }
            }
        }
    }

    /// Asks Slurm about every job without a result, and about the jobs of other runs
    /// this run waits for.
    fn poll(&mut self) {
        self.last_poll = Instant::now();
        let mut ids: BTreeSet<String> = self
            .tasks
            .values()
            .map(|t| array_of(&t.job_id).to_string())
            .collect();
        ids.extend(
            self.watched
                .iter()
                .filter_map(|w| w.claim.job.as_deref().map(|j| array_of(j).to_string())),
        );
        let ids: Vec<String> = ids.into_iter().collect();
        let states = match commands::squeue(&ids) {
            Ok(s) => {
                self.squeue_failures = 0;
                s
            }
            Err(e) => {
                // Nothing is concluded from a failed query; slurmctld may be busy.
                self.squeue_failures += 1;
                if self.squeue_failures == 1 || self.squeue_failures.is_multiple_of(10) {
                    self.warn(format!(
                        "warning: {e:#} ({} times in a row); still waiting for the jobs",
                        self.squeue_failures
                    ));
                }
                return;
            }
        };
        // Results written just before their jobs ended.
        self.collect_results();
        let mut dead = Vec::new();
        for (k, t) in self.tasks.iter_mut() {
            let state = states
                .get(&t.job_id)
                .cloned()
                .or_else(|| commands::sacct(&t.job_id));
            match state {
                Some(s) if s.alive() => {
                    t.ended_at = None;
                    if s.state != t.state || s.node != t.host {
                        let what = match (&s.node, s.state.as_str()) {
                            (Some(n), "RUNNING") => {
                                format!("Slurm job {} running on {n}", t.job_id)
                            }
                            _ => format!(
                                "Slurm job {} {}{}",
                                t.job_id,
                                s.state.to_lowercase(),
                                s.reason
                                    .as_deref()
                                    .map(|r| format!(" ({r})"))
                                    .unwrap_or_default()
                            ),
                        };
                        self.opts.observer.job_state(&t.job.label, &what);
                        t.state = s.state.clone();
                        if s.node.is_some() {
                            t.host = s.node.clone();
                        }
                    }
                }
                Some(s)
                    if s.state == "COMPLETED"
                        && t.ended_at.get_or_insert_with(Instant::now).elapsed()
                            < VISIBILITY_GRACE => {}
                other => dead.push((*k, other)),
            }
        }
        for (k, state) in dead {
            let Some(task) = self.tasks.remove(&k) else {
                continue;
            };
            let why = match &state {
                Some(s) => format!(
                    "ended {}{}{} without a result",
                    s.state,
                    s.node
                        .as_deref()
                        .map(|n| format!(" on {n}"))
                        .unwrap_or_default(),
                    s.reason
                        .as_deref()
                        .map(|r| format!(" ({r})"))
                        .unwrap_or_default()
                ),
                None => "left the queue without a result (and accounting does not know it)".into(),
            };
            match &state {
                Some(s) if s.ends_again() => {
                    let hint = match s.state.as_str() {
                        "TIMEOUT" => {
                            "; give it more time (--slurm-time, or `slurm: (time: ...)` on the node)"
                        }
                        "OUT_OF_MEMORY" => {
                            "; give it more memory (--slurm-mem, or `slurm: (mem: ...)` on the node)"
                        }
                        _ => "",
                    };
                    let msg = format!(
                        "Slurm job {} {why}{hint}{}",
                        task.job_id,
                        self.stderr_tail(&task)
                    );
                    let host = s.node.clone();
                    self.fail(task, msg, host);
                }
                _ => self.lost(task, state.as_ref(), why),
            }
        }
        self.resubmit_pending();
        self.poll_watched(&states);
    }

    /// Jobs of other runs: done (the cache has the record), still alive, or dead (take
    /// the claim over and submit a job of this run's own).
    fn poll_watched(&mut self, states: &std::collections::HashMap<String, JobState>) {
        let mut take: BTreeMap<usize, (SlurmSettings, Vec<Job>)> = BTreeMap::new();
        for w in std::mem::take(&mut self.watched) {
            if let Ok(Some(rec)) = cached(self.store, &w.job.key) {
                let ran_on = rec.ran_on.clone();
                // Another run's work: the producing run's time, as for any cache hit.
                let timing = Timing {
                    seconds: rec.seconds,
                    ..Timing::default()
                };
                self.send(w.job, Ok(rec), Status::Cached, timing, vec![], ran_on);
                continue;
            }
            let claim = match self.claims.read(&w.job.key) {
                Some(c) => c,
                None => match self.claims.claim(&w.job.key) {
                    Ok(Claimed::Mine) => {
                        let e = take
                            .entry(w.job.node)
                            .or_insert((w.settings.clone(), vec![]));
                        e.1.push(w.job);
                        continue;
                    }
                    Ok(Claimed::Theirs(c)) => c,
                    Err(_) => w.claim.clone(),
                },
            };
            if claim.run == self.run_id {
                let e = take
                    .entry(w.job.node)
                    .or_insert((w.settings.clone(), vec![]));
                e.1.push(w.job);
                continue;
            }
            let alive = match &claim.job {
                Some(j) => states
                    .get(j)
                    .cloned()
                    .or_else(|| commands::sacct(j))
                    .is_some_and(|s| s.alive()),
                None => !Claims::abandoned(&claim),
            };
            if alive {
                self.watched.push(Watched { claim, ..w });
                continue;
            }
            match self.claims.take_over(&w.job.key) {
                Ok(Claimed::Mine) => {
                    self.warn(format!(
                        "warning: {} was waiting for {} of another run, which ended without it; submitting its own job",
                        w.job.label,
                        claim.job.as_deref().map_or("a job".into(), |j| format!("Slurm job {j}"))
                    ));
                    let e = take
                        .entry(w.job.node)
                        .or_insert((w.settings.clone(), vec![]));
                    e.1.push(w.job);
                }
                Ok(Claimed::Theirs(c)) => self.watched.push(Watched { claim: c, ..w }),
                Err(_) => self.watched.push(Watched { claim, ..w }),
            }
        }
        for (node, (settings, jobs)) in take {
            self.submit_new(node, &settings, jobs);
        }
    }

    /// Cancels every job of this run and fails what it was computing.
    fn cancel_all(&mut self, why: &str) {
        let mut unconfirmed = std::mem::take(&mut self.unconfirmed);
        // Results that already arrived count.
        self.collect_results();
        let tasks = std::mem::take(&mut self.tasks);
        let ids: Vec<String> = tasks.values().map(|t| t.job_id.clone()).collect();
        if let Err(e) = commands::scancel(&ids) {
            self.warn(format!("warning: {e:#}"));
        }
        for (_, t) in tasks {
            let msg = format!("{why}: Slurm job {} cancelled", t.job_id);
            self.fail(t, msg, None);
        }
        for u in unconfirmed.drain(..) {
            let msg = format!("{why} before its record showed up");
            self.fail(u.task, msg, None);
        }
        for w in std::mem::take(&mut self.watched) {
            self.send_failure(w.job, format!("{why} while waiting for another run's job"));
        }
    }

    /// Removes this run's job files unless a failure's log is worth keeping.
    fn finish(&mut self) {
        if !self.keep_run_dir {
            let _ = fs::remove_dir_all(&self.run_dir);
        }
    }
}
