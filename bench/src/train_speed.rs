//! `objectsplat-bench train-speed`: what training costs per component kind.
//!
//! Runs the decomposed and the holistic pipeline's `train` node on the
//! synthetic room at each requested frame size, with `-j 1` and the `last`
//! checkpoint (every component runs its whole budget), through the
//! `objectsplat` binary, and optionally through a second (older) binary in
//! the same run, so the two are measured under the same machine load. Reads
//! each component's seconds from the run report (`--json`) and its training
//! log, and writes a Markdown table and the raw rows.

use anyhow::{Context, Result, bail};
use objectsplat_raster::TrainingLog;
use serde::Serialize;
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct TrainSpeedArgs {
    /// Frame sizes, WIDTHxHEIGHT.
    #[arg(long, value_delimiter = ',', default_value = "320x240,640x480")]
    sizes: Vec<String>,
    /// Iteration budget of every component (and of the holistic model).
    #[arg(long, default_value_t = 600)]
    iterations: u64,
    /// Views of the synthetic room (dense split: 7 of 8 train).
    #[arg(long, default_value_t = 48)]
    views: u32,
    /// Synthetic scene seed.
    #[arg(long, default_value_t = 7)]
    scene: u64,
    /// The objectsplat binary measured (default: the one next to this program).
    #[arg(long)]
    binary: Option<PathBuf>,
    /// An older objectsplat binary measured in the same run (e.g. built from an earlier commit).
    #[arg(long)]
    baseline: Option<PathBuf>,
    /// Pipelines to run: decomposed, holistic (default both).
    #[arg(long, value_delimiter = ',', default_value = "decomposed,holistic")]
    pipelines: Vec<String>,
    /// Results: train-speed.md, train-speed.json and each run's outputs.
    #[arg(long, default_value = "out/bench-train-speed")]
    out: PathBuf,
}

/// One component's training in one run.
#[derive(Debug, Clone, Serialize)]
struct ItemRow {
    binary: String,
    size: String,
    pipeline: String,
    component: String,
    kind: String,
    iterations: u64,
    seconds: f64,
    iterations_per_second: f64,
    faces: Option<usize>,
    rendered_fraction: Option<f64>,
}

/// A whole `train` node of one run.
#[derive(Debug, Clone, Serialize)]
struct NodeRow {
    binary: String,
    size: String,
    pipeline: String,
    seconds: f64,
}

fn graph_text(
    width: u32,
    height: u32,
    views: u32,
    scene: u64,
    iterations: u64,
    holistic: bool,
) -> String {
    format!(
        r#"(
  nodes: {{
    "scene": (kind: "synthetic_scene", params: (seed: {scene}, views: {views}, width: {width}, height: {height}, split: "dense")),
    "masks": (kind: "gt_masks", inputs: (frames: "scene.frames", mesh: "scene.mesh")),
    "parts": (kind: "partition", inputs: (frames: "scene.frames", masks: "masks.masks"), params: (holistic: {holistic})),
    "train": (kind: "train", inputs: (component: each("parts.components"), points: "scene.points"),
              params: (iterations: {iterations}, seed: 0, checkpoint: "last")),
  }},
  targets: ["train"],
)
"#
    )
}

/// Which kind of component an item of the synthetic room is.
fn kind_of(component: &str) -> &'static str {
    match component {
        "scene" => "holistic",
        "background" => "background",
        // The room's largest object and its smallest ones.
        "obj_7_table" | "obj_11_chair" => "large object",
        _ => "small object",
    }
}

