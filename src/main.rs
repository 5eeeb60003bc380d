//! `objectsplat`: the command-line front end. Parsing, display and exit codes only;
//! the work happens in `objectsplat-runtime` and the node crates.

// The argument structs' doc comments are clap's `--help` text, where `<node>` is a
// placeholder for the reader, not an HTML tag.
#![allow(rustdoc::invalid_html_tags)]

mod cluster;
mod display;
mod run_progress;

use anyhow::{Context as _, Result, anyhow};
use clap::{Parser, Subcommand};
use objectsplat_report::{
    GraphEdge, RunSummary, read_run_summary, write_run_files, write_with_run_summary,
};
use objectsplat_runtime::check;
use objectsplat_runtime::exec::{self, RunOptions};
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::{self, Override, Plan};
use objectsplat_runtime::report::RunReport;
use objectsplat_runtime::store::Store;
use objectsplat_runtime::{Diagnostics, Registry};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Arc;

#[derive(Parser)]
#[command(
    name = "objectsplat",
    version,
    about = "Object-decomposed mesh splatting as a cached dataflow graph"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Run a graph: only what the targets need, reusing cached results.
    Run {
        graph: PathBuf,
        /// Cache folder.
        #[arg(long, default_value = ".objectsplat-cache")]
        cache: PathBuf,
        /// Output folder (default: out/<graph name>/).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Run only these nodes and their ancestors (repeatable).
        #[arg(long = "target")]
        targets: Vec<String>,
        /// Override a param: NODE.PARAM=VALUE (RON syntax; a bare word or text that is not
        /// RON is taken as a string where the param takes one: `--set scene.split=dense`).
        /// Part of the cache key.
        #[arg(long = "set")]
        sets: Vec<String>,
        /// Load a plugin library (repeatable).
        #[arg(long = "plugin")]
        plugins: Vec<PathBuf>,
        /// Also write the run report as JSON to this file (with the graph's edges, so
        /// `objectsplat report --run` can draw the graph later).
        #[arg(long)]
        json: Option<PathBuf>,
        /// Worker threads (default: the number of CPUs).
        #[arg(short = 'j', long = "jobs")]
        jobs: Option<usize>,
        /// Threads each job may use (default: the worker threads not busy when it starts);
        /// `-j 1 --threads N` runs one job at a time on N threads.
        #[arg(long)]
        threads: Option<usize>,
        #[command(flatten)]
        executor: Box<cluster::ExecutorArgs>,
    },
    /// Compute one action of a `run --executor slurm` (what its Slurm jobs run).
    #[command(hide = true)]
    RunAction {
        /// The action's spec, written by the coordinator.
        spec: PathBuf,
    },
    /// Validate a graph without running it: kinds, wiring, types, params (fields inside
    /// nested params too), that input files exist, and params against upstream values
    /// already in the cache (edit targets against the scene's labels).
    Check {
        graph: PathBuf,
        #[arg(long = "plugin")]
        plugins: Vec<PathBuf>,
        #[arg(long = "set")]
        sets: Vec<String>,
        /// Cache folder whose values checks may read (it is not created or changed).
        #[arg(long, default_value = ".objectsplat-cache")]
        cache: PathBuf,
        /// Do not require input files to exist (a graph template whose data is elsewhere).
        #[arg(long)]
        skip_input_files: bool,
    },
    /// Fill in the run summary (graph, node statuses and times) of a `report` node's page
    /// from a run report saved with `run --json`.
    Report {
        /// The run report (`objectsplat run --json RUN.json`).
        #[arg(long = "run")]
        run: PathBuf,
        /// The page written by a `report` node (OUT/<node>/file/index.html).
        #[arg(long)]
        html: PathBuf,
        /// Where to write the filled-in page (default: replace --html).
        #[arg(short = 'o', long = "out")]
        out: Option<PathBuf>,
    },
    /// Print the graph.
    Graph {
        graph: PathBuf,
        /// Graphviz dot output.
        #[arg(long)]
        dot: bool,
        #[arg(long = "plugin")]
        plugins: Vec<PathBuf>,
    },
    /// Say why a node would (re)run.
    Explain {
        graph: PathBuf,
        node: String,
        #[arg(long, default_value = ".objectsplat-cache")]
        cache: PathBuf,
        #[arg(long = "set")]
        sets: Vec<String>,
        #[arg(long = "plugin")]
        plugins: Vec<PathBuf>,
    },
    /// List every node kind with its ports and params (plugins included).
    Nodes {
        #[arg(long = "plugin")]
        plugins: Vec<PathBuf>,
    },
}

