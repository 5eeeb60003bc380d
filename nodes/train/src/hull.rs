//! Seed points for an object the sparse points barely cover, from the visual
//! hull of its masks.
//!
//! Small objects get a handful of SfM points (the demo's ball 5 of 4000), too
//! few for densification to build a surface from before the connectivity step:
//! the ball came out as a 4-face tetrahedron. The object's masks say where it
//! is in every training view, so the region no mask rules out (its visual hull)
//! bounds it; points on that hull's surface, coloured from the views, start it
//! off as a shape instead of a few shards.

use crate::supervision::ComponentData;
use anyhow::Result;
use glam::DVec3;
use objectsplat_core::ComponentKind;
use objectsplat_core::component::OTHER;
use objectsplat_core::{Points, Split};
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_pcg::Pcg64Mcg;

/// Voxels per axis of each carving pass.
const COARSE: usize = 96;
const FINE: usize = 48;

/// A voxel survives when no training view shows an OTHER pixel at its centre
/// and at least this many training views see it inside the image.
const MIN_VIEWS: usize = 2;

/// Axis-aligned box.
type Bounds = (DVec3, DVec3);

struct Carved {
    bounds: Bounds,
    n: usize,
    kept: Vec<bool>,
}

impl Carved {
    fn cell(&self) -> DVec3 {
        (self.bounds.1 - self.bounds.0) / self.n as f64
    }
    fn center(&self, i: usize, j: usize, k: usize) -> DVec3 {
        self.bounds.0 + self.cell() * DVec3::new(i as f64 + 0.5, j as f64 + 0.5, k as f64 + 0.5)
    }
    fn at(&self, i: usize, j: usize, k: usize) -> bool {
        self.kept[(k * self.n + j) * self.n + i]
    }
}

/// Keeps the voxels of `bounds` that no training view of `data` carves away.
fn carve(data: &ComponentData, bounds: Bounds, n: usize) -> Carved {
    let views: Vec<_> = data
        .views
        .iter()
        .filter(|v| v.split == Split::Train)
        .collect();
    let mut carved = Carved {
        bounds,
        n,
        kept: vec![false; n * n * n],
    };
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = carved.center(i, j, k);
                let mut seen = 0;
                let mut inside = true;
                for v in &views {
                    let cam = &v.camera;
                    let Some((u, w, _)) = cam.project(p) else {
                        continue;
                    };
                    if !(u >= 0.0 && w >= 0.0 && u < cam.width as f64 && w < cam.height as f64) {
                        continue;
                    }
                    seen += 1;
                    if v.labels.get(u as u32, w as u32) == OTHER {
                        inside = false;
                        break;
                    }
                }
                carved.kept[(k * n + j) * n + i] = inside && seen >= MIN_VIEWS;
            }
        }
    }
    carved
}

/// Up to `count` points on the surface of the visual hull of the object's
/// masks inside `scene_bounds` (the sparse points' box), coloured from the
/// first training view that shows the point on one of the object's pixels.
/// Empty when the masks carve everything away.
pub fn visual_hull_points(
    data: &ComponentData,
    scene_bounds: Bounds,
    count: usize,
    seed: u64,
) -> Points {
    let coarse = carve(data, scene_bounds, COARSE);
    // The fine pass covers the coarse survivors, one coarse voxel wider.
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for k in 0..COARSE {
        for j in 0..COARSE {
            for i in 0..COARSE {
                if coarse.at(i, j, k) {
                    let c = coarse.center(i, j, k);
                    lo = lo.min(c);
                    hi = hi.max(c);
                }
            }
        }
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return Points::default();
    }
    let fine = carve(data, (lo - coarse.cell(), hi + coarse.cell()), FINE);
    let mut surface = Vec::new();
    for k in 0..FINE {
        for j in 0..FINE {
            for i in 0..FINE {
                if !fine.at(i, j, k) {
                    continue;
                }
                let on_border = [i, j, k].iter().any(|&x| x == 0 || x == FINE - 1)
                    || !fine.at(i - 1, j, k)
                    || !fine.at(i + 1, j, k)
                    || !fine.at(i, j - 1, k)
                    || !fine.at(i, j + 1, k)
                    || !fine.at(i, j, k - 1)
                    || !fine.at(i, j, k + 1);
                if on_border {
                    surface.push(fine.center(i, j, k));
                }
            }
        }
    }
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    surface.shuffle(&mut rng);
    let mut points = Points::default();
    for p in surface {
        if points.positions.len() >= count {
            break;
        }
        let colour = data
            .views
            .iter()
            .filter(|v| v.split == Split::Train)
            .find_map(|v| {
                let cam = &v.camera;
                let (u, w, _) = cam.project(p)?;
                if !(u >= 0.0 && w >= 0.0 && u < cam.width as f64 && w < cam.height as f64) {
                    return None;
                }
                let (x, y) = (u as u32, w as u32);
                (v.labels.get(x, y) == objectsplat_core::component::OWN).then(|| {
                    v.target_at(x, y)
                        .map(|c| (c.clamp(0.0, 1.0) * 255.0).round() as u8)
                })
            });
        if let Some(colour) = colour {
            points.positions.push([p.x as f32, p.y as f32, p.z as f32]);
            points.colors.push(colour);
        }
    }
    points
}

/// A component's initial points: `owned`, the sparse points of `all_points` it
/// owns (`ComponentData::partition_points`), and for an object with fewer than
/// `min_object_points` of them, points on the visual hull of its masks up to
/// that count. Also returns how many came from the hull.
pub fn initial_points(
    data: &ComponentData,
    all_points: &Points,
    owned: Points,
    min_object_points: usize,
    seed: u64,
) -> Result<(Points, usize)> {
    let mut points = owned;
    let mut seeded = 0;
    if data.kind == ComponentKind::Object && points.positions.len() < min_object_points {
        // Narrow baselines leave a hull long along the viewing direction: where the
        // object has points of its own, the search stays near them (their box grown
        // by half its size, at least 2 % of the scene's), else the scene's box.
        let scene = bounds_of(all_points);
        let near_own = bounds_of(&points).zip(scene).map(|((lo, hi), (slo, shi))| {
            let grow = (0.5 * (hi - lo).max_element()).max(0.02 * (shi - slo).length());
            ((lo - grow).max(slo), (hi + grow).min(shi))
        });
        if let Some(bounds) = near_own.or(scene) {
            let hull = visual_hull_points(
                data,
                bounds,
                min_object_points - points.positions.len(),
                seed,
            );
            seeded = hull.positions.len();
            points.positions.extend(hull.positions);
            points.colors.extend(hull.colors);
        }
    }
    if points.positions.is_empty() {
        return Err(data.nothing_to_initialize(all_points.positions.len()));
    }
    Ok((points, seeded))
}

/// The box of a point set (None when empty).
pub fn bounds_of(points: &Points) -> Option<Bounds> {
    let mut it = points
        .positions
        .iter()
        .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
    let first = it.next()?;
    Some(it.fold((first, first), |(lo, hi), p| (lo.min(p), hi.max(p))))
}