pub fn train_speed(args: &TrainSpeedArgs) -> Result<()> {
    let binary = crate::objectsplat_binary(args.binary.as_deref())?;
    if let Some(p) = args
        .pipelines
        .iter()
        .find(|p| !["decomposed", "holistic"].contains(&p.as_str()))
    {
        bail!("unknown pipeline {p:?}: expected decomposed or holistic");
    }
    let mut binaries = vec![("ours", binary)];
    if let Some(b) = &args.baseline {
        binaries.push(("baseline", b.clone()));
    }
    for (_, b) in &binaries {
        if !b.is_file() {
            bail!(
                "{} is not a file (build it with `cargo build --release`)",
                b.display()
            );
        }
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let (mut items, mut nodes) = (Vec::new(), Vec::new());
    for size in &args.sizes {
        let (w, h) = size
            .split_once('x')
            .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
            .with_context(|| format!("size {size:?} is not WIDTHxHEIGHT"))?;
        for holistic in [false, true] {
            let pipeline = if holistic { "holistic" } else { "decomposed" };
            if !args.pipelines.iter().any(|p| p == pipeline) {
                continue;
            }
            let graph = args.out.join(format!("{pipeline}-{size}.ron"));
            std::fs::write(
                &graph,
                graph_text(w, h, args.views, args.scene, args.iterations, holistic),
            )?;
            for (name, binary) in &binaries {
                eprintln!(
                    "[train-speed] {size} {pipeline} with {name} ({})",
                    binary.display()
                );
                let run_dir = args
                    .out
                    .join("runs")
                    .join(format!("{name}-{pipeline}-{size}"));
                let report = crate::quality::run_graph(binary, &graph, &run_dir, 1)?;
                let train = report["nodes"]
                    .as_array()
                    .and_then(|n| n.iter().find(|n| n["id"] == "train"))
                    .context("the run report has no train node")?;
                nodes.push(NodeRow {
                    binary: name.to_string(),
                    size: size.clone(),
                    pipeline: pipeline.into(),
                    seconds: train["seconds"].as_f64().unwrap_or(f64::NAN),
                });
                for item in train["items"].as_array().into_iter().flatten() {
                    let component = item["name"].as_str().unwrap_or("?").to_string();
                    let seconds = item["seconds"].as_f64().unwrap_or(f64::NAN);
                    let log = TrainingLog::load(&run_dir.join("out/train/model").join(&component))?;
                    let iterations = log.as_ref().map_or(args.iterations, |l| l.iterations_run);
                    eprintln!("[train-speed]   {component}: {seconds:.2} s");
                    items.push(ItemRow {
                        binary: name.to_string(),
                        size: size.clone(),
                        pipeline: pipeline.into(),
                        kind: kind_of(&component).into(),
                        component,
                        iterations,
                        seconds,
                        iterations_per_second: iterations as f64 / seconds,
                        faces: log.as_ref().map(|l| l.final_faces),
                        rendered_fraction: log.as_ref().and_then(|l| l.rendered_fraction),
                    });
                }
            }
        }
    }
    std::fs::write(
        args.out.join("train-speed.json"),
        serde_json::to_string_pretty(&serde_json::json!({"items": items, "nodes": nodes}))?,
    )?;
    let md = markdown(args, &binaries, &items, &nodes)?;
    let path = args.out.join("train-speed.md");
    std::fs::write(&path, &md)?;
    print!("{md}");
    eprintln!("[train-speed] wrote {}", path.display());
    Ok(())
}

fn markdown(
    args: &TrainSpeedArgs,
    binaries: &[(&str, PathBuf)],
    items: &[ItemRow],
    nodes: &[NodeRow],
) -> Result<String> {
    let mut md = String::new();
    let with_baseline = binaries.len() > 1;
    writeln!(
        md,
        "Synthetic room (seed {}), {} views, dense split, {} iterations per component, checkpoint `last`, `-j 1`.\n",
        args.scene, args.views, args.iterations
    )?;
    writeln!(md, "#### Per component\n")?;
    if with_baseline {
        writeln!(
            md,
            "| size | component | kind | rendered share | it/s ours | it/s baseline | speed-up |"
        )?;
        writeln!(md, "|---|---|---|---:|---:|---:|---:|")?;
    } else {
        writeln!(md, "| size | component | kind | rendered share | it/s |")?;
        writeln!(md, "|---|---|---|---:|---:|")?;
    }
    for row in items.iter().filter(|r| r.binary == "ours") {
        let share = row
            .rendered_fraction
            .map_or("–".into(), |f| format!("{:.0}%", 100.0 * f));
        if with_baseline {
            let base = items.iter().find(|b| {
                b.binary == "baseline"
                    && b.size == row.size
                    && b.component == row.component
                    && b.pipeline == row.pipeline
            });
            let (b_ips, speedup) = base.map_or(("–".into(), "–".into()), |b| {
                (
                    format!("{:.1}", b.iterations_per_second),
                    format!(
                        "{:.1}×",
                        row.iterations_per_second / b.iterations_per_second
                    ),
                )
            });
            writeln!(
                md,
                "| {} | {} | {} | {share} | {:.1} | {b_ips} | {speedup} |",
                row.size, row.component, row.kind, row.iterations_per_second
            )?;
        } else {
            writeln!(
                md,
                "| {} | {} | {} | {share} | {:.1} |",
                row.size, row.component, row.kind, row.iterations_per_second
            )?;
        }
    }
    writeln!(
        md,
        "\n#### The train node (all components, one after another)\n"
    )?;
    writeln!(
        md,
        "| size | binary | decomposed s | holistic s | decomposed / holistic |"
    )?;
    writeln!(md, "|---|---|---:|---:|---:|")?;
    for size in &args.sizes {
        for (name, _) in binaries {
            let secs = |pipeline: &str| {
                nodes
                    .iter()
                    .find(|n| &n.size == size && n.binary == *name && n.pipeline == pipeline)
                    .map(|n| n.seconds)
            };
            if let (Some(d), Some(h)) = (secs("decomposed"), secs("holistic")) {
                writeln!(md, "| {size} | {name} | {d:.1} | {h:.1} | {:.2}× |", d / h)?;
            }
        }
        if with_baseline {
            let node = |name: &str| {
                nodes
                    .iter()
                    .find(|n| &n.size == size && n.binary == name && n.pipeline == "decomposed")
                    .map(|n| n.seconds)
            };
            if let (Some(ours), Some(base)) = (node("ours"), node("baseline")) {
                writeln!(
                    md,
                    "| {size} | decomposed: baseline / ours | | | {:.1}× |",
                    base / ours
                )?;
            }
        }
    }
    Ok(md)
}
