//! Forward+backward iterations per second, wgpu backend against the CPU
//! backend (2 threads), same scenes, same run.
//!
//! `cargo run --release -p objectsplat-raster-gpu --example wgpu_bench` runs 320×240 with
//! 2k and 20k faces and 1752×1168 with 100k; `-- --case FACES WIDTH HEIGHT`
//! runs one case (e.g. `--case 1000000 1752 1168` on a real GPU);
//! `--no-cpu` skips the CPU side. Prints one Markdown table row per case.
//!
//! `--train` measures whole training iterations instead (render, L1 + D-SSIM
//! loss, backward, Adam): on the device with [`DeviceTrainer`], wgpu with the
//! loss and Adam on the host (the image and every gradient cross each
//! iteration), and the CPU backend. It then measures device steps on a small
//! object (about a tenth of a 320×240 frame, every other pixel supervised
//! toward the background colour) rendering the whole frame and only the
//! footprint (`Region::Footprint`); `--object` runs that table alone.

use objectsplat_core::Camera;
use objectsplat_core::glam::DVec3;
use objectsplat_gpu::{AdapterChoice, GpuContext};
use objectsplat_optim::{LearningRates, Optim};
use objectsplat_raster::backend::{PixelRect, Region};
use objectsplat_raster::loss::{CROP_MARGIN, DEFAULT_LAMBDA_DSSIM, Dims, photometric};
use objectsplat_raster::{
    CpuBackend, Model, OutputGrads, RenderBackend, RenderSettings, SH_COEFFS,
};
use objectsplat_raster_gpu::WgpuBackend;
use objectsplat_raster_gpu::training::{DepthWeights, DeviceTrainer, Step, Trained, TrainingView};
use std::time::{Duration, Instant};

