//! `objectsplat-bench quality`: what each trainer choice does to the result.
//!
//! Runs named variants of the pipeline on the synthetic room — the default
//! (objects first, then the background behind them), the paper's fully
//! independent background, the holistic baseline, and single changes to the
//! default (a schedule setting, the checkpoint rule) — for several training
//! seeds, through the `objectsplat` binary (and optionally an older binary on
//! the old single-train-node graph), and writes a Markdown table of composed
//! test PSNR/SSIM, F-score at τ = 5 cm and 2 cm, and training time.

use crate::run_report::{run_command, run_to_report};
use anyhow::{Context, Result};
use objectsplat_metrics::report::{MetricsReport, ScopeMetrics};
use serde::Serialize;
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct QualityArgs {
    /// Variants to run (default: all); `list` prints them.
    #[arg(long, value_delimiter = ',')]
    variants: Vec<String>,
    /// Training seeds.
    #[arg(long, value_delimiter = ',', default_value = "0")]
    seeds: Vec<u64>,
    /// Synthetic scene seed.
    #[arg(long, default_value_t = 7)]
    scene: u64,
    /// Frame size, WIDTHxHEIGHT.
    #[arg(long, default_value = "320x240")]
    size: String,
    #[arg(long, default_value_t = 48)]
    views: u32,
    #[arg(long, default_value = "dense")]
    split: String,
    /// Iteration budget of every component.
    #[arg(long, default_value_t = 3000)]
    iterations: u64,
    /// Worker threads of each run.
    #[arg(short, long, default_value_t = 2)]
    jobs: usize,
    /// The objectsplat binary (default: the one next to this program).
    #[arg(long)]
    binary: Option<PathBuf>,
    /// An older objectsplat binary, run as variant `baseline` on the single-train-node graph.
    #[arg(long)]
    baseline: Option<PathBuf>,
    /// Results: quality.md, quality.json and each run's outputs.
    #[arg(long, default_value = "out/bench-quality")]
    out: PathBuf,
}

/// How the components are trained.
#[derive(Clone, Copy, PartialEq)]
enum Layout {
    /// Objects first, then the background behind them (the default graphs).
    BehindObjects,
    /// One train node: every component on its own (the paper).
    Independent,
    /// One component for the whole frame.
    Holistic,
}

struct Variant {
    name: &'static str,
    what: &'static str,
    layout: Layout,
    /// Extra `train` params (RON), e.g. `checkpoint: "best"`.
    params: &'static str,
}

