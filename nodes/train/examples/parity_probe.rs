//! Why does training on wgpu land a few tenths of a dB away from training on
//! the CPU? Three experiments on the synthetic plate of
//! `tests/wgpu_training_parity.rs` (results: docs/benchmarks.md, "wgpu training parity"):
//!
//! - `chaos`: CPU-only runs whose gradients are multiplied by `1 + ε·u`
//!   (u uniform in [−1, 1], seeded), and 1 vs 2 CPU threads: how far do
//!   last-bit differences alone move the held-out PSNR?
//! - `lockstep`: one CPU trajectory (a copy of the trainer loop) with the wgpu
//!   backend rendering and back-propagating the same model, view and
//!   background at every step, and recomputing every pruning/densification
//!   decision: where, and how much, do the backends disagree?
//! - `mean`: held-out PSNR over training seeds 0..K on both backends: does the
//!   mean agree within 0.1 dB, and from which K?
//!
//! Run: `XDG_RUNTIME_DIR=/tmp cargo run --release -p objectsplat-train --example parity_probe -- <mode> [options]`
//! (`parity_probe help` lists the modes and options).

#[path = "../tests/common/mod.rs"]
mod common;

use anyhow::{Context, Result, bail};
use objectsplat_core::{Camera, Points, Split};
use objectsplat_raster::loss::{DEFAULT_LAMBDA_DSSIM, Dims, photometric};
use objectsplat_raster::model::SH_COEFFS;
use objectsplat_raster::{
    CpuBackend, Model, ModelGrads, OutputGrads, RenderBackend, RenderOutput, RenderSettings,
    SavedForward,
};
use objectsplat_train::Schedule;
use objectsplat_train::adam::Adam;
use objectsplat_train::connectivity::{ConnectivityOptions, restricted_delaunay};
use objectsplat_train::densify::{
    DensifyPolicy, VertexEdit, prune_faces, select_faces_to_split, subdivide_faces,
};
use objectsplat_train::init::{ComponentMasks, InitSettings, init_model};
use objectsplat_train::trainer::{
    Checkpoint, ComponentData, TrainSettings, View, held_out_eval, supervision, train_component,
};
use objectsplat_wgpu::{AdapterChoice, GpuContext, WgpuBackend};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::sync::Mutex;
use std::time::Instant;

const USAGE: &str = "parity_probe <mode> [options]
modes:
  chaos     [--seeds N] [--densify on|off|both] [--last]   perturbed-gradient CPU runs, 1 vs 2 threads, a few wgpu runs
  lockstep  [--densify on|off] [--seed S] [--verbose]   CPU trajectory, wgpu shadowing every step
  diverge   [--densify on|off] [--seed S]         growth of a 1e-7 perturbation vs the wgpu difference along a run
  mean      [--k K] [--densify on|off] [--last]      held-out PSNR over seeds 0..K on both backends
environment: PARITY_OVERRIDES='{\"sigma_end\": 1.0}' adds schedule overrides (what-if runs)
";

/// The schedule of tests/wgpu_training_parity.rs; `densify = false` also moves
/// the connectivity step beyond the budget (densify_start is 7 at 200 iterations,
/// so densify_until 0 means no densification).
fn settings(densify: bool, seed: u64, last: bool) -> Result<TrainSettings> {
    let mut overrides = serde_json::json!({ "patience": 200 });
    if !densify {
        overrides["densify_until"] = 0.into();
        overrides["connectivity_at"] = 1_000_000.into();
    }
    // Extra schedule overrides for what-if runs, e.g. PARITY_OVERRIDES='{"sigma_end": 1.0}'.
    if let Ok(extra) = std::env::var("PARITY_OVERRIDES") {
        let extra: serde_json::Map<String, serde_json::Value> = serde_json::from_str(&extra)
            .with_context(|| format!("PARITY_OVERRIDES {extra:?} is not a JSON object"))?;
        for (k, v) in extra {
            overrides[k] = v;
        }
    }
    Ok(TrainSettings {
        checkpoint: if last {
            Checkpoint::Last
        } else {
            Checkpoint::Best
        },
        ..common::short_run_settings(200, seed, overrides)
    })
}

/// The plate scene, written to a temporary folder and read back as the trainer sees it.
struct Scene {
    _dir: tempfile::TempDir,
    data: ComponentData,
    points: Points,
}

fn scene() -> Result<Scene> {
    let dir = tempfile::tempdir().context("creating a temporary folder")?;
    common::write_component(dir.path());
    let masks = ComponentMasks::read(dir.path())?;
    let points = masks.component_points(&common::points())?;
    let data = ComponentData::read(dir.path())?;
    Ok(Scene {
        _dir: dir,
        data,
        points,
    })
}

fn gpu_backend() -> Result<WgpuBackend> {
    let (ctx, adapter) = GpuContext::shared(AdapterChoice::Auto)?;
    eprintln!("wgpu adapter: {adapter}");
    WgpuBackend::new(ctx)
}

/// The CPU backend with every gradient value multiplied by `1 + ε·u`, u uniform
/// in [−1, 1] from a seeded generator: a stand-in for "same maths, different last bits".
struct PerturbedCpu {
    inner: CpuBackend,
    epsilon: f32,
    rng: Mutex<Pcg64Mcg>,
}

impl PerturbedCpu {
    fn new(threads: usize, epsilon: f32, seed: u64) -> Self {
        PerturbedCpu {
            inner: CpuBackend::new(threads),
            epsilon,
            rng: Mutex::new(Pcg64Mcg::seed_from_u64(seed)),
        }
    }
}

