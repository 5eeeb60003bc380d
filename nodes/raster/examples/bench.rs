//! Forward/backward timing of the CPU backend against triangle count,
//! resolution and thread count.
//!
//! `cargo run --release -p objectsplat-raster --example bench -- [--quick]`
//! prints one Markdown table row per configuration. The full sweep
//! (10k–1M triangles, 320×240–1752×1168) takes several minutes on 2 cores;
//! `--quick` runs the trainer-sized cases only; `--case N W H` one case.

use objectsplat_core::Camera;
use objectsplat_core::glam::DVec3;
use objectsplat_raster::{
    CpuBackend, Model, OutputGrads, RenderBackend, RenderSettings, SH_COEFFS,
};
use std::time::Instant;

/// A deterministic soup of `count` triangles filling a unit-ish volume. Each
/// triangle covers about `max(6·W·H/count, 40)` px² on screen (depth complexity
/// ≈ 6, but never so small that the 1 px inradius cull removes most of them).
fn soup(count: usize, width: u32, height: u32, seed: u64) -> Model<f32> {
    let mut s = seed;
    let mut next = move || {
        s = s
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut m = Model::<f32>::empty();
    m.sh_degree = 3;
    let area_px = (6.0 * width as f64 * height as f64 / count as f64).max(40.0);
    // The camera below sees about 4 world units across the image width at the soup's depth.
    let size = 1.2 * area_px.sqrt() / (width as f64 / 4.0);
    for _ in 0..count {
        let c = [next() * 2.4 - 1.2, next() * 1.8 - 0.9, next() * 2.0 - 1.0];
        let base = m.vertices.len() as u32;
        for _ in 0..3 {
            m.vertices
                .push([0, 1, 2].map(|a| (c[a] + (next() - 0.5) * 2.0 * size) as f32));
            let mut rows = [[0.0f32; 3]; SH_COEFFS];
            for row in rows.iter_mut() {
                *row = [0, 1, 2].map(|_| (next() * 0.4 - 0.2) as f32);
            }
            m.sh.push(rows);
            m.opacity_logits.push((next() * 4.0 - 1.0) as f32);
        }
        m.faces.push([base, base + 1, base + 2]);
    }
    m
}

/// CPU time consumed by the whole process (all threads), in ms. On a shared,
/// oversubscribed machine this is the honest measure of work; wall time
/// includes waiting for a core.
fn process_cpu_ms() -> f64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec and the clock id is a constant libc knows.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut ts) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_PROCESS_CPUTIME_ID) failed");
    ts.tv_sec as f64 * 1e3 + ts.tv_nsec as f64 * 1e-6
}

struct Timing {
    forward_ms: f64,
    backward_ms: f64,
    forward_cpu_ms: f64,
    backward_cpu_ms: f64,
    fragments: u64,
    visible: usize,
}

fn measure(model: &Model<f32>, camera: &Camera, threads: usize, iters: usize) -> Timing {
    let backend = CpuBackend::new(threads);
    let settings = RenderSettings {
        sigma: 0.5,
        sh_degree: 3,
        ..Default::default()
    };
    let pixels = (camera.width * camera.height) as usize;
    let bg = vec![0.5f32; pixels * 3];
    let grad: Vec<f32> = (0..pixels * 3)
        .map(|i| ((i % 7) as f32 - 3.0) * 0.01)
        .collect();
    let (mut fwd, mut bwd) = (Vec::new(), Vec::new());
    let (mut fwd_cpu, mut bwd_cpu) = (Vec::new(), Vec::new());
    let mut fragments = 0;
    let mut visible = 0;
    for _ in 0..iters {
        let (c0, t0) = (process_cpu_ms(), Instant::now());
        let (out, saved) = backend
            .forward(model, camera, &settings, &bg)
            .expect("bench scene is valid");
        let (c1, t1) = (process_cpu_ms(), Instant::now());
        let g = backend
            .backward(model, &saved, &OutputGrads::color_only(&grad))
            .expect("bench gradients are valid");
        let (c2, t2) = (process_cpu_ms(), Instant::now());
        fwd_cpu.push(c1 - c0);
        bwd_cpu.push(c2 - c1);
        std::hint::black_box(&g);
        fwd.push((t1 - t0).as_secs_f64() * 1e3);
        bwd.push((t2 - t1).as_secs_f64() * 1e3);
        fragments = out.face_pixel_count.iter().map(|&c| c as u64).sum();
        visible = out.face_pixel_count.iter().filter(|&&c| c > 0).count();
    }
    let median = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    Timing {
        forward_ms: median(&mut fwd),
        backward_ms: median(&mut bwd),
        forward_cpu_ms: median(&mut fwd_cpu),
        backward_cpu_ms: median(&mut bwd_cpu),
        fragments,
        visible,
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let single = args.iter().position(|a| a == "--case").map(|i| {
        let num = |j: usize| {
            args.get(i + j)
                .and_then(|v| v.parse::<usize>().ok())
                .expect("--case TRIANGLES WIDTH HEIGHT")
        };
        (num(1), num(2) as u32, num(3) as u32)
    });
    let cases: Vec<(usize, u32, u32)> = if let Some(case) = single {
        vec![case]
    } else if quick {
        vec![(2_000, 160, 120), (20_000, 160, 120), (10_000, 320, 240)]
    } else {
        vec![
            (2_000, 160, 120),
            (20_000, 160, 120),
            (10_000, 320, 240),
            (100_000, 320, 240),
            (1_000_000, 320, 240),
            (100_000, 876, 584),
            (100_000, 1752, 1168),
            (1_000_000, 1752, 1168),
        ]
    };
    println!(
        "| triangles | resolution | threads | visible faces | fragments | forward wall ms | backward wall ms | forward CPU ms | backward CPU ms | fwd Mfrag/s per CPU-s | bwd Mfrag/s per CPU-s | 2-thread wall speed-up (fwd+bwd) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for (count, w, h) in cases {
        let model = soup(count, w, h, 42);
        let camera = Camera::look_at(
            w,
            h,
            w as f64 * 0.8,
            w as f64 * 0.8,
            DVec3::new(0.0, 0.0, -3.2),
            DVec3::ZERO,
            DVec3::Y,
        );
        let iters = if count * (w as usize) < 200_000_000 {
            7
        } else {
            3
        };
        let one = measure(&model, &camera, 1, iters);
        let two = measure(&model, &camera, 2, iters);
        for (threads, t) in [(1, &one), (2, &two)] {
            let per_cpu_second = |ms: f64| t.fragments as f64 / (ms * 1e-3) / 1e6;
            let speedup = if threads == 2 {
                format!(
                    "{:.2}×",
                    (one.forward_ms + one.backward_ms) / (two.forward_ms + two.backward_ms)
                )
            } else {
                "—".into()
            };
            println!(
                "| {count} | {w}×{h} | {threads} | {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.1} | {:.1} | {speedup} |",
                t.visible,
                t.fragments,
                t.forward_ms,
                t.backward_ms,
                t.forward_cpu_ms,
                t.backward_cpu_ms,
                per_cpu_second(t.forward_cpu_ms),
                per_cpu_second(t.backward_cpu_ms)
            );
        }
    }
}
