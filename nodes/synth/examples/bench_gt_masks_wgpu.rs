//! gt_masks time per frame: the CPU rasterizer against the wgpu one (on Mesa lavapipe
//! when there is no GPU), on the synthetic scene at its default resolution (160×120)
//! and at 1752×1168 (the ScanNet++ DSLR size). Both produce the final masks (pixel
//! threshold included) and the example checks that they are identical.
//! Usage: cargo run --release -p objectsplat-synth --example bench_gt_masks_wgpu -- [THREADS] [FRAMES] [auto|gpu|lavapipe]

mod common;

use anyhow::{Result, bail};
use objectsplat_gpu::{AdapterChoice, GpuContext};
use objectsplat_masks::gpu_raster::IdRasterizer;
use objectsplat_masks::gt_masks::{drop_small_objects, face_mask_values, frame_mask};
use objectsplat_synth::{SyntheticParams, scene};
use std::time::Instant;

fn main() -> Result<()> {
    let threads: usize = common::arg_or(0, "THREADS", 2)?;
    let frames: usize = common::arg_or(1, "FRAMES", 24)?;
    let choice = match std::env::args().nth(3).as_deref().unwrap_or("auto") {
        "auto" => AdapterChoice::Auto,
        "gpu" => AdapterChoice::Gpu,
        "lavapipe" => AdapterChoice::Lavapipe,
        other => bail!("adapter {other:?} is not one of auto, gpu, lavapipe"),
    };
    let scene = scene::generate(&SyntheticParams {
        views: frames.max(1),
        points: 10,
        threads,
        ..Default::default()
    })?;
    let params = common::mask_params(threads);
    let values = face_mask_values(&scene.mesh, &scene.labels, &params)?;

    let start = Instant::now();
    let (gpu, why) = GpuContext::shared(choice)?;
    let device_ms = start.elapsed().as_secs_f64() * 1e3;
    let start = Instant::now();
    let rasterizer = IdRasterizer::new(&gpu)?;
    let pipeline_ms = start.elapsed().as_secs_f64() * 1e3;
    println!(
        "mesh {} faces, {} frames, CPU threads {threads}; wgpu adapter {:?} ({why}): device {device_ms:.0} ms, pipeline {pipeline_ms:.0} ms (once per run)",
        scene.mesh.faces.len(),
        scene.frames.len(),
        gpu.adapter_info.name
    );
    println!(
        "{:>11} {:>12} {:>13} {:>8} {:>10}",
        "size", "cpu ms/frame", "wgpu ms/frame", "cpu/wgpu", "identical"
    );
    let base = scene.cameras();
    let (w0, h0) = (base[0].width, base[0].height);
    for (width, height) in [(w0, h0), (1752, 1168)] {
        let cameras: Vec<_> = base.iter().map(|c| c.scaled(width, height)).collect();
        let cpu_mask = |i: usize| {
            frame_mask(&scene.mesh, &values, &cameras[i], &params).map_err(anyhow::Error::msg)
        };
        let wgpu_mask = |i: usize| -> Result<_> {
            let c = &cameras[i];
            let ids = rasterizer.rasterize_ids(
                &scene.mesh.positions,
                &scene.mesh.faces,
                &values,
                c,
                0.01,
            )?;
            Ok(drop_small_objects(c.width, c.height, ids, &params))
        };
        // One warm-up frame each (page faults, allocator, driver caches).
        cpu_mask(0)?;
        wgpu_mask(0)?;
        let start = Instant::now();
        let cpu: Vec<_> = (0..cameras.len()).map(cpu_mask).collect::<Result<_>>()?;
        let cpu_ms = start.elapsed().as_secs_f64() * 1e3 / cameras.len() as f64;
        let start = Instant::now();
        let dev: Vec<_> = (0..cameras.len()).map(wgpu_mask).collect::<Result<_>>()?;
        let wgpu_ms = start.elapsed().as_secs_f64() * 1e3 / cameras.len() as f64;
        println!(
            "{:>11} {cpu_ms:>12.2} {wgpu_ms:>13.2} {:>8.2} {:>10}",
            format!("{width}×{height}"),
            cpu_ms / wgpu_ms,
            cpu == dev
        );
    }
    Ok(())
}
