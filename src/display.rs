//! Terminal output: progress bars while running, the graph as text or dot, the catalogue.

use crate::run_progress::RunProgress;
use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use objectsplat_runtime::exec::Observer;
use objectsplat_runtime::plan::Plan;
use objectsplat_runtime::registry::Origin;
use objectsplat_runtime::report::Status;
use objectsplat_runtime::{ProgressSink, Registry};
use std::collections::HashMap;
use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// Progress bars on a terminal, one per running job, and below them a line for the whole
/// run; one line per finished job otherwise.
pub struct Display {
    multi: MultiProgress,
    bars: Mutex<HashMap<String, ProgressBar>>,
    tty: bool,
    whole_run: Option<WholeRun>,
}

/// The line under the jobs' bars ([`RunProgress`]).
struct WholeRun {
    bar: ProgressBar,
    progress: Mutex<RunProgress>,
}

impl Display {
    /// `whole_run`: also draw the whole-run line (on a terminal only).
    pub fn new(whole_run: bool) -> Display {
        let tty = std::io::stderr().is_terminal();
        let multi = MultiProgress::with_draw_target(if tty {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        });
        let whole_run = (tty && whole_run).then(|| {
            let bar = multi.add(ProgressBar::new_spinner());
            bar.set_style(
                ProgressStyle::with_template("{prefix:>24} {spinner} {msg}")
                    .unwrap_or_else(|_| ProgressStyle::default_spinner()),
            );
            bar.set_prefix("whole run");
            bar.enable_steady_tick(Duration::from_millis(120));
            WholeRun {
                bar,
                progress: Mutex::new(RunProgress::new(Instant::now())),
            }
        });
        Display {
            multi,
            bars: Mutex::new(HashMap::new()),
            tty,
            whole_run,
        }
    }

    pub fn finish(&self) {
        let _ = self.multi.clear();
    }

    /// Applies `event` to the whole run's progress and redraws its line.
    fn whole_run(&self, event: impl FnOnce(&mut RunProgress, Instant)) {
        if let Some(w) = &self.whole_run
            && let Ok(mut progress) = w.progress.lock()
        {
            let now = Instant::now();
            event(&mut progress, now);
            w.bar.set_message(progress.line(now));
        }
    }
}

impl ProgressSink for Display {
    fn progress(&self, job: &str, done: u64, total: u64, what: &str) {
        self.whole_run(|p, now| p.progress(job, done, total, what, now));
        if let Ok(bars) = self.bars.lock()
            && let Some(bar) = bars.get(job)
        {
            if bar.length() != Some(total) {
                bar.set_length(total);
                bar.set_style(
                    ProgressStyle::with_template(
                        "{prefix:>24} [{bar:30}] {pos}/{len} {msg} ({eta})",
                    )
                    .unwrap_or_else(|_| ProgressStyle::default_bar())
                    .progress_chars("=> "),
                );
            }
            bar.set_position(done);
            bar.set_message(what.to_string());
        }
    }
}

impl Observer for Display {
    fn job_queued(&self, job: &str, node: &str) {
        self.whole_run(|p, _| p.queued(job, node));
    }

