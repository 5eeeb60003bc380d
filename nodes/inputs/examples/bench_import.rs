//! Mask-import throughput, end to end (decode, overlap resolution, 16-bit PNG output).
//!
//!     python benches/make_bench_data.py /tmp/bench 20 20
//!     cargo run --release -p objectsplat-inputs --example bench_import -- /tmp/bench 20 20
//!
//! Prints masks/s per format; "masks" counts what the source stores: one per frame for
//! the exclusive formats (davis, grounded_sam2), one per object per frame otherwise.

use objectsplat_inputs::masks_import::{self, MaskFormat, OverlapPolicy};
use std::path::PathBuf;
use std::time::Instant;

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let (Some(root), Some(frames), Some(objects)) = (args.get(1), args.get(2), args.get(3)) else {
        anyhow::bail!("usage: bench_import <data dir> <frames> <objects>");
    };
    let root = PathBuf::from(root);
    let (frames, objects): (usize, usize) = (frames.parse()?, objects.parse()?);
    for (dir, format, policy, masks) in [
        ("davis", MaskFormat::Davis, OverlapPolicy::LowerId, frames),
        (
            "sav",
            MaskFormat::PerObjectPng,
            OverlapPolicy::LowerId,
            frames * objects,
        ),
        (
            "coco_rle",
            MaskFormat::CocoRle,
            OverlapPolicy::HigherScore,
            frames * objects,
        ),
        (
            "gsam",
            MaskFormat::GroundedSam2,
            OverlapPolicy::LowerId,
            frames,
        ),
    ] {
        let out = tempfile::tempdir()?;
        let t = Instant::now();
        let s = masks_import::import(
            &root.join(dir),
            format,
            policy,
            &root.join("frames"),
            out.path(),
            |_, _| {},
        )?;
        let dt = t.elapsed().as_secs_f64();
        println!(
            "ours {dir} ({format:?}, {policy:?}): {masks} masks in {dt:.3} s = {:.1} masks/s ({} objects)",
            masks as f64 / dt,
            s.objects.len()
        );
    }
    Ok(())
}
