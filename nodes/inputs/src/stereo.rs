//! Dense points from posed photos by plane-sweep stereo, on the CPU.
//!
//! Structure from motion triangulates points only where features match, so a room's
//! plain walls and floor get few or none; the trainer seeds one triangle per point and
//! supervises depth at them, and with SfM's points alone the decomposed pipeline loses
//! 1.5 dB and half its F-score against a scan's points (docs/benchmarks.md, "Structure
//! from motion"). COLMAP's own dense stereo needs CUDA, which Debian's build lacks.
//!
//! Per reference view: neighbours chosen by triangulation angle at the view's median
//! sparse depth; fronto-parallel planes swept uniformly in inverse depth over the range
//! of the sparse points it sees; normalised cross-correlation over a window against each
//! neighbour's image warped onto the plane; the best half of the neighbours' scores
//! averaged (a neighbour that sees something else in front does not veto); the best
//! plane refined by a parabola through its neighbours. A depth is kept only where enough
//! neighbours' own depth maps agree with it (reprojection and relative depth), and the
//! kept points are averaged on a voxel grid.

use anyhow::{Result, bail};
use glam::{DMat3, DVec3};
use objectsplat_core::geometry::bounding_box;
use objectsplat_core::{Camera, Image, Points};
use std::collections::BTreeMap;
use std::sync::Mutex;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::mpsc;

/// What the sweep and the consistency check accept.
#[derive(Debug, Clone, PartialEq)]
pub struct StereoSettings {
    /// Neighbour views matched against each reference view.
    pub neighbours: usize,
    /// Planes swept per view, uniform in inverse depth.
    pub depth_planes: usize,
    /// Side of the square correlation window, in pixels (odd).
    pub window: usize,
    /// Lowest averaged correlation a depth is accepted with.
    pub min_ncc: f32,
    /// Lowest standard deviation of the reference window's grey levels (0–1): flat
    /// windows correlate with anything.
    pub min_texture: f32,
    /// Neighbours whose depth maps must agree with a depth for it to be kept.
    pub min_consistent: usize,
    /// Largest reprojection error of that agreement, in pixels.
    pub max_reprojection_px: f64,
    /// Largest relative depth difference of that agreement.
    pub max_relative_depth: f64,
    /// At most this many dense points: the voxel grid is halved until they fit (so
    /// between a quarter of this and this many, on surfaces).
    pub max_points: usize,
}

impl Default for StereoSettings {
    fn default() -> Self {
        StereoSettings {
            neighbours: 4,
            depth_planes: 128,
            window: 7,
            min_ncc: 0.6,
            min_texture: 0.01,
            min_consistent: 2,
            max_reprojection_px: 1.0,
            max_relative_depth: 0.01,
            max_points: 20_000,
        }
    }
}

/// One posed photo, at the size it is matched at.
pub struct StereoView {
    pub camera: Camera,
    /// RGB in 0–1, `camera.width × camera.height`.
    pub rgb: Image,
}

/// A view's depths along its optical axis (0 where none was accepted).
#[derive(Debug, Clone, PartialEq)]
pub struct DepthMap {
    pub width: u32,
    pub height: u32,
    pub depth: Vec<f32>,
}

impl DepthMap {
    fn empty(width: u32, height: u32) -> DepthMap {
        DepthMap {
            width,
            height,
            depth: vec![0.0; width as usize * height as usize],
        }
    }

    /// Pixels with a depth.
    pub fn filled(&self) -> usize {
        self.depth.iter().filter(|d| **d > 0.0).count()
    }
}

/// What the sweep found, view by view, and the fused points.
pub struct StereoResult {
    pub points: Points,
    /// The depth maps before the consistency check.
    pub depth_maps: Vec<DepthMap>,
    /// Each view's neighbours (empty: the view had too few sparse points or no neighbour).
    pub neighbours: Vec<Vec<usize>>,
    /// Points each view kept after the consistency check (before fusion).
    pub kept: Vec<usize>,
    /// The voxel edge the points were averaged on, in scene units.
    pub voxel: f64,
}

