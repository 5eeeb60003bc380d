//! A multi-threaded z-buffer triangle rasterizer: which face is nearest at every pixel.
//!
//! Coverage is sampled at pixel centres `(i + 0.5, j + 0.5)` (the COLMAP convention of
//! [`Camera`]). Projected vertices are snapped to 1/256 pixel and edge functions are
//! evaluated exactly in integers with the top-left fill rule, so two triangles sharing
//! an edge never both cover, nor both miss, a pixel centre on it: a closed mesh leaves
//! no cracks and paints no pixel twice. Depth is perspective-correct (1/z interpolated
//! with screen-space barycentrics). Triangles crossing the near plane, or reaching far
//! outside the image, are clipped in camera space first, so nothing explodes near the
//! camera. Work is split over horizontal bands of rows, each triangle binned by its
//! bounding box into the bands it touches; ties in depth go to the lower face index,
//! so the result does not depend on the thread count.

use glam::DVec3;
use objectsplat_core::Camera;
use std::sync::Mutex;

/// Marks a pixel that no face covers.
pub const NO_FACE: u32 = u32::MAX;

/// Sub-pixel precision of snapped vertices: 8 bits (1/256 pixel).
const SUBPIXEL_BITS: u32 = 8;
const SUBPIXEL: i64 = 1 << SUBPIXEL_BITS;
/// Projected vertices may lie this many pixels outside the image before the triangle
/// is clipped; keeps fixed-point edge products far inside i64.
const GUARD_BAND_PX: f64 = 16384.0;
/// Rows per work band.
const BAND_ROWS: u32 = 16;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RasterOptions {
    /// Camera-space depth of the near clipping plane (metres); surfaces closer are cut away.
    pub near: f64,
    /// Worker threads (≥ 1).
    pub threads: usize,
}

impl Default for RasterOptions {
    fn default() -> Self {
        RasterOptions {
            near: 0.01,
            threads: default_threads(),
        }
    }
}

pub fn default_threads() -> usize {
    std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
}

/// The nearest face and its inverse depth at every pixel (row-major).
#[derive(Debug, Clone, PartialEq)]
pub struct Raster {
    pub width: u32,
    pub height: u32,
    /// Index of the nearest face covering the pixel centre, or [`NO_FACE`].
    pub face: Vec<u32>,
    /// `1/z` (camera depth) of that face at the pixel centre; 0 where no face.
    pub inv_depth: Vec<f32>,
}

impl Raster {
    #[inline]
    pub fn face_at(&self, x: u32, y: u32) -> Option<u32> {
        let f = self.face[(y * self.width + x) as usize];
        (f != NO_FACE).then_some(f)
    }

    /// Camera depth of the visible surface at a pixel, if any.
    #[inline]
    pub fn depth_at(&self, x: u32, y: u32) -> Option<f32> {
        let iz = self.inv_depth[(y * self.width + x) as usize];
        (iz > 0.0).then(|| 1.0 / iz)
    }
}

/// A triangle ready for scan conversion: fixed-point screen vertices with positive
/// orientation, their inverse depths, its pixel bounding box and the face it came from.
#[derive(Debug, Clone, Copy)]
pub(crate) struct ScreenTriangle {
    /// Fixed-point vertices; the guard band keeps them within ±2^25, so i32 holds them
    /// and the triangle list stays small (48 bytes a triangle) at a million faces.
    pub xy: [[i32; 2]; 3],
    pub inv_z: [f32; 3],
    pub face: u32,
    /// Inclusive pixel bounding box, clamped to the image (sides ≤ 65536 pixels).
    pub x0: u16,
    pub x1: u16,
    pub y0: u16,
    pub y1: u16,
}

impl ScreenTriangle {
    pub fn vertex(&self, k: usize) -> [i64; 2] {
        [self.xy[k][0] as i64, self.xy[k][1] as i64]
    }
}

/// A vertex after projection. `inv_z <= 0` marks one that needs the clipping path
/// (behind the near plane or outside the guard band).
#[derive(Debug, Clone, Copy, Default)]
struct ProjectedVertex {
    xy: [i64; 2],
    inv_z: f32,
}

