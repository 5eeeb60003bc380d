//! What a Slurm job asks for (partition, time, CPUs, memory, GPUs, extra `sbatch`
//! arguments), from three places, most specific last: the graph's `slurm: (...)`
//! field, the command line, and a node's own `slurm: (...)` field.
//!
//! ```ron
//! (
//!   nodes: {
//!     "train":    (kind: "train", inputs: (...), slurm: (gres: "gpu:1", time: "02:00:00")),
//!     "evaluate": (kind: "evaluate", inputs: (...), slurm: (cpus: 4)),
//!     "fills":    (kind: "inpaint_background", inputs: (...), slurm: (local: true)),
//!   },
//!   slurm: (partition: "gpu", mem: "16G"),
//! )
//! ```
//!
//! None of this enters a cache key: where an action runs never changes what it computes.

use crate::diag::{Diagnostic, did_you_mean, similar};
use crate::source::GraphSource;
use crate::syntax::{SKind, Spanned};

/// Options for the jobs of one node; `None` = not said here (a less specific place or
/// Slurm's default decides).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SlurmSettings {
    /// `--partition`.
    pub partition: Option<String>,
    /// `--time`, in any form Slurm takes (`"30"`, `"02:00:00"`, `"1-00:00:00"`).
    pub time: Option<String>,
    /// `--cpus-per-task`.
    pub cpus: Option<u32>,
    /// `--mem` (`"16G"`, `"4000M"`).
    pub mem: Option<String>,
    /// `--gres` (`"gpu:1"`, `"gpu:a100:2"`); an empty string asks for none.
    pub gres: Option<String>,
    /// More `sbatch` arguments, passed as given after the ones above (`"--qos=high"`).
    pub args: Vec<String>,
    /// Job names are `<prefix>-<node id>` (default prefix `objectsplat`).
    pub job_name: Option<String>,
    /// At most this many tasks of one array run at once (`--array=...%N`).
    pub array_limit: Option<u32>,
    /// On a node: run it on the coordinating machine even under `--executor slurm`.
    pub local: Option<bool>,
}

/// The field names, for "did you mean" and the expected-list in errors.
const FIELDS: [&str; 9] = [
    "partition",
    "time",
    "cpus",
    "mem",
    "gres",
    "args",
    "job_name",
    "array_limit",
    "local",
];

impl SlurmSettings {
    /// `self` with every option `more` says replacing this one's (`args` are appended,
    /// so a later `--qos` wins where `sbatch` takes the last of a repeated option).
    pub fn overridden_by(&self, more: &SlurmSettings) -> SlurmSettings {
        let pick = |a: &Option<String>, b: &Option<String>| b.clone().or_else(|| a.clone());
        SlurmSettings {
            partition: pick(&self.partition, &more.partition),
            time: pick(&self.time, &more.time),
            cpus: more.cpus.or(self.cpus),
            mem: pick(&self.mem, &more.mem),
            gres: pick(&self.gres, &more.gres),
            args: self.args.iter().chain(&more.args).cloned().collect(),
            job_name: pick(&self.job_name, &more.job_name),
            array_limit: more.array_limit.or(self.array_limit),
            local: more.local.or(self.local),
        }
    }

    /// The `sbatch` arguments these settings stand for (without `--array` and the
    /// job name, which the executor adds).
    pub fn sbatch_args(&self) -> Vec<String> {
        let mut a = Vec::new();
        if let Some(p) = &self.partition {
            a.push(format!("--partition={p}"));
        }
        if let Some(t) = &self.time {
            a.push(format!("--time={t}"));
        }
        if let Some(c) = self.cpus {
            a.push(format!("--cpus-per-task={c}"));
        }
        if let Some(m) = &self.mem {
            a.push(format!("--mem={m}"));
        }
        if let Some(g) = self.gres.as_deref().filter(|g| !g.is_empty()) {
            a.push(format!("--gres={g}"));
        }
        a.extend(self.args.iter().cloned());
        a
    }

