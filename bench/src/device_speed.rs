//! `objectsplat-bench device-speed`: training speed per component kind on
//! each render backend, side by side on one machine.
//!
//! Runs the shipped graph's shape on the synthetic room — the objects, then
//! the background behind the frozen objects (depth loss at measured points and
//! planar prior on, as by default) — and the holistic model, once per backend
//! and frame size, through the `objectsplat` binary, one item at a time.
//! Iterations per second are each item's iterations over the seconds its
//! training took, as the run report gives the times the item measured
//! (`measurements.training_times`): the whole loop with its schedule events
//! (densification, pruning, the opacity floor, connectivity), evaluations and
//! final prune, not the loading of the views. The events come every `--event-every` iterations,
//! the reference schedule's period at its 30k budget, so that a short run
//! has a long run's share of them (a short budget scales them closer). Where
//! `nvidia-smi` answers, the peak GPU memory of each run is polled beside it.
//! Optionally runs the demo graph's `objects` and `train` nodes on each backend.
//! `scripts/gpu-bench.sh` drives it on a GPU machine.

use crate::run_report::{node, run_command, run_to_report, training_record};
use anyhow::{Context, Result, bail};
use serde::Serialize;
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

#[derive(clap::Args)]
pub struct DeviceSpeedArgs {
    /// Frame sizes, WIDTHxHEIGHT.
    #[arg(long, value_delimiter = ',', default_value = "640x480,1752x1168")]
    sizes: Vec<String>,
    /// Render backends: cpu, wgpu.
    #[arg(long, value_delimiter = ',', default_value = "cpu,wgpu")]
    backends: Vec<String>,
    /// Iteration budget of every component (`last` checkpoint: all of it runs).
    #[arg(long, default_value_t = 300)]
    iterations: u64,
    /// Iteration budget on the cpu backend (default: --iterations), for frame
    /// sizes where the CPU would take too long; the events come as often either way.
    #[arg(long)]
    cpu_iterations: Option<u64>,
    /// Iterations between schedule events (densify, prune, opacity floor, evaluation).
    #[arg(long, default_value_t = 500)]
    event_every: u64,
    /// Views of the synthetic room (dense split: 7 of 8 train).
    #[arg(long, default_value_t = 24)]
    views: u32,
    /// Synthetic scene seed.
    #[arg(long, default_value_t = 7)]
    scene: u64,
    /// Also time the demo graph's `objects` and `train` nodes on each backend
    /// with this iteration budget, run as a user would (every core, items in
    /// parallel); 0: skip.
    #[arg(long, default_value_t = 0)]
    demo_iterations: u64,
    /// Folder holding demo.ron.
    #[arg(long, default_value = "graphs")]
    graphs: PathBuf,
    /// Threads of the CPU backend (default: every core); items train one at a time.
    #[arg(long)]
    threads: Option<usize>,
    /// The objectsplat binary measured (default: the one next to this program).
    #[arg(long)]
    binary: Option<PathBuf>,
    /// Fail unless every wgpu training item reports that all its iterations ran on the device.
    #[arg(long)]
    require_device_steps: bool,
    /// Results: device-speed.md, device-speed.json and each run's outputs.
    #[arg(long, default_value = "out/bench-device-speed")]
    out: PathBuf,
}

/// One component's training in one run.
#[derive(Debug, Clone, Serialize)]
struct ItemRow {
    backend: String,
    size: String,
    component: String,
    kind: String,
    iterations: u64,
    /// Iterations over the seconds the item's training took (its run's measurement).
    iterations_per_second: f64,
    faces: usize,
    /// Whether the training log says every iteration ran on the device.
    device_steps: bool,
    rendered_fraction: Option<f64>,
}

/// A whole run (one backend, one size).
#[derive(Debug, Clone, Serialize)]
struct RunRow {
    backend: String,
    size: String,
    /// The `objects`, `background` and `holistic` nodes' seconds, as the run report gives them.
    seconds: Vec<(String, f64)>,
    /// Peak GPU memory used during the run, MiB above what was in use before it (nvidia-smi).
    peak_gpu_mib: Option<u64>,
}