/// Fewest sparse points a view must see for its depth range to be trusted.
const MIN_SPARSE_IN_VIEW: usize = 8;
/// Triangulation angle (degrees) the neighbour choice prefers, and its spread below
/// and above: narrow baselines give imprecise depths, wide ones change the appearance.
const PREFERRED_ANGLE: f64 = 10.0;
const ANGLE_SPREAD_BELOW: f64 = 4.0;
const ANGLE_SPREAD_ABOVE: f64 = 15.0;
/// Optical axes further apart than this see too different sides to match.
const MAX_AXIS_ANGLE: f64 = 60.0;

/// Dense points of `views`, with depth ranges and view choice from the sparse points.
/// `progress(done, total)` is called from this thread as reference views finish.
pub fn dense_points(
    views: &[StereoView],
    sparse: &Points,
    settings: &StereoSettings,
    threads: usize,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<StereoResult> {
    check_settings(settings)?;
    if views.len() < 2 {
        bail!("stereo needs at least two views, got {}", views.len());
    }
    for (i, v) in views.iter().enumerate() {
        if v.rgb.channels != 3 || v.rgb.width != v.camera.width || v.rgb.height != v.camera.height {
            bail!(
                "view {i}: image is {}×{}×{} but its camera is {}×{} RGB",
                v.rgb.width,
                v.rgb.height,
                v.rgb.channels,
                v.camera.width,
                v.camera.height
            );
        }
        v.rgb.check_finite(&format!("view {i}"))?;
    }
    let sparse_world: Vec<DVec3> = sparse
        .positions
        .iter()
        .map(|p| DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64))
        .filter(|p| p.is_finite())
        .collect();
    let ranges: Vec<Option<DepthRange>> = views
        .iter()
        .map(|v| DepthRange::of(&v.camera, &sparse_world))
        .collect();
    let neighbours = choose_neighbours(views, &ranges, settings.neighbours);
    let grey: Vec<Vec<f32>> = views.iter().map(|v| luminance(&v.rgb)).collect();

    let depth_maps = run_parallel(views.len(), threads, progress, |r| match &ranges[r] {
        Some(range) if !neighbours[r].is_empty() => {
            sweep(views, &grey, r, &neighbours[r], range, settings)
        }
        _ => DepthMap::empty(views[r].camera.width, views[r].camera.height),
    });

    let posed: Vec<Posed> = views.iter().map(|v| Posed::new(&v.camera)).collect();
    let mut grid = VoxelGrid::new(&sparse_world, settings.max_points);
    let kept = (0..views.len())
        .map(|r| {
            consistent_points(
                views,
                &posed,
                &depth_maps,
                r,
                &neighbours[r],
                settings,
                &mut grid,
            )
        })
        .collect();
    let (points, voxel) = grid.into_points(settings.max_points);
    Ok(StereoResult {
        points,
        depth_maps,
        neighbours,
        kept,
        voxel,
    })
}

fn check_settings(s: &StereoSettings) -> Result<()> {
    if s.neighbours == 0 || s.depth_planes < 3 || s.window < 3 || s.window.is_multiple_of(2) {
        bail!(
            "stereo settings: neighbours ≥ 1, depth_planes ≥ 3 and an odd window ≥ 3 are needed (got {}, {}, {})",
            s.neighbours,
            s.depth_planes,
            s.window
        );
    }
    if s.min_consistent > s.neighbours {
        bail!(
            "stereo settings: min_consistent {} exceeds the {} neighbours a view is checked against",
            s.min_consistent,
            s.neighbours
        );
    }
    let finite = [
        s.min_ncc as f64,
        s.min_texture as f64,
        s.max_reprojection_px,
        s.max_relative_depth,
    ];
    if finite.iter().any(|v| !v.is_finite())
        || s.max_reprojection_px <= 0.0
        || s.max_relative_depth <= 0.0
    {
        bail!("stereo settings: thresholds must be finite and the agreement bounds positive");
    }
    Ok(())
}