/// A xorshift64 generator of uniform numbers in [0, 1): scenes without files.
fn uniform_from(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// Adds a triangle whose corners lie within `spread` (per axis) around `centre`,
/// with random SH coefficients and opacity.
fn push_random_triangle(
    m: &mut Model<f32>,
    uniform: &mut impl FnMut() -> f64,
    centre: [f64; 3],
    spread: f64,
) {
    let base = m.vertices.len() as u32;
    for _ in 0..3 {
        m.vertices
            .push([0, 1, 2].map(|a| (centre[a] + (uniform() - 0.5) * spread) as f32));
        let mut rows = [[0f32; 3]; SH_COEFFS];
        for row in rows.iter_mut() {
            *row = [0, 1, 2].map(|_| (uniform() * 0.4 - 0.2) as f32);
        }
        m.sh.push(rows);
        m.opacity_logits.push((uniform() * 4.0 - 1.0) as f32);
    }
    m.faces.push([base, base + 1, base + 2]);
}

/// A deterministic soup of `count` triangles with depth complexity ≈ 6,
/// each at least ~40 px² so the inradius cull keeps most of them.
fn soup(count: usize, width: u32, height: u32) -> Model<f32> {
    let mut uniform = uniform_from(0x1234_5678_9abc_def0);
    let mut m = Model::<f32>::empty();
    m.sh_degree = 3;
    let area_px = (6.0 * width as f64 * height as f64 / count as f64).max(40.0);
    let size = 1.2 * area_px.sqrt() / (width as f64 / 4.0);
    for _ in 0..count {
        let c = [
            uniform() * 2.4 - 1.2,
            uniform() * 1.8 - 0.9,
            uniform() * 2.0 - 1.0,
        ];
        push_random_triangle(&mut m, &mut uniform, c, 2.0 * size);
    }
    m
}

/// The camera every case looks through: 4 units back, focal length = image width.
fn bench_camera(w: u32, h: u32) -> Camera {
    let eye = DVec3::new(0.0, 0.0, -4.0);
    Camera::look_at(w, h, w as f64, w as f64, eye, DVec3::ZERO, DVec3::Y)
}

/// Iterations per second of forward + backward, running for at least `budget`.
fn iterations_per_second(
    backend: &dyn RenderBackend<f32>,
    model: &Model<f32>,
    camera: &Camera,
    background: &[f32],
    grad: &[f32],
    budget: Duration,
) -> anyhow::Result<f64> {
    let settings = RenderSettings::for_model(model);
    let forward_time = std::cell::Cell::new(Duration::ZERO);
    let step = || -> anyhow::Result<()> {
        let t = Instant::now();
        let (_, saved) = backend.forward(model, camera, &settings, background)?;
        forward_time.set(forward_time.get() + t.elapsed());
        backend.backward(model, &saved, &OutputGrads::color_only(grad))?;
        Ok(())
    };
    step()?; // warm-up (pipeline compilation, allocations)
    forward_time.set(Duration::ZERO);
    let start = Instant::now();
    let mut n = 0u32;
    while n < 2 || start.elapsed() < budget {
        step()?;
        n += 1;
    }
    let total = start.elapsed().as_secs_f64();
    eprintln!(
        "  {}: {:.1} ms/iteration, forward {:.1} ms",
        backend.name(),
        1e3 * total / n as f64,
        1e3 * forward_time.get().as_secs_f64() / n as f64
    );
    Ok(n as f64 / total)
}

const RATES: LearningRates = LearningRates {
    positions: 1e-4,
    sh_dc: 1e-3,
    sh_rest: 5e-5,
    opacity: 1e-2,
};

/// Runs `step` for at least `budget` after one warm-up call; returns calls per second.
fn rate(budget: Duration, mut step: impl FnMut() -> anyhow::Result<()>) -> anyhow::Result<f64> {
    step()?;
    let start = Instant::now();
    let mut n = 0u32;
    while n < 2 || start.elapsed() < budget {
        step()?;
        n += 1;
    }
    Ok(n as f64 / start.elapsed().as_secs_f64())
}

/// Adam on the host, as the trainer runs it when iterations do not stay on a device.
fn host_adam(values: &mut [f32], grads: &[f32], m: &mut [f32], v: &mut [f32], lr: f64, t: i32) {
    let adam = objectsplat_optim::Adam::new();
    let (bc1, bc2) = (1.0 - adam.beta1.powi(t), 1.0 - adam.beta2.powi(t));
    for i in 0..values.len() {
        let g = grads[i] as f64;
        let mn = adam.beta1 * m[i] as f64 + (1.0 - adam.beta1) * g;
        let vn = adam.beta2 * v[i] as f64 + (1.0 - adam.beta2) * g * g;
        m[i] = mn as f32;
        v[i] = vn as f32;
        values[i] = (values[i] as f64 - lr * (mn / bc1) / ((vn / bc2).sqrt() + adam.eps)) as f32;
    }
}

/// Training iterations per second with the loss and Adam on the host.
fn host_training_rate(
    backend: &dyn RenderBackend<f32>,
    model: &Model<f32>,
    camera: &Camera,
    target: &[f32],
    budget: Duration,
) -> anyhow::Result<f64> {
    let mut model = model.clone();
    let pixels = (camera.width * camera.height) as usize;
    let background = vec![0.3f32; pixels * 3];
    let settings = RenderSettings::for_model(&model);
    let nv = model.vertex_count();
    let mut moments = [nv * 3, nv * 3 * SH_COEFFS, nv].map(|n| (vec![0f32; n], vec![0f32; n]));
    let mut t = 0;
    rate(budget, || {
        let (out, saved) = backend.forward(&model, camera, &settings, &background)?;
        let loss = photometric(
            Dims::rgb(camera.width, camera.height),
            &out.color,
            target,
            None,
            DEFAULT_LAMBDA_DSSIM,
        )?;
        let g = backend.backward(&model, &saved, &OutputGrads::color_only(&loss.grad))?;
        t += 1;
        let mut positions: Vec<f32> = model.vertices.concat();
        let mut sh: Vec<f32> = model.sh.iter().flatten().flatten().copied().collect();
        let [(m0, v0), (m1, v1), (m2, v2)] = &mut moments;
        host_adam(
            &mut positions,
            &g.vertices.concat(),
            m0,
            v0,
            RATES.positions,
            t,
        );
        let sh_grad: Vec<f32> = g.sh.iter().flatten().flatten().copied().collect();
        host_adam(&mut sh, &sh_grad, m1, v1, RATES.sh_dc, t);
        host_adam(
            &mut model.opacity_logits,
            &g.opacity_logits,
            m2,
            v2,
            RATES.opacity,
            t,
        );
        for (v, p) in model.vertices.iter_mut().zip(positions.chunks_exact(3)) {
            v.copy_from_slice(p);
        }
        for (row, values) in model.sh.iter_mut().zip(sh.chunks_exact(3 * SH_COEFFS)) {
            for (c, rgb) in row.iter_mut().zip(values.chunks_exact(3)) {
                c.copy_from_slice(rgb);
            }
        }
        Ok(())
    })
}

/// Training iterations per second on the device.
fn device_training_rate(
    gpu: &WgpuBackend,
    model: &Model<f32>,
    camera: &Camera,
    target: &[f32],
    budget: Duration,
) -> anyhow::Result<f64> {
    let pixels = (camera.width * camera.height) as usize;
    let view = TrainingView::photometric(
        *camera,
        target.to_vec(),
        vec![1.0; pixels],
        vec![false; pixels],
    );
    device_view_rate(gpu, model, view, Region::Full, budget)
}

/// Device training iterations per second on one view, rendering `region`.
fn device_view_rate(
    gpu: &WgpuBackend,
    model: &Model<f32>,
    view: TrainingView,
    region: Region,
    budget: Duration,
) -> anyhow::Result<f64> {
    let mut trainer = DeviceTrainer::new(gpu, &[view])?;
    let optim = Optim::new(RATES, model.vertex_count())?;
    trainer.load(model, Trained::all_of(model), Some(&optim))?;
    let step = Step {
        view: 0,
        background: [0.3; 3],
        render: RenderSettings {
            region,
            ..RenderSettings::for_model(model)
        },
        learning_rates: RATES,
        lambda_dssim: DEFAULT_LAMBDA_DSSIM,
        sh_degree: model.sh_degree,
        depth: DepthWeights::default(),
    };
    let mut steps = 0;
    let r = rate(budget, || {
        trainer.step(&step)?;
        steps += 1;
        // The trainer collects losses every ~iterations/200 steps; 10 is more often than that.
        if steps % 10 == 0 {
            trainer.results()?;
        }
        Ok(())
    })?;
    // Queued work must finish inside the measurement: the last results wait for it.
    trainer.results()?;
    Ok(r)
}

/// A small object: `count` faces in a cube of side 0.8 at the origin (about
/// 80 px across at 320×240, a tenth of the frame), and its view: its own
/// pixels (the central 80×80 box) keep a target, every other pixel is
/// supervised toward the background colour.
fn small_object(count: usize, w: u32, h: u32) -> (Model<f32>, TrainingView) {
    let mut uniform = uniform_from(0x0bad_5eed_1234_5678);
    let mut m = Model::<f32>::empty();
    m.sh_degree = 3;
    for _ in 0..count {
        let c = [0, 1, 2].map(|_| uniform() * 0.8 - 0.4);
        push_random_triangle(&mut m, &mut uniform, c, 0.16);
    }
    let own = |x: u32, y: u32| x.abs_diff(w / 2) < 40 && y.abs_diff(h / 2) < 40;
    let pixels = (w * h) as usize;
    let mut view = TrainingView::photometric(
        bench_camera(w, h),
        vec![0.0; pixels * 3],
        vec![1.0; pixels],
        vec![true; pixels],
    );
    for p in 0..pixels {
        let (x, y) = (p as u32 % w, p as u32 / w);
        if own(x, y) {
            view.from_background[p] = false;
            for c in 0..3 {
                view.target[3 * p + c] = ((p * 3 + c) % 17) as f32 / 17.0;
            }
        }
    }
    (m, view)
}

/// Device steps on a small object: whole frame against its footprint.
fn object_table(gpu: &WgpuBackend, cpu: &CpuBackend) -> anyhow::Result<()> {
    println!(
        "| object faces | image | rendered share (footprint) | device, whole frame (it/s) | device, footprint (it/s) | footprint / whole frame |"
    );
    println!("|---|---|---|---|---|---|");
    let (w, h) = (320, 240);
    for faces in [2_000, 20_000] {
        let (model, view) = small_object(faces, w, h);
        // The share of the frame a footprint render covers, as the CPU backend computes it.
        let include = view
            .from_background
            .iter()
            .enumerate()
            .filter(|(_, b)| !**b)
            .fold(PixelRect::default(), |r, (p, _)| {
                let (x, y) = (p as u32 % w, p as u32 / w);
                r.union(PixelRect {
                    x0: x,
                    y0: y,
                    x1: x + 1,
                    y1: y + 1,
                })
            });
        let footprint = Region::Footprint {
            include,
            margin: CROP_MARGIN,
        };
        let settings = RenderSettings {
            region: footprint,
            ..RenderSettings::for_model(&model)
        };
        let background = vec![0.3f32; (w * h * 3) as usize];
        let (out, _) = cpu.forward(&model, &view.camera, &settings, &background)?;
        let share = out.region.pixels() as f64 / (w * h) as f64;
        let budget = Duration::from_secs(5);
        let whole = device_view_rate(gpu, &model, view.clone(), Region::Full, budget)?;
        let cropped = device_view_rate(gpu, &model, view, footprint, budget)?;
        println!(
            "| {faces} | {w}×{h} | {:.0} % | {whole:.2} | {cropped:.2} | {:.2}× |",
            100.0 * share,
            cropped / whole
        );
    }
    Ok(())
}

fn training_table(
    gpu: &WgpuBackend,
    cpu: &CpuBackend,
    cases: &[(usize, u32, u32)],
    with_cpu: bool,
) -> anyhow::Result<()> {
    println!(
        "| faces | image | wgpu, device loss + Adam (it/s) | wgpu, host loss + Adam (it/s) | cpu(2) (it/s) | device / host | device / cpu |"
    );
    println!("|---|---|---|---|---|---|---|");
    for &(faces, w, h) in cases {
        let model = soup(faces, w, h);
        let camera = bench_camera(w, h);
        let target: Vec<f32> = (0..(w * h * 3) as usize)
            .map(|i| (i % 17) as f32 / 17.0)
            .collect();
        let budget = Duration::from_secs(5);
        let device = device_training_rate(gpu, &model, &camera, &target, budget)?;
        let host = host_training_rate(gpu, &model, &camera, &target, budget)?;
        let (c, ratio) = if with_cpu {
            let c = host_training_rate(cpu, &model, &camera, &target, budget)?;
            (format!("{c:.2}"), format!("{:.2}×", device / c))
        } else {
            ("–".into(), "–".into())
        };
        println!(
            "| {faces} | {w}×{h} | {device:.2} | {host:.2} | {c} | {:.2}× | {ratio} |",
            device / host
        );
    }
    Ok(())
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let with_cpu = !args.iter().any(|a| a == "--no-cpu");
    let cases: Vec<(usize, u32, u32)> = match args.iter().position(|a| a == "--case") {
        Some(i) => {
            let num = |k: usize| -> anyhow::Result<u64> {
                args.get(i + k)
                    .ok_or_else(|| anyhow::anyhow!("--case needs FACES WIDTH HEIGHT"))?
                    .parse::<u64>()
                    .map_err(|e| anyhow::anyhow!("--case argument {k}: {e}"))
            };
            vec![(num(1)? as usize, num(2)? as u32, num(3)? as u32)]
        }
        None => vec![(2_000, 320, 240), (20_000, 320, 240), (100_000, 1752, 1168)],
    };
    let (ctx, why) = GpuContext::shared(AdapterChoice::Auto)?;
    println!("{why}; float atomics: {}", ctx.float_atomics);
    let gpu = WgpuBackend::new(ctx)?;
    let cpu = CpuBackend::new(2);
    if args.iter().any(|a| a == "--object") {
        return object_table(&gpu, &cpu);
    }
    if args.iter().any(|a| a == "--train") {
        training_table(&gpu, &cpu, &cases, with_cpu)?;
        println!();
        return object_table(&gpu, &cpu);
    }
    println!("| faces | image | wgpu it/s | cpu(2) it/s | wgpu / cpu |");
    println!("|---|---|---|---|---|");
    for (faces, w, h) in cases {
        let model = soup(faces, w, h);
        let camera = bench_camera(w, h);
        let pixels = (w * h) as usize;
        let background = vec![0.3f32; pixels * 3];
        let grad: Vec<f32> = (0..pixels * 3)
            .map(|i| ((i % 13) as f32 - 6.0) / 13.0)
            .collect();
        let budget = Duration::from_secs(5);
        let g = iterations_per_second(&gpu, &model, &camera, &background, &grad, budget)?;
        let (c, ratio) = if with_cpu {
            let c = iterations_per_second(&cpu, &model, &camera, &background, &grad, budget)?;
            (format!("{c:.2}"), format!("{:.2}×", g / c))
        } else {
            ("–".into(), "–".into())
        };
        println!("| {faces} | {w}×{h} | {g:.2} | {c} | {ratio} |");
    }
    Ok(())
}
