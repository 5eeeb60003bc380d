//! The run report: what ran, what was cached, skipped or failed, and why.

use serde::Serialize;
use std::collections::BTreeMap;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    Ran,
    Cached,
    Skipped,
    Failed,
}

impl Status {
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Ran => "ran",
            Status::Cached => "cached",
            Status::Skipped => "skipped",
            Status::Failed => "failed",
        }
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct ItemReport {
    pub name: String,
    pub status: Status,
    /// Its own run time; for a cached item, that of the run that produced it.
    pub seconds: f64,
    /// Time it waited for a worker (not part of `seconds`).
    pub queued_seconds: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub reason: Option<String>,
    /// Where it was computed: `local` or `slurm` (a cache hit: where its record says;
    /// `null` for records older than this field and for items that never ran).
    pub executor: Option<String>,
    /// The Slurm job that computed it (`<array job>_<task>`).
    pub job_id: Option<String>,
    /// The machine that computed it.
    pub host: Option<String>,
    /// The notes this item's run left (each item its own).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub notes: BTreeMap<String, String>,
    /// What its run measured about itself (for a cached item, the producing run's), by name:
    /// see [`crate::Context::measurement`].
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub measurements: BTreeMap<String, serde_json::Value>,
}

#[derive(Debug, Clone, Serialize)]
pub struct NodeReport {
    pub id: String,
    pub kind: String,
    pub status: Status,
    /// Its own run time, queue waiting excluded (a fan-out node: the sum over its
    /// items). Cached: the time of the run that produced the cached outputs.
    pub seconds: f64,
    /// Time from being ready to run until a worker took it (or its first item) up.
    pub queued_seconds: f64,
    pub reason: Option<String>,
    pub items: Vec<ItemReport>,
    /// For a node that does not fan out: where it was computed (as for items).
    pub executor: Option<String>,
    pub job_id: Option<String>,
    pub host: Option<String>,
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub notes: BTreeMap<String, String>,
    /// For a node that does not fan out: what its run measured (as for items).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub measurements: BTreeMap<String, serde_json::Value>,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
    /// Output digests by port (absent for failed nodes).
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub outputs: BTreeMap<String, String>,
}

#[derive(Debug, Clone, Serialize)]
pub struct RunReport {
    pub graph: String,
    pub ok: bool,
    pub seconds: f64,
    pub jobs: usize,
    pub nodes: Vec<NodeReport>,
    pub warnings: Vec<String>,
    /// Where target outputs were written.
    pub out: Option<String>,
}

impl RunReport {
    pub fn node(&self, id: &str) -> Option<&NodeReport> {
        self.nodes.iter().find(|n| n.id == id)
    }

    pub fn count(&self, status: Status) -> usize {
        self.nodes.iter().filter(|n| n.status == status).count()
    }

    /// The first failure's message, for the one-line exit cause.
    pub fn first_failure(&self) -> Option<String> {
        self.nodes
            .iter()
            .find(|n| {
                n.status == Status::Failed
                    && !n.reason.as_deref().unwrap_or("").starts_with("upstream")
            })
            .or_else(|| self.nodes.iter().find(|n| n.status == Status::Failed))
            .map(|n| {
                format!(
                    "node `{}` ({}) failed: {}",
                    n.id,
                    n.kind,
                    n.reason.clone().unwrap_or_default()
                )
            })
    }

