//! `objectsplat-bench paper`: the paper's comparison on the synthetic scene.
//!
//! Runs the decomposed pipeline (graphs/decomposed.ron), the holistic baseline
//! (graphs/holistic.ron), the decomposed pipeline with surface completion
//! (graphs/demo.ron) and, optionally, the no-randomization ablation, under the
//! sparse (1:7) and dense (7:1) splits, for several scenes and seeds, with the
//! best-checkpoint and the fixed-iteration variant; then writes a Markdown
//! table like the paper's, the raw rows as JSON and time-vs-error plots (SVG).
//! Everything goes through the ordinary engine and cache: a rerun only
//! computes what is missing.

mod device_speed;
mod quality;
mod run_report;
mod scale;
mod train_speed;

use anyhow::{Context, Result, bail};
use clap::{Parser, Subcommand};
use objectsplat_core::{TRAINING_TIMES, TrainingLog, TrainingTimes};
use objectsplat_metrics::report::MetricsReport;
use objectsplat_report::plot::{PlotSpec, Series, line_plot_svg};
use objectsplat_runtime::exec::{self, RunOptions, Silent};
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::{Override, build_plan};
use objectsplat_runtime::report::RunReport;
use objectsplat_runtime::store::Store;
use serde::Serialize;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

#[derive(Parser)]
#[command(name = "objectsplat-bench", about = "ObjectSplat benchmarks")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Decomposed vs holistic on the synthetic scene, sparse and dense splits.
    Paper(PaperArgs),
    /// Training iterations per second per component kind, optionally against an older binary.
    TrainSpeed(train_speed::TrainSpeedArgs),
    /// Composed-scene quality of trainer variants (an ablation), over seeds.
    Quality(quality::QualityArgs),
    /// Training iterations per second per component kind on each render backend (GPU machines).
    DeviceSpeed(device_speed::DeviceSpeedArgs),
    /// Peak memory and seconds per iteration as views and frames grow.
    Scale(scale::ScaleArgs),
}

#[derive(clap::Args)]
struct PaperArgs {
    /// Synthetic scene seeds (each seed is a different room layout and texture).
    #[arg(long, value_delimiter = ',', default_value = "7,11")]
    scenes: Vec<u64>,
    /// Training seeds.
    #[arg(long, value_delimiter = ',', default_value = "0")]
    seeds: Vec<u64>,
    #[arg(long, value_delimiter = ',', default_value = "sparse,dense")]
    splits: Vec<String>,
    /// Iteration budget of every component (the holistic run gets the same).
    #[arg(long, default_value_t = 600)]
    iterations: u64,
    /// Also run graphs/ablation_no_randomization.ron.
    #[arg(long)]
    ablation: bool,
    /// Folder holding the graphs.
    #[arg(long, default_value = "graphs")]
    graphs: PathBuf,
    #[arg(long, default_value = ".objectsplat-cache")]
    cache: PathBuf,
    /// Results: results.json, paper.md, *.svg, and each run's outputs.
    #[arg(long, default_value = "out/bench-paper")]
    out: PathBuf,
    /// Worker threads (default: all cores).
    #[arg(short, long)]
    jobs: Option<usize>,
}

/// One pipeline of the comparison.
struct Pipeline {
    name: &'static str,
    graph: &'static str,
    checkpoints: &'static [&'static str],
}

const PIPELINES: [Pipeline; 4] = [
    Pipeline {
        name: "decomposed",
        graph: "decomposed.ron",
        checkpoints: &["best", "last"],
    },
    Pipeline {
        name: "holistic",
        graph: "holistic.ron",
        checkpoints: &["best", "last"],
    },
    Pipeline {
        name: "decomposed+completion",
        graph: "demo.ron",
        checkpoints: &["best"],
    },
    Pipeline {
        name: "no-randomization",
        graph: "ablation_no_randomization.ron",
        checkpoints: &["best"],
    },
];