impl RenderBackend<f32> for PerturbedCpu {
    fn name(&self) -> &'static str {
        "cpu-perturbed"
    }

    fn forward(
        &self,
        model: &Model<f32>,
        camera: &Camera,
        settings: &RenderSettings,
        background: &[f32],
    ) -> Result<(RenderOutput<f32>, SavedForward)> {
        self.inner.forward(model, camera, settings, background)
    }

    fn backward(
        &self,
        model: &Model<f32>,
        saved: &SavedForward,
        grads: &OutputGrads<'_, f32>,
    ) -> Result<ModelGrads<f32>> {
        let mut g = self.inner.backward(model, saved, grads)?;
        let mut rng = self
            .rng
            .lock()
            .map_err(|_| anyhow::anyhow!("perturbation generator lock poisoned"))?;
        let eps = self.epsilon;
        let values = g
            .vertices
            .iter_mut()
            .flatten()
            .chain(g.sh.iter_mut().flatten().flatten())
            .chain(g.opacity_logits.iter_mut());
        for v in values {
            *v *= 1.0 + eps * rng.random_range(-1.0f32..=1.0);
        }
        Ok(g)
    }
}

/// Trains with the library trainer and scores on the CPU (as the parity test does).
fn train_and_score(
    backend: &dyn RenderBackend<f32>,
    scene: &Scene,
    settings: &TrainSettings,
) -> Result<(f64, usize, f64, Model<f32>)> {
    let started = Instant::now();
    let report = train_component(backend, &scene.data, &scene.points, settings, |_, _| true)?;
    let seconds = started.elapsed().as_secs_f64();
    let psnr = held_out_eval(&CpuBackend::new(2), &report.model, &scene.data, settings)?.psnr;
    Ok((psnr, report.model.face_count(), seconds, report.model))
}

struct Spread {
    values: Vec<f64>,
}