fn main() -> ExitCode {
    // Started as a plugin's child process this serves one call and exits; otherwise
    // plugins loaded below run in children started from this executable.
    objectsplat_runtime::plugin::child::serve_if_requested();
    // SAFETY: no other thread exists yet (serving a plugin child never returns here).
    unsafe { objectsplat_gpu::quiet_headless_vulkan() };
    let cli = Cli::parse();
    match dispatch(cli) {
        Ok(code) => code,
        Err(e) => {
            match e.downcast_ref::<Diagnostics>() {
                Some(d) => eprintln!("{d}"),
                None => eprintln!("error: {e:#}"),
            }
            ExitCode::FAILURE
        }
    }
}

fn parse_overrides(sets: &[String]) -> Result<Vec<Override>> {
    let overrides = sets
        .iter()
        .map(|s| Override::parse(s))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|d| Diagnostics(vec![d]))?;
    Ok(overrides)
}

fn registry_with(plugins: &[PathBuf]) -> Result<Registry> {
    let mut reg = objectsplat_catalogue::builtin_registry();
    for p in plugins {
        objectsplat_runtime::plugin::load(&mut reg, p)
            .map_err(|e| anyhow!("plugin {}: {e}", p.display()))?;
    }
    Ok(reg)
}

/// Registry with the command line's plugins and the graph's own `plugins: [...]`.
fn load_plan(
    graph: &Path,
    plugins: &[PathBuf],
    sets: &[String],
    targets: &[String],
) -> Result<Plan> {
    let source = GraphSource::read(graph)?;
    let mut libs: Vec<PathBuf> = plugins.to_vec();
    for (p, _) in plan::declared_plugins(&source)? {
        if !libs.contains(&p) {
            libs.push(p);
        }
    }
    let reg = registry_with(&libs)?;
    let overrides = parse_overrides(sets)?;
    Ok(plan::build_plan(&source, &reg, &overrides, targets)?)
}

