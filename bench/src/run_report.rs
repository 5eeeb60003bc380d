//! The `--json` run report an `objectsplat run` child writes, read back by the benches.

use anyhow::{Context, Result};
use serde_json::Value;
use std::path::Path;

/// The run report at `json`.
pub fn read(json: &Path) -> Result<Value> {
    let text =
        std::fs::read_to_string(json).with_context(|| format!("cannot read {}", json.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{} is not JSON", json.display()))
}

/// The report's entry for node `id`.
pub fn node<'a>(report: &'a Value, id: &str) -> Option<&'a Value> {
    report["nodes"]
        .as_array()
        .and_then(|n| n.iter().find(|n| n["id"] == id))
}