impl Spread {
    fn mean(&self) -> f64 {
        self.values.iter().sum::<f64>() / self.values.len().max(1) as f64
    }
    fn std(&self) -> f64 {
        let n = self.values.len();
        if n < 2 {
            return 0.0;
        }
        let m = self.mean();
        (self.values.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt()
    }
    fn range(&self) -> (f64, f64) {
        let lo = self.values.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = self
            .values
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        (lo, hi)
    }
    fn row(&self, label: &str, reference: f64) -> String {
        let (lo, hi) = self.range();
        let max_dev = self
            .values
            .iter()
            .map(|v| (v - reference).abs())
            .fold(0.0, f64::max);
        format!(
            "| {label} | {} | {:.3} | {:.3} | {:.3}–{:.3} ({:.3}) | {:.3} |",
            self.values.len(),
            self.mean(),
            self.std(),
            lo,
            hi,
            hi - lo,
            max_dev
        )
    }
}

fn same_model(a: &Model<f32>, b: &Model<f32>) -> bool {
    let bits = |m: &Model<f32>| -> Vec<u32> {
        m.vertices
            .iter()
            .flatten()
            .chain(m.sh.iter().flatten().flatten())
            .chain(&m.opacity_logits)
            .map(|v| v.to_bits())
            .collect()
    };
    a.faces == b.faces && bits(a) == bits(b)
}

fn chaos(seeds: u64, densify_modes: &[bool], last: bool) -> Result<()> {
    let scene = scene()?;
    let gpu = gpu_backend().ok();
    for &densify in densify_modes {
        let s = settings(densify, 3, last)?;
        println!(
            "\n## densify + connectivity {} (training seed 3), checkpoint {:?}",
            if densify { "ON" } else { "OFF" },
            s.checkpoint
        );
        let (cpu2, faces2, t2, m2) = train_and_score(&CpuBackend::new(2), &scene, &s)?;
        let (cpu1, _, t1, m1) = train_and_score(&CpuBackend::new(1), &scene, &s)?;
        let (cpu2b, _, _, m2b) = train_and_score(&CpuBackend::new(2), &scene, &s)?;
        println!(
            "cpu 2 threads: {cpu2:.4} dB ({faces2} faces, {t2:.1} s); 1 thread: {cpu1:.4} dB ({t1:.1} s); \
             2 threads again: {cpu2b:.4} dB; bit-identical models: 1t≡2t {}, 2t≡2t {}",
            same_model(&m1, &m2),
            same_model(&m2, &m2b)
        );
        println!(
            "| perturbation | runs | mean PSNR | std | range (width) | max abs Δ vs unperturbed |"
        );
        println!("|---|---|---|---|---|---|");
        for eps in [1e-7f32, 1e-5] {
            let mut values = Vec::new();
            for p in 0..seeds {
                let backend = PerturbedCpu::new(2, eps, 1000 + p);
                let (psnr, faces, secs, _) = train_and_score(&backend, &scene, &s)?;
                eprintln!("  ε={eps:e} seed {p}: {psnr:.4} dB, {faces} faces, {secs:.1} s");
                values.push(psnr);
            }
            println!("{}", Spread { values }.row(&format!("ε = {eps:e}"), cpu2));
        }
        if let Some(gpu) = &gpu {
            let mut values = Vec::new();
            for _ in 0..seeds {
                let (psnr, faces, secs, _) = train_and_score(gpu, &scene, &s)?;
                eprintln!("  wgpu: {psnr:.4} dB, {faces} faces, {secs:.1} s");
                values.push(psnr);
            }
            println!("{}", Spread { values }.row("wgpu (float atomics)", cpu2));
        }
    }
    Ok(())
}

/// Held-out PSNR over training seeds 0..k, both backends, with running means.
fn mean(k: u64, densify: bool, last: bool) -> Result<()> {
    let scene = scene()?;
    let gpu = gpu_backend()?;
    let cpu = CpuBackend::new(2);
    println!(
        "\n## seeds 0..{k}, densify + connectivity {}, checkpoint {:?}",
        if densify { "ON" } else { "OFF" },
        settings(densify, 0, last)?.checkpoint
    );
    println!(
        "| seed | cpu PSNR | wgpu PSNR | Δ | cpu s | wgpu s | mean cpu (0..=seed) | mean wgpu | Δ of means |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let (mut sc, mut sg) = (0.0, 0.0);
    let mut deltas = Vec::new();
    let (mut tc, mut tg) = (0.0, 0.0);
    for seed in 0..k {
        let s = settings(densify, seed, last)?;
        let (pc, _, secs_c, _) = train_and_score(&cpu, &scene, &s)?;
        let (pg, _, secs_g, _) = train_and_score(&gpu, &scene, &s)?;
        sc += pc;
        sg += pg;
        tc += secs_c;
        tg += secs_g;
        deltas.push(pg - pc);
        let n = (seed + 1) as f64;
        println!(
            "| {seed} | {pc:.3} | {pg:.3} | {:+.3} | {secs_c:.1} | {secs_g:.1} | {:.3} | {:.3} | {:+.3} |",
            pg - pc,
            sc / n,
            sg / n,
            (sg - sc) / n
        );
    }
    let d = Spread { values: deltas };
    println!(
        "per-seed Δ (wgpu − cpu): mean {:+.3}, std {:.3}; std of the mean at K={k}: {:.3}; \
         total time cpu {tc:.0} s, wgpu {tg:.0} s",
        d.mean(),
        d.std(),
        d.std() / (k as f64).sqrt()
    );
    Ok(())
}

// ---------------------------------------------------------------------------
// Lockstep: a copy of `train_component`'s loop (its internals are private)
// with a shadow backend.
// ---------------------------------------------------------------------------

struct Optim {
    adam: Adam,
    vertices: usize,
    sh_dc: usize,
    sh_rest: usize,
    opacity: usize,
}

impl Optim {
    fn new(schedule: &Schedule, rows: usize) -> Optim {
        let mut adam = Adam::new();
        let vertices = adam.add_group("vertices", schedule.lr_vertices_start, 3, rows);
        let sh_dc = adam.add_group("sh_dc", schedule.lr_sh_dc, 3, rows);
        let sh_rest = adam.add_group(
            "sh_rest",
            schedule.lr_sh_dc / schedule.sh_rest_lr_divisor,
            3 * (SH_COEFFS - 1),
            rows,
        );
        let opacity = adam.add_group("opacity", schedule.lr_opacity, 1, rows);
        Optim {
            adam,
            vertices,
            sh_dc,
            sh_rest,
            opacity,
        }
    }

    fn apply_edit(&mut self, edit: &VertexEdit) -> Result<()> {
        self.adam.retain_rows(&edit.keep)?;
        self.adam.append_rows(edit.appended);
        Ok(())
    }

    fn step(&mut self, model: &mut Model<f32>, grads: &ModelGrads<f32>) -> Result<()> {
        let mut pos: Vec<f32> = model.vertices.iter().flatten().copied().collect();
        let g: Vec<f32> = grads.vertices.iter().flatten().copied().collect();
        self.adam.step(self.vertices, &mut pos, &g)?;
        for (v, p) in model.vertices.iter_mut().zip(pos.chunks_exact(3)) {
            v.copy_from_slice(p);
        }
        let mut dc: Vec<f32> = model.sh.iter().flat_map(|s| s[0]).collect();
        let gdc: Vec<f32> = grads.sh.iter().flat_map(|s| s[0]).collect();
        self.adam.step(self.sh_dc, &mut dc, &gdc)?;
        let mut rest: Vec<f32> = model
            .sh
            .iter()
            .flat_map(|s| s[1..].iter().flatten().copied())
            .collect();
        let grest: Vec<f32> = grads
            .sh
            .iter()
            .flat_map(|s| s[1..].iter().flatten().copied())
            .collect();
        self.adam.step(self.sh_rest, &mut rest, &grest)?;
        for (v, s) in model.sh.iter_mut().enumerate() {
            s[0].copy_from_slice(&dc[3 * v..3 * v + 3]);
            for (k, coeff) in s.iter_mut().enumerate().skip(1) {
                let o = v * 3 * (SH_COEFFS - 1) + 3 * (k - 1);
                coeff.copy_from_slice(&rest[o..o + 3]);
            }
        }
        self.adam.step(
            self.opacity,
            &mut model.opacity_logits,
            &grads.opacity_logits,
        )
    }
}

fn render_settings(model: &Model<f32>, settings: &TrainSettings) -> RenderSettings {
    RenderSettings::for_model(model).with_world_scale(settings.world_scale)
}

/// A table row of the lockstep summary: its label and the quantity it reads.
type QuantityRow = (&'static str, fn(&StepDiff) -> f64);

struct FaceStats {
    max_weight: Vec<f32>,
    pixel_count: Vec<u32>,
    max_screen_extent: Vec<f64>,
}

/// The trainer's face statistics over the training views (plus pixel counts).
fn face_stats(
    backend: &dyn RenderBackend<f32>,
    model: &Model<f32>,
    views: &[&View],
    settings: &TrainSettings,
) -> Result<FaceStats> {
    let mut stats = FaceStats {
        max_weight: vec![0.0; model.face_count()],
        pixel_count: vec![0; model.face_count()],
        max_screen_extent: vec![0.0; model.face_count()],
    };
    for view in views {
        let bg = vec![0.0f32; 3 * view.labels.len()];
        let (out, _) =
            backend.forward(model, &view.camera, &render_settings(model, settings), &bg)?;
        for (m, &w) in stats.max_weight.iter_mut().zip(&out.face_max_weight) {
            *m = m.max(w);
        }
        for (m, &c) in stats.pixel_count.iter_mut().zip(&out.face_pixel_count) {
            *m += c;
        }
        let projected: Vec<Option<(f64, f64, f64)>> = model
            .vertices
            .iter()
            .map(|v| {
                view.camera
                    .project(glam::DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64))
            })
            .collect();
        for (f, face) in model.faces.iter().enumerate() {
            let corners = face.map(|v| projected[v as usize]);
            let [Some(a), Some(b), Some(c)] = corners else {
                continue;
            };
            let (cx, cy) = ((a.0 + b.0 + c.0) / 3.0, (a.1 + b.1 + c.1) / 3.0);
            let extent = [a, b, c]
                .iter()
                .map(|p| (p.0 - cx).hypot(p.1 - cy))
                .fold(0.0, f64::max);
            stats.max_screen_extent[f] = stats.max_screen_extent[f].max(extent);
        }
    }
    Ok(stats)
}

/// ‖a − b‖ / ‖b‖ over one gradient group (0 when both are zero).
fn norm_relative<'a>(
    a: impl Iterator<Item = &'a f32>,
    b: impl Iterator<Item = &'a f32>,
) -> (f64, f64) {
    let (mut d2, mut n2) = (0.0f64, 0.0f64);
    for (x, y) in a.zip(b) {
        d2 += (*x as f64 - *y as f64).powi(2);
        n2 += (*y as f64).powi(2);
    }
    let rel = if n2 > 0.0 {
        (d2 / n2).sqrt()
    } else if d2 > 0.0 {
        f64::INFINITY
    } else {
        0.0
    };
    (rel, n2.sqrt())
}

/// How two forward+backward results of the same inputs differ.
#[derive(Debug, Default, Clone)]
struct StepDiff {
    iteration: u64,
    faces: usize,
    image_max: f64,
    image_worst_pixel: (u32, u32),
    vertices: f64,
    sh: f64,
    opacity: f64,
    /// Faces whose per-view pixel count differs, and the largest difference.
    count_faces: usize,
    count_max: i64,
    /// Largest |Δ face_max_weight|, and faces with weight 0 on one backend only.
    weight_max: f64,
    weight_zero_mismatch: usize,
}

fn compare_step(
    iteration: u64,
    width: u32,
    a: (&RenderOutput<f32>, &ModelGrads<f32>),
    b: (&RenderOutput<f32>, &ModelGrads<f32>),
) -> StepDiff {
    let (ca, ga) = a;
    let (cb, gb) = b;
    let mut d = StepDiff {
        iteration,
        faces: ca.face_max_weight.len(),
        ..Default::default()
    };
    for (i, (x, y)) in ca.color.iter().zip(&cb.color).enumerate() {
        let e = (x - y).abs() as f64;
        if e > d.image_max {
            d.image_max = e;
            let p = (i / 3) as u32;
            d.image_worst_pixel = (p % width, p / width);
        }
    }
    d.vertices = norm_relative(gb.vertices.iter().flatten(), ga.vertices.iter().flatten()).0;
    d.sh = norm_relative(
        gb.sh.iter().flatten().flatten(),
        ga.sh.iter().flatten().flatten(),
    )
    .0;
    d.opacity = norm_relative(gb.opacity_logits.iter(), ga.opacity_logits.iter()).0;
    for (x, y) in ca.face_pixel_count.iter().zip(&cb.face_pixel_count) {
        if x != y {
            d.count_faces += 1;
            d.count_max = d.count_max.max((*x as i64 - *y as i64).abs());
        }
    }
    for (x, y) in ca.face_max_weight.iter().zip(&cb.face_max_weight) {
        d.weight_max = d.weight_max.max((x - y).abs() as f64);
        if (*x > 0.0) != (*y > 0.0) {
            d.weight_zero_mismatch += 1;
        }
    }
    d
}

/// Details of a step where the backends disagree: the worst faces and vertices.
fn explain_step(
    model: &Model<f32>,
    a: (&RenderOutput<f32>, &ModelGrads<f32>),
    b: (&RenderOutput<f32>, &ModelGrads<f32>),
) {
    let (oa, ga) = a;
    let (ob, gb) = b;
    for f in 0..model.face_count() {
        let (ca, cb) = (oa.face_pixel_count[f], ob.face_pixel_count[f]);
        let (wa, wb) = (oa.face_max_weight[f], ob.face_max_weight[f]);
        if ca != cb || (wa - wb).abs() > 1e-4 {
            println!(
                "    face {f} {:?}: pixels cpu {ca} wgpu {cb}; max weight cpu {wa:.6} wgpu {wb:.6}; opacity {:.4}",
                model.faces[f],
                model.face_opacity(f)
            );
        }
    }
    let mut worst: Vec<(f64, usize, &str)> = Vec::new();
    for v in 0..model.vertex_count() {
        let dv = norm_relative(gb.vertices[v].iter(), ga.vertices[v].iter());
        let dsh = norm_relative(gb.sh[v].iter().flatten(), ga.sh[v].iter().flatten());
        let dop = (
            (gb.opacity_logits[v] - ga.opacity_logits[v]).abs() as f64,
            ga.opacity_logits[v].abs() as f64,
        );
        let abs = |r: (f64, f64)| r.0 * r.1;
        worst.push((abs(dv), v, "position"));
        worst.push((abs(dsh), v, "sh"));
        worst.push((dop.0, v, "opacity"));
    }
    worst.sort_by(|x, y| y.0.total_cmp(&x.0));
    for (e, v, what) in worst.iter().take(3) {
        println!(
            "    vertex {v} {what}: |Δ| {e:.3e}; cpu pos-grad {:?} wgpu {:?}",
            ga.vertices[*v], gb.vertices[*v]
        );
    }
}

fn sci(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|x| format!("{x:.3e}")).collect();
    format!("[{}]", parts.join(", "))
}

