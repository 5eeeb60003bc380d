//! The scheduler: runs the ancestors of the targets in dependency order, in
//! parallel, each node (or fan-out item) at most once, reusing cached results
//! (their keys: the `keys` module; one action computed: `action`; why a node would
//! rerun: `explain`).

use crate::action::execute;
use crate::executor::{Batch, Pass};
pub use crate::executor::{Executor, Local};
use crate::job::{Job, JobError, JobOutcome, Timing, cached};
pub use crate::job::{Observer, RunOptions, Silent};
use crate::keys::{compute_key, params_key};
use crate::plan::Plan;
use crate::report::{ItemReport, NodeReport, RunReport, Status};
use crate::store::{ActionRecord, Corrupt, Digest, Manifest, RanOn, Store};
use anyhow::{Result, anyhow};
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

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
    run_on(plan, store, opts, &Local)
}

/// Runs the plan's targets, computing what misses the cache with `executor`.
pub fn run_on(
    plan: &Plan,
    store: &Store,
    opts: &RunOptions,
    executor: &dyn Executor,
) -> Result<RunReport> {
    let start = Instant::now();
    let mut warnings = Vec::new();
    let _held = executor.hold();
    // A corrupt cache entry found mid-run is deleted; the next pass recomputes it. Every
    // such pass deletes at least one entry, so this terminates; the cap guards against a
    // disk that corrupts what we write.
    for _pass in 0..1000 {
        let (mut report, corrupt) = run_pass(plan, store, opts, executor, &mut warnings)?;
        if let Some(why) = executor.interruption() {
            return Err(anyhow!(
                "{why}{}",
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

fn run_pass(
    plan: &Plan,
    store: &Store,
    opts: &RunOptions,
    executor: &dyn Executor,
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
        // The executor's batches go to one thread of its own (Slurm: it submits, watches
        // and resubmits their jobs).
        let (batch_tx, batch_rx) = crossbeam::channel::unbounded::<Batch>();
        {
            let res_tx = res_tx.clone();
            let pass = Pass {
                plan,
                store,
                opts,
                cancel: &cancel,
            };
            s.spawn(move |_| executor.serve(pass, batch_rx, res_tx));
        }
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
                    let taken = executor.takes(plan, node);
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
                                if taken {
                                    remote.push(job);
                                } else {
                                    job_tx
                                        .send(job)
                                        .map_err(|_| anyhow!("worker threads stopped"))?;
                                }
                            }
                        }
                    }
                    // One batch per node (Slurm: its missing items become one job array).
                    if !remote.is_empty() {
                        batch_tx
                            .send(Batch {
                                node: i,
                                jobs: remote,
                            })
                            .map_err(|_| anyhow!("the executor's thread stopped"))?;
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