const VARIANTS: &[Variant] = &[
    Variant {
        name: "default",
        what: "objects first, background trained behind them; default schedule, `last` checkpoint",
        layout: Layout::BehindObjects,
        params: "",
    },
    Variant {
        name: "independent",
        what: "the paper's fully independent background (one train node)",
        layout: Layout::Independent,
        params: "",
    },
    Variant {
        name: "holistic",
        what: "the holistic baseline: one component, whole frames",
        layout: Layout::Holistic,
        params: "",
    },
    Variant {
        name: "no_point_depth",
        what: "no depth loss at the measured points",
        layout: Layout::BehindObjects,
        params: r#"schedule: {"point_depth_weight": 0}"#,
    },
    Variant {
        name: "point_depth_0.1",
        what: "the background's depth loss at weight 0.1 (default 1)",
        layout: Layout::BehindObjects,
        params: r#"schedule: {"point_depth_weight": 0.1}"#,
    },
    Variant {
        name: "object_point_depth",
        what: "the depth loss at the measured points for the objects too (weight 1)",
        layout: Layout::BehindObjects,
        params: r#"schedule: {"object_point_depth_weight": 1}"#,
    },
    Variant {
        name: "no_depth_smoothness",
        what: "no planarity prior on the background's rendered depth (default weight 3)",
        layout: Layout::BehindObjects,
        params: r#"schedule: {"depth_smoothness_weight": 0}"#,
    },
    Variant {
        name: "holistic_no_depth_smoothness",
        what: "the holistic baseline without the planarity prior",
        layout: Layout::Holistic,
        params: r#"schedule: {"depth_smoothness_weight": 0}"#,
    },
    Variant {
        name: "depth_smoothness_from_start",
        what: "the planarity prior from the first iteration (default: after the cleanup that follows the connectivity step)",
        layout: Layout::BehindObjects,
        params: r#"schedule: {"depth_smoothness_start": 0}"#,
    },
    Variant {
        name: "depth_smoothness_1",
        what: "the planarity prior at weight 1 (default 3)",
        layout: Layout::BehindObjects,
        params: r#"schedule: {"depth_smoothness_weight": 1}"#,
    },
    Variant {
        name: "depth_smoothness_10",
        what: "the planarity prior at weight 10 (default 3)",
        layout: Layout::BehindObjects,
        params: r#"schedule: {"depth_smoothness_weight": 10}"#,
    },
    Variant {
        name: "depth_smoothness_30",
        what: "the planarity prior at weight 30 (default 3)",
        layout: Layout::BehindObjects,
        params: r#"schedule: {"depth_smoothness_weight": 30}"#,
    },
    Variant {
        name: "object_normal_agreement",
        what: "faces of the objects that share an edge agree on their normal (weight 0.003; default off)",
        layout: Layout::BehindObjects,
        params: r#"schedule: {"object_normal_agreement_weight": 0.003}"#,
    },
    Variant {
        name: "free_space_own_points",
        what: "the free-space rule counts the component's own points only, not the other components' on their pixels",
        layout: Layout::BehindObjects,
        params: r#"schedule: {"free_space_other_components": 0}"#,
    },
    Variant {
        name: "reference_lr",
        what: "the reference's vertex learning rates (1.5e-3 → 1.5e-5)",
        layout: Layout::BehindObjects,
        params: r#"schedule: {"lr_vertices_start": 1.5e-3, "lr_vertices_end": 1.5e-5}"#,
    },
    Variant {
        name: "no_split_guard",
        what: "densification may split faces too small on screen",
        layout: Layout::BehindObjects,
        params: r#"schedule: {"densify_min_inradius": 0}"#,
    },
    Variant {
        name: "no_cleanup",
        what: "no post-connectivity cleanup",
        layout: Layout::BehindObjects,
        params: r#"schedule: {"connectivity_cleanup_threshold": 0}"#,
    },
    Variant {
        name: "best_validation",
        what: "`best` checkpoint chosen on validation views (1 in 8 training views held out)",
        layout: Layout::BehindObjects,
        params: r#"checkpoint: "best", select_on: "validation""#,
    },
    Variant {
        name: "best_test",
        what: "`best` checkpoint chosen on the test views (the paper's protocol: a leak)",
        layout: Layout::BehindObjects,
        params: r#"checkpoint: "best", select_on: "test""#,
    },
];

#[derive(Debug, Clone, Serialize)]
struct Row {
    variant: String,
    seed: u64,
    psnr: Option<f64>,
    ssim: Option<f64>,
    fscore_5cm: Option<f64>,
    fscore_2cm: Option<f64>,
    train_seconds: f64,
    faces: Option<u64>,
}