/// The same step in f64 on the CPU: which f32 backend is closer to it?
fn f64_reference(
    model: &Model<f32>,
    camera: &Camera,
    rs: &RenderSettings,
    bg: &[f32],
    upstream: &[f32],
    cpu: &ModelGrads<f32>,
    gpu: &ModelGrads<f32>,
) -> Result<()> {
    let cpu64 = CpuBackend::new(2);
    let m64: Model<f64> = model.cast();
    let bg64: Vec<f64> = bg.iter().map(|&v| v as f64).collect();
    let up64: Vec<f64> = upstream.iter().map(|&v| v as f64).collect();
    let (_, saved) = cpu64.forward(&m64, camera, rs, &bg64)?;
    let g64 = cpu64.backward(&m64, &saved, &OutputGrads::color_only(&up64))?;
    let rel = |g: &ModelGrads<f32>| -> f64 {
        let (mut d2, mut n2) = (0.0, 0.0);
        for (a, b) in g
            .vertices
            .iter()
            .flatten()
            .zip(g64.vertices.iter().flatten())
        {
            d2 += (*a as f64 - b).powi(2);
            n2 += b * b;
        }
        (d2 / n2.max(1e-300)).sqrt()
    };
    println!(
        "    f64 reference: vertex grads norm-rel error cpu-f32 {:.2e}, wgpu {:.2e}",
        rel(cpu),
        rel(gpu)
    );
    Ok(())
}

