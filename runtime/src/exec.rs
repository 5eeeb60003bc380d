//! The scheduler: runs the ancestors of the targets in dependency order, in
//! parallel, each node (or fan-out item) at most once, reusing cached results
//! (their keys: [`crate::keys`]; why a node would rerun: [`crate::explain`]).

use crate::keys::{compute_key, params_key};
use crate::node::{Context, InputValue, Outcome, ProgressSink, TypeRef};
use crate::plan::{Plan, PlanNode};
use crate::report::{ItemReport, NodeReport, RunReport, Status};
use crate::slurm::{SlurmConfig, SlurmSettings};
use crate::store::{ActionRecord, Corrupt, Digest, Manifest, RanOn, Store, short};
use anyhow::{Result, anyhow};
use std::collections::BTreeMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
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

/// Where the actions that miss the cache are computed.
#[derive(Debug, Clone, Default)]
pub enum Executor {
    /// In this process, on `-j` worker threads.
    #[default]
    Local,
    /// Fan-out items, and nodes with a `slurm` field, as Slurm jobs; the rest here.
    Slurm(Box<SlurmConfig>),
}

impl Executor {
    /// The job options for `node` when it runs on Slurm; `None` when it runs here.
    pub fn slurm_settings(&self, plan: &Plan, node: &PlanNode) -> Option<SlurmSettings> {
        let Executor::Slurm(cfg) = self else {
            return None;
        };
        let own = node.slurm.clone().unwrap_or_default();
        let settings = plan.slurm.overridden_by(&cfg.settings).overridden_by(&own);
        let asks = node.fans_out || node.slurm.is_some();
        (asks && settings.local != Some(true)).then_some(settings)
    }
}

/// What one job (a node, or one item of a fanned-out node) needs.
pub(crate) struct Job {
    pub node: usize,
    pub item: Option<(String, Digest)>,
    pub key: String,
    pub params_key: String,
    pub inputs: BTreeMap<String, Digest>,
    pub label: String,
    /// When the job was handed to the workers (queue waiting is reported apart).
    pub queued_at: Instant,
}