fn graph_text(size: (u32, u32), args: &DeviceSpeedArgs, backend: &str) -> String {
    let (width, height) = size;
    let (scene, views) = (args.scene, args.views);
    let iterations = budget(args, backend);
    let e = args.event_every;
    let train = format!(
        "iterations: {iterations}, seed: 0, checkpoint: \"last\", backend: \"{backend}\", \
         schedule: {{\"densify_every\": {e}, \"prune_every\": {e}, \"floor_every\": {e}, \"eval_every\": {e}}}"
    );
    format!(
        r#"(
  nodes: {{
    "scene": (kind: "synthetic_scene", params: (seed: {scene}, views: {views}, width: {width}, height: {height}, split: "dense")),
    "masks": (kind: "gt_masks", inputs: (frames: "scene.frames", mesh: "scene.mesh")),
    "parts": (kind: "partition", inputs: (frames: "scene.frames", masks: "masks.masks")),
    "whole": (kind: "partition", inputs: (frames: "scene.frames", masks: "masks.masks"), params: (holistic: true)),
    "objects": (kind: "train", inputs: (component: each("parts.components"), points: "scene.points"),
                params: ({train}, components: "objects")),
    "background": (kind: "train", inputs: (component: each("parts.components"), points: "scene.points",
                                           occluders: "objects.model"),
                   params: ({train}, components: "background")),
    "holistic": (kind: "train", inputs: (component: each("whole.components"), points: "scene.points"),
                 params: ({train})),
  }},
  targets: ["objects", "background", "holistic"],
)
"#
    )
}

/// The iteration budget of `backend`'s runs.
fn budget(args: &DeviceSpeedArgs, backend: &str) -> u64 {
    match (backend, args.cpu_iterations) {
        ("cpu", Some(n)) => n,
        _ => args.iterations,
    }
}

/// Which kind of component an item of the synthetic room is.
fn kind_of(node: &str, component: &str) -> &'static str {
    match (node, component) {
        ("holistic", _) => "holistic",
        (_, "background") => "background behind occluders",
        (_, c) if c.ends_with("_table") || c.ends_with("_chair") => "table-sized object",
        _ => "small object",
    }
}

/// The training log's note that every iteration ran on the device.
const DEVICE_NOTE: &str = "iterations ran on the device";

/// Polls `nvidia-smi` for the GPU's used memory while a run goes on.
struct GpuMemoryPoller {
    stop: Arc<AtomicBool>,
    peak: Arc<AtomicU64>,
    before: u64,
    thread: std::thread::JoinHandle<()>,
}

fn gpu_memory_used_mib() -> Option<u64> {
    let out = std::process::Command::new("nvidia-smi")
        .args(["--query-gpu=memory.used", "--format=csv,noheader,nounits"])
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    // One line per GPU; the bench machine's first GPU is the one wgpu picks.
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .next()?
        .trim()
        .parse()
        .ok()
}

impl GpuMemoryPoller {
    fn start() -> Option<Self> {
        let before = gpu_memory_used_mib()?;
        let stop = Arc::new(AtomicBool::new(false));
        let peak = Arc::new(AtomicU64::new(before));
        let thread = {
            let (stop, peak) = (stop.clone(), peak.clone());
            std::thread::spawn(move || {
                while !stop.load(Ordering::Relaxed) {
                    if let Some(used) = gpu_memory_used_mib() {
                        peak.fetch_max(used, Ordering::Relaxed);
                    }
                    std::thread::sleep(std::time::Duration::from_millis(100));
                }
            })
        };
        Some(GpuMemoryPoller {
            stop,
            peak,
            before,
            thread,
        })
    }

    /// Peak MiB above the level before the run.
    fn finish(self) -> u64 {
        self.stop.store(true, Ordering::Relaxed);
        // A poller thread that panicked leaves the peak it had.
        let _ = self.thread.join();
        self.peak
            .load(Ordering::Relaxed)
            .saturating_sub(self.before)
    }
}

/// How a bench run schedules its items.
enum Jobs {
    /// One item at a time on this many threads.
    OneAtATime(usize),
    /// As many items at once as there are cores (`objectsplat run`'s default).
    Default,
}

/// Runs `graph` with `binary` on the cache `cache` (shared by the runs of one
/// scene: only the train nodes differ), with the GPU visible (unlike the CPU benches).
fn run(
    binary: &Path,
    graph: &Path,
    cache: &Path,
    dir: &Path,
    jobs: Jobs,
    sets: &[String],
) -> Result<Value> {
    if dir.exists() {
        std::fs::remove_dir_all(dir)?;
    }
    std::fs::create_dir_all(dir)?;
    let (mut command, json) = run_command(binary, graph, cache, dir);
    if let Jobs::OneAtATime(threads) = jobs {
        command
            .args(["-j", "1", "--threads"])
            .arg(threads.to_string());
    }
    for set in sets {
        command.arg("--set").arg(set);
    }
    run_to_report(command, &json, binary, graph)
}

