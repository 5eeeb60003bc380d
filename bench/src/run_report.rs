//! The `--json` run report an `objectsplat run` child writes, read back by the benches.

use anyhow::{Context, Result, bail};
use objectsplat_core::{TRAINING_TIMES, TrainingLog, TrainingTimes};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

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

/// `binary run GRAPH --cache CACHE --out DIR/out --json DIR/report.json`: the child every
/// bench starts (the caller adds its own options), and where its report will be.
pub fn run_command(binary: &Path, graph: &Path, cache: &Path, dir: &Path) -> (Command, PathBuf) {
    let json = dir.join("report.json");
    let mut command = Command::new(binary);
    command
        .arg("run")
        .arg(graph)
        .arg("--cache")
        .arg(cache)
        .arg("--out")
        .arg(dir.join("out"))
        .arg("--json")
        .arg(&json);
    (command, json)
}

/// Runs `command` (from [`run_command`]) to its end and reads the report at `json`.
pub fn run_to_report(
    mut command: Command,
    json: &Path,
    binary: &Path,
    graph: &Path,
) -> Result<Value> {
    let status = command
        .status()
        .with_context(|| format!("cannot start {}", binary.display()))?;
    if !status.success() {
        bail!(
            "{} run {} failed ({status})",
            binary.display(),
            graph.display()
        );
    }
    read(json)
}

/// A trained item's log (in its Model folder `model`) and when it reached its log
/// points (from the run report's `item`, named `node[component]` in errors).
pub fn training_record(
    item: &Value,
    model: &Path,
    node: &str,
    component: &str,
) -> Result<(TrainingLog, TrainingTimes)> {
    let log = TrainingLog::load(model)?
        .with_context(|| format!("no training log in {}", model.display()))?;
    let times = item["measurements"]
        .get(TRAINING_TIMES)
        .map(TrainingTimes::from_json)
        .transpose()
        .with_context(|| format!("{node}[{component}] in the run report"))?
        .with_context(|| format!("{node}[{component}]: the run report has no training times"))?;
    Ok((log, times))
}