/// Runs `job(i)` for every view on `threads` workers, reporting completions here.
fn run_parallel<T: Send>(
    count: usize,
    threads: usize,
    progress: &mut dyn FnMut(usize, usize),
    job: impl Fn(usize) -> T + Sync,
) -> Vec<T> {
    let next = AtomicUsize::new(0);
    let slots: Mutex<Vec<Option<T>>> = Mutex::new((0..count).map(|_| None).collect());
    let (done_tx, done_rx) = mpsc::channel::<()>();
    std::thread::scope(|scope| {
        for _ in 0..threads.clamp(1, count.max(1)) {
            let done_tx = done_tx.clone();
            let (next, slots, job) = (&next, &slots, &job);
            scope.spawn(move || {
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    if i >= count {
                        break;
                    }
                    let out = job(i);
                    // A poisoned lock means another worker panicked; the scope re-raises it.
                    if let Ok(mut slots) = slots.lock() {
                        slots[i] = Some(out);
                    }
                    let _ = done_tx.send(());
                }
            });
        }
        drop(done_tx);
        let mut done = 0;
        while done_rx.recv().is_ok() {
            done += 1;
            progress(done, count);
        }
    });
    slots
        .into_inner()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
        .into_iter()
        // Every index below `count` was taken by exactly one worker, and a worker that
        // panicked re-raised at the scope's end before this line.
        .map(|slot| slot.expect("every view was computed"))
        .collect()
}

/// The depths a view's sweep covers.
#[derive(Debug, Clone, Copy)]
struct DepthRange {
    near: f64,
    far: f64,
    /// The median depth of the sparse points the view sees.
    median: f64,
}

impl DepthRange {
    /// From the sparse points in front of the camera and inside its image: their 2nd
    /// to 98th percentile depths, widened by a quarter each way.
    fn of(camera: &Camera, sparse: &[DVec3]) -> Option<DepthRange> {
        let (w, h) = (camera.width as f64, camera.height as f64);
        let mut depths: Vec<f64> = sparse
            .iter()
            .filter_map(|p| camera.project(*p))
            .filter(|(u, v, z)| *u >= 0.0 && *v >= 0.0 && *u < w && *v < h && z.is_finite())
            .map(|(_, _, z)| z)
            .collect();
        if depths.len() < MIN_SPARSE_IN_VIEW {
            return None;
        }
        depths.sort_by(f64::total_cmp);
        let at = |q: f64| depths[((depths.len() - 1) as f64 * q).round() as usize];
        let (lo, hi) = (at(0.02), at(0.98));
        Some(DepthRange {
            near: lo * 0.75,
            far: hi * 1.25,
            median: at(0.5),
        })
    }
}

/// For each view, up to `k` others scored by triangulation angle at its median depth
/// (COLMAP's and MVSNet's rule: a Gaussian around a preferred angle, wider above it),
/// among those whose optical axes are within 60° and that see the view's centre point.
fn choose_neighbours(
    views: &[StereoView],
    ranges: &[Option<DepthRange>],
    k: usize,
) -> Vec<Vec<usize>> {
    let max_axis_cos = MAX_AXIS_ANGLE.to_radians().cos();
    views
        .iter()
        .enumerate()
        .map(|(r, view)| {
            let Some(range) = ranges[r] else {
                return Vec::new();
            };
            let cam = &view.camera;
            let axis_r = cam.rotation().row(2);
            let centre_ray = DVec3::new(0.0, 0.0, 1.0);
            let target =
                cam.rotation().transpose() * (centre_ray * range.median - cam.translation());
            let mut scored: Vec<(f64, usize)> = views
                .iter()
                .enumerate()
                .filter(|(n, _)| *n != r)
                .filter_map(|(n, other)| {
                    let oc = &other.camera;
                    if oc.rotation().row(2).dot(axis_r) < max_axis_cos {
                        return None;
                    }
                    let (u, v, _) = oc.project(target)?;
                    if !(u >= 0.0 && v >= 0.0 && u < oc.width as f64 && v < oc.height as f64) {
                        return None;
                    }
                    let (a, b) = (cam.center() - target, oc.center() - target);
                    let angle = a.angle_between(b).to_degrees();
                    if !angle.is_finite() || angle < 1.0 {
                        return None;
                    }
                    let spread = if angle < PREFERRED_ANGLE {
                        ANGLE_SPREAD_BELOW
                    } else {
                        ANGLE_SPREAD_ABOVE
                    };
                    let score =
                        (-(angle - PREFERRED_ANGLE).powi(2) / (2.0 * spread * spread)).exp();
                    Some((score, n))
                })
                .collect();
            // Ties broken by view index, so the choice does not depend on sort stability.
            scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
            scored.into_iter().take(k).map(|(_, n)| n).collect()
        })
        .collect()
}

/// Rec. 601 luma of an RGB image.
fn luminance(rgb: &Image) -> Vec<f32> {
    rgb.data
        .chunks_exact(3)
        .map(|c| 0.299 * c[0] + 0.587 * c[1] + 0.114 * c[2])
        .collect()
}