    fn job_started(&self, job: &str) {
        // Above the whole-run line, which stays last.
        let bar = match &self.whole_run {
            Some(w) => self.multi.insert_before(&w.bar, ProgressBar::new_spinner()),
            None => self.multi.add(ProgressBar::new_spinner()),
        };
        bar.set_style(
            ProgressStyle::with_template("{prefix:>24} {spinner} {msg} {elapsed}")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        bar.set_prefix(job.to_string());
        bar.enable_steady_tick(Duration::from_millis(120));
        if let Ok(mut bars) = self.bars.lock() {
            bars.insert(job.to_string(), bar);
        }
    }

    /// A Slurm job's state (queued, running on a node) shows as the spinner's message.
    fn job_state(&self, job: &str, state: &str) {
        if let Ok(bars) = self.bars.lock()
            && let Some(bar) = bars.get(job)
        {
            bar.set_message(state.to_string());
        }
    }

    fn job_finished(&self, job: &str, status: Status, seconds: f64) {
        self.whole_run(|p, _| p.finished(job));
        if let Ok(mut bars) = self.bars.lock()
            && let Some(bar) = bars.remove(job)
        {
            bar.finish_and_clear();
            self.multi.remove(&bar);
        }
        let line = format!("{:>24} {} in {seconds:.2}s", job, status.as_str());
        if self.tty {
            let _ = self.multi.println(line);
        } else {
            eprintln!("{line}");
        }
    }

    fn warning(&self, message: &str) {
        if self.tty {
            let _ = self.multi.println(message);
        } else {
            eprintln!("{message}");
        }
    }
}

pub fn to_dot(plan: &Plan) -> String {
    let mut s = String::from(
        "digraph objectsplat {\n  rankdir=LR;\n  node [shape=box, fontname=\"Helvetica\"];\n",
    );
    for n in &plan.nodes {
        let style = if plan.targets.iter().any(|&t| plan.nodes[t].id == n.id) {
            ", style=bold"
        } else {
            ""
        };
        s.push_str(&format!(
            "  \"{}\" [label=\"{}\\n({})\"{style}];\n",
            n.id, n.id, n.kind
        ));
    }
    for n in &plan.nodes {
        for inp in &n.inputs {
            let label = if inp.each {
                format!("each {}→{}", inp.from_port, inp.port)
            } else {
                format!("{}→{}", inp.from_port, inp.port)
            };
            let style = if inp.each { ", style=dashed" } else { "" };
            s.push_str(&format!(
                "  \"{}\" -> \"{}\" [label=\"{label}\"{style}];\n",
                plan.nodes[inp.from].id, n.id
            ));
        }
    }
    s.push_str("}\n");
    s
}

pub fn to_text(plan: &Plan) -> String {
    let mut s = String::new();
    for &i in &plan.order {
        let n = &plan.nodes[i];
        let ins: Vec<String> = n
            .inputs
            .iter()
            .map(|inp| {
                let r = format!("{}.{}", plan.nodes[inp.from].id, inp.from_port);
                if inp.each {
                    format!("{}: each({r})", inp.port)
                } else {
                    format!("{}: {r}", inp.port)
                }
            })
            .collect();
        s.push_str(&format!(
            "{} ({}) <- {}\n",
            n.id,
            n.kind,
            if ins.is_empty() {
                "-".into()
            } else {
                ins.join(", ")
            }
        ));
    }
    s
}

pub fn catalogue(reg: &Registry) -> String {
    let mut s = String::new();
    for r in reg.kinds() {
        let spec = &r.spec;
        let origin = match &r.origin {
            Origin::Builtin => String::new(),
            Origin::Plugin { path, .. } => format!("  [plugin {path}]"),
        };
        s.push_str(&format!("{} (v{}){origin}\n", spec.kind, spec.version));
        if !spec.doc.is_empty() {
            s.push_str(&format!("    {}\n", spec.doc));
        }
        for p in &spec.inputs {
            let opt = if p.optional { ", optional" } else { "" };
            s.push_str(&format!("    in  {}: {}{opt}  {}\n", p.name, p.ty, p.doc));
        }
        for p in &spec.outputs {
            s.push_str(&format!("    out {}: {}  {}\n", p.name, p.ty, p.doc));
        }
        for p in &spec.params {
            let def = p
                .default
                .as_deref()
                .map(|d| format!(" = {d}"))
                .unwrap_or_else(|| " (required)".into());
            s.push_str(&format!("    param {}: {}{def}  {}\n", p.name, p.ty, p.doc));
        }
    }
    s.push_str("\ntypes:\n");
    for t in reg.types() {
        s.push_str(&format!("  {}: {}\n", t.name, t.doc));
    }
    s
}