fn dispatch(cli: Cli) -> Result<ExitCode> {
    match cli.command {
        Command::Run {
            graph,
            cache,
            out,
            targets,
            sets,
            plugins,
            json,
            jobs,
            threads,
            executor,
        } => {
            let executor = executor.executor(&sets, &plugins)?;
            let plan = load_plan(&graph, &plugins, &sets, &targets)?;
            let store = Store::open(&cache)?;
            let out = out.unwrap_or_else(|| PathBuf::from("out").join(plan.source.name()));
            let jobs = jobs
                .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
                .max(1);
            // The whole-run line is for people at a terminal, not for CI logs or for runs
            // whose report a program reads.
            let in_ci =
                std::env::var("CI").is_ok_and(|v| !["", "0", "false"].contains(&v.as_str()));
            let observer = Arc::new(display::Display::new(!in_ci && json.is_none()));
            let report = exec::run_on(
                &plan,
                &store,
                &RunOptions {
                    jobs,
                    threads_per_job: threads,
                    out_dir: Some(out.clone()),
                    observer: observer.clone(),
                },
                executor.as_ref(),
            )?;
            observer.finish();
            eprint!("{}", report.render_table());
            let mut value = serde_json::to_value(&report)?;
            value["edges"] = serde_json::to_value(graph_edges(&plan, &report))?;
            if let Some(path) = json {
                let text = serde_json::to_string_pretty(&value)?;
                std::fs::write(&path, text)
                    .with_context(|| format!("{}: cannot write report", path.display()))?;
            }
            if report.out.is_some() {
                // Another run may be writing the same --out: take its turn.
                let written = objectsplat_runtime::outdir::lock(&out).and_then(|_lock| {
                    let summary: RunSummary = serde_json::from_value(value.clone())?;
                    write_run_files(&out, &value, &summary)
                });
                if let Err(e) = written {
                    eprintln!("warning: the run summary was not written beside the outputs: {e:#}")
                }
            }
            if report.ok {
                eprintln!("outputs in {}", out.display());
                Ok(ExitCode::SUCCESS)
            } else {
                eprintln!(
                    "error: {}",
                    report
                        .first_failure()
                        .unwrap_or_else(|| "the run failed".into())
                );
                Ok(ExitCode::FAILURE)
            }
        }
        Command::RunAction { spec } => {
            let code = objectsplat_runtime::slurm::worker::run_action(&spec, |spec| {
                let args = cluster::plan_args(spec)?;
                load_plan(&spec.graph, &args.plugins, &args.sets, &[])
            });
            Ok(ExitCode::from(u8::try_from(code).unwrap_or(1)))
        }
        Command::Report { run, html, out } => {
            let summary = read_run_summary(&run)?;
            let out = out.unwrap_or_else(|| html.clone());
            write_with_run_summary(&html, &summary, &out)?;
            eprintln!(
                "run summary of {} written to {}",
                run.display(),
                out.display()
            );
            Ok(ExitCode::SUCCESS)
        }
        Command::Check {
            graph,
            plugins,
            sets,
            cache,
            skip_input_files,
        } => {
            let plan = load_plan(&graph, &plugins, &sets, &[])?;
            let overrides = parse_overrides(&sets)?;
            let mut problems = Vec::new();
            if !skip_input_files {
                problems.extend(check::missing_input_paths(&plan, &overrides));
            }
            if problems.is_empty() {
                let found = if cache.is_dir() {
                    check::with_cached_inputs(&plan, &Store::open(&cache)?, &overrides)?
                } else {
                    check::InputChecks::default()
                };
                problems.extend(found.errors);
                for line in &found.not_checked {
                    println!("note: {line}");
                }
                if !cache.is_dir() {
                    for n in &plan.nodes {
                        for w in n.reg.node.checked_inputs() {
                            println!(
                                "note: node `{}` ({}): {} not checked: no cache at {} to read its input `{}` from",
                                n.id,
                                n.kind,
                                w.what,
                                cache.display(),
                                w.port
                            );
                        }
                    }
                }
            }
            if !problems.is_empty() {
                return Err(Diagnostics(problems).into());
            }
            println!(
                "{}: ok ({} nodes, targets: {})",
                graph.display(),
                plan.nodes.len(),
                target_names(&plan)
            );
            Ok(ExitCode::SUCCESS)
        }
        Command::Graph {
            graph,
            dot,
            plugins,
        } => {
            let plan = load_plan(&graph, &plugins, &[], &[])?;
            print!(
                "{}",
                if dot {
                    display::to_dot(&plan)
                } else {
                    display::to_text(&plan)
                }
            );
            Ok(ExitCode::SUCCESS)
        }
        Command::Explain {
            graph,
            node,
            cache,
            sets,
            plugins,
        } => {
            let plan = load_plan(&graph, &plugins, &sets, &[])?;
            let store = Store::open(&cache)?;
            println!(
                "{}",
                objectsplat_runtime::explain::explain(&plan, &store, &node)?
            );
            Ok(ExitCode::SUCCESS)
        }
        Command::Nodes { plugins } => {
            let reg = registry_with(&plugins)?;
            print!("{}", display::catalogue(&reg));
            Ok(ExitCode::SUCCESS)
        }
    }
}

fn target_names(plan: &Plan) -> String {
    plan.targets
        .iter()
        .map(|&t| plan.nodes[t].id.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The graph's data dependencies between nodes of the run, one per producer–consumer pair.
fn graph_edges(plan: &Plan, report: &RunReport) -> Vec<GraphEdge> {
    let ran = |id: &str| report.node(id).is_some();
    let mut edges: Vec<GraphEdge> = Vec::new();
    for node in &plan.nodes {
        for input in &node.inputs {
            let edge = GraphEdge {
                from: plan.nodes[input.from].id.clone(),
                to: node.id.clone(),
            };
            // A node may read several ports of one producer: one edge in the drawing.
            if ran(&edge.from) && ran(&edge.to) && !edges.contains(&edge) {
                edges.push(edge);
            }
        }
    }
    edges
}