/// Bilinear sample at continuous pixel coordinates (pixel centres at +0.5); None
/// outside the centres' hull.
fn sample(grey: &[f32], width: usize, height: usize, u: f32, v: f32) -> Option<f32> {
    let (x, y) = (u - 0.5, v - 0.5);
    if !(x >= 0.0 && y >= 0.0 && x <= (width - 1) as f32 && y <= (height - 1) as f32) {
        return None;
    }
    let (x0, y0) = (x.floor() as usize, y.floor() as usize);
    let (x1, y1) = ((x0 + 1).min(width - 1), (y0 + 1).min(height - 1));
    let (fx, fy) = (x - x0 as f32, y - y0 as f32);
    let top = grey[y0 * width + x0] * (1.0 - fx) + grey[y0 * width + x1] * fx;
    let bottom = grey[y1 * width + x0] * (1.0 - fx) + grey[y1 * width + x1] * fx;
    Some(top * (1.0 - fy) + bottom * fy)
}

/// Sums of `values` over the `window`×`window` box around each pixel (the box clipped
/// at the border), by two running-sum passes.
fn box_sum(
    values: &[f32],
    width: usize,
    height: usize,
    window: usize,
    out: &mut [f32],
    row: &mut [f32],
) {
    let half = window / 2;
    // Rows: f64 running sums would be exact, but the differences of f32 prefix sums
    // over a row of a few thousand values in 0–1 lose at most ~1e-4: well below the
    // correlation's thresholds.
    for y in 0..height {
        let line = &values[y * width..(y + 1) * width];
        let mut prefix = 0.0f32;
        row[0] = 0.0;
        for (x, v) in line.iter().enumerate() {
            prefix += v;
            row[x + 1] = prefix;
        }
        for x in 0..width {
            let lo = x.saturating_sub(half);
            let hi = (x + half + 1).min(width);
            out[y * width + x] = row[hi] - row[lo];
        }
    }
    // Columns, in place, one column at a time through `row` as scratch.
    let mut column = vec![0.0f32; height + 1];
    for x in 0..width {
        let mut prefix = 0.0f32;
        column[0] = 0.0;
        for y in 0..height {
            prefix += out[y * width + x];
            column[y + 1] = prefix;
        }
        for y in 0..height {
            let lo = y.saturating_sub(half);
            let hi = (y + half + 1).min(height);
            out[y * width + x] = column[hi] - column[lo];
        }
    }
}

/// A neighbour as the sweep sees it: each reference pixel's ray mapped into the
/// neighbour's image (`K_n R_nr ray`) and the offset `K_n t_nr`, so the point at depth
/// `d` along the ray lands at `d·ray + offset` (homogeneous pixel coordinates).
struct Warp<'a> {
    rays: Vec<[f32; 3]>,
    offset: [f32; 3],
    width: usize,
    height: usize,
    grey: &'a [f32],
}