/// Projection constants shared by both paths: the camera, and its pose unpacked once.
#[derive(Debug, Clone, Copy)]
struct Projector {
    camera: Camera,
    rotation: [[f64; 3]; 3],
    translation: [f64; 3],
    near: f64,
}

impl Projector {
    fn new(camera: &Camera, near: f64) -> Projector {
        let m = &camera.world_to_camera;
        Projector {
            rotation: [
                [m[0][0], m[0][1], m[0][2]],
                [m[1][0], m[1][1], m[1][2]],
                [m[2][0], m[2][1], m[2][2]],
            ],
            translation: [m[0][3], m[1][3], m[2][3]],
            camera: *camera,
            near,
        }
    }

    #[inline]
    fn camera_space(&self, p: [f32; 3]) -> [f64; 3] {
        let (r, t) = (&self.rotation, &self.translation);
        let (x, y, z) = (p[0] as f64, p[1] as f64, p[2] as f64);
        [
            r[0][0] * x + r[0][1] * y + r[0][2] * z + t[0],
            r[1][0] * x + r[1][1] * y + r[1][2] * z + t[1],
            r[2][0] * x + r[2][1] * y + r[2][2] * z + t[2],
        ]
    }

    /// Continuous pixel coordinates of a camera-space point with `z > 0`.
    #[inline]
    fn pixel_coords(&self, c: [f64; 3]) -> (f64, f64) {
        (
            self.camera.fx * c[0] / c[2] + self.camera.cx,
            self.camera.fy * c[1] / c[2] + self.camera.cy,
        )
    }

    #[inline]
    fn inside_guard(&self, u: f64, v: f64) -> bool {
        u >= -GUARD_BAND_PX
            && u <= self.camera.width as f64 + GUARD_BAND_PX
            && v >= -GUARD_BAND_PX
            && v <= self.camera.height as f64 + GUARD_BAND_PX
    }

    fn project_vertex(&self, p: [f32; 3]) -> ProjectedVertex {
        let c = self.camera_space(p);
        if c[2] < self.near {
            return ProjectedVertex::default();
        }
        let (u, v) = self.pixel_coords(c);
        if !self.inside_guard(u, v) {
            return ProjectedVertex::default();
        }
        ProjectedVertex {
            xy: [snap(u), snap(v)],
            inv_z: (1.0 / c[2]) as f32,
        }
    }

    /// The clipping planes, as `a·x + b·y + c·z + d ≥ 0` in camera space: the near plane
    /// and the four guard-band planes through the camera centre.
    fn clip_planes(&self) -> [[f64; 4]; 5] {
        let g = GUARD_BAND_PX;
        [
            [0.0, 0.0, 1.0, -self.near],
            [self.camera.fx, 0.0, self.camera.cx + g, 0.0],
            [
                -self.camera.fx,
                0.0,
                self.camera.width as f64 + g - self.camera.cx,
                0.0,
            ],
            [0.0, self.camera.fy, self.camera.cy + g, 0.0],
            [
                0.0,
                -self.camera.fy,
                self.camera.height as f64 + g - self.camera.cy,
                0.0,
            ],
        ]
    }
}

#[inline]
fn snap(pixel_coord: f64) -> i64 {
    (pixel_coord * SUBPIXEL as f64).round() as i64
}

