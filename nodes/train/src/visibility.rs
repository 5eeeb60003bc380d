//! Which sparse points a camera sees: a point is hidden when another point
//! lies clearly in front of it on screen.
//!
//! Sparse points have gaps between them, so each point is splatted into a
//! depth buffer with a radius of about the points' neighbour spacing on
//! screen; a point more than two spacings behind that buffer at its own pixel
//! is hidden. Without this test a floor point seen past a table from across
//! the room counted as the table's (see `ComponentMasks::select_points`).

use glam::DVec3;
use objectsplat_core::Camera;
use std::collections::HashMap;

/// Splat radii on screen are clamped to this many pixels.
const MAX_SPLAT_PX: f64 = 8.0;

/// The median distance from a point to its nearest neighbour (0 for fewer than two points).
pub fn neighbour_spacing(points: &[DVec3]) -> f64 {
    if points.len() < 2 {
        return 0.0;
    }
    let (lo, hi) = points.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    // Cells holding about two points each if the points covered the box's surface.
    let extent = (hi - lo).max_element().max(1e-12);
    let cell = (extent / (points.len() as f64 / 2.0).sqrt()).max(1e-12);
    let key = |p: DVec3| {
        let c = ((p - lo) / cell).floor();
        (c.x as i64, c.y as i64, c.z as i64)
    };
    let mut grid: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
    for (i, p) in points.iter().enumerate() {
        grid.entry(key(*p)).or_default().push(i);
    }
    let mut nearest: Vec<f64> = points
        .iter()
        .enumerate()
        .filter_map(|(i, p)| {
            let (cx, cy, cz) = key(*p);
            // The 3×3×3 block finds the nearest neighbour when it lies within one
            // cell; farther neighbours are rare and only overestimate the spacing.
            let mut best = f64::INFINITY;
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        if let Some(cell) = grid.get(&(cx + dx, cy + dy, cz + dz)) {
                            for &j in cell.iter().filter(|&&j| j != i) {
                                best = best.min(p.distance(points[j]));
                            }
                        }
                    }
                }
            }
            best.is_finite().then_some(best)
        })
        .collect();
    if nearest.is_empty() {
        return cell;
    }
    let mid = nearest.len() / 2;
    *nearest.select_nth_unstable_by(mid, f64::total_cmp).1
}

/// Per point: its pixel (index in the full frame) and camera depth when
/// `camera` sees it (in front, inside the image, not hidden by the others).
pub fn visible_pixels(points: &[DVec3], spacing: f64, camera: &Camera) -> Vec<Option<(u32, f64)>> {
    let (w, h) = (camera.width as i64, camera.height as i64);
    let projected: Vec<Option<(f64, f64, f64)>> = points
        .iter()
        .map(|&p| {
            camera.project(p).filter(|&(x, y, z)| {
                z > 0.0 && x >= 0.0 && y >= 0.0 && x < w as f64 && y < h as f64
            })
        })
        .collect();
    let mut nearest = vec![f64::INFINITY; (w * h) as usize];
    for &(x, y, z) in projected.iter().flatten() {
        let r = (spacing * camera.fx / z).clamp(0.5, MAX_SPLAT_PX);
        let (x0, x1) = (
            ((x - r).floor() as i64).max(0),
            ((x + r).ceil() as i64).min(w - 1),
        );
        let (y0, y1) = (
            ((y - r).floor() as i64).max(0),
            ((y + r).ceil() as i64).min(h - 1),
        );
        for py in y0..=y1 {
            for px in x0..=x1 {
                let cell = &mut nearest[(py * w + px) as usize];
                *cell = cell.min(z);
            }
        }
    }
    projected
        .into_iter()
        .map(|p| {
            let (x, y, z) = p?;
            let pixel = (y as i64 * w + x as i64) as usize;
            (z <= nearest[pixel] + 2.0 * spacing).then_some((pixel as u32, z))
        })
        .collect()
}