pub(crate) struct JobOutcome {
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
pub(crate) struct Timing {
    pub seconds: f64,
    pub queued: f64,
    /// When a worker took it up (`None`: answered from the cache by the scheduler).
    pub started: Option<Instant>,
}

pub(crate) enum JobError {
    Failed(String),
    Corrupt(String),
}

#[derive(Default)]
struct NodeState {
    outputs: Option<BTreeMap<String, Digest>>,
    status: Option<Status>,
    reason: Option<String>,
    started: Option<Instant>,
    /// When its first job was taken up by a worker.
    first_job: Option<Instant>,
    seconds: f64,
    queued: f64,
    pending: usize,
    items: Vec<(String, Option<ActionRecord>, ItemReport)>,
    notes: BTreeMap<String, String>,
    measurements: BTreeMap<String, serde_json::Value>,
    warnings: Vec<String>,
    keys: BTreeMap<String, String>,
    record: Option<ActionRecord>,
    /// Where a node that does not fan out was computed.
    ran_on: Option<RanOn>,
    corrupt: bool,
}

/// Runs the plan's targets with every action computed in this process.
pub fn run(plan: &Plan, store: &Store, opts: &RunOptions) -> Result<RunReport> {
    run_on(plan, store, opts, &Executor::Local)
}

/// Runs the plan's targets, computing what misses the cache with `executor`.
pub fn run_on(
    plan: &Plan,
    store: &Store,
    opts: &RunOptions,
    executor: &Executor,
) -> Result<RunReport> {
    let start = Instant::now();
    let mut warnings = Vec::new();
    // Ctrl-C must cancel the cluster jobs, not orphan them.
    let _signals =
        matches!(executor, Executor::Slurm(_)).then(crate::slurm::interrupt::Guard::install);
    // A corrupt cache entry found mid-run is deleted; the next pass recomputes it. Every
    // such pass deletes at least one entry, so this terminates; the cap guards against a
    // disk that corrupts what we write.
    for _pass in 0..1000 {
        let (mut report, corrupt) = run_pass(plan, store, opts, executor, &mut warnings)?;
        if crate::slurm::interrupt::interrupted() && _signals.is_some() {
            return Err(anyhow!(
                "interrupted: this run's Slurm jobs were cancelled{}",
                report
                    .first_failure()
                    .map(|f| format!(" ({f})"))
                    .unwrap_or_default()
            ));
        }
        if corrupt {
            continue;
        }
        // Targets that succeeded are written out even when another branch failed.
        if let Some(out) = &opts.out_dir {
            match materialize_targets(plan, store, &report, out) {
                Ok(()) => report.out = Some(out.display().to_string()),
                Err(e) if e.downcast_ref::<Corrupt>().is_some() => {
                    let msg = format!("warning: {e:#}; recomputing");
                    opts.observer.warning(&msg);
                    warnings.push(msg);
                    continue;
                }
                Err(e) => return Err(e),
            }
        }
        report.seconds = start.elapsed().as_secs_f64();
        report.warnings = warnings;
        return Ok(report);
    }
    Err(anyhow!(
        "the cache keeps returning corrupt entries ({}); delete {} and run again",
        warnings.join("; "),
        store.root().display()
    ))
}

/// Longest failure message a node's report carries.
pub(crate) const MAX_FAILURE_TEXT: usize = 16 << 10;

fn run_pass(
    plan: &Plan,
    store: &Store,
    opts: &RunOptions,
    executor: &Executor,
    warnings: &mut Vec<String>,
) -> Result<(RunReport, bool)> {
    let needed = plan.needed();
    let mut state: BTreeMap<usize, NodeState> =
        needed.iter().map(|&i| (i, NodeState::default())).collect();
    let jobs = opts.jobs.max(1);
    let active = AtomicUsize::new(0);
    let cancel = AtomicBool::new(false);
    let mut corrupt_seen = false;
    let mut pkeys: BTreeMap<usize, Result<String, String>> = BTreeMap::new();
    let warn_lock = Mutex::new(Vec::<String>::new());

    crossbeam::scope(|s| -> Result<()> {
        let (job_tx, job_rx) = crossbeam::channel::unbounded::<Job>();
        let (res_tx, res_rx) = crossbeam::channel::unbounded::<JobOutcome>();
        for _ in 0..jobs {
            let job_rx = job_rx.clone();
            let res_tx = res_tx.clone();
            let (active, cancel) = (&active, &cancel);
            s.spawn(move |_| {
                for job in job_rx {
                    let out = execute(plan, store, opts, job, active, jobs, cancel);
                    if res_tx.send(out).is_err() {
                        break;
                    }
                }
            });
        }
        // Actions for Slurm go to one thread that submits, watches and resubmits them.
        let batch_tx = match executor {
            Executor::Local => None,
            Executor::Slurm(cfg) => {
                let (batch_tx, batch_rx) =
                    crossbeam::channel::unbounded::<crate::slurm::executor::Batch>();
                let res_tx = res_tx.clone();
                let cancel = &cancel;
                s.spawn(move |_| {
                    crate::slurm::executor::track(plan, store, opts, cfg, batch_rx, res_tx, cancel)
                });
                Some(batch_tx)
            }
        };
        drop(res_tx);
        let mut in_flight = 0usize;
        // Ready queue: a node is dispatched once every input edge's source has settled.
        let mut waiting: Vec<usize> = plan.nodes.iter().map(|n| n.inputs.len()).collect();
        let mut dependents: Vec<Vec<usize>> = vec![Vec::new(); plan.nodes.len()];
        for &i in &needed {
            for inp in &plan.nodes[i].inputs {
                dependents[inp.from].push(i);
            }
        }
        let mut ready: std::collections::VecDeque<usize> = needed
            .iter()
            .copied()
            .filter(|&i| waiting[i] == 0)
            .collect();
        let mut settle = |i: usize, ready: &mut std::collections::VecDeque<usize>| {
            for &d in &dependents[i] {
                waiting[d] -= 1;
                if waiting[d] == 0 {
                    ready.push_back(d);
                }
            }
        };
        loop {
            while let Some(i) = ready.pop_front() {
                'node: {
                    let node = &plan.nodes[i];
                    let st = state.get_mut(&i).expect("needed nodes have state");
                    st.started = Some(Instant::now());
                    // Upstream failures and skips propagate.
                    let mut blocked = None;
                    let mut inputs = BTreeMap::new();
                    for inp in &node.inputs {
                        let up = &state[&inp.from];
                        match (
                            up.status,
                            up.outputs.as_ref().and_then(|o| o.get(&inp.from_port)),
                        ) {
                            (Some(Status::Failed), _) => {
                                blocked = Some((
                                    Status::Failed,
                                    format!("upstream `{}` failed", plan.nodes[inp.from].id),
                                ));
                                break;
                            }
                            (_, Some(d)) => {
                                inputs.insert(inp.port.clone(), d.clone());
                            }
                            (_, None) => {
                                let why = up.reason.clone().unwrap_or_default();
                                blocked = Some((
                                    Status::Skipped,
                                    format!(
                                        "upstream `{}` skipped ({why}), so `{}` has no value",
                                        plan.nodes[inp.from].id, inp.from_port
                                    ),
                                ));
                                break;
                            }
                        }
                    }
                    let st = state.get_mut(&i).expect("needed nodes have state");
                    if blocked.is_none() && cancel.load(Ordering::SeqCst) {
                        blocked = Some((Status::Failed, "interrupted before it started".into()));
                    }
                    if let Some((status, reason)) = blocked {
                        st.status = Some(status);
                        st.reason = Some(reason);
                        break 'node;
                    }
                    let pk = pkeys
                        .entry(i)
                        .or_insert_with(|| params_key(plan, i).map_err(|e| format!("{e:#}")));
                    let pk = match pk {
                        Ok(k) => k.clone(),
                        Err(e) => {
                            st.status = Some(Status::Failed);
                            st.reason = Some(e.clone());
                            break 'node;
                        }
                    };
                    // Fan-out: one job per item of the `each` input.
                    let each = node.inputs.iter().find(|x| x.each);
                    let items: Vec<Option<(String, Digest)>> = match each {
                        None => vec![None],
                        Some(e) => {
                            let d = inputs.remove(&e.port).expect("each input resolved above");
                            match store.manifest(&d) {
                                Ok(Some(Manifest::Collection { items, .. })) => {
                                    items.into_iter().map(Some).collect()
                                }
                                Ok(_) => {
                                    st.status = Some(Status::Failed);
                                    st.reason = Some(format!(
                                        "input `{}` is not a collection in the cache",
                                        e.port
                                    ));
                                    break 'node;
                                }
                                Err(c) => {
                                    let msg = format!("warning: {c}; recomputing");
                                    opts.observer.warning(&msg);
                                    warnings.push(msg);
                                    corrupt_seen = true;
                                    st.status = Some(Status::Failed);
                                    st.reason =
                                        Some("corrupt cache entry (recomputed next pass)".into());
                                    break 'node;
                                }
                            }
                        }
                    };
                    let (kind, version) = (&node.reg.spec.kind, &node.reg.spec.version);
                    let on_slurm = executor.slurm_settings(plan, node);
                    let mut remote = Vec::new();
                    for item in items {
                        let key = compute_key(kind, version, &pk, &inputs, item.as_ref());
                        let item_name = item.as_ref().map(|(n, _)| n.clone());
                        st.keys
                            .insert(item_name.clone().unwrap_or_default(), key.clone());
                        let label = match &item_name {
                            Some(n) => format!("{}[{n}]", node.id),
                            None => node.id.clone(),
                        };
                        match cached(store, &key) {
                            Ok(Some(rec)) => {
                                let timing = Timing {
                                    seconds: rec.seconds,
                                    ..Timing::default()
                                };
                                let ran_on = rec.ran_on.clone();
                                record_item(
                                    st,
                                    item_name,
                                    Ok(rec),
                                    Status::Cached,
                                    timing,
                                    vec![],
                                    ran_on,
                                );
                            }
                            miss => {
                                if let Err(c) = miss {
                                    let msg = format!("warning: {c}; recomputing");
                                    opts.observer.warning(&msg);
                                    warnings.push(msg);
                                }
                                let mut job_inputs = inputs.clone();
                                if let (Some(e), Some((_, d))) = (each, &item) {
                                    job_inputs.insert(e.port.clone(), d.clone());
                                }
                                st.pending += 1;
                                in_flight += 1;
                                opts.observer.job_queued(&label, &node.id);
                                let job = Job {
                                    node: i,
                                    item: item.clone(),
                                    key,
                                    params_key: pk.clone(),
                                    inputs: job_inputs,
                                    label,
                                    queued_at: Instant::now(),
                                };
                                if on_slurm.is_some() {
                                    remote.push(job);
                                } else {
                                    job_tx
                                        .send(job)
                                        .map_err(|_| anyhow!("worker threads stopped"))?;
                                }
                            }
                        }
                    }
                    // One batch per node: its missing items become one job array.
                    if let (Some(settings), Some(tx)) = (on_slurm, &batch_tx)
                        && !remote.is_empty()
                    {
                        tx.send(crate::slurm::executor::Batch {
                            node: i,
                            settings,
                            jobs: remote,
                        })
                        .map_err(|_| anyhow!("the Slurm thread stopped"))?;
                    }
                    if st.pending == 0 {
                        finish_node(plan, store, i, st, each.is_some());
                    }
                }
                if state[&i].status.is_some() {
                    settle(i, &mut ready);
                }
            }
            if in_flight == 0 {
                break;
            }
            let out = res_rx
                .recv()
                .map_err(|_| anyhow!("worker threads stopped"))?;
            in_flight -= 1;
            let st = state
                .get_mut(&out.node)
                .expect("jobs belong to needed nodes");
            st.pending -= 1;
            if let Err(JobError::Corrupt(_)) = &out.result {
                corrupt_seen = true;
                st.corrupt = true;
            }
            for w in &out.warnings {
                opts.observer.warning(w);
                if let Ok(mut v) = warn_lock.lock() {
                    v.push(w.clone());
                }
            }
            let result = out.result.map_err(|e| match e {
                JobError::Failed(m) | JobError::Corrupt(m) => m,
            });
            record_item(
                st,
                out.item,
                result,
                out.status,
                out.timing,
                out.warnings,
                out.ran_on,
            );
            if st.pending == 0 {
                let fans = plan.nodes[out.node].fans_out;
                finish_node(plan, store, out.node, st, fans);
                settle(out.node, &mut ready);
            }
        }
        drop(job_tx);
        drop(batch_tx);
        Ok(())
    })
    .map_err(|_| anyhow!("a scheduler thread panicked"))??;

