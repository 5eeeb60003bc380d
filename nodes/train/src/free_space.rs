//! Free space: what a training view sees at some depth was not in front of it.
//!
//! A measured point that a view sees (`point_depth.rs` keeps, per view, the
//! points on the component's own pixels that no other point hides) proves the
//! ray from the camera to it empty. A face that covers such a point's pixel
//! clearly nearer than the point hangs in that empty space: the camera saw
//! through it. Faces seen through more often than they are seen on — more of
//! the points they cover lie behind them than on them — are floaters or sheets
//! (a wall-coloured triangle in front of the table), which the photometric loss
//! alone leaves wherever no view shows them against a different colour. Counting
//! on-surface points too keeps a true surface behind a stray outlier point.
//!
//! A sighting counts only where, in that view, some face of the model lies on the
//! point: the camera saw through the face *to a surface the model has*. Where the
//! model has none there, the point is an outlier or the surface is still missing,
//! and removing the face in front opens a hole nothing refills. Scanner-like points
//! lie on every surface, so this changes little there; structure from motion's lie
//! where features matched, none on a plain wall, and without it the rule removed
//! whole walls around outliers (docs/benchmarks.md, "Structure from motion").

use crate::screen::projected_faces;
use objectsplat_core::Camera;
use objectsplat_raster::Model;
use objectsplat_raster::parallel::run_iter_pooled;

/// How far in front of a point a face must lie to be seen through: the larger
/// of this (metres, times the scene's world scale) and [`RELATIVE_MARGIN`] of
/// the point's depth, so point noise and a slanted surface's depth range do not count.
pub const ABSOLUTE_MARGIN: f64 = 0.05;
pub const RELATIVE_MARGIN: f64 = 0.03;

/// Per face: the points seen through it and the points on it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Sightings {
    pub through: u32,
    pub on: u32,
}

impl Sightings {
    /// Seen through at least `min_through` times (≥ 1) and more often than seen on.
    pub fn floats(&self, min_through: u32) -> bool {
        self.through >= min_through.max(1) && self.through > self.on
    }
}

/// One worker's share of [`sightings`]: `on` counts per face, and the
/// (view, pixel) lists that decide `through` once every view is done.
struct Partial {
    on: Vec<u32>,
    backed: Vec<(u32, u32)>,
    through: Vec<(u32, u32, u32)>,
    scratch: Vec<Option<crate::screen::Projected>>,
}

/// The sightings of every face of `model` over `views`: each a camera and its
/// kept points (pixel index in the frame, camera depth), sorted by pixel. The
/// views are shared among `threads` workers; counts and sorted lists make the
/// result independent of which worker saw which view.
pub fn sightings(
    model: &Model<f32>,
    views: &[(&Camera, &[(u32, f32)])],
    world_scale: f64,
    threads: usize,
) -> Vec<Sightings> {
    let faces = model.face_count();
    let mut partials = Vec::new();
    run_iter_pooled(
        threads,
        views.iter().enumerate().filter(|(_, v)| !v.1.is_empty()),
        &mut partials,
        || Partial {
            on: vec![0; faces],
            backed: Vec::new(),
            through: Vec::new(),
            scratch: Vec::new(),
        },
        |partial, (view, &(camera, points))| see(model, view, camera, points, world_scale, partial),
    );
    let mut out = vec![Sightings::default(); faces];
    // (view, pixel) of every point some face lies on, and the candidate
    // see-through sightings, kept until the first list is complete.
    let mut backed: Vec<(u32, u32)> = Vec::new();
    let mut through: Vec<(u32, u32, u32)> = Vec::new();
    for p in partials {
        for (o, on) in out.iter_mut().zip(p.on) {
            o.on += on;
        }
        backed.extend(p.backed);
        through.extend(p.through);
    }
    backed.sort_unstable();
    backed.dedup();
    for (view, pixel, f) in through {
        if backed.binary_search(&(view, pixel)).is_ok() {
            out[f as usize].through += 1;
        }
    }
    out
}