/// Which single pixel's upstream gradient makes the backends' position
/// gradients of `vertex` differ most, and how close that pixel is to the
/// edges of the faces around the vertex (the window argument G = min_k λ_k·P/L_k).
#[allow(clippy::too_many_arguments)]
fn attribute_to_pixel(
    cpu: &dyn RenderBackend<f32>,
    gpu: &dyn RenderBackend<f32>,
    model: &Model<f32>,
    camera: &Camera,
    rs: &RenderSettings,
    bg: &[f32],
    upstream: &[f32],
    vertex: usize,
) -> Result<()> {
    let (_, saved_a) = cpu.forward(model, camera, rs, bg)?;
    let (_, saved_b) = gpu.forward(model, camera, rs, bg)?;
    let (w, h) = (camera.width, camera.height);
    let mut ranked = Vec::new();
    let mut single = vec![0.0f32; upstream.len()];
    for p in 0..(w * h) as usize {
        if upstream[3 * p..3 * p + 3].iter().all(|v| *v == 0.0) {
            continue;
        }
        single[3 * p..3 * p + 3].copy_from_slice(&upstream[3 * p..3 * p + 3]);
        let ga = cpu.backward(model, &saved_a, &OutputGrads::color_only(&single))?;
        let gb = gpu.backward(model, &saved_b, &OutputGrads::color_only(&single))?;
        single[3 * p..3 * p + 3].fill(0.0);
        let d: f64 = (0..3)
            .map(|k| (ga.vertices[vertex][k] as f64 - gb.vertices[vertex][k] as f64).powi(2))
            .sum::<f64>()
            .sqrt();
        let n: f64 = (0..3)
            .map(|k| (ga.vertices[vertex][k] as f64).powi(2))
            .sum::<f64>()
            .sqrt();
        ranked.push((d, n, p, ga.vertices[vertex], gb.vertices[vertex]));
    }
    ranked.sort_by(|x, y| y.0.total_cmp(&x.0));
    let total: f64 = ranked.iter().map(|r| r.0).sum();
    println!(
        "    vertex {vertex}: per-pixel |Δ grad| summed over {} pixels {total:.3e}; largest:",
        ranked.len()
    );
    let projected: Vec<Option<(f64, f64, f64)>> = model
        .vertices
        .iter()
        .map(|v| camera.project(glam::DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64)))
        .collect();
    for (d, n, p, a, b) in ranked.iter().take(3) {
        let (x, y) = ((*p as u32 % w) as f64 + 0.5, (*p as u32 / w) as f64 + 0.5);
        println!(
            "      pixel ({}, {}): |Δ| {d:.3e} (|cpu| {n:.3e}); cpu {a:?} wgpu {b:?}",
            p % w as usize,
            p / w as usize
        );
        for (f, face) in model.faces.iter().enumerate() {
            if !face.contains(&(vertex as u32)) {
                continue;
            }
            let Some(c) = face
                .map(|v| projected[v as usize])
                .into_iter()
                .collect::<Option<Vec<_>>>()
            else {
                continue;
            };
            // λ_k: signed area of the sub-triangle opposite corner k over the whole.
            let area = |a: (f64, f64), b: (f64, f64), c: (f64, f64)| {
                0.5 * ((b.0 - a.0) * (c.1 - a.1) - (c.0 - a.0) * (b.1 - a.1))
            };
            let pts: Vec<(f64, f64)> = c.iter().map(|q| (q.0, q.1)).collect();
            let whole = area(pts[0], pts[1], pts[2]);
            let lambda = [
                area((x, y), pts[1], pts[2]) / whole,
                area(pts[0], (x, y), pts[2]) / whole,
                area(pts[0], pts[1], (x, y)) / whole,
            ];
            let len = |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).hypot(a.1 - b.1);
            let l = [
                len(pts[1], pts[2]),
                len(pts[2], pts[0]),
                len(pts[0], pts[1]),
            ];
            let perimeter = l[0] + l[1] + l[2];
            let inradius = 2.0 * whole.abs() / perimeter;
            // distance of the pixel centre to edge k = λ_k·2A/L_k
            let dist: Vec<f64> = (0..3)
                .map(|k| lambda[k] * 2.0 * whole.abs() / l[k])
                .collect();
            if lambda.iter().all(|v| *v > -0.05) {
                println!(
                    "        face {f} {face:?}: λ {}, edge distances {} px, inradius {inradius:.2} px, \
                     opacity {:.4}, G ≈ {:.3e}",
                    sci(&lambda),
                    sci(&dist),
                    model.face_opacity(f),
                    dist.iter().copied().fold(f64::INFINITY, f64::min) / inradius
                );
            }
        }
    }
    Ok(())
}

