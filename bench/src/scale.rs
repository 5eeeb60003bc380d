//! `objectsplat-bench scale`: memory and time as a scene grows — more views,
//! larger frames — on the synthetic room.
//!
//! Each configuration runs twice through the `objectsplat` binary on one
//! cache: the scene (`synthetic_scene`, `gt_masks`, `partition`,
//! `point_visibility`), then the training (the objects, then the background
//! behind them, `-j` jobs). The peak resident memory of each run is the
//! child's own (`wait4`'s rusage, what `/usr/bin/time -v` reports as maximum
//! resident set size); per component the seconds per iteration come from its
//! training log, its views' memory from its `memory` note, and the scene's
//! load time from the nodes' seconds (frames decoded, masks rasterized and
//! split, visibility computed, on every core).

use crate::run_report::{node, run_command, training_record};
use anyhow::{Context, Result, bail};
use serde::Serialize;
use serde_json::Value;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

#[derive(clap::Args)]
pub struct ScaleArgs {
    /// View counts of the views sweep (at --size).
    #[arg(long, value_delimiter = ',', default_value = "48,96,192,384")]
    views: Vec<u32>,
    /// Frame size of the views sweep, WIDTHxHEIGHT.
    #[arg(long, default_value = "640x480")]
    size: String,
    /// Frame sizes of the size sweep (at --views-for-sizes views).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "320x240,640x480,1752x1168"
    )]
    sizes: Vec<String>,
    #[arg(long, default_value_t = 48)]
    views_for_sizes: u32,
    /// Extra configurations VIEWSxWIDTHxHEIGHT (e.g. 384x1752x1168, the issue's case).
    #[arg(long, value_delimiter = ',')]
    extra: Vec<String>,
    /// Iterations of every component.
    #[arg(long, default_value_t = 30)]
    iterations: u64,
    /// Jobs of the training run (`-j`).
    #[arg(long, default_value_t = 2)]
    jobs: usize,
    /// Anti-aliasing of the synthetic renders (1 keeps the generator's memory in bounds at scale).
    #[arg(long, default_value_t = 1)]
    supersample: u32,
    #[arg(long, default_value_t = 7)]
    scene: u64,
    /// The objectsplat binary (default: the one next to this program).
    #[arg(long)]
    binary: Option<PathBuf>,
    /// Results: scale.md, scale.json and each run's outputs.
    #[arg(long, default_value = "out/bench-scale")]
    out: PathBuf,
}

/// One configuration's figures.
#[derive(Debug, Clone, Serialize)]
struct Row {
    views: u32,
    size: String,
    /// Seconds of synthetic_scene, gt_masks, partition, point_visibility.
    scene_seconds: [f64; 4],
    scene_peak_rss_bytes: u64,
    train_peak_rss_bytes: u64,
    train_seconds: f64,
    components: Vec<ComponentRow>,
}

#[derive(Debug, Clone, Serialize)]
struct ComponentRow {
    name: String,
    kind: &'static str,
    /// Views the component's folder holds (the frames it appears in).
    views: usize,
    seconds_per_iteration: f64,
    /// The train item's memory note (its views' bytes, the process peak then).
    memory: String,
    /// The views' bytes parsed from the note.
    view_bytes: f64,
}

fn kind_of(name: &str) -> &'static str {
    match name {
        "background" => "background",
        n if n.ends_with("_table") || n.ends_with("_chair") => "table-sized object",
        _ => "small object",
    }
}

fn graph(views: u32, (w, h): (u32, u32), args: &ScaleArgs, train: bool) -> String {
    let (scene, ss, it) = (args.scene, args.supersample, args.iterations);
    let mut nodes = format!(
        r#"    "scene": (kind: "synthetic_scene", params: (seed: {scene}, views: {views}, width: {w}, height: {h}, split: "dense", supersample: {ss})),
    "visible": (kind: "point_visibility", inputs: (frames: "scene.frames", points: "scene.points")),
    "masks": (kind: "gt_masks", inputs: (frames: "scene.frames", mesh: "scene.mesh")),
    "parts": (kind: "partition", inputs: (frames: "scene.frames", masks: "masks.masks")),
"#
    );
    let targets = if train {
        nodes.push_str(&format!(
            r#"    "objects": (kind: "train", inputs: (component: each("parts.components"), points: "scene.points", visibility: "visible.visibility"),
                params: (iterations: {it}, seed: 0, checkpoint: "last", backend: "cpu", components: "objects")),
    "background": (kind: "train", inputs: (component: each("parts.components"), points: "scene.points", visibility: "visible.visibility", occluders: "objects.model"),
                   params: (iterations: {it}, seed: 0, checkpoint: "last", backend: "cpu", components: "background")),
"#
        ));
        r#"["background"]"#
    } else {
        r#"["parts", "visible"]"#
    };
    format!("(\n  nodes: {{\n{nodes}  }},\n  targets: {targets},\n)\n")
}