    warnings.extend(warn_lock.into_inner().unwrap_or_default());
    let heads = needed
        .iter()
        .filter(|i| {
            matches!(
                state[i].status,
                Some(Status::Ran | Status::Cached | Status::Skipped)
            )
        })
        .map(|&i| (plan.nodes[i].id.clone(), state[&i].keys.clone()))
        .collect();
    let _ = store.set_heads(&plan.source.path, heads);
    let nodes: Vec<NodeReport> = needed
        .iter()
        .map(|&i| {
            let st = state.remove(&i).expect("state exists for needed nodes");
            let n = &plan.nodes[i];
            NodeReport {
                id: n.id.clone(),
                kind: n.kind.clone(),
                status: st.status.unwrap_or(Status::Failed),
                seconds: st.seconds,
                queued_seconds: st.queued,
                reason: st.reason,
                items: st.items.into_iter().map(|(_, _, r)| r).collect(),
                executor: st.ran_on.as_ref().map(|r| r.executor.clone()),
                job_id: st.ran_on.as_ref().and_then(|r| r.job_id.clone()),
                host: st.ran_on.map(|r| r.host),
                notes: st.notes,
                measurements: st.measurements,
                warnings: st.warnings,
                outputs: st.outputs.unwrap_or_default(),
            }
        })
        .collect();
    let ok = nodes.iter().all(|n| n.status != Status::Failed);
    Ok((
        RunReport {
            graph: plan.source.path.display().to_string(),
            ok,
            seconds: 0.0,
            jobs,
            nodes,
            warnings: vec![],
            out: None,
        },
        corrupt_seen,
    ))
}