/// The sightings of one view into `partial`.
fn see(
    model: &Model<f32>,
    view: usize,
    camera: &Camera,
    points: &[(u32, f32)],
    world_scale: f64,
    partial: &mut Partial,
) {
    let width = camera.width as usize;
    let Partial {
        on,
        backed,
        through,
        scratch,
    } = partial;
    for (f, [a, b, c]) in projected_faces(model, camera, scratch) {
        let area = (b.0 - a.0) * (c.1 - a.1) - (c.0 - a.0) * (b.1 - a.1);
        if area.abs() < 1e-12 {
            continue;
        }
        // Pixel centres at (x + ½, y + ½) inside the projected triangle.
        let x0 = (a.0.min(b.0).min(c.0) - 0.5).ceil().max(0.0);
        let x1 = (a.0.max(b.0).max(c.0) - 0.5)
            .floor()
            .min(camera.width as f64 - 1.0);
        let y0 = (a.1.min(b.1).min(c.1) - 0.5).ceil().max(0.0);
        let y1 = (a.1.max(b.1).max(c.1) - 0.5)
            .floor()
            .min(camera.height as f64 - 1.0);
        if x0 > x1 || y0 > y1 {
            continue;
        }
        for y in y0 as usize..=y1 as usize {
            let row_start = (y * width + x0 as usize) as u32;
            let row_end = (y * width + x1 as usize) as u32;
            let first = points.partition_point(|&(p, _)| p < row_start);
            for &(pixel, depth) in points[first..].iter().take_while(|&&(p, _)| p <= row_end) {
                let (px, py) = ((pixel as usize % width) as f64 + 0.5, y as f64 + 0.5);
                // Screen-space barycentrics; depth interpolates as 1/z.
                let wa = ((b.0 - px) * (c.1 - py) - (c.0 - px) * (b.1 - py)) / area;
                let wb = ((c.0 - px) * (a.1 - py) - (a.0 - px) * (c.1 - py)) / area;
                let wc = 1.0 - wa - wb;
                if wa < 0.0 || wb < 0.0 || wc < 0.0 {
                    continue;
                }
                let face_depth = 1.0 / (wa / a.2 + wb / b.2 + wc / c.2);
                let depth = depth as f64;
                let margin = (ABSOLUTE_MARGIN * world_scale).max(RELATIVE_MARGIN * depth);
                if face_depth < depth - margin {
                    through.push((view as u32, pixel, f as u32));
                } else if face_depth <= depth + margin {
                    on[f] += 1;
                    backed.push((view as u32, pixel));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    fn camera() -> Camera {
        Camera::look_at(
            64,
            64,
            64.0,
            64.0,
            DVec3::new(0.0, 0.0, 4.0),
            DVec3::ZERO,
            DVec3::Y,
        )
    }

    /// Two triangles facing the camera, each covering the image's centre: one at
    /// z = 0 (4 m away), one at z = 2 (2 m away).
    fn model() -> Model<f32> {
        let mut m = Model::<f32>::empty();
        m.vertices = vec![
            [-3.0, -3.0, 0.0],
            [3.0, -3.0, 0.0],
            [0.0, 3.0, 0.0],
            [-1.0, -1.0, 2.0],
            [1.0, -1.0, 2.0],
            [0.0, 1.0, 2.0],
        ];
        m.faces = vec![[0, 1, 2], [3, 4, 5]];
        m
    }

    #[test]
    fn a_face_in_front_of_what_a_view_saw_is_seen_through() {
        let cam = camera();
        let m = model();
        // Points on the far face (depth 4) at pixels inside both faces' projections.
        let points: Vec<(u32, f32)> = [(30u32, 30u32), (32, 32), (33, 31)]
            .iter()
            .map(|&(x, y)| (y * 64 + x, 4.0))
            .collect();
        let s = sightings(&m, &[(&cam, &points)], 1.0, 1);
        assert_eq!(s[0], Sightings { through: 0, on: 3 });
        assert_eq!(s[1], Sightings { through: 3, on: 0 });
        assert!(!s[0].floats(2) && s[1].floats(2) && !s[1].floats(4));
        // Points at the near face's depth: both faces are fine (the far one is behind).
        let near: Vec<(u32, f32)> = points.iter().map(|&(p, _)| (p, 2.0)).collect();
        let s = sightings(&m, &[(&cam, &near)], 1.0, 1);
        assert_eq!(s[1], Sightings { through: 0, on: 3 });
        assert_eq!(s[0], Sightings { through: 0, on: 0 });
    }

    #[test]
    fn a_point_outside_the_projection_or_within_the_margin_does_not_count() {
        let cam = camera();
        let m = model();
        // (2, 2) lies outside both faces; the centre point 4 cm behind the near face.
        let points = vec![(2 * 64 + 2, 4.0f32), (32 * 64 + 32, 2.04)];
        let s = sightings(&m, &[(&cam, &points)], 1.0, 1);
        assert_eq!(s[1], Sightings { through: 0, on: 1 });
        assert_eq!(s[0].through + s[0].on, 0);
    }

    #[test]
    fn a_point_behind_a_face_counts_only_where_the_model_has_a_surface_on_it() {
        let cam = camera();
        let mut m = model();
        // Without the far face, the far points lie on nothing the model has: an outlier,
        // or a surface still missing. The near face stays.
        m.faces = vec![[3, 4, 5]];
        let points: Vec<(u32, f32)> = [(30u32, 30u32), (32, 32), (33, 31)]
            .iter()
            .map(|&(x, y)| (y * 64 + x, 4.0))
            .collect();
        let s = sightings(&m, &[(&cam, &points)], 1.0, 1);
        assert_eq!(s[0], Sightings { through: 0, on: 0 });
    }

    #[test]
    fn sightings_do_not_depend_on_the_thread_count() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(5);
        let mut m = Model::<f32>::empty();
        m.vertices = (0..900)
            .map(|_| {
                [
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-1.0..1.5),
                ]
            })
            .collect();
        m.faces = (0..600)
            .map(|_| {
                let a = rng.random_range(0..900u32);
                [a, (a + 1) % 900, (a + 2) % 900]
            })
            .collect();
        let cameras: Vec<Camera> = (0..6)
            .map(|k| {
                let eye = DVec3::new(k as f64 * 0.4 - 1.0, 0.3, 4.0);
                Camera::look_at(64, 64, 64.0, 64.0, eye, DVec3::ZERO, DVec3::Y)
            })
            .collect();
        // Measured points at random depths around the model, sorted by pixel.
        let points: Vec<Vec<(u32, f32)>> = cameras
            .iter()
            .map(|_| {
                let mut p: Vec<(u32, f32)> = (0..64 * 64)
                    .step_by(3)
                    .map(|px| (px as u32, rng.random_range(2.5..5.5)))
                    .collect();
                p.sort_by_key(|&(px, _)| px);
                p
            })
            .collect();
        let views: Vec<(&Camera, &[(u32, f32)])> = cameras
            .iter()
            .zip(&points)
            .map(|(c, p)| (c, p.as_slice()))
            .collect();
        let one = sightings(&m, &views, 1.0, 1);
        assert!(one.iter().any(|s| s.through > 0) && one.iter().any(|s| s.on > 0));
        for threads in [2, 3, 8] {
            assert_eq!(sightings(&m, &views, 1.0, threads), one);
        }
    }
}
