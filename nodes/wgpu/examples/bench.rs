//! Forward+backward iterations per second, wgpu backend against the CPU
//! backend (2 threads), same scenes, same run.
//!
//! `cargo run --release -p objectsplat-wgpu --example bench` runs 320×240 with
//! 2k and 20k faces and 1752×1168 with 100k; `-- --case FACES WIDTH HEIGHT`
//! runs one case (e.g. `--case 1000000 1752 1168` on a real GPU);
//! `--no-cpu` skips the CPU side. Prints one Markdown table row per case.

use objectsplat_core::Camera;
use objectsplat_core::glam::DVec3;
use objectsplat_raster::{
    CpuBackend, Model, OutputGrads, RenderBackend, RenderSettings, SH_COEFFS,
};
use objectsplat_wgpu::{AdapterChoice, GpuContext, WgpuBackend};
use std::time::{Duration, Instant};

/// A deterministic soup of `count` triangles with depth complexity ≈ 6,
/// each at least ~40 px² so the inradius cull keeps most of them.
fn soup(count: usize, width: u32, height: u32) -> Model<f32> {
    let mut state = 0x1234_5678_9abc_def0u64;
    let mut uniform = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64
    };
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
        let base = m.vertices.len() as u32;
        for _ in 0..3 {
            m.vertices
                .push([0, 1, 2].map(|a| (c[a] + (uniform() - 0.5) * 2.0 * size) as f32));
            let mut rows = [[0f32; 3]; SH_COEFFS];
            for row in rows.iter_mut() {
                *row = [0, 1, 2].map(|_| (uniform() * 0.4 - 0.2) as f32);
            }
            m.sh.push(rows);
            m.opacity_logits.push((uniform() * 4.0 - 1.0) as f32);
        }
        m.faces.push([base, base + 1, base + 2]);
    }
    m
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
    println!("| faces | image | wgpu it/s | cpu(2) it/s | wgpu / cpu |");
    println!("|---|---|---|---|---|");
    for (faces, w, h) in cases {
        let model = soup(faces, w, h);
        let camera = Camera::look_at(
            w,
            h,
            w as f64,
            w as f64,
            DVec3::new(0.0, 0.0, -4.0),
            DVec3::ZERO,
            DVec3::Y,
        );
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