/// A cache hit: a record for the key whose outputs are all present.
pub(crate) fn cached(store: &Store, key: &str) -> Result<Option<ActionRecord>, Corrupt> {
    match store.action(key)? {
        Some(rec) if rec.outputs.values().all(|d| store.has_artifact(d)) => Ok(Some(rec)),
        _ => Ok(None),
    }
}

fn record_item(
    st: &mut NodeState,
    item: Option<String>,
    result: Result<ActionRecord, String>,
    status: Status,
    timing: Timing,
    warnings: Vec<String>,
    ran_on: Option<RanOn>,
) {
    st.warnings.extend(warnings);
    if let Some(t) = timing.started {
        st.first_job = Some(st.first_job.map_or(t, |f| f.min(t)));
    }
    let mut notes = BTreeMap::new();
    let mut measurements = BTreeMap::new();
    let (rec, status, reason) = match result {
        Ok(rec) => {
            let status = if rec.status == "skipped" && status == Status::Ran {
                Status::Skipped
            } else {
                status
            };
            let reason = match (status, &rec.reason) {
                (Status::Cached, Some(r)) if rec.status == "skipped" => {
                    Some(format!("skipped: {r}"))
                }
                (_, r) => r.clone(),
            };
            notes.extend(rec.notes.iter().cloned());
            measurements.clone_from(&rec.measurements);
            (Some(rec), status, reason)
        }
        Err(msg) => (None, Status::Failed, Some(msg)),
    };
    match item {
        Some(name) => {
            st.items.push((
                name.clone(),
                rec,
                ItemReport {
                    name,
                    status,
                    seconds: timing.seconds,
                    queued_seconds: timing.queued,
                    reason,
                    notes,
                    measurements,
                    executor: ran_on.as_ref().map(|r| r.executor.clone()),
                    job_id: ran_on.as_ref().and_then(|r| r.job_id.clone()),
                    host: ran_on.map(|r| r.host),
                },
            ));
        }
        None => {
            st.status = Some(status);
            st.reason = reason;
            st.record = rec;
            st.notes = notes;
            st.measurements = measurements;
            st.seconds = timing.seconds;
            st.queued = timing.queued;
            st.ran_on = ran_on;
        }
    }
}

