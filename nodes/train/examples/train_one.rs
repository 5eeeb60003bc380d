//! Trains one component folder and prints where the time went: for profiling.
//! ($MODEL and $RENDERS, below, keep the model and test renders.)
//! Usage: cargo run --release -p objectsplat-train --example train_one -- COMPONENT_DIR POINTS_PLY ITERATIONS [last|best] [threads]

use anyhow::{Context, Result};
use objectsplat_core::Points;
use objectsplat_raster::CpuBackend;
use objectsplat_train::Schedule;
use objectsplat_train::trainer::{Checkpoint, ComponentData, TrainSettings, train_component};
use std::path::PathBuf;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: train_one COMPONENT_DIR POINTS_PLY ITERATIONS [last|best] [threads]";
    let dir = PathBuf::from(args.first().context(usage)?);
    let points = Points::read_ply(&PathBuf::from(args.get(1).context(usage)?))?;
    let iterations: u64 = args.get(2).context(usage)?.parse()?;
    let checkpoint = match args.get(3).map(String::as_str) {
        Some("best") => Checkpoint::Best,
        _ => Checkpoint::Last,
    };
    let threads: usize = args.get(4).map_or(Ok(1), |t| t.parse())?;
    let mut data = ComponentData::read(&dir, threads)?;
    // As the train node's default min_object_points.
    let (owned, others) = data.partition_points(&points, None)?;
    let (points, seeded) = objectsplat_train::hull::initial_points(&data, &points, owned, 300, 0)?;
    data.depth_points = points.positions[..points.positions.len() - seeded].to_vec();
    data.other_points = others;
    // Schedule overrides as a JSON object in $SCHEDULE, e.g. '{"lr_sh_dc": 0.03}'.
    let overrides: serde_json::Map<String, serde_json::Value> = match std::env::var("SCHEDULE") {
        Ok(text) => serde_json::from_str(&text).context("$SCHEDULE is not a JSON object")?,
        Err(_) => Default::default(),
    };
    let settings = TrainSettings {
        checkpoint,
        threads,
        ..TrainSettings::new(Schedule::new(iterations, &overrides)?)
    };
    let start = std::time::Instant::now();
    let report = train_component(
        &CpuBackend::new(threads),
        &data,
        &points,
        &settings,
        |_, _| true,
    )?;
    let secs = start.elapsed().as_secs_f64();
    println!(
        "{}: {} iterations in {secs:.2} s ({:.1} it/s), {} faces, held-out PSNR {:.2} dB",
        data.name,
        report.iterations_run,
        report.iterations_run as f64 / secs,
        report.model.face_count(),
        report.log.final_psnr
    );
    for n in &report.notes {
        println!("  {n}");
    }
    // $MODEL=folder: the trained model, for inspection with other tools.
    if let Ok(out) = std::env::var("MODEL") {
        std::fs::create_dir_all(&out)?;
        objectsplat_raster::save_model(&report.model, &PathBuf::from(out))?;
    }
    // $RENDERS=folder: each test view of the trained model over grey, beside its image.
    if let Ok(out) = std::env::var("RENDERS") {
        std::fs::create_dir_all(&out)?;
        for v in data
            .views
            .iter()
            .filter(|v| v.split == objectsplat_core::Split::Test)
        {
            let img =
                objectsplat_raster::render_model(&report.model, &v.camera, [0.5; 3], threads)?;
            let mut both =
                objectsplat_core::Image::from_fn(2 * img.width, img.height, 3, |x, y, c| {
                    if x < img.width {
                        v.target_at(x, y)[c as usize]
                    } else {
                        img.data[3 * (y * img.width + x - img.width) as usize + c as usize]
                    }
                });
            both.data.iter_mut().for_each(|x| *x = x.clamp(0.0, 1.0));
            both.save_png8(&PathBuf::from(&out).join(format!("{}.png", v.name)))?;
        }
    }
    Ok(())
}
