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
//!
//! The other components' points count too, on the pixels those components own
//! (`ComponentData::other_points`): where a view's mask shows the chair and the
//! chair's point lies 2 m away, nothing of the background is nearer than that
//! along the ray. Those need no face of the model on them — the mask is the
//! witness that a surface is there, and the model is not meant to have it. They
//! catch the background faces that hang in front of an object where every view
//! that sees them sees them against that object (docs/benchmarks.md, "Free space
//! in front of the other components").

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

/// What one training view saw: (pixel index in the frame, camera depth) of the
/// component's own points on its own pixels and of the other components' points
/// on theirs, each sorted by pixel.
#[derive(Debug, Clone, Copy)]
pub struct Seen<'a> {
    pub camera: &'a Camera,
    pub own: &'a [(u32, f32)],
    pub others: &'a [(u32, f32)],
}

/// One worker's share of [`sightings`]: `on` counts per face, the faces seen
/// through to the other components' points (`witnessed`), and the (view, pixel)
/// lists that decide the rest of `through` once every view is done.
struct Partial {
    on: Vec<u32>,
    witnessed: Vec<u32>,
    backed: Vec<(u32, u32)>,
    through: Vec<(u32, u32, u32)>,
    scratch: Vec<Option<crate::screen::Projected>>,
    own_rows: Vec<usize>,
    other_rows: Vec<usize>,
}

