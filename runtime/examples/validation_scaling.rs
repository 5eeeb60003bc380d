//! Graph validation time against graph size: parsing, checking and planning only.
//!
//!     cargo run --release -p objectsplat-runtime --example validation_scaling -- [NODES]...
//!
//! For each size (default 10000 40000 100000) it writes a graph like
//! `scheduler_overhead`'s (a tenth leaves, the rest `join` nodes reading the previous
//! node and a pseudo-random earlier one, every node with a param) and times
//! `GraphSource::read` + `build_plan`, best of three. Linear validation keeps the
//! per-node figure flat as the graph grows.

use anyhow::Result;
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::build_plan;
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, ParamType};
use std::sync::Arc;
use std::time::Instant;

mod bench_graph;

struct Leaf;
impl Node for Leaf {
    fn spec(&self) -> NodeSpec {
        bench_graph::leaf_spec()
    }
    fn run(&self, _: &mut Context) -> Result<Outcome> {
        Ok(Outcome::Done)
    }
}

struct Join;
impl Node for Join {
    fn spec(&self) -> NodeSpec {
        bench_graph::join_spec().param("scale", ParamType::float(), Some("1.0"), "")
    }
    fn run(&self, _: &mut Context) -> Result<Outcome> {
        Ok(Outcome::Done)
    }
}

fn main() -> Result<()> {
    let sizes: Vec<usize> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let sizes = if sizes.is_empty() {
        vec![10_000, 40_000, 100_000]
    } else {
        sizes
    };
    let reg = bench_graph::registry(vec![Arc::new(Leaf), Arc::new(Join)])?;
    let dir = tempfile::tempdir()?;
    println!("| nodes | graph MB | validation ms (best of 3) | per node µs |");
    println!("|---:|---:|---:|---:|");
    for n in sizes {
        let path = dir.path().join(format!("g{n}.ron"));
        let text = bench_graph::wide_deep_graph(n, "scale: 2");
        std::fs::write(&path, &text)?;
        let mut best = f64::INFINITY;
        for _ in 0..3 {
            let t0 = Instant::now();
            let src = GraphSource::read(&path)?;
            let plan = build_plan(&src, &reg, &[], &[])?;
            let t = t0.elapsed().as_secs_f64();
            assert_eq!(plan.nodes.len(), n);
            best = best.min(t);
        }
        println!(
            "| {n} | {:.1} | {:.1} | {:.2} |",
            text.len() as f64 / 1e6,
            best * 1e3,
            best * 1e6 / n as f64
        );
    }
    Ok(())
}