    /// Reads a `slurm: (...)` field of the graph (`node` = `None`) or of a node.
    pub fn parse(
        src: &GraphSource,
        value: &Spanned,
        node: Option<&str>,
    ) -> Result<SlurmSettings, Vec<Diagnostic>> {
        let whose = match node {
            Some(id) => format!("node {id:?}: slurm"),
            None => "slurm".to_string(),
        };
        let fields = match &value.kind {
            SKind::Struct(_, f) => f.as_slice(),
            SKind::Unit => &[],
            _ => {
                return Err(vec![src.diag(
                    value.span,
                    format!(
                        "{whose} must be a struct like `(partition: \"gpu\", gres: \"gpu:1\")`, found {}",
                        value.shape()
                    ),
                )]);
            }
        };
        let mut s = SlurmSettings::default();
        let mut diags = Vec::new();
        for (name, name_span, v) in fields {
            let wrong = |expected: &str| {
                src.diag(
                    v.span,
                    format!("{whose}.{name} must be {expected}, found {}", v.shape()),
                )
            };
            let text = |v: &Spanned| match &v.kind {
                SKind::Str(t) => Some(t.clone()),
                _ => None,
            };
            let count = |v: &Spanned| match &v.kind {
                SKind::Int(i) if *i >= 1 && *i <= u32::MAX as i64 => Some(*i as u32),
                _ => None,
            };
            match name.as_str() {
                "partition" | "time" | "mem" | "gres" | "job_name" => {
                    let Some(t) = text(v) else {
                        diags.push(wrong("a string"));
                        continue;
                    };
                    if t.chars().any(char::is_control) || (name != "gres" && t.trim().is_empty()) {
                        diags.push(src.diag(
                            v.span,
                            format!("{whose}.{name} must be a non-empty single-line string"),
                        ));
                        continue;
                    }
                    let slot = match name.as_str() {
                        "partition" => &mut s.partition,
                        "time" => &mut s.time,
                        "mem" => &mut s.mem,
                        "gres" => &mut s.gres,
                        _ => &mut s.job_name,
                    };
                    *slot = Some(t);
                }
                "cpus" | "array_limit" => match count(v) {
                    Some(c) if name == "cpus" => s.cpus = Some(c),
                    Some(c) => s.array_limit = Some(c),
                    None => diags.push(wrong("a whole number ≥ 1")),
                },
                "args" => match &v.kind {
                    SKind::List(items) => {
                        for item in items {
                            match text(item) {
                                Some(t) if t.starts_with('-') => s.args.push(t),
                                Some(t) => diags.push(src.diag(
                                    item.span,
                                    format!(
                                        "{whose}.args: {t:?} is not an sbatch option (options start with `-`, e.g. \"--qos=high\")"
                                    ),
                                )),
                                None => diags.push(src.diag(
                                    item.span,
                                    format!(
                                        "{whose}.args: expected a string, found {}",
                                        item.shape()
                                    ),
                                )),
                            }
                        }
                    }
                    _ => diags.push(wrong("a list of strings like [\"--qos=high\"]")),
                },
                "local" if node.is_none() => diags.push(src.diag(
                    *name_span,
                    "`slurm.local` belongs on a node (which node should stay on this machine?)",
                )),
                "local" => match &v.kind {
                    SKind::Bool(b) => s.local = Some(*b),
                    _ => diags.push(wrong("true or false")),
                },
                other => diags.push(src.diag(
                    *name_span,
                    format!(
                        "{whose} has no option `{other}`{}; it takes {}",
                        did_you_mean(&similar(other, FIELDS.iter().copied())),
                        FIELDS.map(|f| format!("`{f}`")).join(", ")
                    ),
                )),
            }
        }
        if diags.is_empty() { Ok(s) } else { Err(diags) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_most_specific_place_wins_and_args_accumulate() {
        let graph = SlurmSettings {
            partition: Some("cpu".into()),
            mem: Some("4G".into()),
            args: vec!["--qos=low".into()],
            ..Default::default()
        };
        let cli = SlurmSettings {
            partition: Some("gpu".into()),
            time: Some("1:00:00".into()),
            ..Default::default()
        };
        let node = SlurmSettings {
            gres: Some("gpu:1".into()),
            cpus: Some(8),
            args: vec!["--qos=high".into()],
            ..Default::default()
        };
        let s = graph.overridden_by(&cli).overridden_by(&node);
        assert_eq!(
            s.sbatch_args(),
            [
                "--partition=gpu",
                "--time=1:00:00",
                "--cpus-per-task=8",
                "--mem=4G",
                "--gres=gpu:1",
                "--qos=low",
                "--qos=high"
            ]
        );
        // An empty gres asks for none, overriding a GPU asked for elsewhere.
        let none = SlurmSettings {
            gres: Some(String::new()),
            ..Default::default()
        };
        assert!(
            !s.overridden_by(&none)
                .sbatch_args()
                .iter()
                .any(|a| a.starts_with("--gres"))
        );
    }
}