fn finish_node(plan: &Plan, store: &Store, i: usize, st: &mut NodeState, fans_out: bool) {
    if fans_out {
        // Its own time is its items' (they may run side by side); the wait is until a
        // worker took up its first item.
        st.seconds = st.items.iter().map(|(_, _, r)| r.seconds).sum();
        st.queued = match (st.started, st.first_job) {
            (Some(ready), Some(first)) => first.saturating_duration_since(ready).as_secs_f64(),
            _ => 0.0,
        };
    }
    if st.corrupt {
        st.status = Some(Status::Failed);
        st.reason = Some("corrupt cache entry (recomputed next pass)".into());
        return;
    }
    if !fans_out {
        if let Some(rec) = &st.record {
            st.outputs = Some(rec.outputs.clone());
        }
        return;
    }
    // Assemble collection outputs from the items.
    let node = &plan.nodes[i];
    let failed: Vec<&str> = st
        .items
        .iter()
        .filter(|(_, _, r)| r.status == Status::Failed)
        .map(|(n, _, _)| n.as_str())
        .collect();
    if !failed.is_empty() {
        st.status = Some(Status::Failed);
        let first = st
            .items
            .iter()
            .find(|(_, _, r)| r.status == Status::Failed)
            .and_then(|(_, _, r)| r.reason.clone());
        st.reason = Some(format!(
            "{} of {} items failed ({}): {}",
            failed.len(),
            st.items.len(),
            failed.join(", "),
            first.unwrap_or_default()
        ));
        return;
    }
    // Items finish in any order; the collection (and so its digest) must not depend on it.
    st.items.sort_by(|a, b| a.0.cmp(&b.0));
    let mut outputs = BTreeMap::new();
    for (port, ty) in &node.outputs {
        let items: Vec<(String, Digest)> = st
            .items
            .iter()
            .filter_map(|(name, rec, _)| {
                rec.as_ref()
                    .and_then(|r| r.outputs.get(port))
                    .map(|d| (name.clone(), d.clone()))
            })
            .collect();
        match store.put_manifest(&Manifest::Collection {
            ty: ty.element().to_string(),
            items,
        }) {
            Ok(d) => {
                outputs.insert(port.clone(), d);
            }
            Err(e) => {
                st.status = Some(Status::Failed);
                st.reason = Some(format!("cannot record outputs: {e:#}"));
                return;
            }
        }
    }
    st.outputs = Some(outputs);
    let all = |s: Status| st.items.iter().all(|(_, _, r)| r.status == s);
    st.status = Some(if st.items.is_empty() || all(Status::Cached) {
        Status::Cached
    } else if all(Status::Skipped) {
        Status::Skipped
    } else {
        Status::Ran
    });
    let skipped = st
        .items
        .iter()
        .filter(|(_, _, r)| r.status == Status::Skipped)
        .count();
    if skipped > 0 && st.status != Some(Status::Skipped) {
        st.reason = Some(format!("{skipped} of {} items skipped", st.items.len()));
    } else if st.status == Some(Status::Skipped) {
        st.reason = st.items.first().and_then(|(_, _, r)| r.reason.clone());
    }
}