/// The plane sweep of reference view `r` against its neighbours.
fn sweep(
    views: &[StereoView],
    grey: &[Vec<f32>],
    r: usize,
    neighbours: &[usize],
    range: &DepthRange,
    s: &StereoSettings,
) -> DepthMap {
    let cam = &views[r].camera;
    let (w, h) = (cam.width as usize, cam.height as usize);
    let n_px = w * h;
    let g = &grey[r];
    let full = (s.window * s.window) as f32;
    let mut row = vec![0.0f32; w + 1];

    // The reference windows' statistics (zero-mean, so NCC needs Σg, Σg² and Σgw).
    let mut sum_g = vec![0.0f32; n_px];
    let mut sum_gg = vec![0.0f32; n_px];
    let gg: Vec<f32> = g.iter().map(|v| v * v).collect();
    box_sum(g, w, h, s.window, &mut sum_g, &mut row);
    box_sum(&gg, w, h, s.window, &mut sum_gg, &mut row);
    let textured: Vec<bool> = (0..n_px)
        .map(|p| {
            let var = sum_gg[p] / full - (sum_g[p] / full).powi(2);
            var.max(0.0).sqrt() >= s.min_texture
        })
        .collect();

    let reference = Posed::new(cam);
    let (r_r, t_r) = (reference.rotation, reference.translation);
    let warps: Vec<Warp> = neighbours
        .iter()
        .map(|&n| {
            let oc = &views[n].camera;
            let k_n = DMat3::from_cols(
                DVec3::new(oc.fx, 0.0, 0.0),
                DVec3::new(0.0, oc.fy, 0.0),
                DVec3::new(oc.cx, oc.cy, 1.0),
            );
            let r_nr = oc.rotation() * r_r.transpose();
            let t_nr = oc.translation() - r_nr * t_r;
            let m = k_n * r_nr;
            let a = (0..n_px)
                .map(|p| (m * reference.ray(p)).as_vec3().to_array())
                .collect();
            Warp {
                rays: a,
                offset: (k_n * t_nr).as_vec3().to_array(),
                width: oc.width as usize,
                height: oc.height as usize,
                grey: &grey[n],
            }
        })
        .collect();

    let inv_near = 1.0 / range.near;
    let inv_step = (1.0 / range.near - 1.0 / range.far) / (s.depth_planes - 1) as f64;
    let take = neighbours.len().div_ceil(2);

    let mut best = vec![f32::NEG_INFINITY; n_px];
    let mut best_plane = vec![usize::MAX; n_px];
    let mut best_before = vec![f32::NAN; n_px];
    let mut best_after = vec![f32::NAN; n_px];
    let mut previous = vec![f32::NAN; n_px];

    let mut warped = vec![0.0f32; n_px];
    let mut valid = vec![0.0f32; n_px];
    let mut products = vec![0.0f32; n_px];
    let mut squares = vec![0.0f32; n_px];
    let (mut sum_v, mut sum_w, mut sum_ww, mut sum_gw) = (
        vec![0.0f32; n_px],
        vec![0.0f32; n_px],
        vec![0.0f32; n_px],
        vec![0.0f32; n_px],
    );
    let mut scores = vec![f32::NEG_INFINITY; n_px * neighbours.len()];

    for plane in 0..s.depth_planes {
        let depth = (1.0 / (inv_near - plane as f64 * inv_step)) as f32;
        for (j, warp) in warps.iter().enumerate() {
            let (a, b) = (&warp.rays, &warp.offset);
            for p in 0..n_px {
                let hz = depth * a[p][2] + b[2];
                let value = if hz > 1e-6 {
                    let u = (depth * a[p][0] + b[0]) / hz;
                    let v = (depth * a[p][1] + b[1]) / hz;
                    sample(warp.grey, warp.width, warp.height, u, v)
                } else {
                    None
                };
                let (wv, ok) = match value {
                    Some(wv) => (wv, 1.0),
                    None => (0.0, 0.0),
                };
                warped[p] = wv;
                valid[p] = ok;
                products[p] = wv * g[p];
                squares[p] = wv * wv;
            }
            box_sum(&valid, w, h, s.window, &mut sum_v, &mut row);
            box_sum(&warped, w, h, s.window, &mut sum_w, &mut row);
            box_sum(&squares, w, h, s.window, &mut sum_ww, &mut row);
            box_sum(&products, w, h, s.window, &mut sum_gw, &mut row);
            for p in 0..n_px {
                // Border windows are clipped: compare their own pixel counts.
                let count = window_count(p % w, p / w, w, h, s.window);
                scores[p * neighbours.len() + j] = if sum_v[p] + 0.5 < count {
                    f32::NEG_INFINITY
                } else {
                    ncc(sum_g[p], sum_gg[p], sum_w[p], sum_ww[p], sum_gw[p], count)
                };
            }
        }
        for p in 0..n_px {
            let mine = &mut scores[p * neighbours.len()..(p + 1) * neighbours.len()];
            mine.sort_by(|a, b| b.total_cmp(a));
            let score = if mine[take - 1] == f32::NEG_INFINITY {
                f32::NEG_INFINITY
            } else {
                mine[..take].iter().sum::<f32>() / take as f32
            };
            if score > best[p] {
                best[p] = score;
                best_plane[p] = plane;
                best_before[p] = previous[p];
                best_after[p] = f32::NAN;
            } else if best_plane[p] != usize::MAX && best_plane[p] + 1 == plane {
                best_after[p] = score;
            }
            previous[p] = score;
        }
    }

    let mut map = DepthMap::empty(cam.width, cam.height);
    for p in 0..n_px {
        let plane = best_plane[p];
        // The range's ends hold depths the sweep could not bracket.
        if !textured[p] || best[p] < s.min_ncc || plane == 0 || plane + 1 >= s.depth_planes {
            continue;
        }
        let (before, at, after) = (best_before[p], best[p], best_after[p]);
        let mut offset = 0.0f64;
        if before.is_finite() && after.is_finite() {
            let curvature = before - 2.0 * at + after;
            if curvature < 0.0 {
                offset = (0.5 * (before - after) / curvature).clamp(-0.5, 0.5) as f64;
            }
        }
        let inverse = inv_near - (plane as f64 + offset) * inv_step;
        if inverse > 0.0 {
            map.depth[p] = (1.0 / inverse) as f32;
        }
    }
    map
}

