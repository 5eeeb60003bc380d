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
    fn run(&self, _: &mut Context) -> Result<Outcome> {
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
            .param("scale", ParamType::float(), Some("1.0"), "")
    }
    fn run(&self, _: &mut Context) -> Result<Outcome> {
        Ok(Outcome::Done)
    }
}

fn graph_text(n: usize) -> String {
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
            "  \"n{i}\": (kind: \"join\", inputs: (a: \"n{a}.out\", b: \"n{b}.out\"), params: (scale: 2)),\n"
        ));
    }
    text.push_str("})\n");
    text
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
    let mut reg = Registry::new();
    reg.add_type("Num", "a folder with one number");
    reg.add_node(Arc::new(Leaf)).map_err(anyhow::Error::msg)?;
    reg.add_node(Arc::new(Join)).map_err(anyhow::Error::msg)?;
    let dir = tempfile::tempdir()?;
    println!("| nodes | graph MB | validation ms (best of 3) | per node µs |");
    println!("|---:|---:|---:|---:|");
    for n in sizes {
        let path = dir.path().join(format!("g{n}.ron"));
        let text = graph_text(n);
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