/// What both rasterizers (this one and the wgpu one in `gpu_raster`) require of
/// their inputs; the error says which input is wrong.
pub(crate) fn validate_inputs(
    positions: &[[f32; 3]],
    faces: &[[u32; 3]],
    camera: &Camera,
    near: f64,
) -> Result<(), String> {
    camera.validate()?;
    if !(near.is_finite() && near > 0.0) {
        return Err(format!("near plane {} must be finite and positive", near));
    }
    if camera.width > 1 << 16 || camera.height > 1 << 16 {
        return Err(format!(
            "image size {}×{} is larger than 65536 pixels a side",
            camera.width, camera.height
        ));
    }
    if let Some(i) = positions
        .iter()
        .position(|p| p.iter().any(|v| !v.is_finite()))
    {
        return Err(format!("vertex {i} has a non-finite coordinate"));
    }
    if let Some((i, f)) = faces
        .iter()
        .enumerate()
        .find(|(_, f)| f.iter().any(|&v| v as usize >= positions.len()))
    {
        return Err(format!(
            "face {i} refers to vertex {f:?} but there are only {} vertices",
            positions.len()
        ));
    }
    if faces.len() >= NO_FACE as usize {
        return Err(format!(
            "{} faces is more than this rasterizer indexes",
            faces.len()
        ));
    }
    Ok(())
}

/// The triangles to scan-convert, in face order: projected, clipped against the near
/// plane and the guard band, snapped, positively oriented and bounded. Inputs must
/// have passed [`validate_inputs`].
pub(crate) fn screen_triangles(
    positions: &[[f32; 3]],
    faces: &[[u32; 3]],
    camera: &Camera,
    near: f64,
    threads: usize,
) -> Vec<ScreenTriangle> {
    let projector = Projector::new(camera, near);
    let projected = project_vertices(positions, &projector, threads);
    setup_triangles(positions, faces, &projected, &projector, threads)
}

/// Rasterizes `faces` of the mesh `positions` into `camera`'s image.
///
/// Errors (never panics) on a bad camera, a non-finite vertex, a face index out of
/// range or a bad near plane.
pub fn rasterize(
    positions: &[[f32; 3]],
    faces: &[[u32; 3]],
    camera: &Camera,
    options: &RasterOptions,
) -> Result<Raster, String> {
    validate_inputs(positions, faces, camera, options.near)?;
    let threads = options.threads.max(1);
    let triangles = screen_triangles(positions, faces, camera, options.near, threads);
    let (band_offsets, band_members) = bin_by_band(&triangles, camera.height);

    let (width, height) = (camera.width, camera.height);
    let mut face = vec![NO_FACE; (width * height) as usize];
    let mut inv_depth = vec![0.0f32; (width * height) as usize];
    let band_len = (BAND_ROWS * width) as usize;
    let work: Vec<(usize, &mut [u32], &mut [f32])> = face
        .chunks_mut(band_len)
        .zip(inv_depth.chunks_mut(band_len))
        .enumerate()
        .map(|(b, (f, z))| (b, f, z))
        .collect();
    let queue = Mutex::new(work);
    crossbeam::scope(|s| {
        for _ in 0..threads {
            s.spawn(|_| {
                loop {
                    // A poisoned lock means another worker panicked; the scope re-raises that.
                    let next = match queue.lock() {
                        Ok(mut q) => q.pop(),
                        Err(_) => return,
                    };
                    let Some((band, face_out, depth_out)) = next else {
                        return;
                    };
                    let members = &band_members[band_offsets[band]..band_offsets[band + 1]];
                    let row0 = band as u32 * BAND_ROWS;
                    raster_band(&triangles, members, row0, width, face_out, depth_out);
                }
            });
        }
    })
    .map_err(|_| "a rasterizer worker thread panicked".to_string())?;
    Ok(Raster {
        width,
        height,
        face,
        inv_depth,
    })
}

fn project_vertices(
    positions: &[[f32; 3]],
    projector: &Projector,
    threads: usize,
) -> Vec<ProjectedVertex> {
    let mut out = vec![ProjectedVertex::default(); positions.len()];
    let chunk = positions.len().div_ceil(threads).max(1);
    crossbeam::scope(|s| {
        for (src, dst) in positions.chunks(chunk).zip(out.chunks_mut(chunk)) {
            s.spawn(move |_| {
                for (p, o) in src.iter().zip(dst.iter_mut()) {
                    *o = projector.project_vertex(*p);
                }
            });
        }
    })
    .expect(
        "vertex projection does not panic: it only does arithmetic on validated, finite inputs",
    );
    out
}