/// Pixels in the (clipped) window around `(x, y)`.
fn window_count(x: usize, y: usize, w: usize, h: usize, window: usize) -> f32 {
    let half = window / 2;
    let span = |c: usize, n: usize| ((c + half + 1).min(n) - c.saturating_sub(half)) as f32;
    span(x, w) * span(y, h)
}

/// Normalised cross-correlation from window sums; 0 when either window is flat.
fn ncc(sg: f32, sgg: f32, sw: f32, sww: f32, sgw: f32, n: f32) -> f32 {
    let var_g = sgg - sg * sg / n;
    let var_w = sww - sw * sw / n;
    let floor = 1e-6 * n;
    if var_g <= floor || var_w <= floor {
        return 0.0;
    }
    ((sgw - sg * sw / n) / (var_g * var_w).sqrt()).clamp(-1.0, 1.0)
}

/// A camera with its pose unpacked once: the consistency check projects and
/// back-projects every pixel into several views, and `Camera` rebuilds its rotation
/// matrix on each call.
struct Posed {
    camera: Camera,
    rotation: DMat3,
    translation: DVec3,
}

impl Posed {
    fn new(camera: &Camera) -> Posed {
        Posed {
            camera: *camera,
            rotation: camera.rotation(),
            translation: camera.translation(),
        }
    }

    /// The camera-space ray through pixel `p`'s centre, at depth 1.
    fn ray(&self, p: usize) -> DVec3 {
        let (c, w) = (&self.camera, self.camera.width as usize);
        DVec3::new(
            ((p % w) as f64 + 0.5 - c.cx) / c.fx,
            ((p / w) as f64 + 0.5 - c.cy) / c.fy,
            1.0,
        )
    }

    /// The world point at `depth` along pixel `p`'s ray.
    fn back_project(&self, p: usize, depth: f64) -> DVec3 {
        self.rotation.transpose() * (self.ray(p) * depth - self.translation)
    }

    /// Continuous pixel coordinates and depth of a world point; None behind the camera.
    fn project(&self, x: DVec3) -> Option<(f64, f64, f64)> {
        let c = self.rotation * x + self.translation;
        if c.z <= 0.0 {
            return None;
        }
        let cam = &self.camera;
        Some((
            cam.fx * c.x / c.z + cam.cx,
            cam.fy * c.y / c.z + cam.cy,
            c.z,
        ))
    }

    /// The index of the pixel a world point lands on; None behind the camera or outside
    /// the image.
    fn pixel_of(&self, x: DVec3) -> Option<usize> {
        let (u, v, _) = self.project(x)?;
        let cam = &self.camera;
        if !(u >= 0.0 && v >= 0.0 && u < cam.width as f64 && v < cam.height as f64) {
            return None;
        }
        Some(v as usize * cam.width as usize + u as usize)
    }
}

/// Adds to `grid` the points of view `r` whose depth at least `min_consistent`
/// neighbours confirm — the point lands in the neighbour on a pixel whose own depth, sent
/// back to `r`, falls within the reprojection and relative-depth bounds — and returns
/// how many there were.
fn consistent_points(
    views: &[StereoView],
    posed: &[Posed],
    maps: &[DepthMap],
    r: usize,
    neighbours: &[usize],
    s: &StereoSettings,
    grid: &mut VoxelGrid,
) -> usize {
    let mut count = 0;
    let reference = &posed[r];
    let w = reference.camera.width as usize;
    for (p, &d) in maps[r].depth.iter().enumerate() {
        if d <= 0.0 {
            continue;
        }
        let (d, x) = (d as f64, reference.back_project(p, d as f64));
        let (pu, pv) = ((p % w) as f64 + 0.5, (p / w) as f64 + 0.5);
        let agreeing = neighbours
            .iter()
            .filter(|&&n| {
                let Some(q) = posed[n].pixel_of(x) else {
                    return false;
                };
                let dn = maps[n].depth[q];
                if dn <= 0.0 {
                    return false;
                }
                match reference.project(posed[n].back_project(q, dn as f64)) {
                    Some((u2, v2, z2)) => {
                        (u2 - pu).hypot(v2 - pv) <= s.max_reprojection_px
                            && ((z2 - d) / d).abs() <= s.max_relative_depth
                    }
                    None => false,
                }
            })
            .count();
        if agreeing >= s.min_consistent {
            let c = &views[r].rgb.data[p * 3..p * 3 + 3];
            grid.add(x, [c[0], c[1], c[2]]);
            count += 1;
        }
    }
    count
}

