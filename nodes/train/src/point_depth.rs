//! Depth supervision from the component's measured points (the SfM or scanner
//! points it was initialized from).
//!
//! The photometric loss alone leaves the depth of a surface free wherever
//! moving it changes no pixel's colour: weakly textured walls seen only from
//! across the room slide toward the cameras, where each triangle covers more
//! pixels and holes between triangles (which the randomized background
//! punishes) close. On the synthetic room the background's walls came out as a
//! cylinder inside the square room and the floor as a bowl, although the
//! initial points lay within 1 cm of the surfaces. The measured points are the
//! one geometric signal that does not depend on texture, so each training view
//! keeps the points it sees and the loss asks the rendered surface to pass
//! through them.
//!
//! Per view, a point is kept when it projects onto one of the component's own
//! pixels (an object in front makes the pixel another component's) and no other
//! point lies clearly in front of it there: every point is splatted into a
//! depth buffer with a radius of about its neighbour spacing on screen, and a
//! point more than two spacings behind that buffer is hidden. With `D` the
//! rendered expected depth `Σ w_n z_n` and `α` the coverage `Σ w_n` at the
//! point's pixel, the loss is `λ · mean |D/α − d| / d` over the kept points
//! whose pixel is at least half covered (`d` the point's depth): the depth
//! error of whatever covers the pixel, relative to the distance. Normalizing
//! by the coverage matters: `|D − α·d| = α·|z − d|` for one surface at depth
//! `z`, which a surface at the wrong depth lowers by turning transparent
//! (small objects faded away) instead of moving.

use crate::supervision::ComponentData;
use glam::DVec3;
use objectsplat_core::component::OWN;
use objectsplat_raster::RenderOutput;
use std::collections::HashMap;

/// Pixels covered less than this carry no depth loss (their depth is mostly
/// the background's absence, not a surface's).
const MIN_COVERAGE: f32 = 0.5;

/// Splat radii on screen are clamped to this many pixels.
const MAX_SPLAT_PX: f64 = 8.0;

/// The measured points each view of a component sees.
#[derive(Debug, Default)]
pub struct PointDepth {
    /// Per view: (pixel index in the full frame, the point's camera depth).
    views: Vec<Vec<(u32, f32)>>,
}

impl PointDepth {
    /// The visible points of every view of `data` (none when `points` is empty).
    pub fn new(points: &[[f32; 3]], data: &ComponentData) -> Self {
        let points: Vec<DVec3> = points
            .iter()
            .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
            .filter(|p| p.is_finite())
            .collect();
        let spacing = neighbour_spacing(&points);
        let views = data
            .views
            .iter()
            .map(|view| visible_points(&points, spacing, view))
            .collect();
        PointDepth { views }
    }

    /// Points kept in view `view`.
    pub fn count(&self, view: usize) -> usize {
        self.views.get(view).map_or(0, Vec::len)
    }

    /// Adds `weight · mean |D/α − d| / d` over view `view`'s points inside the
    /// render's region (at least half covered) to the depth and alpha gradients
    /// (region-sized) and returns that loss (0 when the view keeps no point there).
    pub fn add_gradient(
        &self,
        view: usize,
        out: &RenderOutput<f32>,
        weight: f64,
        d_depth: &mut [f32],
        d_alpha: &mut [f32],
    ) -> f64 {
        let Some(points) = self.views.get(view) else {
            return 0.0;
        };
        let region = out.region;
        let width = out.width;
        let inside: Vec<(usize, f32)> = points
            .iter()
            .filter_map(|&(pixel, d)| {
                let (x, y) = (pixel % width, pixel / width);
                region.contains(x, y).then(|| {
                    let i = (y - region.y0) as usize * region.width() as usize
                        + (x - region.x0) as usize;
                    (i, d)
                })
            })
            .collect();
        if inside.is_empty() {
            return 0.0;
        }
        let scale = weight / inside.len() as f64;
        let mut loss = 0.0;
        for (i, d) in inside {
            let alpha = out.alpha[i];
            if alpha < MIN_COVERAGE {
                continue;
            }
            // e = D/α − d: the depth of what covers the pixel, whatever its coverage.
            let depth = out.depth[i] / alpha;
            let error = depth - d;
            loss += (error.abs() / d) as f64;
            let sign = if error > 0.0 {
                1.0
            } else if error < 0.0 {
                -1.0
            } else {
                0.0
            };
            // d|e|/dD = sign/α, d|e|/dα = −sign·D/α²; both divided by d.
            let g = scale * sign / (d as f64 * alpha as f64);
            d_depth[i] += g as f32;
            d_alpha[i] -= (g * depth as f64) as f32;
        }
        scale * loss
    }
}

/// The median distance from a point to its nearest neighbour (0 for fewer than two points).
fn neighbour_spacing(points: &[DVec3]) -> f64 {
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

/// The points of `points` that `view` sees on its component's own pixels.
fn visible_points(
    points: &[DVec3],
    spacing: f64,
    view: &crate::supervision::View,
) -> Vec<(u32, f32)> {
    let camera = &view.camera;
    let (w, h) = (camera.width as i64, camera.height as i64);
    let projected: Vec<(f64, f64, f64)> = points
        .iter()
        .filter_map(|&p| camera.project(p))
        .filter(|&(x, y, z)| z > 0.0 && x >= 0.0 && y >= 0.0 && x < w as f64 && y < h as f64)
        .collect();
    let mut nearest = vec![f64::INFINITY; (w * h) as usize];
    for &(x, y, z) in &projected {
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
    let mut kept: HashMap<u32, f32> = HashMap::new();
    for &(x, y, z) in &projected {
        let pixel = (y as i64 * w + x as i64) as usize;
        if view.labels[pixel] != OWN || z > nearest[pixel] + 2.0 * spacing {
            continue;
        }
        // One point per pixel: the nearest.
        let d = kept.entry(pixel as u32).or_insert(z as f32);
        *d = d.min(z as f32);
    }
    let mut kept: Vec<(u32, f32)> = kept.into_iter().collect();
    kept.sort_unstable_by_key(|&(p, _)| p);
    kept
}
