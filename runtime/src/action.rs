//! Computing one action in this process: the node run in a staging folder, its
//! outputs ingested, its record stored — for a local worker and for a Slurm task.

use crate::job::{Job, JobError, JobOutcome, MAX_FAILURE_TEXT, RunOptions, Timing, cached};
use crate::keys::{compute_key, params_key};
use crate::node::{Context, InputValue, Outcome, PortFolders, Threads, TypeRef};
use crate::plan::Plan;
use crate::report::Status;
use crate::store::{ActionRecord, Corrupt, Manifest, RanOn, Store, short};
use anyhow::{Result, anyhow};
use std::collections::BTreeMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

/// Runs `job` on a worker thread: its threads from the jobs running when it asks
/// (see [`Threads`]), its outcome with status and timing.
pub(crate) fn execute(
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
    active.fetch_add(1, Ordering::SeqCst);
    let threads = match opts.threads_per_job {
        Some(n) => Threads::Fixed(n.max(1)),
        None => Threads::Share { jobs, active },
    };
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
    threads: Threads<'_>,
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
            folders: PortFolders {
                inputs,
                outputs: outputs.clone(),
            },
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

/// Computes the action a Slurm task was handed (the Slurm worker's one call): the
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
        Threads::Fixed(threads.max(1)),
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