/// Sums of the confirmed points per voxel. Points are added as they are confirmed (a
/// scene's millions of confirmed depths are never held at once), on a fine grid that
/// [`VoxelGrid::into_points`] coarsens by halving until the voxels fit. Ordered maps and
/// a fixed adding order (view by view, pixel by pixel) keep the sums, and so the output,
/// the same on every run whatever the thread timing of the sweep.
struct VoxelGrid {
    origin: DVec3,
    voxel: f64,
    cells: BTreeMap<(i64, i64, i64), Cell>,
}

#[derive(Default, Clone, Copy)]
struct Cell {
    position: DVec3,
    colour: [f64; 3],
    count: u32,
}

impl Cell {
    fn merge(&mut self, other: &Cell) {
        self.position += other.position;
        for (a, b) in self.colour.iter_mut().zip(other.colour) {
            *a += b;
        }
        self.count += other.count;
    }
}

impl VoxelGrid {
    /// A grid over the sparse points' box, fine enough that `max_points` voxels
    /// would cover its surface several times over (so coarsening decides the size).
    fn new(sparse: &[DVec3], max_points: usize) -> VoxelGrid {
        let (lo, hi) = bounding_box(sparse.iter().map(|p| p.to_array()));
        let (lo, hi) = (DVec3::from_array(lo), DVec3::from_array(hi));
        let (origin, extent) = if lo.is_finite() && hi.is_finite() {
            (lo, (hi - lo).max_element())
        } else {
            (DVec3::ZERO, 1.0)
        };
        VoxelGrid {
            origin,
            voxel: (extent.max(1e-9) / (max_points.max(1) as f64).sqrt() / 4.0).max(1e-9),
            cells: BTreeMap::new(),
        }
    }

    fn add(&mut self, position: DVec3, colour: [f32; 3]) {
        let k = ((position - self.origin) / self.voxel).floor();
        let cell = self
            .cells
            .entry((k.x as i64, k.y as i64, k.z as i64))
            .or_default();
        cell.merge(&Cell {
            position,
            colour: colour.map(f64::from),
            count: 1,
        });
    }

