//! gt_masks throughput against mesh size at 1752×1168 (the ScanNet++ DSLR size).
//!
//! The synthetic room is refined by splitting every triangle into k² (k = 1, 2, 4, 13:
//! about 6k, 24k, 94k and 1M faces), then masks are computed for the orbit cameras.
//! Usage: cargo run --release -p objectsplat-synth --example bench_gt_masks -- [THREADS] [FRAMES] [EXPORT_DIR]
//! With EXPORT_DIR, also writes there each refined mesh (`mesh_k<k>.ply`), its per-face
//! mask values (`face_values_k<k>.bin`, u16 little-endian), the cameras (`frames.json`)
//! and our mask of the first camera (`mask_k<k>.png`, no pixel threshold), for
//! `embree_peer.py` to time and cross-check against Embree ray casting.

mod common;

use anyhow::Result;
use objectsplat_core::{Frame, Frames, Mesh, Split};
use objectsplat_masks::GtMaskParams;
use objectsplat_masks::gt_masks::{face_mask_values, frame_mask};
use objectsplat_synth::{SyntheticParams, scene};
use std::time::Instant;

/// Splits every triangle into k² by a barycentric grid (object ids carried over).
fn refine(mesh: &Mesh, k: u32) -> Mesh {
    let ids = mesh.object_ids.as_ref();
    let mut out = Mesh {
        object_ids: ids.map(|_| Vec::new()),
        ..Mesh::default()
    };
    for (f, face) in mesh.faces.iter().enumerate() {
        let [a, b, c] = face.map(|v| mesh.positions[v as usize]);
        let base = out.positions.len() as u32;
        // Row j of the barycentric grid holds k + 1 − j vertices.
        let mut row_start = Vec::with_capacity(k as usize + 1);
        let mut n = base;
        for j in 0..=k {
            row_start.push(n);
            for i in 0..=(k - j) {
                let (s, t) = (i as f32 / k as f32, j as f32 / k as f32);
                out.positions.push(std::array::from_fn(|d| {
                    a[d] + (b[d] - a[d]) * s + (c[d] - a[d]) * t
                }));
                if let (Some(src), Some(dst)) = (ids, out.object_ids.as_mut()) {
                    dst.push(src[mesh.faces[f][0] as usize]);
                }
                n += 1;
            }
        }
        let at = |i: u32, j: u32| row_start[j as usize] + i;
        for j in 0..k {
            for i in 0..(k - j) {
                out.faces.push([at(i, j), at(i + 1, j), at(i, j + 1)]);
                if i + 1 < k - j {
                    out.faces
                        .push([at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
                }
            }
        }
    }
    out
}

/// CPU seconds (user + system, all threads) this process has used, from /proc/self/stat;
/// on a shared, oversubscribed machine it shows the work done where wall time cannot.
fn cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the parenthesised command name; utime and stime are the 14th and 15th.
    let rest = &stat[stat.rfind(')')? + 2..];
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0) // USER_HZ is 100 on Linux
}

fn main() -> Result<()> {
    let threads: usize = common::arg_or(0, "THREADS", 2)?;
    let frames: usize = common::arg_or(1, "FRAMES", 6)?;
    let export = std::env::args().nth(3).map(std::path::PathBuf::from);
    let base = scene::generate(&SyntheticParams {
        views: frames.max(2),
        points: 10,
        width: 64,
        height: 48,
        ..Default::default()
    })?;
    let cameras: Vec<_> = base
        .cameras()
        .iter()
        .map(|c| c.scaled(1752, 1168))
        .collect();
    let params = common::mask_params(threads);
    println!(
        "threads {threads}, {} frames of 1752×1168 per mesh",
        cameras.len()
    );
    println!(
        "{:>9} {:>10} {:>10} {:>12} {:>10}",
        "faces", "ms/frame", "cpu ms/fr", "frames/s", "Mfaces/s"
    );
    if let Some(dir) = &export {
        std::fs::create_dir_all(dir)?;
        let list: Vec<Frame> = cameras
            .iter()
            .enumerate()
            .map(|(i, c)| Frame::new(format!("frame_{i:03}"), "none.png", c, Split::Train))
            .collect();
        Frames::write_json(dir, &list)?;
    }
    for k in [1, 2, 4, 13] {
        let mesh = refine(&base.mesh, k);
        let values = face_mask_values(&mesh, &base.labels, &params)?;
        if let Some(dir) = &export {
            mesh.write_ply(&dir.join(format!("mesh_k{k}.ply")))?;
            let raw: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
            std::fs::write(dir.join(format!("face_values_k{k}.bin")), raw)?;
            let every_object = GtMaskParams {
                min_pixels: Some(0),
                ..params.clone()
            };
            let mask = frame_mask(&mesh, &values, &cameras[0], &every_object)
                .map_err(anyhow::Error::msg)?;
            mask.save(&dir.join(format!("mask_k{k}.png")))?;
        }
        // One warm-up frame (page faults, allocator), then the timed frames.
        frame_mask(&mesh, &values, &cameras[0], &params).map_err(anyhow::Error::msg)?;
        let (start, cpu_start) = (Instant::now(), cpu_seconds());
        for camera in &cameras {
            frame_mask(&mesh, &values, camera, &params).map_err(anyhow::Error::msg)?;
        }
        let per_frame = start.elapsed().as_secs_f64() / cameras.len() as f64;
        let cpu_per_frame = match (cpu_start, cpu_seconds()) {
            (Some(a), Some(b)) => (b - a) / cameras.len() as f64,
            _ => f64::NAN,
        };
        println!(
            "{:>9} {:>10.1} {:>10.1} {:>12.2} {:>10.2}",
            mesh.faces.len(),
            per_frame * 1e3,
            cpu_per_frame * 1e3,
            1.0 / per_frame,
            mesh.faces.len() as f64 / per_frame / 1e6
        );
    }
    Ok(())
}
