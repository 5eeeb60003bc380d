//! `objectsplat-bench train-speed`: what training costs per component kind.
//!
//! Runs the decomposed and the holistic pipeline's `train` node on the
//! synthetic room at each requested frame size and thread count (`-j N`),
//! with the `last` checkpoint (every component runs its whole budget),
//! through the `objectsplat` binary, and optionally through a second (older)
//! binary in the same run, so the two are measured under the same machine
//! load. The decomposed pipeline runs as two graphs: the background alone,
//! then the objects (the `train` node's `components` param), so with N > 1
//! the background trains on N threads by itself; the objects then run side
//! by side, N at a time, as the runtime schedules items. Reads each
//! component's seconds from the run report (`--json`) and its training log,
//! and writes a Markdown table and the raw rows.
//!
//! The `roofline` line puts the renderer against the machine: the trained
//! background model (ours) rendered and differentiated from the scene's
//! cameras in this process, as fragments per second and achieved GFLOP/s
//! (the kernels' counted arithmetic per fragment), against the peak GFLOP/s
//! of a loop of independent 8-lane fused multiply-adds on the same threads.

use anyhow::{Context, Result, bail};
use objectsplat_core::TrainingLog;
use objectsplat_raster::cpu::{Background, CpuWorkspace};
use objectsplat_raster::{CpuBackend, OutputGrads, RenderSettings, load_model};
use objectsplat_synth::scene::{SyntheticParams, orbit_cameras};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

#[derive(clap::Args)]
pub struct TrainSpeedArgs {
    /// Frame sizes, WIDTHxHEIGHT.
    #[arg(long, value_delimiter = ',', default_value = "320x240,640x480")]
    sizes: Vec<String>,
    /// Iteration budget of every component (and of the holistic model).
    #[arg(long, default_value_t = 600)]
    iterations: u64,
    /// Worker threads of each run (`-j`), one pass per value.
    #[arg(long, value_delimiter = ',', default_value = "1")]
    threads: Vec<usize>,
    /// Views rendered for the roofline line (0: no roofline).
    #[arg(long, default_value_t = 8)]
    roofline_views: usize,
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
    threads: usize,
    pipeline: String,
    component: String,
    kind: String,
    iterations: u64,
    seconds: f64,
    iterations_per_second: f64,
    faces: Option<usize>,
    rendered_fraction: Option<f64>,
}

/// A whole `train` node of one run (the decomposed pipeline's two runs summed).
#[derive(Debug, Clone, Serialize)]
struct NodeRow {
    binary: String,
    size: String,
    threads: usize,
    pipeline: String,
    seconds: f64,
}