fn execute(
    plan: &Plan,
    store: &Store,
    opts: &RunOptions,
    job: Job,
    active: &AtomicUsize,
    jobs: usize,
    cancel: &AtomicBool,
) -> JobOutcome {
    let t0 = Instant::now();
    let queued = t0.saturating_duration_since(job.queued_at).as_secs_f64();
    opts.observer.job_started(&job.label);
    let running = active.fetch_add(1, Ordering::SeqCst) + 1;
    let threads = opts.threads_per_job.unwrap_or(jobs / running).max(1);
    let mut warnings = Vec::new();
    let here = RanOn::local();
    let result = execute_inner(
        plan,
        store,
        opts,
        &job,
        threads,
        cancel,
        &mut warnings,
        &here,
    );
    active.fetch_sub(1, Ordering::SeqCst);
    // A stored action carries its own run time (the producing run's, for a hit);
    // a failure has none and is timed here.
    let seconds = match &result {
        Ok((rec, _)) => rec.seconds,
        Err(_) => t0.elapsed().as_secs_f64(),
    };
    let mut ran_on = Some(here);
    let (result, status) = match result {
        Ok((rec, hit)) => {
            let status = if hit {
                // Computed by another process while this one waited for the key.
                ran_on = rec.ran_on.clone();
                Status::Cached
            } else if rec.status == "skipped" {
                Status::Skipped
            } else {
                Status::Ran
            };
            (Ok(rec), status)
        }
        Err(e) => {
            let status = Status::Failed;
            if let Some(c) = e.downcast_ref::<Corrupt>() {
                warnings.push(format!("warning: {c}; recomputing"));
                (Err(JobError::Corrupt(c.to_string())), status)
            } else {
                // A node may fail with megabytes of text (a dump, a log); the report
                // and the terminal get the start of it.
                let msg = crate::diag::bounded(&format!("{e:#}"), MAX_FAILURE_TEXT);
                (Err(JobError::Failed(msg)), status)
            }
        }
    };
    opts.observer.job_finished(&job.label, status, seconds);
    JobOutcome {
        node: job.node,
        item: job.item.map(|(n, _)| n),
        result,
        status,
        timing: Timing {
            seconds,
            queued,
            started: Some(t0),
        },
        warnings,
        ran_on,
    }
}

