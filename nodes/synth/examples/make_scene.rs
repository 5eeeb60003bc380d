//! Writes the synthetic scene and its GT masks into a folder, to look at them.
//! Usage: cargo run --release -p objectsplat-synth --example make_scene -- OUT [WIDTH HEIGHT VIEWS]

use anyhow::{Context, Result};
use objectsplat_masks::{GtMaskParams, gt_masks};
use objectsplat_synth::{SyntheticParams, scene};
use std::path::PathBuf;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let out = PathBuf::from(
        args.first()
            .context("usage: make_scene OUT [WIDTH HEIGHT VIEWS]")?,
    );
    let mut params = SyntheticParams::default();
    if args.len() >= 4 {
        params.width = args[1].parse().context("WIDTH")?;
        params.height = args[2].parse().context("HEIGHT")?;
        params.views = args[3].parse().context("VIEWS")?;
    }
    let start = std::time::Instant::now();
    let s = scene::generate(&params)?;
    println!(
        "generated in {:.2} s: {} faces, {} points",
        start.elapsed().as_secs_f64(),
        s.mesh.faces.len(),
        s.points.positions.len()
    );
    s.write(&out.join("frames"), &out.join("mesh"), &out.join("points"))?;
    let masks = gt_masks(&s.mesh, &s.labels, &s.cameras(), &GtMaskParams::default())?;
    let dir = out.join("masks");
    std::fs::create_dir_all(&dir)?;
    for (f, m) in s.frames.iter().zip(&masks.masks) {
        m.save(&dir.join(format!("{}.png", f.name)))?;
    }
    objectsplat_core::masks::write_objects(&dir, &masks.labels)?;
    println!("objects in masks: {:?}", masks.labels);
    Ok(())
}