#[derive(Debug, Clone, Serialize)]
struct ComponentRow {
    component: String,
    budget: u64,
    iterations_run: u64,
    best_iteration: u64,
    stopped_early: bool,
    /// Seconds its training took, as the run measured them.
    wall_seconds: f64,
    final_psnr: f64,
    faces: usize,
    /// (wall seconds, held-out PSNR) at each evaluation: the log's PSNR at the time the
    /// run measured for that iteration.
    curve: Vec<(f64, f64)>,
}

#[derive(Debug, Clone, Serialize)]
struct Row {
    scene: u64,
    split: String,
    seed: u64,
    pipeline: String,
    checkpoint: String,
    psnr: Option<f64>,
    ssim: Option<f64>,
    lpips: Option<f64>,
    fscore: Option<f64>,
    precision: Option<f64>,
    recall: Option<f64>,
    run_seconds: f64,
    components: Vec<ComponentRow>,
}

impl Row {
    fn iterations_run(&self) -> u64 {
        self.components.iter().map(|c| c.iterations_run).sum()
    }
    fn iterations_budget(&self) -> u64 {
        self.components.iter().map(|c| c.budget).sum()
    }
    fn train_seconds(&self) -> f64 {
        self.components.iter().map(|c| c.wall_seconds).sum()
    }
}

fn main() -> std::process::ExitCode {
    // SAFETY: the first statement of main; no other thread exists yet.
    unsafe { objectsplat_gpu::quiet_headless_vulkan() };
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Paper(args) => paper(&args),
        Command::TrainSpeed(args) => train_speed::train_speed(&args),
        Command::Quality(args) => quality::quality(&args),
        Command::DeviceSpeed(args) => device_speed::device_speed(&args),
        Command::Scale(args) => scale::scale(&args),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}

fn paper(args: &PaperArgs) -> Result<()> {
    for split in &args.splits {
        if split != "sparse" && split != "dense" {
            bail!("split {split:?} is not \"sparse\" or \"dense\"");
        }
    }
    if args.scenes.is_empty() || args.seeds.is_empty() || args.splits.is_empty() {
        bail!("--scenes, --seeds and --splits each need at least one value");
    }
    let registry = objectsplat_catalogue::builtin_registry();
    let store = Store::open(&args.cache)?;
    let jobs = threads_or_all_cores(args.jobs);
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let pipelines: Vec<&Pipeline> = PIPELINES
        .iter()
        .filter(|p| args.ablation || p.name != "no-randomization")
        .collect();
    let mut rows = Vec::new();
    for &scene in &args.scenes {
        for split in &args.splits {
            for &seed in &args.seeds {
                for pipeline in &pipelines {
                    for &checkpoint in pipeline.checkpoints {
                        let name = format!(
                            "scene{scene}-{split}-seed{seed}-{}-{checkpoint}",
                            pipeline.name
                        );
                        eprintln!("[bench] {name}");
                        let source = GraphSource::read(&args.graphs.join(pipeline.graph))?;
                        let mut sets = vec![
                            format!("scene.seed={scene}"),
                            format!("scene.split=\"{split}\""),
                        ];
                        // Graphs that train the objects first have a second train node.
                        let train_nodes: &[&str] = if source.text.contains("\"objects\":") {
                            &["objects", "train"]
                        } else {
                            &["train"]
                        };
                        for node in train_nodes {
                            sets.push(format!("{node}.seed={seed}"));
                            sets.push(format!("{node}.iterations={}", args.iterations));
                            sets.push(format!("{node}.checkpoint=\"{checkpoint}\""));
                        }
                        let out = args.out.join("runs").join(&name);
                        let overrides = sets
                            .iter()
                            .map(|s| Override::parse(s))
                            .collect::<Result<Vec<_>, _>>()?;
                        let plan = build_plan(
                            &source,
                            &registry,
                            &overrides,
                            &["metrics".to_string(), "train".to_string()],
                        )?;
                        let started = Instant::now();
                        let report = exec::run(
                            &plan,
                            &store,
                            &RunOptions {
                                jobs,
                                threads_per_job: None,
                                out_dir: Some(out.clone()),
                                observer: Arc::new(Silent),
                            },
                        )?;
                        if !report.ok {
                            bail!("{name}: {}", report.first_failure().unwrap_or_default());
                        }
                        let row = read_row(
                            &out,
                            &report,
                            scene,
                            split,
                            seed,
                            pipeline.name,
                            checkpoint,
                            started.elapsed().as_secs_f64(),
                        )?;
                        eprintln!(
                            "[bench]   PSNR {:.2}  SSIM {:.3}  F {:.3}  iterations {}/{}",
                            row.psnr.unwrap_or(f64::NAN),
                            row.ssim.unwrap_or(f64::NAN),
                            row.fscore.unwrap_or(f64::NAN),
                            row.iterations_run(),
                            row.iterations_budget()
                        );
                        rows.push(row);
                    }
                }
            }
        }
    }
    let json = serde_json::to_string_pretty(&rows)?;
    std::fs::write(args.out.join("results.json"), json)?;
    let markdown = render_markdown(args, &rows)?;
    let md_path = args.out.join("paper.md");
    std::fs::write(&md_path, markdown)?;
    eprintln!("[bench] wrote {}", md_path.display());
    Ok(())
}