    /// A human table for stderr.
    pub fn render_table(&self) -> String {
        let mut s = String::new();
        let w = self
            .nodes
            .iter()
            .map(|n| n.id.len())
            .max()
            .unwrap_or(4)
            .max(4);
        for n in &self.nodes {
            let items = if n.items.is_empty() {
                String::new()
            } else {
                let mut counts: BTreeMap<&str, usize> = BTreeMap::new();
                for i in &n.items {
                    *counts.entry(i.status.as_str()).or_default() += 1;
                }
                let parts: Vec<String> = counts.iter().map(|(k, v)| format!("{v} {k}")).collect();
                format!(" [{} items: {}]", n.items.len(), parts.join(", "))
            };
            let reason = n
                .reason
                .as_deref()
                .map(|r| format!("  {}", first_line(r)))
                .unwrap_or_default();
            s.push_str(&format!(
                "  {:<w$}  {:<7} {:>8.2}s{}{items}{reason}\n",
                n.id,
                n.status.as_str(),
                n.seconds,
                timing_note(n.status, n.queued_seconds)
            ));
            for (k, v) in &n.notes {
                s.push_str(&format!("  {:<w$}    {k}: {v}\n", ""));
            }
            if let Some(line) = slurm_summary(n) {
                s.push_str(&format!("  {:<w$}    {line}\n", ""));
            }
            for i in &n.items {
                for (k, v) in &i.notes {
                    s.push_str(&format!("  {:<w$}    [{}] {k}: {v}\n", "", i.name));
                }
            }
            for i in n
                .items
                .iter()
                .filter(|i| i.status == Status::Failed || i.status == Status::Skipped)
            {
                let r = i.reason.as_deref().map(first_line).unwrap_or("");
                s.push_str(&format!(
                    "  {:<w$}    {} {}: {r}\n",
                    "",
                    i.name,
                    i.status.as_str()
                ));
            }
        }
        s.push_str(&format!(
            "{} nodes: {} ran, {} cached, {} skipped, {} failed in {:.2}s (-j {})\n",
            self.nodes.len(),
            self.count(Status::Ran),
            self.count(Status::Cached),
            self.count(Status::Skipped),
            self.count(Status::Failed),
            self.seconds,
            self.jobs
        ));
        s
    }
}

/// One line on where a node's work ran on Slurm in this run (every item's job and
/// host is in `--json`): how many jobs, in which arrays, on which hosts.
fn slurm_summary(n: &NodeReport) -> Option<String> {
    let mut jobs: Vec<(&str, Option<&str>)> = n
        .items
        .iter()
        .filter(|i| i.status != Status::Cached)
        .filter(|i| i.executor.as_deref() == Some("slurm"))
        .filter_map(|i| Some((i.job_id.as_deref()?, i.host.as_deref())))
        .collect();
    if n.items.is_empty() && n.status != Status::Cached && n.executor.as_deref() == Some("slurm") {
        jobs.extend(n.job_id.as_deref().map(|j| (j, n.host.as_deref())));
    }
    if jobs.is_empty() {
        return None;
    }
    let mut arrays: Vec<&str> = jobs
        .iter()
        .map(|(j, _)| j.split('_').next().unwrap_or(j))
        .collect();
    arrays.sort_unstable();
    arrays.dedup();
    let mut hosts: Vec<&str> = jobs.iter().filter_map(|(_, h)| *h).collect();
    hosts.sort_unstable();
    hosts.dedup();
    Some(format!(
        "slurm: {} job{} (array{} {}) on {}",
        jobs.len(),
        if jobs.len() == 1 { "" } else { "s" },
        if arrays.len() == 1 { "" } else { "s" },
        arrays.join(", "),
        if hosts.is_empty() {
            "an unknown node".to_string()
        } else {
            hosts.join(", ")
        }
    ))
}

/// After the seconds column: where a cached time comes from, and queue waiting worth
/// mentioning (under 0.05 s it is scheduling noise).
fn timing_note(status: Status, queued: f64) -> String {
    let mut parts = Vec::new();
    if status == Status::Cached {
        parts.push("when produced".to_string());
    }
    if queued >= 0.05 {
        parts.push(format!("queued {queued:.2}s"));
    }
    if parts.is_empty() {
        String::new()
    } else {
        format!(" ({})", parts.join(", "))
    }
}

fn first_line(s: &str) -> &str {
    s.lines().next().unwrap_or("")
}