/// The graph of one run; `components` is the train node's param (all, background, objects).
fn graph_text(
    width: u32,
    height: u32,
    views: u32,
    scene: u64,
    iterations: u64,
    holistic: bool,
    components: &str,
) -> String {
    format!(
        r#"(
  nodes: {{
    "scene": (kind: "synthetic_scene", params: (seed: {scene}, views: {views}, width: {width}, height: {height}, split: "dense")),
    "masks": (kind: "gt_masks", inputs: (frames: "scene.frames", mesh: "scene.mesh")),
    "parts": (kind: "partition", inputs: (frames: "scene.frames", masks: "masks.masks"), params: (holistic: {holistic})),
    "train": (kind: "train", inputs: (component: each("parts.components"), points: "scene.points"),
              params: (iterations: {iterations}, seed: 0, checkpoint: "last", components: "{components}")),
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
    if let Some(t) = args.threads.iter().find(|&&t| t == 0) {
        bail!("--threads {t}: a run needs at least one thread");
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let (mut items, mut nodes, mut rooflines) = (Vec::new(), Vec::new(), Vec::new());
    for size in &args.sizes {
        let (w, h) = size
            .split_once('x')
            .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
            .with_context(|| format!("size {size:?} is not WIDTHxHEIGHT"))?;
        for &threads in &args.threads {
            for holistic in [false, true] {
                let pipeline = if holistic { "holistic" } else { "decomposed" };
                if !args.pipelines.iter().any(|p| p == pipeline) {
                    continue;
                }
                let parts: &[&str] = if holistic {
                    &["all"]
                } else {
                    &["background", "objects"]
                };
                for (name, binary) in &binaries {
                    let mut node_seconds = 0.0;
                    for components in parts {
                        let graph = args.out.join(format!("{pipeline}-{components}-{size}.ron"));
                        std::fs::write(
                            &graph,
                            graph_text(
                                w,
                                h,
                                args.views,
                                args.scene,
                                args.iterations,
                                holistic,
                                components,
                            ),
                        )?;
                        eprintln!(
                            "[train-speed] {size} {pipeline} ({components}), -j {threads}, with {name} ({})",
                            binary.display()
                        );
                        let run_dir = args
                            .out
                            .join("runs")
                            .join(format!("{name}-{pipeline}-{components}-{size}-j{threads}"));
                        let report = crate::quality::run_graph(binary, &graph, &run_dir, threads)?;
                        let train = report["nodes"]
                            .as_array()
                            .and_then(|n| n.iter().find(|n| n["id"] == "train"))
                            .context("the run report has no train node")?;
                        node_seconds += train["seconds"].as_f64().unwrap_or(f64::NAN);
                        // Components this run does not train are reported as skipped.
                        for item in train["items"]
                            .as_array()
                            .into_iter()
                            .flatten()
                            .filter(|i| i["status"] == "ran")
                        {
                            let component = item["name"].as_str().unwrap_or("?").to_string();
                            let seconds = item["seconds"].as_f64().unwrap_or(f64::NAN);
                            let log = TrainingLog::load(
                                &run_dir.join("out/train/model").join(&component),
                            )?;
                            let iterations =
                                log.as_ref().map_or(args.iterations, |l| l.iterations_run);
                            eprintln!("[train-speed]   {component}: {seconds:.2} s");
                            items.push(ItemRow {
                                binary: name.to_string(),
                                size: size.clone(),
                                threads,
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
                    nodes.push(NodeRow {
                        binary: name.to_string(),
                        size: size.clone(),
                        threads,
                        pipeline: pipeline.into(),
                        seconds: node_seconds,
                    });
                }
            }
            let background = args.out.join("runs").join(format!(
                "ours-decomposed-background-{size}-j{threads}/out/train/model/background"
            ));
            if args.roofline_views > 0 && background.is_dir() {
                eprintln!("[train-speed] roofline {size}, {threads} thread(s)");
                rooflines.push(roofline(&background, args, (w, h), threads)?);
            }
        }
    }
    std::fs::write(
        args.out.join("train-speed.json"),
        serde_json::to_string_pretty(
            &serde_json::json!({"items": items, "nodes": nodes, "roofline": rooflines}),
        )?,
    )?;
    let md = markdown(args, &binaries, &items, &nodes, &rooflines)?;
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
    rooflines: &[RooflineRow],
) -> Result<String> {
    let mut md = String::new();
    let with_baseline = binaries.len() > 1;
    writeln!(
        md,
        "Synthetic room (seed {}), {} views, dense split, {} iterations per component, checkpoint `last`; \
         threads = the runs' `-j` (decomposed: the background alone, then the objects, side by side).\n",
        args.scene, args.views, args.iterations
    )?;
    writeln!(md, "#### Per component\n")?;
    if with_baseline {
        writeln!(
            md,
            "| size | threads | component | kind | rendered share | it/s ours | it/s baseline | speed-up |"
        )?;
        writeln!(md, "|---|---:|---|---|---:|---:|---:|---:|")?;
    } else {
        writeln!(
            md,
            "| size | threads | component | kind | rendered share | it/s |"
        )?;
        writeln!(md, "|---|---:|---|---|---:|---:|")?;
    }
    for row in items.iter().filter(|r| r.binary == "ours") {
        let share = row
            .rendered_fraction
            .map_or("–".into(), |f| format!("{:.0}%", 100.0 * f));
        let lead = format!(
            "| {} | {} | {} | {} | {share} | {:.1} |",
            row.size, row.threads, row.component, row.kind, row.iterations_per_second
        );
        if with_baseline {
            let base = items.iter().find(|b| {
                b.binary == "baseline"
                    && b.size == row.size
                    && b.threads == row.threads
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
            writeln!(md, "{lead} {b_ips} | {speedup} |")?;
        } else {
            writeln!(md, "{lead}")?;
        }
    }
    writeln!(
        md,
        "\n#### The train node (all components, one after another)\n"
    )?;
    writeln!(
        md,
        "| size | threads | binary | decomposed s | holistic s | decomposed / holistic |"
    )?;
    writeln!(md, "|---|---:|---|---:|---:|---:|")?;
    for size in &args.sizes {
        for &threads in &args.threads {
            let secs = |name: &str, pipeline: &str| {
                nodes
                    .iter()
                    .find(|n| {
                        &n.size == size
                            && n.threads == threads
                            && n.binary == name
                            && n.pipeline == pipeline
                    })
                    .map(|n| n.seconds)
            };
            for (name, _) in binaries {
                if let (Some(d), Some(h)) = (secs(name, "decomposed"), secs(name, "holistic")) {
                    writeln!(
                        md,
                        "| {size} | {threads} | {name} | {d:.1} | {h:.1} | {:.2}× |",
                        d / h
                    )?;
                }
            }
            if let (Some(ours), Some(base)) =
                (secs("ours", "decomposed"), secs("baseline", "decomposed"))
            {
                writeln!(
                    md,
                    "| {size} | {threads} | decomposed: baseline / ours | | | {:.1}× |",
                    base / ours
                )?;
            }
        }
    }
    if !rooflines.is_empty() {
        writeln!(
            md,
            "\n#### Roofline (ours: the trained background, forward + backward of {} views)\n",
            args.roofline_views
        )?;
        for r in rooflines {
            writeln!(md, "{}", r.line())?;
        }
    }
    Ok(md)
}

/// The renderer against the machine at one frame size and thread count.
#[derive(Debug, Clone, Serialize)]
struct RooflineRow {
    size: String,
    threads: usize,
    views: usize,
    fragments_per_view: f64,
    forward_seconds_per_view: f64,
    backward_seconds_per_view: f64,
    /// Fragments through forward and backward per second.
    fragments_per_second: f64,
    achieved_gflops: f64,
    /// None where the CPU has no AVX2/FMA (no peak loop to run).
    peak_gflops: Option<f64>,
}

impl RooflineRow {
    fn line(&self) -> String {
        let peak = match self.peak_gflops {
            Some(p) => format!(
                "of {p:.1} GFLOP/s peak ({:.1} %)",
                100.0 * self.achieved_gflops / p
            ),
            None => "(no AVX2/FMA: peak not measured)".into(),
        };
        format!(
            "roofline {}, {} thread(s): {:.1} M fragments/s, {:.2} GFLOP/s achieved {peak}; \
             {:.2} M fragments per view, forward {:.1} ms + backward {:.1} ms per view",
            self.size,
            self.threads,
            self.fragments_per_second / 1e6,
            self.achieved_gflops,
            self.fragments_per_view / 1e6,
            self.forward_seconds_per_view * 1e3,
            self.backward_seconds_per_view * 1e3,
        )
    }
}

/// Renders and differentiates the trained background `model_dir` from the
/// first `args.roofline_views` cameras of the scene (the synthetic node's own
/// orbit), on `threads` threads, and measures the FMA peak on as many.
fn roofline(
    model_dir: &Path,
    args: &TrainSpeedArgs,
    (width, height): (u32, u32),
    threads: usize,
) -> Result<RooflineRow> {
    let model = load_model(model_dir)?;
    let cameras = orbit_cameras(&SyntheticParams {
        seed: args.scene,
        views: args.views as usize,
        width,
        height,
        ..SyntheticParams::default()
    });
    let settings = RenderSettings::for_model(&model);
    let backend = CpuBackend::new(threads);
    let mut ws = CpuWorkspace::<f32>::default();
    let (mut forward, mut backward, mut fragments) = (0.0, 0.0, 0u64);
    let views = args.roofline_views.min(cameras.len());
    // One untimed pass first, so the workspace has grown to the scene.
    for (i, camera) in cameras.iter().take(views).enumerate() {
        for timed in [false, true].into_iter().skip(usize::from(i > 0)) {
            let start = Instant::now();
            backend.forward_into(
                &mut ws,
                &model,
                camera,
                &settings,
                Background::Uniform([0.5; 3]),
            )?;
            let rendered = Instant::now();
            // Any fixed upstream gradient exercises the whole backward.
            let grad: Vec<f32> = ws.output.color.iter().map(|c| c - 0.5).collect();
            let differentiated = Instant::now();
            backend.backward_into(&mut ws, &model, &OutputGrads::color_only(&grad))?;
            if timed {
                forward += (rendered - start).as_secs_f64();
                backward += differentiated.elapsed().as_secs_f64();
                fragments += ws
                    .output
                    .face_pixel_count
                    .iter()
                    .map(|&c| c as u64)
                    .sum::<u64>();
            }
        }
    }
    let views_f = views.max(1) as f64;
    let seconds = (forward + backward).max(f64::MIN_POSITIVE);
    Ok(RooflineRow {
        size: format!("{width}x{height}"),
        threads,
        views,
        fragments_per_view: fragments as f64 / views_f,
        forward_seconds_per_view: forward / views_f,
        backward_seconds_per_view: backward / views_f,
        fragments_per_second: fragments as f64 / seconds,
        achieved_gflops: fragments as f64 * FLOPS_PER_FRAGMENT / seconds / 1e9,
        peak_gflops: fma_peak_gflops(threads),
    })
}

/// Counted arithmetic of one fragment through the eight-lane forward and backward kernels.
#[cfg(target_arch = "x86_64")]
const FLOPS_PER_FRAGMENT: f64 = (objectsplat_raster::cpu::simd::FORWARD_FLOPS_PER_FRAGMENT
    + objectsplat_raster::cpu::simd::BACKWARD_FLOPS_PER_FRAGMENT)
    as f64;
#[cfg(not(target_arch = "x86_64"))]
const FLOPS_PER_FRAGMENT: f64 = f64::NAN;

/// Independent FMA chains per thread in the peak loop: enough to cover the
/// instruction's latency on the machine's FMA units.
const FMA_CHAINS: usize = 12;
const FMA_ROUNDS: usize = 50_000_000;

/// Peak f32 GFLOP/s of `threads` threads each running [`FMA_CHAINS`]
/// independent 8-lane fused multiply-add chains (2 flops per lane); None
/// without AVX2/FMA.
fn fma_peak_gflops(threads: usize) -> Option<f64> {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
        let start = Instant::now();
        let sink: f32 = std::thread::scope(|scope| {
            let workers: Vec<_> = (0..threads)
                .map(|i| {
                    // SAFETY: the CPU has AVX2 and FMA (checked above).
                    scope.spawn(move || unsafe { fma_chains(FMA_ROUNDS, i as f32) })
                })
                .collect();
            // A worker only fails by panicking, which the scope re-raises.
            workers.into_iter().map(|w| w.join().unwrap_or(0.0)).sum()
        });
        let seconds = start.elapsed().as_secs_f64();
        std::hint::black_box(sink);
        let flops = (threads * FMA_ROUNDS * FMA_CHAINS * 8 * 2) as f64;
        return Some(flops / seconds / 1e9);
    }
    let _ = threads;
    None
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn fma_chains(rounds: usize, seed: f32) -> f32 {
    use std::arch::x86_64::*;
    let mut chains = [_mm256_set1_ps(seed); FMA_CHAINS];
    let (scale, shift) = (_mm256_set1_ps(0.999_999), _mm256_set1_ps(1e-7));
    for _ in 0..rounds {
        for c in chains.iter_mut() {
            *c = _mm256_fmadd_ps(*c, scale, shift);
        }
    }
    let mut total = _mm256_setzero_ps();
    for c in chains {
        total = _mm256_add_ps(total, c);
    }
    let mut lanes = [0.0f32; 8];
    // SAFETY: `lanes` holds exactly the 8 floats written.
    unsafe { _mm256_storeu_ps(lanes.as_mut_ptr(), total) };
    lanes.iter().sum()
}