/// The `objectsplat` binary to measure: the one given, or the one built beside this bench.
fn objectsplat_binary(given: Option<&Path>) -> Result<PathBuf> {
    match given {
        Some(b) => Ok(b.to_path_buf()),
        None => Ok(std::env::current_exe()?
            .parent()
            .context("the bench binary has no folder")?
            .join("objectsplat")),
    }
}

/// What each trained item of a run measured about its training (by item name), from the
/// `train` nodes that trained it (not those that passed it through).
fn training_times(report: &RunReport) -> Result<BTreeMap<String, TrainingTimes>> {
    let mut times = BTreeMap::new();
    for node in report.nodes.iter().filter(|n| n.kind == "train") {
        for item in &node.items {
            if let Some(value) = item.measurements.get(TRAINING_TIMES) {
                let t = TrainingTimes::from_json(value)
                    .with_context(|| format!("{}[{}]", node.id, item.name))?;
                times.insert(item.name.clone(), t);
            }
        }
    }
    Ok(times)
}

#[allow(clippy::too_many_arguments)]
fn read_row(
    out: &Path,
    report: &RunReport,
    scene: u64,
    split: &str,
    seed: u64,
    pipeline: &str,
    checkpoint: &str,
    run_seconds: f64,
) -> Result<Row> {
    let metrics = MetricsReport::read(&out.join("metrics/metrics"))?.scene;
    let mut components = Vec::new();
    let times = training_times(report)?;
    let models = out.join("train/model");
    let mut dirs: Vec<PathBuf> = std::fs::read_dir(&models)
        .with_context(|| format!("cannot list {}", models.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .collect();
    dirs.sort();
    for dir in dirs {
        let Some(log) = TrainingLog::load(&dir)? else {
            continue;
        };
        let t = times.get(&log.component).with_context(|| {
            format!("the run report has no training times of {}", log.component)
        })?;
        components.push(ComponentRow {
            component: log.component.clone(),
            budget: log.iterations_budget,
            iterations_run: log.iterations_run,
            best_iteration: log.best_iteration,
            stopped_early: log.stopped_early,
            wall_seconds: t.seconds,
            final_psnr: log.final_psnr,
            faces: log.final_faces,
            curve: log
                .evals
                .iter()
                .filter_map(|e| Some((t.eval_seconds(e.iteration)?, e.psnr)))
                .collect(),
        });
    }
    Ok(Row {
        scene,
        split: split.to_string(),
        seed,
        pipeline: pipeline.to_string(),
        checkpoint: checkpoint.to_string(),
        psnr: metrics.psnr,
        ssim: metrics.ssim,
        lpips: metrics.lpips,
        fscore: metrics.fscore,
        precision: metrics.precision,
        recall: metrics.recall,
        run_seconds,
        components,
    })
}

fn mean(values: impl Iterator<Item = Option<f64>>) -> Option<f64> {
    let v: Vec<f64> = values.collect::<Option<Vec<f64>>>()?;
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

fn cell(v: Option<f64>, decimals: usize) -> String {
    v.map_or("–".into(), |v| format!("{v:.decimals$}"))
}

/// Rows of one configuration, averaged over training seeds.
fn select<'a>(
    rows: &'a [Row],
    scene: Option<u64>,
    split: &str,
    pipeline: &str,
    checkpoint: &str,
) -> Vec<&'a Row> {
    rows.iter()
        .filter(|r| {
            scene.is_none_or(|s| r.scene == s)
                && r.split == split
                && r.pipeline == pipeline
                && r.checkpoint == checkpoint
        })
        .collect()
}

/// A table column: its name, how to read it from a row, and its decimals.
type Column = (&'static str, fn(&Row) -> Option<f64>, usize);

fn render_markdown(args: &PaperArgs, rows: &[Row]) -> Result<String> {
    let mut md = String::new();
    writeln!(
        md,
        "Command: `cargo run --release -p objectsplat-bench -- paper --scenes {} --seeds {} \
         --splits {} --iterations {}{}`\n",
        join(&args.scenes),
        join(&args.seeds),
        args.splits.join(","),
        args.iterations,
        if args.ablation { " --ablation" } else { "" }
    )?;
    writeln!(
        md,
        "Scenes are `synthetic_scene` seeds; each value is the mean over training seeds {}. \
         PSNR/SSIM over the test views of the composed scene; F-score at τ = 5 cm against the \
         complete synthetic mesh. `best` = per-component best held-out checkpoint with early \
         stopping; `last` = the model after the full budget of {} iterations.\n",
        join(&args.seeds),
        args.iterations
    )?;
    let metrics: [Column; 4] = [
        ("PSNR", |r| r.psnr, 2),
        ("SSIM", |r| r.ssim, 3),
        ("LPIPS", |r| r.lpips, 3),
        ("F-score", |r| r.fscore, 3),
    ];
    for split in &args.splits {
        for checkpoint in ["last", "best"] {
            writeln!(
                md,
                "**{split} split, {} checkpoint**\n",
                if checkpoint == "last" {
                    "fixed-iteration"
                } else {
                    "best"
                }
            )?;
            let mut header = "| scene |".to_string();
            let mut rule = "|---|".to_string();
            for (name, _, _) in &metrics {
                header += &format!(" {name} holistic | {name} ours |");
                rule += "---:|---:|";
            }
            writeln!(md, "{header}\n{rule}")?;
            let scenes: Vec<Option<u64>> = args
                .scenes
                .iter()
                .map(|&s| Some(s))
                .chain(std::iter::once(None))
                .collect();
            for scene in scenes {
                let label = scene.map_or("**average**".to_string(), |s| s.to_string());
                let mut line = format!("| {label} |");
                for (_, get, decimals) in &metrics {
                    for pipeline in ["holistic", "decomposed"] {
                        let sel = select(rows, scene, split, pipeline, checkpoint);
                        let value = mean(sel.iter().map(|r| get(r)));
                        line += &format!(" {} |", cell(value, *decimals));
                    }
                }
                writeln!(md, "{line}")?;
            }
            writeln!(md)?;
        }
    }

    writeln!(
        md,
        "**Surface completion on vs off (best checkpoint, F-score)**\n"
    )?;
    writeln!(
        md,
        "| split | scene | off | on | Δ |\n|---|---|---:|---:|---:|"
    )?;
    for split in &args.splits {
        for &scene in &args.scenes {
            let off = mean(
                select(rows, Some(scene), split, "decomposed", "best")
                    .iter()
                    .map(|r| r.fscore),
            );
            let on = mean(
                select(rows, Some(scene), split, "decomposed+completion", "best")
                    .iter()
                    .map(|r| r.fscore),
            );
            let delta = off.zip(on).map(|(a, b)| b - a);
            writeln!(
                md,
                "| {split} | {scene} | {} | {} | {} |",
                cell(off, 4),
                cell(on, 4),
                cell(delta, 4)
            )?;
        }
    }
    writeln!(md)?;

    writeln!(
        md,
        "**Early stopping: training compute at an equal cap of {} iterations per component**\n",
        args.iterations
    )?;
    writeln!(
        md,
        "| split | scene | seed | pipeline | components | iterations run / budget | train s (best) | train s (full budget) |\n|---|---|---|---|---:|---:|---:|---:|"
    )?;
    for row in rows.iter().filter(|r| r.checkpoint == "best") {
        let full = rows
            .iter()
            .find(|r| {
                r.checkpoint == "last"
                    && r.scene == row.scene
                    && r.split == row.split
                    && r.seed == row.seed
                    && r.pipeline == row.pipeline
            })
            .map(Row::train_seconds);
        writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} / {} ({:.0}%) | {:.1} | {} |",
            row.split,
            row.scene,
            row.seed,
            row.pipeline,
            row.components.len(),
            row.iterations_run(),
            row.iterations_budget(),
            100.0 * row.iterations_run() as f64 / row.iterations_budget().max(1) as f64,
            row.train_seconds(),
            cell(full, 1)
        )?;
    }
    writeln!(md)?;
    writeln!(
        md,
        "**Where each component peaked and stopped (decomposed, best checkpoint)**\n"
    )?;
    writeln!(
        md,
        "| split | scene | seed | component | best iteration | stopped at | early stop | held-out PSNR |\n|---|---|---|---|---:|---:|---|---:|"
    )?;
    for row in rows.iter().filter(|r| {
        r.checkpoint == "best" && (r.pipeline == "decomposed" || r.pipeline == "holistic")
    }) {
        for c in &row.components {
            writeln!(
                md,
                "| {} | {} | {} | {} | {} | {} | {} | {:.2} |",
                row.split,
                row.scene,
                row.seed,
                c.component,
                c.best_iteration,
                c.iterations_run,
                if c.stopped_early { "yes" } else { "no" },
                c.final_psnr
            )?;
        }
    }
    writeln!(md)?;

    // Time against error: held-out PSNR per component against its wall time.
    for split in &args.splits {
        let Some(&scene) = args.scenes.first() else {
            continue;
        };
        let seed = args.seeds[0];
        let mut series = Vec::new();
        for pipeline in ["decomposed", "holistic"] {
            if let Some(row) = rows.iter().find(|r| {
                r.scene == scene
                    && r.split == *split
                    && r.seed == seed
                    && r.pipeline == pipeline
                    && r.checkpoint == "last"
            }) {
                for c in &row.components {
                    let name = if pipeline == "holistic" {
                        "holistic".to_string()
                    } else {
                        c.component.clone()
                    };
                    series.push(Series::new(&name, c.curve.clone()));
                }
            }
        }
        if series.is_empty() {
            continue;
        }
        let svg = line_plot_svg(&PlotSpec {
            title: format!("Held-out PSNR against training time ({split}, scene {scene})"),
            x_label: "wall seconds".into(),
            y_label: "held-out PSNR (dB)".into(),
            series,
            markers: true,
        });
        let file = format!("time_vs_psnr_{split}.svg");
        std::fs::write(args.out.join(&file), svg)?;
        writeln!(md, "![time vs PSNR, {split}]({file})\n")?;
    }
    Ok(md)
}

fn join(values: &[u64]) -> String {
    values
        .iter()
        .map(u64::to_string)
        .collect::<Vec<_>>()
        .join(",")
}

/// `n`, or every core when not given; at least 1.
pub fn threads_or_all_cores(n: Option<usize>) -> usize {
    n.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1)
}