fn setup_triangles(
    positions: &[[f32; 3]],
    faces: &[[u32; 3]],
    projected: &[ProjectedVertex],
    projector: &Projector,
    threads: usize,
) -> Vec<ScreenTriangle> {
    let chunk = faces.len().div_ceil(threads).max(1);
    let parts: Vec<Vec<ScreenTriangle>> = crossbeam::scope(|s| {
        let handles: Vec<_> = faces
            .chunks(chunk)
            .enumerate()
            .map(|(c, part)| {
                s.spawn(move |_| {
                    let mut out = Vec::with_capacity(part.len());
                    for (k, f) in part.iter().enumerate() {
                        let face_index = (c * chunk + k) as u32;
                        let pv = [
                            projected[f[0] as usize],
                            projected[f[1] as usize],
                            projected[f[2] as usize],
                        ];
                        if pv.iter().all(|v| v.inv_z > 0.0) {
                            push_screen_triangle(&mut out, pv, face_index, projector);
                        } else {
                            let corners = f.map(|v| projector.camera_space(positions[v as usize]));
                            clip_and_push(&mut out, corners, face_index, projector);
                        }
                    }
                    out
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| {
                h.join()
                    .expect("triangle setup does not panic: indices were validated")
            })
            .collect()
    })
    .expect("triangle setup does not panic: indices were validated");
    parts.concat()
}

/// Orients, bounds and keeps a triangle if it covers at least one pixel centre.
fn push_screen_triangle(
    out: &mut Vec<ScreenTriangle>,
    mut v: [ProjectedVertex; 3],
    face: u32,
    p: &Projector,
) {
    let area = edge(v[0].xy, v[1].xy, v[2].xy);
    if area == 0 {
        return;
    }
    if area < 0 {
        v.swap(1, 2);
    }
    let xs = [v[0].xy[0], v[1].xy[0], v[2].xy[0]];
    let ys = [v[0].xy[1], v[1].xy[1], v[2].xy[1]];
    let (Some(x0), Some(x1)) = pixel_span(xs, p.camera.width) else {
        return;
    };
    let (Some(y0), Some(y1)) = pixel_span(ys, p.camera.height) else {
        return;
    };
    // Vertices inside the guard band fit i32 and image coordinates fit u16 (both
    // checked on entry to `rasterize`), so these conversions are lossless.
    let narrow = |p: [i64; 2]| [p[0] as i32, p[1] as i32];
    out.push(ScreenTriangle {
        xy: [narrow(v[0].xy), narrow(v[1].xy), narrow(v[2].xy)],
        inv_z: [v[0].inv_z, v[1].inv_z, v[2].inv_z],
        face,
        x0: x0 as u16,
        x1: x1 as u16,
        y0: y0 as u16,
        y1: y1 as u16,
    });
}

/// First and last pixel whose centre lies within the fixed-point range of `coords`,
/// clamped to `[0, size)`; `None`s when there is none.
fn pixel_span(coords: [i64; 3], size: u32) -> (Option<u32>, Option<u32>) {
    let lo = coords.iter().copied().min().unwrap_or(0);
    let hi = coords.iter().copied().max().unwrap_or(0);
    let half = SUBPIXEL / 2;
    // Pixel i has its centre at i·S + S/2: first i with centre ≥ lo, last with centre ≤ hi.
    let first = (lo - half).div_euclid(SUBPIXEL) + i64::from((lo - half).rem_euclid(SUBPIXEL) != 0);
    let last = (hi - half).div_euclid(SUBPIXEL);
    let first = first.max(0);
    let last = last.min(size as i64 - 1);
    if first > last {
        (None, None)
    } else {
        (Some(first as u32), Some(last as u32))
    }
}

/// Edge function of `(a, b)` at `p`: twice the signed area of `(a, b, p)`, positive
/// when `p` is on the interior side of a positively oriented triangle.
#[inline]
pub(crate) fn edge(a: [i64; 2], b: [i64; 2], p: [i64; 2]) -> i64 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// Sutherland–Hodgman clipping of a camera-space triangle against the near plane and
/// the guard band, then fan triangulation of what is left.
fn clip_and_push(out: &mut Vec<ScreenTriangle>, corners: [[f64; 3]; 3], face: u32, p: &Projector) {
    let mut polygon: Vec<[f64; 3]> = corners.to_vec();
    let mut next = Vec::with_capacity(8);
    for plane in p.clip_planes() {
        let dist = |q: &[f64; 3]| plane[0] * q[0] + plane[1] * q[1] + plane[2] * q[2] + plane[3];
        next.clear();
        for i in 0..polygon.len() {
            let a = polygon[i];
            let b = polygon[(i + 1) % polygon.len()];
            let (da, db) = (dist(&a), dist(&b));
            if da >= 0.0 {
                next.push(a);
            }
            if (da >= 0.0) != (db >= 0.0) {
                next.push(edge_plane_intersection(a, da, b, db));
            }
        }
        std::mem::swap(&mut polygon, &mut next);
        if polygon.len() < 3 {
            return;
        }
    }
    let verts: Vec<ProjectedVertex> = polygon
        .iter()
        .map(|c| {
            let (u, v) = p.pixel_coords(*c);
            // Clipping leaves z ≥ near > 0, so the inverse depth is finite and positive.
            ProjectedVertex {
                xy: [snap(u), snap(v)],
                inv_z: (1.0 / c[2]) as f32,
            }
        })
        .collect();
    for i in 1..verts.len() - 1 {
        push_screen_triangle(out, [verts[0], verts[i], verts[i + 1]], face, p);
    }
}

/// Where segment `ab` crosses a plane, computed from the endpoints in a canonical
/// order so that two triangles sharing the edge get bit-identical points (no cracks).
fn edge_plane_intersection(a: [f64; 3], da: f64, b: [f64; 3], db: f64) -> [f64; 3] {
    let (s, ds, e, de) = if a < b {
        (a, da, b, db)
    } else {
        (b, db, a, da)
    };
    let t = ds / (ds - de);
    [
        s[0] + (e[0] - s[0]) * t,
        s[1] + (e[1] - s[1]) * t,
        s[2] + (e[2] - s[2]) * t,
    ]
}

/// Counting sort of triangle indices into bands by their row span, in face order.
fn bin_by_band(triangles: &[ScreenTriangle], height: u32) -> (Vec<usize>, Vec<u32>) {
    let bands = height.div_ceil(BAND_ROWS) as usize;
    let mut counts = vec![0usize; bands + 1];
    for t in triangles {
        for b in (t.y0 as u32 / BAND_ROWS)..=(t.y1 as u32 / BAND_ROWS) {
            counts[b as usize + 1] += 1;
        }
    }
    for b in 0..bands {
        counts[b + 1] += counts[b];
    }
    let offsets = counts.clone();
    let mut cursor = counts;
    let mut members = vec![0u32; offsets[bands]];
    for (i, t) in triangles.iter().enumerate() {
        for b in (t.y0 as u32 / BAND_ROWS)..=(t.y1 as u32 / BAND_ROWS) {
            members[cursor[b as usize]] = i as u32;
            cursor[b as usize] += 1;
        }
    }
    (offsets, members)
}

fn raster_band(
    triangles: &[ScreenTriangle],
    members: &[u32],
    row0: u32,
    width: u32,
    face_out: &mut [u32],
    depth_out: &mut [f32],
) {
    let rows = (face_out.len() / width as usize) as u32;
    let row_end = row0 + rows; // exclusive
    for &ti in members {
        let t = &triangles[ti as usize];
        let [a, b, c] = [t.vertex(0), t.vertex(1), t.vertex(2)];
        let (x0, x1) = (t.x0 as u32, t.x1 as u32);
        // Weights opposite each vertex, the top-left bias of their edges, and the
        // per-pixel steps; w0 + w1 + w2 = area everywhere.
        let edges = [(b, c), (c, a), (a, b)];
        let area = edge(a, b, c) as f32;
        let mut step_x = [0i64; 3];
        let mut step_y = [0i64; 3];
        let mut bias = [0i64; 3];
        for (k, (p, q)) in edges.iter().enumerate() {
            let dx = p[1] - q[1]; // ∂E/∂x
            let dy = q[0] - p[0]; // ∂E/∂y
            step_x[k] = dx * SUBPIXEL;
            step_y[k] = dy * SUBPIXEL;
            // Interior is where E > 0 and the gradient points inward: a left edge has
            // the interior to its right (∂E/∂x > 0), a top edge is horizontal with the
            // interior below it (y grows downward).
            let top_left = dx > 0 || (dx == 0 && dy > 0);
            bias[k] = i64::from(top_left);
        }
        let y_start = (t.y0 as u32).max(row0);
        let y_end = (t.y1 as u32).min(row_end - 1);
        if y_start > y_end {
            continue;
        }
        let px0 = [
            x0 as i64 * SUBPIXEL + SUBPIXEL / 2,
            y_start as i64 * SUBPIXEL + SUBPIXEL / 2,
        ];
        let mut row_w = [edge(b, c, px0), edge(c, a, px0), edge(a, b, px0)];
        let [iz0, iz1, iz2] = t.inv_z;
        for y in y_start..=y_end {
            let mut w = row_w;
            let row_base = ((y - row0) * width) as usize;
            for x in x0..=x1 {
                if w[0] + bias[0] > 0 && w[1] + bias[1] > 0 && w[2] + bias[2] > 0 {
                    let iz = (w[0] as f32 * iz0 + w[1] as f32 * iz1 + w[2] as f32 * iz2) / area;
                    let idx = row_base + x as usize;
                    if iz > depth_out[idx] {
                        depth_out[idx] = iz;
                        face_out[idx] = t.face;
                    }
                }
                for k in 0..3 {
                    w[k] += step_x[k];
                }
            }
            for k in 0..3 {
                row_w[k] += step_y[k];
            }
        }
    }
}

/// The ray through the centre of pixel `(x, y)`: camera centre and unit direction, in world space.
pub fn pixel_ray(camera: &Camera, x: f64, y: f64) -> (DVec3, DVec3) {
    let d_cam = DVec3::new(
        (x - camera.cx) / camera.fx,
        (y - camera.cy) / camera.fy,
        1.0,
    );
    let dir = (camera.rotation().transpose() * d_cam).normalize();
    (camera.center(), dir)
}

/// Where a ray meets the plane of triangle `(a, b, c)`, with the point's barycentric
/// coordinates; `None` when the ray is parallel to the plane or the triangle is degenerate.
/// This recovers the exact, perspective-correct surface point behind a rasterized pixel.
pub fn ray_triangle_plane(
    origin: DVec3,
    dir: DVec3,
    a: DVec3,
    b: DVec3,
    c: DVec3,
) -> Option<(DVec3, [f64; 3])> {
    let n = (b - a).cross(c - a);
    let n2 = n.length_squared();
    let denom = n.dot(dir);
    if n2 == 0.0 || denom.abs() < 1e-14 * n2.sqrt() {
        return None;
    }
    let t = n.dot(a - origin) / denom;
    let p = origin + dir * t;
    let l0 = (c - b).cross(p - b).dot(n) / n2;
    let l1 = (a - c).cross(p - c).dot(n) / n2;
    Some((p, [l0, l1, 1.0 - l0 - l1]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixel_span_matches_pixel_centres() {
        // Centres of pixels 0, 1, 2 are at 128, 384, 640 in 1/256 pixel.
        assert_eq!(pixel_span([128, 384, 200], 10), (Some(0), Some(1)));
        assert_eq!(pixel_span([129, 383, 200], 10), (None, None));
        assert_eq!(pixel_span([-5000, 300, 0], 10), (Some(0), Some(0)));
        assert_eq!(pixel_span([0, 100_000, 5], 10), (Some(0), Some(9)));
    }
}