/// A pruning or densification decision taken with both backends' statistics.
fn compare_decision(
    what: &str,
    iteration: u64,
    a: &FaceStats,
    b: &FaceStats,
    chosen_a: &[usize],
    chosen_b: &[usize],
    model: &Model<f32>,
) -> bool {
    let mut weight_max = 0.0f64;
    let mut worst_face = 0;
    for (f, (x, y)) in a.max_weight.iter().zip(&b.max_weight).enumerate() {
        let e = (x - y).abs() as f64;
        if e > weight_max {
            weight_max = e;
            worst_face = f;
        }
    }
    let positive = |s: &FaceStats| s.max_weight.iter().filter(|w| **w > 0.0).count();
    let counts_differ = a
        .pixel_count
        .iter()
        .zip(&b.pixel_count)
        .filter(|(x, y)| x != y)
        .count();
    let same = chosen_a == chosen_b;
    println!(
        "  it {iteration:>3} {what:<8} faces {:>4}: max|Δ max_weight| {weight_max:.2e} (face {worst_face}: cpu {:.6} wgpu {:.6}); \
         faces with weight>0 cpu {} wgpu {}; faces with different pixel totals {counts_differ}; decision {} ({} vs {} faces)",
        model.face_count(),
        a.max_weight.get(worst_face).copied().unwrap_or(0.0),
        b.max_weight.get(worst_face).copied().unwrap_or(0.0),
        positive(a),
        positive(b),
        if same { "same" } else { "DIFFERS" },
        chosen_a.len(),
        chosen_b.len(),
    );
    if !same {
        let only_a: Vec<usize> = chosen_a
            .iter()
            .filter(|f| !chosen_b.contains(f))
            .copied()
            .collect();
        let only_b: Vec<usize> = chosen_b
            .iter()
            .filter(|f| !chosen_a.contains(f))
            .copied()
            .collect();
        println!(
            "    only cpu: {:?}; only wgpu: {:?}",
            &only_a[..only_a.len().min(12)],
            &only_b[..only_b.len().min(12)]
        );
        for &f in only_a.iter().chain(&only_b).take(6) {
            println!(
                "    face {f}: max weight cpu {:.7} wgpu {:.7}, pixels cpu {} wgpu {}, opacity {:.5}",
                a.max_weight[f],
                b.max_weight[f],
                a.pixel_count[f],
                b.pixel_count[f],
                model.face_opacity(f)
            );
        }
    }
    same
}

fn pruning_mask(model: &Model<f32>, stats: &FaceStats, threshold: f64, s: &Schedule) -> Vec<bool> {
    (0..model.face_count())
        .map(|f| {
            model.face_opacity(f) as f64 > threshold
                && stats.max_weight[f] as f64 > threshold
                && stats.max_screen_extent[f] <= s.prune_max_screen_extent
        })
        .collect()
}