/// The sightings of every face of `model` over `views`. The views are shared
/// among `threads` workers; counts and sorted lists make the result independent
/// of which worker saw which view.
pub fn sightings(
    model: &Model<f32>,
    views: &[Seen<'_>],
    world_scale: f64,
    threads: usize,
) -> Vec<Sightings> {
    let faces = model.face_count();
    let mut partials = Vec::new();
    run_iter_pooled(
        threads,
        views
            .iter()
            .enumerate()
            .filter(|(_, v)| !(v.own.is_empty() && v.others.is_empty())),
        &mut partials,
        || Partial {
            on: vec![0; faces],
            witnessed: vec![0; faces],
            backed: Vec::new(),
            through: Vec::new(),
            scratch: Vec::new(),
            own_rows: Vec::new(),
            other_rows: Vec::new(),
        },
        |partial, (view, seen)| see(model, view, seen, world_scale, partial),
    );
    let mut out = vec![Sightings::default(); faces];
    // (view, pixel) of every point some face lies on, and the candidate
    // see-through sightings, kept until the first list is complete.
    let mut backed: Vec<(u32, u32)> = Vec::new();
    let mut through: Vec<(u32, u32, u32)> = Vec::new();
    for p in partials {
        for ((o, on), witnessed) in out.iter_mut().zip(p.on).zip(p.witnessed) {
            o.on += on;
            o.through += witnessed;
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
fn see(model: &Model<f32>, view: usize, seen: &Seen<'_>, world_scale: f64, partial: &mut Partial) {
    let camera = seen.camera;
    let width = camera.width as usize;
    let Partial {
        on,
        witnessed,
        backed,
        through,
        scratch,
        own_rows,
        other_rows,
    } = partial;
    // Most of a face's rows hold no point: the rows' ranges in the lists
    // skip those without a search.
    row_starts(seen.own, camera, own_rows);
    row_starts(seen.others, camera, other_rows);
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
            let own_row = &seen.own[own_rows[y]..own_rows[y + 1]];
            let others_row = &seen.others[other_rows[y]..other_rows[y + 1]];
            if own_row.is_empty() && others_row.is_empty() {
                continue;
            }
            let row_start = (y * width + x0 as usize) as u32;
            let row_end = (y * width + x1 as usize) as u32;
            let own = in_pixels(own_row, row_start, row_end)
                .iter()
                .map(|&p| (p, false));
            let others = in_pixels(others_row, row_start, row_end)
                .iter()
                .map(|&p| (p, true));
            for ((pixel, depth), other_component) in own.chain(others) {
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
                    if other_component {
                        witnessed[f] += 1;
                    } else {
                        through.push((view as u32, pixel, f as u32));
                    }
                } else if face_depth <= depth + margin {
                    on[f] += 1;
                    backed.push((view as u32, pixel));
                }
            }
        }
    }
}

/// Where each image row's points start in a pixel-sorted list: row `y`'s
/// are `points[starts[y]..starts[y + 1]]`.
fn row_starts(points: &[(u32, f32)], camera: &Camera, starts: &mut Vec<usize>) {
    let width = camera.width as u64;
    starts.clear();
    starts.extend(
        (0..=camera.height as u64)
            .map(|y| points.partition_point(|&(p, _)| (p as u64) < y * width)),
    );
}

/// The points of a pixel-sorted list whose pixel lies in `first..=last`.
fn in_pixels(points: &[(u32, f32)], first: u32, last: u32) -> &[(u32, f32)] {
    let start = points.partition_point(|&(p, _)| p < first);
    let rest = &points[start..];
    &rest[..rest.partition_point(|&(p, _)| p <= last)]
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

    /// Three points at depth 4 inside both faces' projections, sorted by pixel.
    fn far_points() -> Vec<(u32, f32)> {
        [(30u32, 30u32), (33, 31), (32, 32)]
            .iter()
            .map(|&(x, y)| (y * 64 + x, 4.0))
            .collect()
    }

    /// A view of the component's own points only.
    fn own<'a>(camera: &'a Camera, points: &'a [(u32, f32)]) -> Seen<'a> {
        Seen {
            camera,
            own: points,
            others: &[],
        }
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
        let points = far_points();
        let s = sightings(&m, &[own(&cam, &points)], 1.0, 1);
        assert_eq!(s[0], Sightings { through: 0, on: 3 });
        assert_eq!(s[1], Sightings { through: 3, on: 0 });
        assert!(!s[0].floats(2) && s[1].floats(2) && !s[1].floats(4));
        // Points at the near face's depth: both faces are fine (the far one is behind).
        let near: Vec<(u32, f32)> = points.iter().map(|&(p, _)| (p, 2.0)).collect();
        let s = sightings(&m, &[own(&cam, &near)], 1.0, 1);
        assert_eq!(s[1], Sightings { through: 0, on: 3 });
        assert_eq!(s[0], Sightings { through: 0, on: 0 });
    }

    #[test]
    fn a_point_outside_the_projection_or_within_the_margin_does_not_count() {
        let cam = camera();
        let m = model();
        // (2, 2) lies outside both faces; the centre point 4 cm behind the near face.
        let points = vec![(2 * 64 + 2, 4.0f32), (32 * 64 + 32, 2.04)];
        let s = sightings(&m, &[own(&cam, &points)], 1.0, 1);
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
        let points = far_points();
        let s = sightings(&m, &[own(&cam, &points)], 1.0, 1);
        assert_eq!(s[0], Sightings { through: 0, on: 0 });
    }

    #[test]
    fn another_components_point_is_seen_through_without_a_face_on_it() {
        let cam = camera();
        let mut m = model();
        // The model has only the near face; another component's points lie 4 m away
        // on its own pixels (the far face's place): the mask witnesses that surface.
        m.faces = vec![[3, 4, 5]];
        let points = far_points();
        let seen = Seen {
            camera: &cam,
            own: &[],
            others: &points,
        };
        assert_eq!(
            sightings(&m, &[seen], 1.0, 1)[0],
            Sightings { through: 3, on: 0 }
        );
        // In front of the near face they prove nothing about it.
        let near: Vec<(u32, f32)> = points.iter().map(|&(p, _)| (p, 1.5)).collect();
        let seen = Seen {
            others: &near,
            ..seen
        };
        assert_eq!(sightings(&m, &[seen], 1.0, 1)[0], Sightings::default());
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
        // Every other pixel's point is another component's.
        let (own_points, other_points): (Vec<Vec<_>>, Vec<Vec<_>>) = points
            .iter()
            .map(|p| p.iter().partition(|&&(px, _)| px % 2 == 0))
            .unzip();
        let views: Vec<Seen> = cameras
            .iter()
            .zip(own_points.iter().zip(&other_points))
            .map(|(camera, (own, others))| Seen {
                camera,
                own,
                others,
            })
            .collect();
        let one = sightings(&m, &views, 1.0, 1);
        assert!(one.iter().any(|s| s.through > 0) && one.iter().any(|s| s.on > 0));
        for threads in [2, 3, 8] {
            assert_eq!(sightings(&m, &views, 1.0, threads), one);
        }
    }
}