/// Computes one job in this process (unless another process has meanwhile): the
/// record, and whether it was a cache hit after all.
#[allow(clippy::too_many_arguments)]
pub(crate) fn execute_inner(
    plan: &Plan,
    store: &Store,
    opts: &RunOptions,
    job: &Job,
    threads: usize,
    cancel: &AtomicBool,
    warnings: &mut Vec<String>,
    ran_on: &RanOn,
) -> Result<(ActionRecord, bool)> {
    let node = &plan.nodes[job.node];
    let spec = &node.reg.spec;
    // Another process may be computing the same key: wait for it, then reuse.
    let _lock = store.lock_key(&job.key)?;
    if let Ok(Some(rec)) = cached(store, &job.key) {
        return Ok((rec, true));
    }
    // The action's time: inputs laid out, the run, outputs stored (not the wait for
    // the lock above, which is another process's work).
    let t0 = Instant::now();
    let stage = store.staging(&job.label)?;
    let result = (|| {
        let mut inputs = BTreeMap::new();
        for (port, digest) in &job.inputs {
            let dir = stage.join("in").join(port);
            let items = store.materialize(digest, &dir, false)?;
            let v = match items {
                Some(items) => InputValue::Items { dir, items },
                None => InputValue::One(dir),
            };
            inputs.insert(port.clone(), v);
        }
        let mut outputs = BTreeMap::new();
        for o in &spec.outputs {
            let d = stage.join("out").join(&o.name);
            std::fs::create_dir_all(&d)?;
            outputs.insert(o.name.clone(), d);
        }
        let scratch = stage.join("scratch");
        std::fs::create_dir_all(&scratch)?;
        let mut ctx = Context {
            job: job.label.clone(),
            item: job.item.as_ref().map(|(n, _)| n.clone()),
            inputs,
            outputs: outputs.clone(),
            forwarded: BTreeMap::new(),
            params: &node.params,
            notes: vec![],
            measurements: BTreeMap::new(),
            warnings: vec![],
            threads,
            scratch,
            resume: store.resume_dir(&job.key),
            progress: opts.observer.as_ref(),
            cancel,
        };
        let outcome = catch_unwind(AssertUnwindSafe(|| node.reg.node.run(&mut ctx)))
            .unwrap_or_else(|p| {
                let msg = p
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_else(|| "unknown panic".into());
                Err(anyhow!("node panicked: {msg}"))
            })?;
        warnings.extend(ctx.warnings.iter().map(|w| format!("{}: {w}", job.label)));
        let mut out_digests = BTreeMap::new();
        for o in &spec.outputs {
            if let Some(inp) = ctx.forwarded.get(&o.name) {
                let d = job
                    .inputs
                    .get(inp)
                    .ok_or_else(|| anyhow!("forwarded input `{inp}` has no value"))?;
                out_digests.insert(o.name.clone(), d.clone());
                continue;
            }
            if matches!(outcome, Outcome::Skipped(_)) {
                continue;
            }
            let dir = &outputs[&o.name];
            let digest = match &o.ty {
                TypeRef::One(t) => store.ingest_folder(t, dir)?,
                TypeRef::List(t) => {
                    let mut names: Vec<String> = Vec::new();
                    for e in std::fs::read_dir(dir)? {
                        let e = e?;
                        if !e.file_type()?.is_dir() {
                            anyhow::bail!(
                                "output `{}` is a collection: expected one sub-folder per item, found file {:?}",
                                o.name,
                                e.file_name()
                            );
                        }
                        let name = e.file_name().into_string().map_err(|n| {
                            anyhow!("output `{}`: item name {n:?} is not UTF-8", o.name)
                        })?;
                        crate::paths::check_component(&name)
                            .map_err(|why| anyhow!("output `{}`: item {why}", o.name))?;
                        names.push(name);
                    }
                    names.sort();
                    let mut items = Vec::new();
                    for n in names {
                        items.push((n.clone(), store.ingest_folder(t, &dir.join(&n))?));
                    }
                    store.put_manifest(&Manifest::Collection {
                        ty: t.clone(),
                        items,
                    })?
                }
            };
            out_digests.insert(o.name.clone(), digest);
        }
        let (status, reason) = match outcome {
            Outcome::Done => ("ran", None),
            Outcome::Skipped(r) => ("skipped", Some(r)),
        };
        let rec = ActionRecord {
            key: job.key.clone(),
            node: node.id.clone(),
            kind: spec.kind.clone(),
            version: spec.version.clone(),
            item: job.item.as_ref().map(|(n, _)| n.clone()),
            params: job.params_key.clone(),
            inputs: job.inputs.clone(),
            outputs: out_digests,
            status: status.into(),
            reason,
            seconds: t0.elapsed().as_secs_f64(),
            notes: ctx.notes,
            measurements: ctx.measurements,
            ran_on: Some(ran_on.clone()),
        };
        store.put_action(&rec)?;
        // The action is stored: progress saved for a resume is no longer needed.
        let resume = store.resume_dir(&job.key);
        if resume.exists() {
            let _ = std::fs::remove_dir_all(&resume);
        }
        Ok((rec, false))
    })();
    let _ = std::fs::remove_dir_all(&stage);
    result
}