/// Runs the trainer's loop driven by `driver`; with a `shadow`, every render,
/// backward pass and topology decision is repeated on it and compared.
/// Returns the held-out PSNR (CPU-scored) of the returned model.
fn trajectory(
    driver: &dyn RenderBackend<f32>,
    shadow: Option<&dyn RenderBackend<f32>>,
    scene: &Scene,
    settings: &TrainSettings,
    verbose: bool,
    mut record: Option<&mut Vec<(Model<f32>, f64)>>,
) -> Result<(f64, Vec<StepDiff>, usize)> {
    let data = &scene.data;
    let s = &settings.schedule;
    let train: Vec<usize> = (0..data.views.len())
        .filter(|&i| data.views[i].split == Split::Train)
        .collect();
    let mut model = init_model(
        &scene.points,
        &InitSettings {
            seed: settings.seed,
            ..settings.init
        },
    )?;
    let mut optim = Optim::new(s, model.vertex_count());
    let mut rng = Pcg64Mcg::seed_from_u64(settings.seed ^ 0x9e37_79b9_7f4a_7c15);
    let train_views: Vec<&View> = train.iter().map(|&i| &data.views[i]).collect();
    let mut best: Option<(f64, u64, Model<f32>)> = None;
    let mut diffs = Vec::new();
    let mut decisions_differing = 0;
    let mut it = 0;
    while it < s.iterations {
        if it == s.connectivity_at && model.face_count() > 0 {
            model.faces = restricted_delaunay(
                &model.vertices,
                &model.faces,
                ConnectivityOptions {
                    include_hull_faces: true,
                    seed: settings.seed,
                },
            )?;
            if shadow.is_some() {
                println!(
                    "  it {it:>3} connectivity step: {} faces",
                    model.face_count()
                );
            }
            best = None;
        }
        if let Some(m) = s.floor_update(it) {
            model.set_opacity_floor(m)?;
        }
        model.sigma = s.sigma(it);
        model.sh_degree = s.sh_degree(it);
        if let Some(threshold) = s.prune_at(it) {
            let stats = face_stats(driver, &model, &train_views, settings)?;
            let keep = pruning_mask(&model, &stats, threshold, s);
            if let Some(sh) = shadow {
                let other = face_stats(sh, &model, &train_views, settings)?;
                let keep_b = pruning_mask(&model, &other, threshold, s);
                let pruned =
                    |k: &[bool]| -> Vec<usize> { (0..k.len()).filter(|&f| !k[f]).collect() };
                if !compare_decision(
                    "prune",
                    it,
                    &stats,
                    &other,
                    &pruned(&keep),
                    &pruned(&keep_b),
                    &model,
                ) {
                    decisions_differing += 1;
                }
            }
            if keep.iter().any(|&k| k) {
                let edit = prune_faces(&mut model, &keep)?;
                optim.apply_edit(&edit)?;
            }
        }
        if s.densify_at(it) && model.vertex_count() < s.max_vertices {
            let policy = DensifyPolicy {
                count: s.densify_count(model.face_count()),
                min_area: s.densify_min_area * settings.world_scale * settings.world_scale,
                always_largest: s.densify_always_largest,
            };
            let stats = face_stats(driver, &model, &train_views, settings)?;
            let mut shadow_rng = rng.clone();
            let chosen = select_faces_to_split(&model, &stats.max_weight, policy, &mut rng)?;
            if let Some(sh) = shadow {
                let other = face_stats(sh, &model, &train_views, settings)?;
                let chosen_b =
                    select_faces_to_split(&model, &other.max_weight, policy, &mut shadow_rng)?;
                if !compare_decision("densify", it, &stats, &other, &chosen, &chosen_b, &model) {
                    decisions_differing += 1;
                }
                // The trainer's single generator also draws views and backgrounds:
                // a different number of positive-weight faces shifts every later draw.
                if rng.clone().random::<u64>() != shadow_rng.random::<u64>() {
                    println!("  it {it:>3} densify: the generator streams diverge after this draw");
                }
            }
            let edit = subdivide_faces(&mut model, &chosen)?;
            optim.apply_edit(&edit)?;
        }
        optim.adam.set_lr(optim.vertices, s.lr_vertices(it))?;

        let view = &data.views[train[rng.random_range(0..train.len())]];
        let b = if settings.background_randomization {
            [
                rng.random::<f32>(),
                rng.random::<f32>(),
                rng.random::<f32>(),
            ]
        } else {
            settings.fixed_background
        };
        let pixels = view.labels.len();
        let bg: Vec<f32> = (0..3 * pixels).map(|i| b[i % 3]).collect();
        let rs = render_settings(&model, settings);
        let (out, saved) = driver.forward(&model, &view.camera, &rs, &bg)?;
        let (target, weights) = supervision(view, data.kind, b);
        let dims = Dims::rgb(view.camera.width, view.camera.height);
        let loss = photometric(
            dims,
            &out.color,
            &target,
            Some(&weights),
            DEFAULT_LAMBDA_DSSIM,
        )?;
        let grads = driver.backward(&model, &saved, &OutputGrads::color_only(&loss.grad))?;
        if let Some(sh) = shadow {
            let (out_b, saved_b) = sh.forward(&model, &view.camera, &rs, &bg)?;
            let grads_b = sh.backward(&model, &saved_b, &OutputGrads::color_only(&loss.grad))?;
            let d = compare_step(it, view.camera.width, (&out, &grads), (&out_b, &grads_b));
            let large = d.image_max > 1e-4
                || d.vertices > 1e-3
                || d.sh > 1e-3
                || d.opacity > 1e-3
                || d.count_faces > 0;
            if verbose || large {
                println!(
                    "  it {it:>3} view {} faces {:>4}: image max|Δ| {:.2e} at {:?}; grads rel vertices {:.2e} sh {:.2e} opacity {:.2e}; \
                     pixel-count faces {} (max {}); max|Δ face weight| {:.2e}; zero-weight mismatches {}",
                    view.name,
                    d.faces,
                    d.image_max,
                    d.image_worst_pixel,
                    d.vertices,
                    d.sh,
                    d.opacity,
                    d.count_faces,
                    d.count_max,
                    d.weight_max,
                    d.weight_zero_mismatch
                );
            }
            if large {
                explain_step(&model, (&out, &grads), (&out_b, &grads_b));
                f64_reference(&model, &view.camera, &rs, &bg, &loss.grad, &grads, &grads_b)?;
                if d.vertices > 1e-3 {
                    let v = (0..model.vertex_count())
                        .map(|v| {
                            let e: f64 = (0..3)
                                .map(|k| {
                                    (grads.vertices[v][k] as f64 - grads_b.vertices[v][k] as f64)
                                        .powi(2)
                                })
                                .sum();
                            (e, v)
                        })
                        .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a })
                        .1;
                    attribute_to_pixel(driver, sh, &model, &view.camera, &rs, &bg, &loss.grad, v)?;
                }
            }
            diffs.push(d);
        }
        optim.step(&mut model, &grads)?;
        it += 1;
        if let Some(r) = record.as_deref_mut() {
            let psnr = held_out_eval(&CpuBackend::new(2), &model, data, settings)?.psnr;
            r.push((model.clone(), psnr));
        }
        if it % s.eval_every == 0 || it == s.iterations {
            let score = held_out_eval(driver, &model, data, settings)?;
            if best.as_ref().is_none_or(|(b, _, _)| score.loss < *b) {
                best = Some((score.loss, it, model.clone()));
            }
            if let Some((_, best_it, _)) = &best
                && it > s.connectivity_at
                && it - best_it >= s.patience
                && it < s.iterations
            {
                break;
            }
        }
    }
    let mut model = match best {
        Some((_, _, m)) => m,
        None => model,
    };
    let max_weight = face_stats(driver, &model, &train_views, settings)?.max_weight;
    let keep: Vec<bool> = max_weight
        .iter()
        .map(|&w| w as f64 > s.final_prune_threshold)
        .collect();
    if keep.iter().any(|&k| k) {
        prune_faces(&mut model, &keep)?;
    }
    let psnr = held_out_eval(&CpuBackend::new(2), &model, data, settings)?.psnr;
    Ok((psnr, diffs, decisions_differing))
}

fn lockstep(densify: bool, seed: u64, verbose: bool) -> Result<()> {
    let scene = scene()?;
    let s = settings(densify, seed, false)?;
    let cpu = CpuBackend::new(2);
    // The copied loop must be the trainer's: same PSNR, bit for bit, on the CPU.
    let (library, _, _, _) = train_and_score(&cpu, &scene, &s)?;
    let (copied, _, _) = trajectory(&cpu, None, &scene, &s, false, None)?;
    if library.to_bits() != copied.to_bits() {
        bail!("the copied loop drifted from train_component: {copied} vs {library} dB");
    }
    println!(
        "\n## lockstep, densify + connectivity {}, seed {seed} (copied loop ≡ train_component: {library:.4} dB)",
        if densify { "ON" } else { "OFF" }
    );
    let gpu = gpu_backend()?;
    let (psnr, diffs, decisions) = trajectory(&cpu, Some(&gpu), &scene, &s, verbose, None)?;
    let worst = |f: fn(&StepDiff) -> f64| -> (f64, u64) {
        diffs
            .iter()
            .map(|d| (f(d), d.iteration))
            .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a })
    };
    let median = |f: fn(&StepDiff) -> f64| -> f64 {
        let mut v: Vec<f64> = diffs.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        v.get(v.len() / 2).copied().unwrap_or(0.0)
    };
    println!(
        "CPU-driven trajectory: {psnr:.4} dB, {} steps compared",
        diffs.len()
    );
    println!("| quantity | median over steps | max (iteration) |");
    println!("|---|---|---|");
    let rows: [QuantityRow; 6] = [
        ("image max abs Δ", |d| d.image_max),
        ("vertex grad norm-rel Δ", |d| d.vertices),
        ("SH grad norm-rel Δ", |d| d.sh),
        ("opacity grad norm-rel Δ", |d| d.opacity),
        ("max abs Δ face_max_weight", |d| d.weight_max),
        ("faces with Δ face_pixel_count", |d| d.count_faces as f64),
    ];
    for (name, f) in rows {
        let (m, i) = worst(f);
        println!("| {name} | {:.2e} | {m:.2e} ({i}) |", median(f));
    }
    println!("topology decisions that differ: {decisions}");
    Ok(())
}