    /// The voxels' mean points and colours, after halving the grid's resolution until at
    /// most `max_points` voxels are occupied; also the voxel edge used.
    fn into_points(mut self, max_points: usize) -> (Points, f64) {
        while self.cells.len() > max_points.max(1) {
            let mut coarser: BTreeMap<(i64, i64, i64), Cell> = BTreeMap::new();
            for ((x, y, z), cell) in &self.cells {
                coarser
                    .entry((x.div_euclid(2), y.div_euclid(2), z.div_euclid(2)))
                    .or_default()
                    .merge(cell);
            }
            self.cells = coarser;
            self.voxel *= 2.0;
        }
        let mut points = Points::default();
        for cell in self.cells.values() {
            let n = cell.count as f64;
            let p = cell.position / n;
            points.positions.push([p.x as f32, p.y as f32, p.z as f32]);
            points.colors.push(
                cell.colour
                    .map(|c| ((c / n).clamp(0.0, 1.0) * 255.0).round() as u8),
            );
        }
        (points, self.voxel)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_sums_match_a_direct_sum_with_clipped_borders() {
        let (w, h) = (7, 5);
        let values: Vec<f32> = (0..w * h).map(|i| ((i * 37) % 11) as f32 / 10.0).collect();
        let mut out = vec![0.0; w * h];
        let mut row = vec![0.0; w + 1];
        box_sum(&values, w, h, 3, &mut out, &mut row);
        for y in 0..h {
            for x in 0..w {
                let mut direct = 0.0;
                for yy in y.saturating_sub(1)..(y + 2).min(h) {
                    for xx in x.saturating_sub(1)..(x + 2).min(w) {
                        direct += values[yy * w + xx];
                    }
                }
                assert!((out[y * w + x] - direct).abs() < 1e-5, "({x}, {y})");
                let count = window_count(x, y, w, h, 3);
                let expected =
                    ((x + 2).min(w) - x.saturating_sub(1)) * ((y + 2).min(h) - y.saturating_sub(1));
                assert_eq!(count, expected as f32);
            }
        }
    }

    #[test]
    fn correlation_is_one_for_an_affine_copy_and_zero_for_a_flat_window() {
        let g = [0.1f32, 0.5, 0.3, 0.9];
        let w: Vec<f32> = g.iter().map(|v| 0.5 * v + 0.2).collect();
        let sums = |a: &[f32], b: &[f32]| {
            (
                a.iter().sum::<f32>(),
                a.iter().map(|v| v * v).sum::<f32>(),
                b.iter().sum::<f32>(),
                b.iter().map(|v| v * v).sum::<f32>(),
                a.iter().zip(b).map(|(x, y)| x * y).sum::<f32>(),
            )
        };
        let (sg, sgg, sw, sww, sgw) = sums(&g, &w);
        assert!((ncc(sg, sgg, sw, sww, sgw, 4.0) - 1.0).abs() < 1e-4);
        let flat = [0.4f32; 4];
        let (sg, sgg, sw, sww, sgw) = sums(&g, &flat);
        assert_eq!(ncc(sg, sgg, sw, sww, sgw, 4.0), 0.0);
    }

    #[test]
    fn settings_out_of_range_are_refused() {
        let even = StereoSettings {
            window: 6,
            ..StereoSettings::default()
        };
        assert!(check_settings(&even).is_err());
        let strict = StereoSettings {
            min_consistent: 9,
            ..StereoSettings::default()
        };
        assert!(check_settings(&strict).is_err());
        assert!(check_settings(&StereoSettings::default()).is_ok());
    }

    fn view_at(eye: DVec3) -> StereoView {
        let camera = Camera::look_at(32, 24, 30.0, 30.0, eye, DVec3::new(0.0, 0.0, 3.0), DVec3::Y);
        let rgb = Image::from_fn(32, 24, 3, |x, y, c| {
            ((x * 7 + y * 13 + c) % 10) as f32 / 10.0
        });
        StereoView { camera, rgb }
    }

    fn wall_points() -> Points {
        let mut points = Points::default();
        for i in 0..50 {
            points.positions.push([
                (i % 10) as f32 * 0.2 - 1.0,
                (i / 10) as f32 * 0.2 - 0.5,
                3.0,
            ]);
            points.colors.push([128; 3]);
        }
        points
    }

    #[test]
    fn views_without_baseline_give_no_depth_and_say_so() {
        let views = [view_at(DVec3::ZERO), view_at(DVec3::ZERO)];
        let r = dense_points(
            &views,
            &wall_points(),
            &StereoSettings::default(),
            2,
            &mut |_, _| {},
        )
        .unwrap();
        assert!(r.neighbours.iter().all(Vec::is_empty));
        assert!(r.points.positions.is_empty());
        assert_eq!(r.depth_maps.iter().map(DepthMap::filled).sum::<usize>(), 0);
    }

    #[test]
    fn a_non_finite_image_or_a_mismatched_size_is_refused() {
        let mut bad = view_at(DVec3::new(0.3, 0.0, 0.0));
        bad.rgb.data[5] = f32::NAN;
        let views = [view_at(DVec3::ZERO), bad];
        let e = dense_points(
            &views,
            &wall_points(),
            &StereoSettings::default(),
            1,
            &mut |_, _| {},
        );
        assert!(format!("{:#}", e.err().unwrap()).contains("view 1"));
        let mut small = view_at(DVec3::new(0.3, 0.0, 0.0));
        small.camera.width = 16;
        let views = [view_at(DVec3::ZERO), small];
        let e = dense_points(
            &views,
            &wall_points(),
            &StereoSettings::default(),
            1,
            &mut |_, _| {},
        );
        assert!(format!("{:#}", e.err().unwrap()).contains("but its camera is 16×24"));
    }
}
