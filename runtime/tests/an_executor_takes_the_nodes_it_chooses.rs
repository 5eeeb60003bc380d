//! An executor of a test's own: the scheduler hands it exactly the nodes it takes — one
//! batch per node with that node's cache misses, none for cache hits — runs everything
//! else on its workers, and reports what the executor sent back as the node's outcome.

mod common;
use common::*;
use crossbeam::channel::{Receiver, Sender};
use objectsplat_runtime::exec::{self, Executor, Local, RunOptions, Silent};
use objectsplat_runtime::executor::{Batch, Pass};
use objectsplat_runtime::job::{JobError, JobOutcome, Timing};
use objectsplat_runtime::plan::{Plan, PlanNode};
use objectsplat_runtime::report::{RunReport, Status};
use objectsplat_runtime::store::Store;
use std::path::Path;
use std::sync::{Arc, Mutex};

/// Takes fan-out nodes and has no machine for them: each job fails, and each batch is
/// logged as (node, item labels).
#[derive(Default)]
struct NoMachine {
    log: Mutex<Vec<(String, Vec<String>)>>,
}

impl Executor for NoMachine {
    fn takes(&self, _: &Plan, node: &PlanNode) -> bool {
        node.fans_out
    }

    fn serve(&self, pass: Pass<'_>, batches: Receiver<Batch>, results: Sender<JobOutcome>) {
        for batch in batches {
            let labels = batch.jobs.iter().map(|j| j.label.clone()).collect();
            let node = pass.plan.nodes[batch.node].id.clone();
            self.log.lock().unwrap().push((node, labels));
            for job in batch.jobs {
                let outcome = JobOutcome {
                    node: job.node,
                    item: job.item.map(|(name, _)| name),
                    result: Err(JobError::Failed(format!("no machine for {}", job.label))),
                    status: Status::Failed,
                    timing: Timing::default(),
                    warnings: vec![],
                    ran_on: None,
                };
                if results.send(outcome).is_err() {
                    return;
                }
            }
        }
    }
}

const GRAPH: &str = r#"(
  nodes: {
    "x": (kind: "const", params: (value: 1)),
    "s": (kind: "split", params: (values: [1, 2, 3])),
    "d": (kind: "double", inputs: (x: each("s.items"))),
    "y": (kind: "add", inputs: (a: "x.out")),
  },
  targets: ["d", "y"],
)"#;

fn run(plan: &Plan, cache: &Path, executor: &dyn Executor) -> RunReport {
    let store = Store::open(cache).unwrap();
    let opts = RunOptions {
        jobs: 2,
        threads_per_job: None,
        out_dir: None,
        observer: Arc::new(Silent),
    };
    exec::run_on(plan, &store, &opts, executor).unwrap()
}

#[test]
fn the_fan_out_goes_to_the_executor_as_one_batch_and_the_rest_runs_here() {
    let ws = Workspace::new();
    let plan = plan_graph(&ws.graph(GRAPH), &registry(), &[], &[]);
    let executor = NoMachine::default();
    let r = run(&plan, &ws.cache(), &executor);

    let log = executor.log.lock().unwrap().clone();
    assert_eq!(
        log,
        [(
            "d".to_string(),
            vec!["d[item0]".to_string(), "d[item1]".into(), "d[item2]".into()]
        )]
    );
    for id in ["x", "s", "y"] {
        assert_eq!(r.node(id).unwrap().status, Status::Ran, "{id}");
    }
    let d = r.node("d").unwrap();
    assert_eq!(d.status, Status::Failed);
    assert!(
        format!("{:?}", d).contains("no machine for d[item0]"),
        "the executor's error reaches the report: {d:?}"
    );
}

#[test]
fn cache_hits_never_reach_the_executor() {
    let ws = Workspace::new();
    let plan = plan_graph(&ws.graph(GRAPH), &registry(), &[], &[]);
    let here = run(&plan, &ws.cache(), &Local);
    assert_eq!(here.node("d").unwrap().status, Status::Ran);

    let executor = NoMachine::default();
    let again = run(&plan, &ws.cache(), &executor);
    assert!(executor.log.lock().unwrap().is_empty());
    for id in ["x", "s", "d", "y"] {
        assert_eq!(again.node(id).unwrap().status, Status::Cached, "{id}");
    }
}