/// How fast a last-bit difference grows: the CPU trajectory against an
/// ε = 1e-7 perturbed CPU trajectory and against the wgpu trajectory, same seed.
fn diverge(densify: bool, seed: u64) -> Result<()> {
    let scene = scene()?;
    let s = settings(densify, seed, false)?;
    let cpu = CpuBackend::new(2);
    let perturbed = PerturbedCpu::new(2, 1e-7, 1000);
    let gpu = gpu_backend()?;
    let mut traces: Vec<Vec<(Model<f32>, f64)>> = Vec::new();
    for backend in [&cpu as &dyn RenderBackend<f32>, &perturbed, &gpu] {
        let mut trace = Vec::new();
        trajectory(backend, None, &scene, &s, false, Some(&mut trace))?;
        traces.push(trace);
    }
    println!(
        "\n## divergence from the CPU trajectory, densify + connectivity {}, seed {seed}",
        if densify { "ON" } else { "OFF" }
    );
    println!(
        "| after iteration | faces cpu / ε=1e-7 / wgpu | max abs Δ vertex position: ε=1e-7 | wgpu | held-out PSNR cpu | Δ ε=1e-7 | Δ wgpu |"
    );
    println!("|---|---|---|---|---|---|---|");
    let delta = |a: &Model<f32>, b: &Model<f32>| -> Option<f64> {
        (a.faces == b.faces).then(|| {
            a.vertices
                .iter()
                .flatten()
                .zip(b.vertices.iter().flatten())
                .map(|(x, y)| (x - y).abs() as f64)
                .fold(0.0, f64::max)
        })
    };
    let show = |d: Option<f64>| d.map_or("topology differs".to_string(), |v| format!("{v:.1e}"));
    let n = traces.iter().map(Vec::len).min().unwrap_or(0);
    for i in [0usize, 1, 4, 9, 19, 29, 49, 74, 99, 124, 149, 174, 199] {
        if i >= n {
            break;
        }
        let (a, b, c) = (&traces[0][i], &traces[1][i], &traces[2][i]);
        println!(
            "| {} | {} / {} / {} | {} | {} | {:.3} | {:+.3} | {:+.3} |",
            i + 1,
            a.0.face_count(),
            b.0.face_count(),
            c.0.face_count(),
            show(delta(&a.0, &b.0)),
            show(delta(&a.0, &c.0)),
            a.1,
            b.1 - a.1,
            c.1 - a.1
        );
    }
    println!("per-iteration growth of the ε = 1e-7 difference (iterations 60–110):");
    let mut line = String::new();
    let mut previous: Option<f64> = None;
    let pairs = traces[0].iter().zip(&traces[1]).enumerate();
    for (i, (a, b)) in pairs.skip(59).take(51) {
        if let Some(d) = delta(&a.0, &b.0) {
            let growth = previous.map_or(String::new(), |p| format!("×{:.1}", d / p.max(1e-30)));
            line.push_str(&format!(
                " {}:{d:.1e}{growth} (σ {:.2}, floor {:.2});",
                i + 1,
                s.schedule.sigma(i as u64),
                a.0.opacity_floor
            ));
            previous = Some(d);
        }
    }
    println!("{line}");
    Ok(())
}

fn flag<'a>(args: &'a [String], name: &str) -> Option<&'a str> {
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .map(|s| s.as_str())
}

fn on_off(v: Option<&str>, default: &[bool]) -> Result<Vec<bool>> {
    Ok(match v {
        None => default.to_vec(),
        Some("on") => vec![true],
        Some("off") => vec![false],
        Some("both") => vec![true, false],
        Some(other) => bail!("--densify {other:?}: expected on, off or both"),
    })
}

fn number(v: Option<&str>, name: &str, default: u64) -> Result<u64> {
    match v {
        None => Ok(default),
        Some(s) => s
            .parse()
            .with_context(|| format!("{name} {s:?} is not a non-negative integer")),
    }
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let started = Instant::now();
    match args.first().map(String::as_str) {
        Some("chaos") => chaos(
            number(flag(&args, "--seeds"), "--seeds", 5)?,
            &on_off(flag(&args, "--densify"), &[true, false])?,
            args.iter().any(|a| a == "--last"),
        )?,
        Some("lockstep") => {
            for densify in on_off(flag(&args, "--densify"), &[true, false])? {
                lockstep(
                    densify,
                    number(flag(&args, "--seed"), "--seed", 3)?,
                    args.iter().any(|a| a == "--verbose"),
                )?
            }
        }
        Some("diverge") => {
            for densify in on_off(flag(&args, "--densify"), &[true, false])? {
                diverge(densify, number(flag(&args, "--seed"), "--seed", 3)?)?
            }
        }
        Some("mean") => {
            for densify in on_off(flag(&args, "--densify"), &[true])? {
                mean(
                    number(flag(&args, "--k"), "--k", 10)?,
                    densify,
                    args.iter().any(|a| a == "--last"),
                )?
            }
        }
        _ => {
            eprint!("{USAGE}");
            if args.is_empty() || args[0] == "help" {
                return Ok(());
            }
            bail!("unknown mode {:?}", args[0]);
        }
    }
    eprintln!("total {:.0} s", started.elapsed().as_secs_f64());
    Ok(())
}
