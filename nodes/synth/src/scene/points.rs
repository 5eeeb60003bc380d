//! SfM-like sparse points: area-weighted surface samples that at least two cameras see,
//! displaced by Gaussian noise, coloured like the renders.

use super::SyntheticParams;
use super::layout::{Room, to_u8};
use super::render::Depth;
use anyhow::{Result, bail};
use glam::DVec3;
use objectsplat_core::{Camera, Points};
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_pcg::Pcg64;

/// Cameras that must see a sample for it to become a point (like a triangulated track).
const MIN_VIEWS: usize = 2;

pub fn sample_points(
    room: &Room,
    cameras: &[Camera],
    views: &[(Camera, Depth)],
    params: &SyntheticParams,
    texture_seed: u64,
) -> Result<Points> {
    let b = &room.builder;
    let vertex = |i: u32| {
        let p = b.positions[i as usize];
        DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
    };
    // Cumulative face areas for area-weighted face choice.
    let mut cumulative = Vec::with_capacity(b.faces.len());
    let mut total = 0.0;
    for f in &b.faces {
        let [a, bb, c] = f.map(vertex);
        total += 0.5 * (bb - a).cross(c - a).length();
        cumulative.push(total);
    }
    let mut rng = Pcg64::seed_from_u64(params.seed ^ 0x5EED_5EED_5EED_5EED);
    // Validated by SyntheticParams::validate: finite and non-negative.
    let noise =
        Normal::new(0.0, params.points_noise).map_err(|e| anyhow::anyhow!("points_noise: {e}"))?;
    let mut points = Points::default();
    let max_attempts = params.points.saturating_mul(200).max(20_000);
    let mut attempts = 0;
    while points.positions.len() < params.points {
        attempts += 1;
        if attempts > max_attempts {
            bail!(
                "only {} of {} points are seen by {MIN_VIEWS} cameras after {max_attempts} samples; use more views",
                points.positions.len(),
                params.points
            );
        }
        let r = rng.random_range(0.0..total);
        let face = cumulative
            .partition_point(|&c| c <= r)
            .min(b.faces.len() - 1);
        let (mut s, mut t): (f64, f64) = (rng.random(), rng.random());
        if s + t > 1.0 {
            (s, t) = (1.0 - s, 1.0 - t);
        }
        let [a, bb, c] = b.faces[face].map(vertex);
        let p = a + (bb - a) * s + (c - a) * t;
        let seen = views
            .iter()
            .filter(|(cam, raster)| visible(cam, raster, p))
            .count();
        if seen < MIN_VIEWS {
            continue;
        }
        let color = room.surface_color(face, p, texture_seed).map(to_u8);
        let offset = DVec3::new(
            noise.sample(&mut rng),
            noise.sample(&mut rng),
            noise.sample(&mut rng),
        );
        let q = p + offset;
        points.positions.push([q.x as f32, q.y as f32, q.z as f32]);
        points.colors.push(color);
    }
    debug_assert_eq!(views.len(), cameras.len());
    Ok(points)
}

/// Whether `p` is the visible surface at its pixel in this view (depth within tolerance).
fn visible(camera: &Camera, raster: &Depth, p: DVec3) -> bool {
    let Some((u, v, z)) = camera.project(p) else {
        return false;
    };
    if u < 0.0 || v < 0.0 || u >= camera.width as f64 || v >= camera.height as f64 {
        return false;
    }
    match raster.depth_at(u as u32, v as u32) {
        Some(d) => (d as f64 - z).abs() <= 0.01 + 0.01 * z,
        None => false,
    }
}
