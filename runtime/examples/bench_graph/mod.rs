//! What the benchmark examples share: their graphs pass one number per node, in a folder
//! (`Num`), and the overhead ones are wide and deep, a tenth of them leaves.

// Each example uses a part of it.
#![allow(dead_code)]

use anyhow::Result;
use objectsplat_runtime::{Node, NodeSpec, ParamType, Registry};
use std::sync::Arc;

/// A registry of the `kinds`, over the one type `Num`.
pub fn registry(kinds: Vec<Arc<dyn Node>>) -> Result<Registry> {
    let mut reg = Registry::new();
    reg.add_type("Num", "a folder with one number");
    for kind in kinds {
        reg.add_node(kind).map_err(anyhow::Error::msg)?;
    }
    Ok(reg)
}

/// `leaf`: a number from its `value` param.
pub fn leaf_spec() -> NodeSpec {
    let value = ParamType::int();
    NodeSpec::new("leaf", "1")
        .output("out", "Num", "")
        .param("value", value, Some("0"), "")
}

/// `join`: a number from the two it reads.
pub fn join_spec() -> NodeSpec {
    NodeSpec::new("join", "1")
        .input("a", "Num", "")
        .input("b", "Num", "")
        .output("out", "Num", "")
}

/// `n` nodes: `n / 10` leaves (at least two), then `join` nodes (with `join_params`, a RON
/// tuple's fields, where not empty) each reading the node before it and a pseudo-random earlier one, so the
/// DAG is wide and deep; the same graph for the same arguments.
pub fn wide_deep_graph(n: usize, join_params: &str) -> String {
    let leaves = (n / 10).max(2);
    let mut text = String::from("(nodes: {\n");
    for i in 0..leaves {
        text.push_str(&format!(
            "  \"n{i}\": (kind: \"leaf\", params: (value: {i})),\n"
        ));
    }
    let params = match join_params {
        "" => String::new(),
        fields => format!(", params: ({fields})"),
    };
    let mut s: u64 = 0x9e3779b97f4a7c15;
    for i in leaves..n {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        let a = i - 1;
        let b = (s % i as u64) as usize;
        text.push_str(&format!(
            "  \"n{i}\": (kind: \"join\", inputs: (a: \"n{a}.out\", b: \"n{b}.out\"){params}),\n"
        ));
    }
    text.push_str("})\n");
    text
}