/// Computes the action a Slurm task was handed (see [`crate::slurm::worker`]): the
/// record, whether another process computed it meanwhile, and the node's warnings.
/// Refuses to compute anything but the coordinator's key.
pub(crate) fn compute_action(
    plan: &Plan,
    store: &Store,
    opts: &RunOptions,
    spec: &crate::slurm::ActionSpec,
    ran_on: &RanOn,
    threads: usize,
) -> Result<(ActionRecord, bool, Vec<String>)> {
    let i = plan
        .index(&spec.node)
        .ok_or_else(|| anyhow!("no node `{}` in {}", spec.node, plan.source.path.display()))?;
    let node = &plan.nodes[i];
    let pk = params_key(plan, i)?;
    // The key covers the item separately from the other inputs.
    let mut key_inputs = spec.inputs.clone();
    if let Some(each) = node.inputs.iter().find(|x| x.each) {
        key_inputs.remove(&each.port);
    }
    let spec_ = &node.reg.spec;
    let key = compute_key(
        &spec_.kind,
        &spec_.version,
        &pk,
        &key_inputs,
        spec.item.as_ref(),
    );
    if key != spec.key {
        anyhow::bail!(
            "this is not the action the coordinator planned (key {} here, {} there): the graph file, \
             a param, a file the node reads, a program it starts or the objectsplat build differs \
             between the coordinator and this node; the cache, the graph and its inputs must be the \
             same files on both, and the programs the same versions",
            short(&key),
            short(&spec.key)
        );
    }
    let job = Job {
        node: i,
        item: spec.item.clone(),
        key,
        params_key: pk,
        inputs: spec.inputs.clone(),
        label: match &spec.item {
            Some((n, _)) => format!("{}[{n}]", node.id),
            None => node.id.clone(),
        },
        queued_at: Instant::now(),
    };
    opts.observer.job_started(&job.label);
    let cancel = AtomicBool::new(false);
    let mut warnings = Vec::new();
    let t0 = Instant::now();
    let (rec, hit) = execute_inner(
        plan,
        store,
        opts,
        &job,
        threads,
        &cancel,
        &mut warnings,
        ran_on,
    )?;
    let status = match (hit, rec.status.as_str()) {
        (true, _) => Status::Cached,
        (false, "skipped") => Status::Skipped,
        _ => Status::Ran,
    };
    opts.observer
        .job_finished(&job.label, status, t0.elapsed().as_secs_f64());
    Ok((rec, hit, warnings))
}

fn materialize_targets(plan: &Plan, store: &Store, report: &RunReport, out: &Path) -> Result<()> {
    let mut targets = Vec::new();
    for &t in &plan.targets {
        let id = &plan.nodes[t].id;
        let Some(n) = report.node(id) else { continue };
        for (port, digest) in &n.outputs {
            targets.push(crate::outdir::TargetOutput {
                node: id,
                port,
                digest,
            });
        }
    }
    crate::outdir::write_targets(store, out, &targets)
}

/// The outputs node `i` has in the cache for its params key `pk` and resolved
/// `inputs` (a fan-out node's `each` input as the whole collection), assembled as a
/// run assembles them; `None` when some run (item) is not cached.
pub(crate) fn cached_outputs(
    plan: &Plan,
    store: &Store,
    i: usize,
    pk: &str,
    inputs: &BTreeMap<String, Digest>,
) -> Option<BTreeMap<String, Digest>> {
    let node = &plan.nodes[i];
    let spec = &node.reg.spec;
    let mut inputs = inputs.clone();
    let each = node.inputs.iter().find(|x| x.each);
    let items: Vec<Option<(String, Digest)>> = match each {
        None => vec![None],
        Some(e) => match store.manifest(&inputs.remove(&e.port)?).ok().flatten()? {
            Manifest::Collection { items, .. } => items.into_iter().map(Some).collect(),
            _ => return None,
        },
    };
    let mut by_port: BTreeMap<String, Vec<(String, Digest)>> = BTreeMap::new();
    for item in &items {
        let key = compute_key(&spec.kind, &spec.version, pk, &inputs, item.as_ref());
        let rec = cached(store, &key).ok().flatten()?;
        let name = item.as_ref().map(|(n, _)| n.clone()).unwrap_or_default();
        for (port, d) in rec.outputs {
            by_port.entry(port).or_default().push((name.clone(), d));
        }
    }
    if each.is_none() {
        return Some(
            by_port
                .into_iter()
                .filter_map(|(port, mut v)| v.pop().map(|(_, d)| (port, d)))
                .collect(),
        );
    }
    let mut outputs = BTreeMap::new();
    for (port, ty) in &node.outputs {
        let mut items = by_port.remove(port).unwrap_or_default();
        items.sort_by(|a, b| a.0.cmp(&b.0));
        let m = Manifest::Collection {
            ty: ty.element().to_string(),
            items,
        };
        outputs.insert(port.clone(), store.put_manifest(&m).ok()?);
    }
    Some(outputs)
}
