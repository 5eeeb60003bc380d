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
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, ParamType, Registry};
use std::sync::Arc;
use std::time::Instant;

struct Leaf;
impl Node for Leaf {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("leaf", "1").output("out", "Num", "").param(
            "value",
            ParamType::int(),
            Some("0"),
            "",
        )
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
        NodeSpec::new("join", "1")
            .input("a", "Num", "")
            .input("b", "Num", "")
            .output("out", "Num", "")
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
    let leaves = (n / 10).max(2);
    let mut text = String::from("(nodes: {\n");
    for i in 0..leaves {
        text.push_str(&format!(
            "  \"n{i}\": (kind: \"leaf\", params: (value: {i})),\n"
        ));
    }
    // Deterministic pseudo-random wiring to earlier nodes.
    let mut s: u64 = 0x9e3779b97f4a7c15;
    for i in leaves..n {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        let a = i - 1;
        let b = (s % i as u64) as usize;
        text.push_str(&format!(
            "  \"n{i}\": (kind: \"join\", inputs: (a: \"n{a}.out\", b: \"n{b}.out\")),\n"
        ));
    }
    text.push_str("})\n");
    let dir = tempfile::tempdir()?;
    let graph = dir.path().join("bench.ron");
    std::fs::write(&graph, &text)?;
    let mut reg = Registry::new();
    reg.add_type("Num", "a folder with one number");
    reg.add_node(Arc::new(Leaf)).map_err(anyhow::Error::msg)?;
    reg.add_node(Arc::new(Join)).map_err(anyhow::Error::msg)?;
    let src = GraphSource::read(&graph)?;
    let opts = RunOptions {
        jobs,
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
