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
use objectsplat_core::component::{OTHER, OWN};
use objectsplat_core::visibility::{neighbour_spacing, visible_pixels};
use objectsplat_raster::RenderOutput;
use std::collections::HashMap;

/// Pixels covered less than this carry no depth loss (their depth is mostly
/// the background's absence, not a surface's).
const MIN_COVERAGE: f32 = 0.5;

/// The measured points each view of a component sees.
#[derive(Debug, Default)]
pub struct PointDepth {
    /// Per view: (pixel index in the full frame, the point's camera depth).
    views: Vec<Vec<(u32, f32)>>,
}

impl PointDepth {
    /// The visible points of every view of `data` on its own pixels (none when
    /// `points` is empty).
    pub fn new(points: &[[f32; 3]], data: &ComponentData) -> Self {
        Self::on_label(points, data, OWN)
    }

    /// The points of every view of `data` that lie on pixels another component
    /// owns (label OTHER): `points` are those components' (see
    /// `ComponentData::partition_points`), used by the free-space rule only.
    pub fn on_other_components(points: &[[f32; 3]], data: &ComponentData) -> Self {
        Self::on_label(points, data, OTHER)
    }

    fn on_label(points: &[[f32; 3]], data: &ComponentData, label: u8) -> Self {
        let points: Vec<DVec3> = points
            .iter()
            .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
            .filter(|p| p.is_finite())
            .collect();
        let spacing = neighbour_spacing(&points);
        let views = data
            .views
            .iter()
            .map(|view| visible_points(&points, spacing, view, label))
            .collect();
        PointDepth { views }
    }

    /// Points kept in view `view`.
    pub fn count(&self, view: usize) -> usize {
        self.views.get(view).map_or(0, Vec::len)
    }

    /// The points kept in view `view`: (pixel index in the frame, camera
    /// depth), one per pixel, in pixel order.
    pub fn of_view(&self, view: usize) -> &[(u32, f32)] {
        self.views.get(view).map_or(&[], Vec::as_slice)
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
        // The region index of each point inside the render's region (no allocation:
        // this runs on every training step).
        let inside = points.iter().filter_map(|&(pixel, d)| {
            let (x, y) = (pixel % out.width, pixel / out.width);
            region.contains(x, y).then(|| {
                let i =
                    (y - region.y0) as usize * region.width() as usize + (x - region.x0) as usize;
                (i, d)
            })
        });
        let count = inside.clone().count();
        if count == 0 {
            return 0.0;
        }
        let scale = weight / count as f64;
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

/// The points of `points` that `view` sees on its pixels labelled `label`:
/// (pixel, depth), the nearest one per pixel.
fn visible_points(
    points: &[DVec3],
    spacing: f64,
    view: &crate::supervision::View,
    label: u8,
) -> Vec<(u32, f32)> {
    let mut kept: HashMap<u32, f32> = HashMap::new();
    for (pixel, z) in visible_pixels(points, spacing, &view.camera)
        .into_iter()
        .flatten()
    {
        if view.label(pixel as usize) != label {
            continue;
        }
        let d = kept.entry(pixel).or_insert(z as f32);
        *d = d.min(z as f32);
    }
    let mut kept: Vec<(u32, f32)> = kept.into_iter().collect();
    kept.sort_unstable_by_key(|&(p, _)| p);
    kept
}
