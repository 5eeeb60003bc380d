//! Scheduler overhead on a synthetic graph of trivial nodes.
//!
//!     cargo run --release -p objectsplat-runtime --example scheduler_overhead -- [NODES] [JOBS]
//!
//! The graph: NODES/10 leaves (`leaf`, a param-only node) and the rest `join` nodes,
//! each reading two earlier nodes, so the DAG is wide and deep. Measures a cold run,
//! a fully cached rerun, and a rerun after one leaf's param changed.

use anyhow::Result;
use objectsplat_runtime::exec::{self, RunOptions, Silent};
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::{Override, build_plan};
use objectsplat_runtime::report::Status;
use objectsplat_runtime::store::Store;
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome};
use std::sync::Arc;
use std::time::Instant;

mod bench_graph;

struct Leaf;
impl Node for Leaf {
    fn spec(&self) -> NodeSpec {
        bench_graph::leaf_spec()
    }
    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        std::fs::write(
            ctx.output("out")?.join("v"),
            ctx.param::<i64>("value")?.to_string(),
        )?;
        Ok(Outcome::Done)
    }
}

struct Join;
impl Node for Join {
    fn spec(&self) -> NodeSpec {
        bench_graph::join_spec()
    }
    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let a: i64 = std::fs::read_to_string(ctx.input("a")?.join("v"))?.parse()?;
        let b: i64 = std::fs::read_to_string(ctx.input("b")?.join("v"))?.parse()?;
        // Bounded so outputs stay small (and many repeat: early cutoff has work to do).
        std::fs::write(
            ctx.output("out")?.join("v"),
            ((a + b) % 1_000_003).to_string(),
        )?;
        Ok(Outcome::Done)
    }
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let n: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(1000);
    let jobs: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(2);
    let text = bench_graph::wide_deep_graph(n, "");
    let dir = tempfile::tempdir()?;
    let graph = dir.path().join("bench.ron");
    std::fs::write(&graph, &text)?;
    let reg = bench_graph::registry(vec![Arc::new(Leaf), Arc::new(Join)])?;
    let src = GraphSource::read(&graph)?;
    let opts = RunOptions {
        jobs,
        threads_per_job: None,
        out_dir: None,
        observer: Arc::new(Silent),
    };
    let cache = dir.path().join("cache");

    let run = |sets: &[&str]| -> Result<(f64, f64, usize)> {
        let overrides: Vec<Override> = sets
            .iter()
            .map(|s| Override::parse(s))
            .collect::<Result<_, _>>()?;
        let t0 = Instant::now();
        let plan = build_plan(&src, &reg, &overrides, &[])?;
        let t_plan = t0.elapsed().as_secs_f64();
        let store = Store::open(&cache)?;
        let report = exec::run(&plan, &store, &opts)?;
        let ran = report
            .nodes
            .iter()
            .filter(|n| n.status == Status::Ran)
            .count();
        Ok((t0.elapsed().as_secs_f64(), t_plan, ran))
    };
    println!("| run | nodes ran | total ms | of which validation ms | per node µs |");
    println!("|---|---|---|---|---|");
    for (label, sets) in [
        ("cold", vec![]),
        ("fully cached", vec![]),
        ("one leaf changed", vec!["n0.value=12345"]),
        ("fully cached again", vec!["n0.value=12345"]),
    ] {
        let (t, tp, ran) = run(&sets)?;
        println!(
            "| {label} | {ran} | {:.1} | {:.1} | {:.1} |",
            t * 1e3,
            tp * 1e3,
            t * 1e6 / n as f64
        );
    }
    Ok(())
}