fn parse_size(size: &str) -> Result<(u32, u32)> {
    size.split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .filter(|&(w, h)| w > 0 && h > 0)
        .with_context(|| format!("size {size:?} is not WIDTHxHEIGHT"))
}

pub fn device_speed(args: &DeviceSpeedArgs) -> Result<()> {
    let binary = crate::objectsplat_binary(args.binary.as_deref())?;
    if !binary.is_file() {
        bail!(
            "{} is not a file (build it with `cargo build --release`)",
            binary.display()
        );
    }
    if let Some(b) = args
        .backends
        .iter()
        .find(|b| !["cpu", "wgpu"].contains(&b.as_str()))
    {
        bail!("unknown backend {b:?}: expected cpu or wgpu");
    }
    if args.iterations == 0 || args.event_every == 0 {
        bail!("--iterations and --event-every must be at least 1");
    }
    let sizes = args
        .sizes
        .iter()
        .filter(|s| !s.is_empty())
        .map(|s| parse_size(s).map(|wh| (s.clone(), wh)))
        .collect::<Result<Vec<_>>>()?;
    let threads = crate::threads_or_all_cores(args.threads);
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let (mut items, mut runs) = (Vec::new(), Vec::new());
    for (size, wh) in &sizes {
        for backend in &args.backends {
            let graph = args.out.join(format!("{backend}-{size}.ron"));
            std::fs::write(&graph, graph_text(*wh, args, backend))?;
            eprintln!("[device-speed] {size} on {backend}");
            let run_dir = args.out.join("runs").join(format!("{backend}-{size}"));
            let cache = args.out.join("cache").join(size);
            let poller = GpuMemoryPoller::start();
            let report = run(
                &binary,
                &graph,
                &cache,
                &run_dir,
                Jobs::OneAtATime(threads),
                &[],
            )?;
            let peak_gpu_mib = poller.map(GpuMemoryPoller::finish);
            let mut seconds = Vec::new();
            for id in ["objects", "background", "holistic"] {
                let n = node(&report, id)
                    .with_context(|| format!("the run report has no {id} node"))?;
                seconds.push((id.to_string(), n["seconds"].as_f64().unwrap_or(f64::NAN)));
                // Items this node trained (not skipped, not passed through from `occluders`).
                let trained = n["items"].as_array().into_iter().flatten().filter(|item| {
                    item["status"] == "ran" && item["notes"].get("passed through").is_none()
                });
                for item in trained {
                    let component = item["name"].as_str().unwrap_or("?").to_string();
                    let dir = run_dir.join("out").join(id).join("model").join(&component);
                    let (log, times) = training_record(item, &dir, id, &component)?;
                    let ips = times.iterations_per_second().unwrap_or(f64::NAN);
                    let device_steps = log.notes.iter().any(|n| n.contains(DEVICE_NOTE));
                    eprintln!(
                        "[device-speed]   {id}/{component}: {ips:.2} it/s, {} faces{}",
                        log.final_faces,
                        if device_steps { ", device steps" } else { "" }
                    );
                    items.push(ItemRow {
                        backend: backend.clone(),
                        size: size.clone(),
                        kind: kind_of(id, &component).into(),
                        component,
                        iterations: log.iterations_run,
                        iterations_per_second: ips,
                        faces: log.final_faces,
                        device_steps,
                        rendered_fraction: log.rendered_fraction,
                    });
                }
            }
            runs.push(RunRow {
                backend: backend.clone(),
                size: size.clone(),
                seconds,
                peak_gpu_mib,
            });
        }
    }
    let mut demo = Vec::new();
    if args.demo_iterations > 0 {
        let graph = args.graphs.join("demo.ron");
        for backend in &args.backends {
            eprintln!("[device-speed] demo on {backend}");
            let sets: Vec<String> = ["objects", "train"]
                .iter()
                .flat_map(|n| {
                    [
                        format!("{n}.backend=\"{backend}\""),
                        format!("{n}.iterations={}", args.demo_iterations),
                    ]
                })
                .collect();
            let report = run(
                &binary,
                &graph,
                &args.out.join("cache").join("demo"),
                &args.out.join("runs").join(format!("demo-{backend}")),
                Jobs::Default,
                &sets,
            )?;
            let secs = |id: &str| node(&report, id).and_then(|n| n["seconds"].as_f64());
            demo.push((backend.clone(), secs("objects"), secs("train")));
        }
    }
    std::fs::write(
        args.out.join("device-speed.json"),
        serde_json::to_string_pretty(&serde_json::json!({
            "items": items, "runs": runs,
            "demo": demo.iter().map(|(b, o, t)| serde_json::json!({"backend": b, "objects_seconds": o, "train_seconds": t})).collect::<Vec<_>>(),
        }))?,
    )?;
    let md = markdown(args, threads, &items, &runs, &demo)?;
    let path = args.out.join("device-speed.md");
    std::fs::write(&path, &md)?;
    print!("{md}");
    eprintln!("[device-speed] wrote {}", path.display());
    if args.require_device_steps
        && let Some(host) = items
            .iter()
            .find(|i| i.backend == "wgpu" && !i.device_steps)
    {
        bail!(
            "{} ({}) ran host steps on the wgpu backend",
            host.component,
            host.kind
        );
    }
    Ok(())
}

