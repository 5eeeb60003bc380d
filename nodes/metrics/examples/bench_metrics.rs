//! Evaluation throughput: SSIM megapixels per second and F-score points per second.
//!
//! Usage: `bench_metrics <dir> [lpips.safetensors]` where `<dir>` holds `reference.png`, `distorted.png`,
//! `gt.f64` and `pred.f64` (raw little-endian f64 N×3), as `benches/compare_peers.py`
//! writes them. With a weights file, LPIPS is timed on a 512×512 crop too.
//! Prints one JSON object with the timings (best of the repeats).

use anyhow::{Context, Result, bail};
use objectsplat_core::Image;
use objectsplat_metrics::{Lpips, SsimMode, fscore, ssim, voxel_downsample};
use std::path::Path;
use std::time::Instant;

fn read_points(path: &Path) -> Result<Vec<[f64; 3]>> {
    let bytes = std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
    if bytes.len() % 24 != 0 {
        bail!(
            "{}: length {} is not a multiple of 24 (N×3 f64)",
            path.display(),
            bytes.len()
        );
    }
    Ok(bytes
        .chunks_exact(24)
        .map(|c| {
            std::array::from_fn(|k| {
                f64::from_le_bytes(c[k * 8..k * 8 + 8].try_into().unwrap_or([0; 8]))
            })
        })
        .collect())
}

/// Process CPU seconds (user + system) from /proc/self/stat; robust to other load on the machine.
fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the parenthesised command name; utime and stime are fields 14 and 15.
    let rest = stat.rsplit_once(')').map(|(_, r)| r).unwrap_or("");
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks = |i: usize| {
        fields
            .get(i)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(f64::NAN)
    };
    (ticks(11) + ticks(12)) / 100.0
}

/// Best wall-clock and best CPU seconds over the repeats, and the last value.
fn best_of<T>(repeats: usize, mut f: impl FnMut() -> Result<T>) -> Result<(f64, f64, T)> {
    let (mut wall, mut cpu) = (f64::INFINITY, f64::INFINITY);
    let mut last = None;
    for _ in 0..repeats {
        let (t, c) = (Instant::now(), cpu_seconds());
        let v = f()?;
        wall = wall.min(t.elapsed().as_secs_f64());
        cpu = cpu.min(cpu_seconds() - c);
        last = Some(v);
    }
    Ok((wall, cpu, last.context("no repeat ran")?))
}

fn main() -> Result<()> {
    let dir = std::env::args()
        .nth(1)
        .context("usage: bench_metrics <dir>")?;
    let dir = Path::new(&dir);
    let a = Image::load(&dir.join("reference.png"))?;
    let b = Image::load(&dir.join("distorted.png"))?;
    let gt = read_points(&dir.join("gt.f64"))?;
    let pred = read_points(&dir.join("pred.f64"))?;
    let megapixels = a.pixel_count() as f64 / 1e6;
    let (t_cropped, c_cropped, v_cropped) = best_of(5, || ssim(&a, &b, SsimMode::Cropped, None))?;
    let (t_gs3d, c_gs3d, _) = best_of(5, || ssim(&a, &b, SsimMode::Gs3d, None))?;
    let (t_fscore, c_fscore, f) = best_of(3, || fscore(&pred, &gt, 0.05))?;
    let (t_voxel, _, _) = best_of(3, || voxel_downsample(&gt, 0.02))?;
    let lpips = match std::env::args().nth(2) {
        Some(path) => {
            let net = Lpips::load(Path::new(&path))?;
            let side = 512.min(a.width).min(a.height);
            let crop = |img: &Image| Image::from_fn(side, side, 3, |x, y, c| img.get(x, y, c));
            let (ca, cb) = (crop(&a), crop(&b));
            let (t, _, v) = best_of(2, || net.distance(&ca, &cb))?;
            serde_json::json!({"side": side, "seconds": t, "value": v.total})
        }
        None => serde_json::Value::Null,
    };
    let out = serde_json::json!({
        "lpips": lpips,
        "threads": rayon::current_num_threads(),
        "megapixels": megapixels,
        "ssim_cropped_s": t_cropped,
        "ssim_cropped_value": v_cropped,
        "ssim_cropped_mp_per_s": megapixels / t_cropped,
        "ssim_cropped_cpu_s": c_cropped,
        "ssim_gs3d_mp_per_s": megapixels / t_gs3d,
        "ssim_gs3d_cpu_s": c_gs3d,
        "fscore_points": gt.len() + pred.len(),
        "fscore_s": t_fscore,
        "fscore_cpu_s": c_fscore,
        "fscore_value": f.fscore,
        "fscore_points_per_s": (gt.len() + pred.len()) as f64 / t_fscore,
        "voxel_points_per_s": gt.len() as f64 / t_voxel,
    });
    println!("{out}");
    Ok(())
}
