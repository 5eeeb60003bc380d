//! Export throughput: a scene of `OBJECTS` grid meshes (2·(N−1)² triangles each) written as
//! one `.glb` and as per-component PLYs, plus a report with test views. Prints the median of
//! `RUNS` runs per stage. Usage:
//!   cargo run --release -p objectsplat-report --example bench_export -- OUT_DIR [N] [OBJECTS]
//! OUT_DIR keeps the last files so a peer (e.g. trimesh) can be timed on the same data.

use anyhow::{Context, Result};
use objectsplat_core::Image;
use objectsplat_core::artifact::SCENE_GLB;
use objectsplat_export::ply::write_component_plys;
use objectsplat_export::{ExportObject, SrgbColors, write_glb};
use objectsplat_report::{ReportData, ViewTriplet, render_report};
use std::path::PathBuf;
use std::time::Instant;

const RUNS: usize = 5;

fn grid(id: u16, n: u32) -> ExportObject {
    let mut positions = Vec::with_capacity((n * n) as usize);
    let mut colors = Vec::with_capacity((n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            let (x, y) = (i as f32 / n as f32, j as f32 / n as f32);
            positions.push([
                x + id as f32 * 1.5,
                y,
                0.1 * (6.0 * x).sin() * (4.0 * y).cos(),
            ]);
            colors.push([
                (i * 255 / n) as u8,
                (j * 255 / n) as u8,
                (id as u32 * 40 % 256) as u8,
            ]);
        }
    }
    let mut faces = Vec::with_capacity(2 * ((n - 1) * (n - 1)) as usize);
    for j in 0..n - 1 {
        for i in 0..n - 1 {
            let v = j * n + i;
            faces.push([v, v + 1, v + n]);
            faces.push([v + 1, v + n + 1, v + n]);
        }
    }
    ExportObject::object(
        id,
        &format!("part {id}"),
        positions,
        faces,
        SrgbColors::U8(colors),
    )
}

fn median_seconds(mut f: impl FnMut() -> Result<()>) -> Result<f64> {
    let mut times = Vec::with_capacity(RUNS);
    for _ in 0..RUNS {
        let start = Instant::now();
        f()?;
        times.push(start.elapsed().as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    Ok(times[RUNS / 2])
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let out = PathBuf::from(
        args.get(1)
            .context("usage: bench_export OUT_DIR [N] [OBJECTS]")?,
    );
    let n: u32 = args
        .get(2)
        .map_or(Ok(500), |s| s.parse())
        .context("N must be an integer")?;
    let objects: u16 = args
        .get(3)
        .map_or(Ok(4), |s| s.parse())
        .context("OBJECTS must be an integer")?;
    anyhow::ensure!(n >= 2, "N must be at least 2");
    std::fs::create_dir_all(&out)?;
    let scene: Vec<ExportObject> = (1..=objects).map(|id| grid(id, n)).collect();
    let triangles: usize = scene.iter().map(|o| o.faces.len()).sum();

    let glb = out.join(SCENE_GLB);
    let t_glb = median_seconds(|| write_glb(&glb, &scene, None).map(|_| ()))?;
    let t_ply = median_seconds(|| write_component_plys(&out.join("ply"), &scene).map(|_| ()))?;

    // Report: 8 test views at the ScanNet++ undistorted DSLR size.
    let views_dir = out.join("views");
    std::fs::create_dir_all(&views_dir)?;
    let mut views = Vec::new();
    for k in 0..8u32 {
        let gt = Image::from_fn(1752, 1168, 3, |x, y, c| {
            ((x + 2 * y + 50 * c + k) % 256) as f32 / 255.0
        });
        let render = Image::from_fn(1752, 1168, 3, |x, y, c| {
            ((x + 2 * y + 50 * c + k + (x / 97) % 5) % 256) as f32 / 255.0
        });
        let (gt_path, render_path) = (
            views_dir.join(format!("gt{k}.png")),
            views_dir.join(format!("r{k}.png")),
        );
        gt.save_png8(&gt_path)?;
        render.save_png8(&render_path)?;
        views.push(ViewTriplet {
            name: format!("view{k}"),
            ground_truth: gt_path,
            render: render_path,
        });
    }
    let data = ReportData {
        title: "bench".into(),
        views,
        ..Default::default()
    };
    let t_report = median_seconds(|| render_report(&out.join("report"), &data).map(|_| ()))?;

    let glb_mb = std::fs::metadata(&glb)?.len() as f64 / 1e6;
    println!("objects={objects} grid={n}x{n} triangles={triangles}");
    println!(
        "write_glb: {t_glb:.4} s median of {RUNS} ({:.1} M tri/s, {glb_mb:.1} MB)",
        triangles as f64 / t_glb / 1e6
    );
    println!("write_component_plys: {t_ply:.4} s median of {RUNS}");
    println!("render_report (8 views 1752x1168): {t_report:.4} s median of {RUNS}");
    Ok(())
}