/// Runs `graph` and returns its run report and the child's peak resident bytes.
fn run_measured(
    binary: &Path,
    graph: &Path,
    cache: &Path,
    dir: &Path,
    jobs: usize,
) -> Result<(Value, u64)> {
    std::fs::create_dir_all(dir)?;
    let (mut command, json) = run_command(binary, graph, cache, dir);
    let child = command
        .args(["-j", &jobs.to_string()])
        .env("OBJECTSPLAT_NO_GPU", "1")
        .spawn()
        .with_context(|| format!("cannot start {}", binary.display()))?;
    let (status, peak) = wait_with_peak_rss(child)?;
    if status != 0 {
        bail!(
            "{} run {} exited with {status}",
            binary.display(),
            graph.display()
        );
    }
    Ok((crate::run_report::read(&json)?, peak))
}

/// Waits for `child`; its exit code and peak resident set in bytes (its own,
/// not its siblings': `wait4` reports the rusage of the one child).
fn wait_with_peak_rss(child: std::process::Child) -> Result<(i32, u64)> {
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: rusage is plain data; wait4 fills it for the child `pid` we spawned.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: pid is our unwaited child; the pointers are to live locals.
    let r = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    if r != pid {
        bail!("waiting for the run: {}", std::io::Error::last_os_error());
    }
    let code = if libc::WIFEXITED(status) {
        libc::WEXITSTATUS(status)
    } else {
        -1
    };
    // Linux reports ru_maxrss in kilobytes.
    Ok((code, usage.ru_maxrss as u64 * 1024))
}

fn seconds(report: &Value, id: &str) -> f64 {
    node(report, id)
        .and_then(|n| n["seconds"].as_f64())
        .unwrap_or(f64::NAN)
}

/// "12.3 MB in 40 views; …" → 12.3e6.
fn view_bytes(note: &str) -> f64 {
    note.split_whitespace()
        .next()
        .and_then(|n| n.parse::<f64>().ok())
        .map_or(f64::NAN, |mb| mb * 1e6)
}

fn parse_size(size: &str) -> Result<(u32, u32)> {
    size.split_once('x')
        .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
        .with_context(|| format!("size {size:?} is not WIDTHxHEIGHT"))
}

