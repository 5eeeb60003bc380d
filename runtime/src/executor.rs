//! Where the actions that miss the cache are computed.
//!
//! The scheduler (`exec`) always owns the `-j` worker threads of this process. An
//! [`Executor`] may take some nodes' actions away from them — one batch per node, its
//! missing items together — and compute them elsewhere; it sends each action's outcome
//! back on the channel the workers use, so the scheduler cannot tell who computed what.
//! [`Local`] takes nothing; the Slurm executor (`slurm::SlurmConfig`) takes fan-out items
//! and nodes that ask for it. A cloud batch service would be a third implementation; the
//! scheduler, the graph parser and the store would not change.

use crate::job::{Job, JobOutcome, RunOptions};
use crate::plan::{Plan, PlanNode};
use crate::store::Store;
use crossbeam::channel::{Receiver, Sender};
use std::any::Any;
use std::sync::atomic::AtomicBool;

/// One node's actions that missed the cache, handed to an executor together.
pub struct Batch {
    /// The node's index in the plan.
    pub node: usize,
    pub jobs: Vec<Job>,
}

/// What one pass of the scheduler shares with the executor serving it.
pub struct Pass<'a> {
    pub plan: &'a Plan,
    pub store: &'a Store,
    pub opts: &'a RunOptions,
    /// Set by whoever stops the run early; the workers stop taking up jobs.
    pub cancel: &'a AtomicBool,
}

/// Computes the actions of the nodes it [takes](Executor::takes); every other action
/// runs on this process's worker threads.
pub trait Executor: Sync {
    /// Whether the actions of `node` that miss the cache are sent here, as one
    /// [`Batch`], instead of to the local workers.
    fn takes(&self, plan: &Plan, node: &PlanNode) -> bool;

    /// Computes the batches that arrive until `batches` closes, sending one outcome per
    /// job on `results`. Runs on its own thread, once per scheduler pass; the scheduler
    /// closes `batches` only once every job it sent has an outcome, or when it failed
    /// (then what is still outstanding must be stopped).
    fn serve(&self, pass: Pass<'_>, batches: Receiver<Batch>, results: Sender<JobOutcome>);

    /// Set up for the whole run and held until it ends (Slurm: signal handlers that
    /// cancel the run's jobs on Ctrl-C instead of leaving them queued).
    fn hold(&self) -> Option<Box<dyn Any>> {
        None
    }

    /// Why the run must stop after the current pass, if it must (Slurm: a Ctrl-C
    /// cancelled its jobs).
    fn interruption(&self) -> Option<String> {
        None
    }
}

/// Everything in this process, on `-j` worker threads.
#[derive(Debug, Clone, Copy, Default)]
pub struct Local;

impl Executor for Local {
    fn takes(&self, _: &Plan, _: &PlanNode) -> bool {
        false
    }

    /// Takes no node, so no batch ever arrives.
    fn serve(&self, _: Pass<'_>, _: Receiver<Batch>, _: Sender<JobOutcome>) {}
}
