//! Times `inpaint` on one image and mask; used by benches/compare_opencv.py, which
//! times `cv2.inpaint` on the same files in the same run.
//!
//! Usage: bench_inpaint IMAGE.png MASK.png ns|telea RADIUS THREADS REPEATS
//! Prints one JSON object: {"median_s", "min_s", "min_thread_cpu_s", "filled",
//! "checksum"} (thread CPU time is meaningful for THREADS = 1 only).

use anyhow::{Context, Result, bail};
use objectsplat_completion::inpaint::{Method, Options, Raster, inpaint};
use std::time::Instant;

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [image, mask, method, radius, threads, repeats] = args.as_slice() else {
        bail!("usage: bench_inpaint IMAGE.png MASK.png ns|telea RADIUS THREADS REPEATS");
    };
    let img = image::open(image).with_context(|| format!("{image}: cannot read"))?;
    let (w, h) = (img.width() as usize, img.height() as usize);
    let raster = match img {
        image::DynamicImage::ImageLuma8(b) => Raster::new(w, h, 1, b.into_raw())?,
        other => Raster::new(w, h, 3, other.to_rgb8().into_raw())?,
    };
    let mask = image::open(mask)
        .with_context(|| format!("{mask}: cannot read"))?
        .to_luma8()
        .into_raw();
    let method: Method = method.parse().map_err(anyhow::Error::msg)?;
    let options = Options {
        method,
        radius: radius.parse()?,
        threads: threads.parse()?,
    };
    let repeats: usize = repeats.parse()?;
    let mut times = Vec::with_capacity(repeats);
    let mut cpu_times = Vec::with_capacity(repeats);
    let mut out = None;
    for _ in 0..repeats.max(1) {
        let (start, cpu_start) = (Instant::now(), thread_cpu_seconds());
        out = Some(std::hint::black_box(inpaint(&raster, &mask, &options)?));
        times.push(start.elapsed().as_secs_f64());
        cpu_times.push(thread_cpu_seconds() - cpu_start);
    }
    times.sort_by(f64::total_cmp);
    cpu_times.sort_by(f64::total_cmp);
    let filled = mask.iter().filter(|&&m| m != 0).count();
    // Keep the result alive so the work cannot be optimised away.
    let checksum: u64 = out.map_or(0, |o| o.data.iter().map(|&v| v as u64).sum());
    println!(
        "{{\"median_s\": {}, \"min_s\": {}, \"min_thread_cpu_s\": {}, \"filled\": {filled}, \"checksum\": {checksum}}}",
        times[times.len() / 2],
        times[0],
        cpu_times[0]
    );
    Ok(())
}

/// CPU time of the calling thread (Linux schedstat, nanoseconds), so single-thread
/// runs can be compared on a machine shared with other work; NaN where unavailable.
fn thread_cpu_seconds() -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| {
            s.split_whitespace()
                .next()
                .and_then(|v| v.parse::<u64>().ok())
        })
        .map_or(f64::NAN, |ns| ns as f64 * 1e-9)
}