pub fn scale(args: &ScaleArgs) -> Result<()> {
    let binary = crate::objectsplat_binary(args.binary.as_deref())?;
    let mut configs: Vec<(u32, String)> =
        args.views.iter().map(|&v| (v, args.size.clone())).collect();
    configs.extend(args.sizes.iter().map(|s| (args.views_for_sizes, s.clone())));
    for extra in &args.extra {
        let (views, size) = extra
            .split_once('x')
            .with_context(|| format!("--extra {extra:?} is not VIEWSxWIDTHxHEIGHT"))?;
        configs.push((views.parse()?, size.to_string()));
    }
    // Each configuration once (the sweeps share one), in order.
    let mut seen = std::collections::HashSet::new();
    configs.retain(|c| seen.insert(c.clone()));
    std::fs::create_dir_all(&args.out)?;
    let mut rows = Vec::new();
    for (views, size) in configs {
        let wh = parse_size(&size)?;
        let name = format!("{views}x{size}");
        eprintln!("[scale] {name}");
        let dir = args.out.join("runs").join(&name);
        let cache = dir.join("cache");
        let (scene_graph, train_graph) = (dir.join("scene.ron"), dir.join("train.ron"));
        std::fs::create_dir_all(&dir)?;
        std::fs::write(&scene_graph, graph(views, wh, args, false))?;
        std::fs::write(&train_graph, graph(views, wh, args, true))?;
        let (scene, scene_peak) =
            run_measured(&binary, &scene_graph, &cache, &dir.join("scene"), 2)?;
        let started = std::time::Instant::now();
        let (train, train_peak) =
            run_measured(&binary, &train_graph, &cache, &dir.join("train"), args.jobs)?;
        let train_seconds = started.elapsed().as_secs_f64();
        let mut components = Vec::new();
        for id in ["objects", "background"] {
            let items = node(&train, id)
                .and_then(|n| n["items"].as_array())
                .into_iter()
                .flatten();
            for item in items.filter(|i| i["notes"].get("memory").is_some()) {
                let component = item["name"].as_str().unwrap_or("?").to_string();
                let model = dir
                    .join("train/out")
                    .join("background/model")
                    .join(&component);
                let (log, times) = training_record(item, &model, id, &component)?;
                let memory = item["notes"]["memory"].as_str().unwrap_or("").to_string();
                let frames = cache_frames(&dir, &component)?;
                components.push(ComponentRow {
                    kind: kind_of(&component),
                    name: component,
                    views: frames,
                    seconds_per_iteration: times.seconds / log.iterations_run.max(1) as f64,
                    view_bytes: view_bytes(&memory),
                    memory,
                });
            }
        }
        eprintln!(
            "[scale]   scene peak {:.2} GB, training peak {:.2} GB",
            scene_peak as f64 / 1e9,
            train_peak as f64 / 1e9
        );
        rows.push(Row {
            views,
            size,
            scene_seconds: ["scene", "masks", "parts", "visible"].map(|id| seconds(&scene, id)),
            scene_peak_rss_bytes: scene_peak,
            train_peak_rss_bytes: train_peak,
            train_seconds,
            components,
        });
    }
    std::fs::write(
        args.out.join("scale.json"),
        serde_json::to_string_pretty(&rows)?,
    )?;
    let md = markdown(args, &rows)?;
    std::fs::write(args.out.join("scale.md"), &md)?;
    print!("{md}");
    Ok(())
}

/// Views in a component's folder, from the `parts` output of the scene run.
fn cache_frames(dir: &Path, component: &str) -> Result<usize> {
    let folder = dir.join("scene/out/parts/components").join(component);
    Ok(objectsplat_core::Frames::read(&folder)?.frames.len())
}

fn markdown(args: &ScaleArgs, rows: &[Row]) -> Result<String> {
    let mut md = String::new();
    writeln!(
        md,
        "Synthetic room (seed {}, supersample {}), dense split, {} iterations per component, \
         objects then the background behind them, `-j {}`, CPU backend. Peak RSS: each run's \
         own (wait4). s/it: the training loop's wall time over its iterations (the mean over \
         the components of a kind). Views' memory: what the trainer holds of a component's \
         views.\n",
        args.scene, args.supersample, args.iterations, args.jobs
    )?;
    writeln!(
        md,
        "| views | frame | scene s (render, masks, partition, visibility) | scene peak RSS | \
         training peak RSS | training s | s/it small object | s/it table-sized | s/it background | \
         object views MB (views) | background views MB |"
    )?;
    writeln!(md, "|---:|---|---|---:|---:|---:|---:|---:|---:|---|---:|")?;
    for r in rows {
        let mean = |kind: &str| {
            let v: Vec<f64> = r
                .components
                .iter()
                .filter(|c| c.kind == kind)
                .map(|c| c.seconds_per_iteration)
                .collect();
            if v.is_empty() {
                "–".to_string()
            } else {
                format!("{:.3}", v.iter().sum::<f64>() / v.len() as f64)
            }
        };
        let objects: Vec<String> = r
            .components
            .iter()
            .filter(|c| c.kind != "background")
            .map(|c| format!("{:.2} ({})", c.view_bytes / 1e6, c.views))
            .collect();
        let background = r
            .components
            .iter()
            .find(|c| c.kind == "background")
            .map_or("–".into(), |c| format!("{:.0}", c.view_bytes / 1e6));
        let s = r.scene_seconds;
        writeln!(
            md,
            "| {} | {} | {:.1}, {:.1}, {:.1}, {:.1} | {:.2} GB | {:.2} GB | {:.0} | {} | {} | {} | {} | {} |",
            r.views,
            r.size,
            s[0],
            s[1],
            s[2],
            s[3],
            r.scene_peak_rss_bytes as f64 / 1e9,
            r.train_peak_rss_bytes as f64 / 1e9,
            r.train_seconds,
            mean("small object"),
            mean("table-sized object"),
            mean("background"),
            objects.join(", "),
            background
        )?;
    }
    Ok(md)
}