const KINDS: [&str; 4] = [
    "small object",
    "table-sized object",
    "background behind occluders",
    "holistic",
];

fn markdown(
    args: &DeviceSpeedArgs,
    threads: usize,
    items: &[ItemRow],
    runs: &[RunRow],
    demo: &[(String, Option<f64>, Option<f64>)],
) -> Result<String> {
    let mut md = String::new();
    writeln!(
        md,
        "Synthetic room (seed {}), {} views, dense split, {} iterations per component{} with a \
         schedule event every {} (densify, prune, opacity floor, evaluation), checkpoint `last`, \
         one item at a time ({} CPU threads); objects, then the background behind them (depth \
         loss and planar prior on), and the holistic model. it/s: iterations over the training \
         loop's wall time (events, evaluations and the final prune included); small objects averaged.\n",
        args.scene,
        args.views,
        args.iterations,
        match args.cpu_iterations {
            Some(n) if n != args.iterations => format!(" ({n} on the cpu backend)"),
            _ => String::new(),
        },
        args.event_every,
        threads
    )?;
    let backends = &args.backends;
    write!(md, "| size | kind |")?;
    for b in backends {
        write!(md, " it/s {b} | device steps ({b}) |")?;
    }
    if backends.len() == 2 {
        write!(md, " {} / {} |", backends[1], backends[0])?;
    }
    writeln!(md)?;
    writeln!(
        md,
        "|---|---|{}{}",
        "---:|---:|".repeat(backends.len()),
        if backends.len() == 2 { "---:|" } else { "" }
    )?;
    for size in args.sizes.iter().filter(|s| !s.is_empty()) {
        for kind in KINDS {
            let mean = |b: &str| -> Option<(f64, bool)> {
                let rows: Vec<&ItemRow> = items
                    .iter()
                    .filter(|r| &r.size == size && r.kind == kind && r.backend == b)
                    .collect();
                (!rows.is_empty()).then(|| {
                    (
                        rows.iter().map(|r| r.iterations_per_second).sum::<f64>()
                            / rows.len() as f64,
                        rows.iter().all(|r| r.device_steps),
                    )
                })
            };
            write!(md, "| {size} | {kind} |")?;
            let speeds: Vec<Option<f64>> = backends.iter().map(|b| mean(b).map(|m| m.0)).collect();
            for b in backends {
                match mean(b) {
                    Some((ips, device)) => {
                        write!(md, " {ips:.2} | {} |", if device { "all" } else { "no" })?
                    }
                    None => write!(md, " – | – |")?,
                }
            }
            if let [Some(a), Some(b)] = speeds[..] {
                write!(md, " {:.1}× |", b / a)?;
            } else if backends.len() == 2 {
                write!(md, " – |")?;
            }
            writeln!(md)?;
        }
    }
    writeln!(
        md,
        "\n| size | backend | objects s | background s | holistic s | peak GPU memory |"
    )?;
    writeln!(md, "|---|---|---:|---:|---:|---:|")?;
    for r in runs {
        let s = |id: &str| {
            r.seconds
                .iter()
                .find(|(n, _)| n == id)
                .map_or("–".into(), |(_, s)| format!("{s:.1}"))
        };
        writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} |",
            r.size,
            r.backend,
            s("objects"),
            s("background"),
            s("holistic"),
            r.peak_gpu_mib.map_or("–".into(), |m| format!("{m} MiB")),
        )?;
    }
    if !demo.is_empty() {
        writeln!(
            md,
            "\n`graphs/demo.ron` with {} iterations per component, every core, items in parallel:\n\n| backend | objects s | train (background) s |\n|---|---:|---:|",
            args.demo_iterations
        )?;
        for (b, o, t) in demo {
            let f = |x: &Option<f64>| x.map_or("–".into(), |s| format!("{s:.1}"));
            writeln!(md, "| {b} | {} | {} |", f(o), f(t))?;
        }
    }
    Ok(md)
}