fn graph_text(
    args: &QualityArgs,
    w: u32,
    h: u32,
    seed: u64,
    layout: Layout,
    params: &str,
) -> String {
    let scene = format!(
        r#""scene": (kind: "synthetic_scene", params: (seed: {}, views: {}, width: {w}, height: {h}, split: "{}")),
    "masks": (kind: "gt_masks", inputs: (frames: "scene.frames", mesh: "scene.mesh")),"#,
        args.scene, args.views, args.split
    );
    let train_params = |extra: &str| {
        let sep = if params.is_empty() { "" } else { ", " };
        format!(
            "iterations: {}, seed: {seed}, checkpoint: \"last\"{extra}{sep}{params}",
            args.iterations
        )
    };
    let training = match layout {
        Layout::BehindObjects => format!(
            r#""parts": (kind: "partition", inputs: (frames: "scene.frames", masks: "masks.masks")),
    "objects": (kind: "train", inputs: (component: each("parts.components"), points: "scene.points"),
                params: ({})),
    "train": (kind: "train", inputs: (component: each("parts.components"), points: "scene.points", occluders: "objects.model"),
              params: ({})),"#,
            train_params(r#", components: "objects""#),
            train_params(r#", components: "background""#)
        ),
        Layout::Independent | Layout::Holistic => format!(
            r#""parts": (kind: "partition", inputs: (frames: "scene.frames", masks: "masks.masks"), params: (holistic: {})),
    "train": (kind: "train", inputs: (component: each("parts.components"), points: "scene.points"),
              params: ({})),"#,
            layout == Layout::Holistic,
            train_params("")
        ),
    };
    format!(
        r#"(
  nodes: {{
    {scene}
    {training}
    "composed": (kind: "compose", inputs: (models: "train.model")),
    "renders": (kind: "render", inputs: (scene: "composed.scene", frames: "scene.frames"), params: (views: "test")),
    "metrics": (kind: "evaluate", inputs: (images: "renders.images", frames: "scene.frames", scene: "composed.scene", mesh: "scene.mesh")),
    "metrics_2cm": (kind: "evaluate", inputs: (images: "renders.images", frames: "scene.frames", scene: "composed.scene", mesh: "scene.mesh"),
                    params: (tau: 0.02, voxel: 0.01)),
  }},
  targets: ["metrics", "metrics_2cm", "train"],
)
"#
    )
}

/// The graph an older binary understands: one train node, no `components`/`occluders`.
fn baseline_graph(args: &QualityArgs, w: u32, h: u32, seed: u64) -> String {
    graph_text(args, w, h, seed, Layout::Independent, "").replace(
        "\n    \"metrics_2cm\"",
        "\n    // no 2 cm evaluation: older evaluate\n    \"metrics_2cm_unused\"",
    )
}

/// Runs `graph` with `binary` into a fresh `dir` (cache and outputs), with `-j jobs` and
/// no GPU, and returns its `--json` run report.
pub fn run_graph(binary: &Path, graph: &Path, dir: &Path, jobs: usize) -> Result<Value> {
    if dir.exists() {
        std::fs::remove_dir_all(dir)?;
    }
    std::fs::create_dir_all(dir)?;
    let (mut command, json) = run_command(binary, graph, &dir.join("cache"), dir);
    command
        .arg("-j")
        .arg(jobs.to_string())
        .env("OBJECTSPLAT_NO_GPU", "1");
    run_to_report(command, &json, binary, graph)
}

/// The scene-level scores of a metrics node's output, if it ran.
fn scores(out: &Path, node: &str) -> Option<ScopeMetrics> {
    MetricsReport::read(&out.join(node).join("metrics"))
        .ok()
        .map(|m| m.scene)
}

pub fn quality(args: &QualityArgs) -> Result<()> {
    if args.variants.iter().any(|v| v == "list") {
        for v in VARIANTS {
            println!("{:16} {}", v.name, v.what);
        }
        return Ok(());
    }
    let chosen: Vec<&Variant> = if args.variants.is_empty() {
        VARIANTS.iter().collect()
    } else {
        args.variants
            .iter()
            .map(|name| {
                VARIANTS
                    .iter()
                    .find(|v| v.name == name)
                    .with_context(|| format!("no variant {name:?} (`--variants list` names them)"))
            })
            .collect::<Result<_>>()?
    };
    let (w, h) = args
        .size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .with_context(|| format!("size {:?} is not WIDTHxHEIGHT", args.size))?;
    let binary = crate::objectsplat_binary(args.binary.as_deref())?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut rows = Vec::new();
    let mut runs: Vec<(String, PathBuf, String)> = Vec::new();
    for &seed in &args.seeds {
        for v in &chosen {
            runs.push((
                v.name.to_string(),
                binary.clone(),
                graph_text(args, w, h, seed, v.layout, v.params),
            ));
        }
        if let Some(base) = &args.baseline {
            runs.push((
                "baseline".into(),
                base.clone(),
                baseline_graph(args, w, h, seed),
            ));
        }
        for (name, bin, text) in runs.drain(..) {
            let tag = format!("{name}-seed{seed}");
            eprintln!("[quality] {tag}");
            let graph = args.out.join(format!("{tag}.ron"));
            std::fs::write(&graph, text)?;
            let dir = args.out.join("runs").join(&tag);
            let started = std::time::Instant::now();
            let report = run_graph(&bin, &graph, &dir, args.jobs)?;
            let train_seconds: f64 = report["nodes"]
                .as_array()
                .into_iter()
                .flatten()
                .filter(|n| n["kind"] == "train")
                .filter_map(|n| n["seconds"].as_f64())
                .sum();
            let out = dir.join("out");
            let faces = std::fs::read_dir(out.join("train/model"))
                .ok()
                .map(|entries| {
                    entries
                        .filter_map(|e| e.ok())
                        .filter_map(|e| {
                            objectsplat_core::TrainingLog::load(&e.path())
                                .ok()
                                .flatten()
                        })
                        .map(|l| l.final_faces as u64)
                        .sum()
                });
            let (at_5cm, at_2cm) = (scores(&out, "metrics"), scores(&out, "metrics_2cm"));
            let row = Row {
                variant: name,
                seed,
                psnr: at_5cm.as_ref().and_then(|m| m.psnr),
                ssim: at_5cm.as_ref().and_then(|m| m.ssim),
                fscore_5cm: at_5cm.and_then(|m| m.fscore),
                fscore_2cm: at_2cm.and_then(|m| m.fscore),
                train_seconds,
                faces,
            };
            eprintln!(
                "[quality]   PSNR {:.2}  SSIM {:.3}  F5 {:.3}  F2 {:.3}  train {:.0} s (run {:.0} s)",
                row.psnr.unwrap_or(f64::NAN),
                row.ssim.unwrap_or(f64::NAN),
                row.fscore_5cm.unwrap_or(f64::NAN),
                row.fscore_2cm.unwrap_or(f64::NAN),
                row.train_seconds,
                started.elapsed().as_secs_f64()
            );
            rows.push(row);
        }
    }
    std::fs::write(
        args.out.join("quality.json"),
        serde_json::to_string_pretty(&rows)?,
    )?;
    let md = markdown(args, &chosen, &rows)?;
    std::fs::write(args.out.join("quality.md"), &md)?;
    print!("{md}");
    Ok(())
}

fn mean(v: &[Option<f64>]) -> Option<f64> {
    let v: Vec<f64> = v.iter().copied().collect::<Option<Vec<_>>>()?;
    (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
}

fn markdown(args: &QualityArgs, chosen: &[&Variant], rows: &[Row]) -> Result<String> {
    let mut md = String::new();
    writeln!(
        md,
        "Synthetic room (seed {}), {} views at {}, {} split, {} iterations per component, seeds {:?}; \
         PSNR/SSIM over the test views of the composed scene, F-score against the observed ground-truth surface.\n",
        args.scene, args.views, args.size, args.split, args.iterations, args.seeds
    )?;
    writeln!(
        md,
        "| variant | what | PSNR | SSIM | F (5 cm) | F (2 cm) | train s | faces |"
    )?;
    writeln!(md, "|---|---|---:|---:|---:|---:|---:|---:|")?;
    let mut names: Vec<(&str, &str)> = chosen.iter().map(|v| (v.name, v.what)).collect();
    if args.baseline.is_some() {
        names.push((
            "baseline",
            "the code before this round (one train node, its defaults)",
        ));
    }
    for (name, what) in names {
        let mine: Vec<&Row> = rows.iter().filter(|r| r.variant == name).collect();
        let cell = |f: &dyn Fn(&Row) -> Option<f64>, d: usize| {
            mean(&mine.iter().map(|r| f(r)).collect::<Vec<_>>())
                .map_or("–".into(), |v| format!("{v:.d$}"))
        };
        writeln!(
            md,
            "| {name} | {what} | {} | {} | {} | {} | {} | {} |",
            cell(&|r| r.psnr, 2),
            cell(&|r| r.ssim, 3),
            cell(&|r| r.fscore_5cm, 3),
            cell(&|r| r.fscore_2cm, 3),
            cell(&|r| Some(r.train_seconds), 0),
            cell(&|r| r.faces.map(|f| f as f64), 0),
        )?;
    }
    Ok(md)
}
