//! Per-vertex (camera transform, projection, SH colour, opacity) and per-face
//! (culling, 2D window and barycentric data) preprocessing.
//!
//! The window is evaluated in an equivalent closed form. For vertex k with
//! opposite edge length L_k and perimeter P, the distance of a point to that
//! edge is λ_k·2A/L_k (λ = screen-space barycentrics, A = area) and the
//! inradius is 2A/P, so `φ(p)/φ(s) = min_k λ_k(p)·P/L_k`: the edge attaining
//! the max in φ is the vertex attaining the min here, the incenter normaliser
//! and the edge-normal normalisation are the factor `P/L_k`. Differentiating
//! this expression is the full chain rule through all of them.

use super::binning::TileGrid;
use crate::backend::{PixelRect, RenderSettings};
use crate::model::Model;
use crate::parallel::{chunk_size, for_chunks_mut, run_iter};
use crate::real::Real;
use crate::sh;
use objectsplat_core::Camera;

/// The camera in the renderer's scalar type.
#[derive(Debug, Clone, Copy)]
pub struct CameraParams<R: Real> {
    pub width: u32,
    pub height: u32,
    pub fx: R,
    pub fy: R,
    pub cx: R,
    pub cy: R,
    /// Row-major world→camera rotation.
    pub rotation: [[R; 3]; 3],
    pub translation: [R; 3],
    pub center: [R; 3],
}

impl<R: Real> CameraParams<R> {
    pub fn new(camera: &Camera) -> Self {
        let rot = camera.rotation();
        let t = camera.translation();
        let c = camera.center();
        CameraParams {
            width: camera.width,
            height: camera.height,
            fx: R::of(camera.fx),
            fy: R::of(camera.fy),
            cx: R::of(camera.cx),
            cy: R::of(camera.cy),
            rotation: [0, 1, 2].map(|i| [0, 1, 2].map(|j| R::of(rot.col(j)[i]))),
            translation: [R::of(t.x), R::of(t.y), R::of(t.z)],
            center: [R::of(c.x), R::of(c.y), R::of(c.z)],
        }
    }

    #[inline]
    pub fn to_camera(&self, p: [R; 3]) -> [R; 3] {
        let r = &self.rotation;
        [0, 1, 2].map(|i| r[i][0] * p[0] + r[i][1] * p[1] + r[i][2] * p[2] + self.translation[i])
    }

    /// `Rᵀ·v`: a camera-space gradient back in world space.
    #[inline]
    pub fn to_world_vector(&self, v: [R; 3]) -> [R; 3] {
        let r = &self.rotation;
        [0, 1, 2].map(|j| r[0][j] * v[0] + r[1][j] * v[1] + r[2][j] * v[2])
    }
}

/// Per-vertex quantities of one view.
#[derive(Debug, Clone, Copy)]
pub struct VertexRow<R: Real> {
    pub cam: [R; 3],
    pub screen: [R; 2],
    pub color: [R; 3],
    pub clamped: [bool; 3],
    pub dir: [R; 3],
    pub distance: R,
    pub opacity: R,
}

pub type VertexData<R> = Vec<VertexRow<R>>;

/// Camera-space position, projection, view direction and opacity of every
/// vertex into `rows` (resized to the model); colours come later, only for
/// vertices of visible faces ([`shade_vertices`]).
pub fn preprocess_vertices<R: Real>(
    model: &Model<R>,
    cam: &CameraParams<R>,
    settings: &RenderSettings,
    threads: usize,
    rows: &mut VertexData<R>,
    sides: &mut Vec<u8>,
) {
    let n = model.vertex_count();
    let zero = VertexRow {
        cam: [R::zero(); 3],
        screen: [R::zero(); 2],
        color: [R::zero(); 3],
        clamped: [false; 3],
        dir: [R::zero(); 3],
        distance: R::zero(),
        opacity: R::zero(),
    };
    rows.clear();
    rows.resize(n, zero);
    sides.clear();
    sides.resize(n, 0);
    let chunk = chunk_size(n, threads, 4096);
    // Each job owns the same vertex range of both arrays.
    let jobs = rows.chunks_mut(chunk).zip(sides.chunks_mut(chunk));
    let z_near = R::of(settings.z_near);
    let (w, h) = (cam.width as f64, cam.height as f64);
    run_iter(
        threads,
        jobs.enumerate(),
        || (),
        |_, (job, (rows, sides))| {
            let start = job * chunk;
            for (i, (row, side)) in rows.iter_mut().zip(sides).enumerate() {
                let v = start + i;
                let p = model.vertices[v];
                let c = cam.to_camera(p);
                // Projection of points at or behind the camera is meaningless; such
                // vertices only belong to faces culled by `z_near`, so any finite value works.
                let screen = if c[2] > R::zero() {
                    [cam.fx * c[0] / c[2] + cam.cx, cam.fy * c[1] / c[2] + cam.cy]
                } else {
                    [R::zero(); 2]
                };
                let (dir, distance) = sh::view_direction(p, cam.center);
                *row = VertexRow {
                    cam: c,
                    screen,
                    color: [R::zero(); 3],
                    clamped: [false; 3],
                    dir,
                    distance,
                    opacity: model.vertex_opacity(v),
                };
                let (x, y) = (screen[0].f64(), screen[1].f64());
                let bit = |set: bool, bit: u8| if set { bit } else { 0 };
                *side = bit(!(c[2] > z_near), BEHIND)
                    | bit(x < 0.5, LEFT)
                    | bit(x > w - 0.5, RIGHT)
                    | bit(y < 0.5, ABOVE)
                    | bit(y > h - 0.5, BELOW);
            }
        },
    );
}

/// Where a vertex lies against the view ([`preprocess_vertices`]), as bits:
/// at or behind the near plane, or beyond an edge of the image far enough
/// that no pixel centre is on its side. A face with a corner behind, or
/// whose three corners are beyond the same edge, fails [`preprocess_face`]'s
/// near-plane or pixel-box test; `preprocess_faces` rejects it from three
/// bytes instead of three vertex rows (most faces of a room are outside a
/// view, and the rows are 56 bytes each).
const BEHIND: u8 = 1;
const LEFT: u8 = 2;
const RIGHT: u8 = 4;
const ABOVE: u8 = 8;
const BELOW: u8 = 16;

/// Whether the corners' [`BEHIND`]… bits alone reject a face.
#[inline]
fn outside(corners: [u8; 3]) -> bool {
    (corners[0] | corners[1] | corners[2]) & BEHIND != 0
        || corners[0] & corners[1] & corners[2] != 0
}

/// Everything the pixel loop needs about one visible face, in a local 2D
/// frame `q = p − origin` (origin = floor of the projected centroid, a
/// constant) so f32 keeps its precision far from the image origin.
#[derive(Debug, Clone, Copy)]
pub struct ScreenFace<R: Real> {
    /// Index into the model's faces.
    pub face: u32,
    pub origin: [R; 2],
    /// Projected corners in the local frame.
    pub q: [[R; 2]; 3],
    /// `λ_k(q) = lam[k][0]·qx + lam[k][1]·qy + lam[k][2]`.
    pub lam: [[R; 3]; 3],
    /// `P/L_k`: window argument `g_k = λ_k·scale[k]`, `φ/φ(s) = min_k g_k`.
    pub scale: [R; 3],
    /// Doubled signed area `cross(q1 − q0, q2 − q0)` and its inverse.
    pub area2: R,
    pub inv_area2: R,
    /// Edge lengths opposite each corner and the perimeter.
    pub len: [R; 3],
    pub perimeter: R,
    /// Window sharpness σ of this face.
    pub sigma: R,
    /// Triangle opacity (min of the corners') and the corner attaining it.
    pub opacity: R,
    pub argmin_corner: u8,
    pub color: [[R; 3]; 3],
    /// Camera depth of each corner.
    pub z: [R; 3],
    /// Centroid camera depth, the sort key.
    pub depth: R,
    /// Inclusive pixel range `[x0, x1] × [y0, y1]` whose centres may be inside.
    pub pixels: [u32; 4],
}

#[inline]
fn cross2<R: Real>(a: [R; 2], b: [R; 2]) -> R {
    a[0] * b[1] - a[1] * b[0]
}

/// Applies every culling rule; `None` when the face is not drawn.
pub fn preprocess_face<R: Real>(
    model: &Model<R>,
    verts: &VertexData<R>,
    cam: &CameraParams<R>,
    settings: &RenderSettings,
    f: usize,
) -> Option<ScreenFace<R>> {
    let idx = model.faces[f].map(|i| i as usize);
    let c = idx.map(|v| verts[v].cam);
    let z_near = R::of(settings.z_near);
    if c.iter().any(|p| !(p[2] > z_near)) {
        return None;
    }
    // Most faces of a room lie outside any one view: the pixel box, a few
    // compares, rejects them before the normal, extent and window arithmetic
    // (every rule must pass, so the order of the tests does not change which
    // faces are drawn).
    let p = idx.map(|v| verts[v].screen);
    let (w, h) = (cam.width as f64, cam.height as f64);
    let lo = |a: usize| p.iter().map(|pk| pk[a].f64()).fold(f64::INFINITY, f64::min);
    let hi = |a: usize| {
        p.iter()
            .map(|pk| pk[a].f64())
            .fold(f64::NEG_INFINITY, f64::max)
    };
    // Pixel i is sampled at i + 0.5; keep the centres within the bounding box.
    let x0 = (lo(0) - 0.5).ceil().max(0.0);
    let x1 = (hi(0) - 0.5).floor().min(w - 1.0);
    let y0 = (lo(1) - 0.5).ceil().max(0.0);
    let y1 = (hi(1) - 0.5).floor().min(h - 1.0);
    if x0 > x1 || y0 > y1 {
        return None;
    }
    let three = R::of(3.0);
    let centroid = [0, 1, 2].map(|a| (c[0][a] + c[1][a] + c[2][a]) / three);
    if !(centroid[2] > R::of(settings.min_centroid_depth)) {
        return None;
    }
    let e1 = [0, 1, 2].map(|a| c[1][a] - c[0][a]);
    let e2 = [0, 1, 2].map(|a| c[2][a] - c[0][a]);
    let n = [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ];
    let n_len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    let c_len =
        (centroid[0] * centroid[0] + centroid[1] * centroid[1] + centroid[2] * centroid[2]).sqrt();
    let dot = (n[0] * centroid[0] + n[1] * centroid[1] + n[2] * centroid[2]).abs();
    if !(n_len > R::zero()) || !(dot >= R::of(settings.min_abs_cos) * n_len * c_len) {
        return None;
    }
    let op = idx.map(|v| verts[v].opacity);
    let mut argmin = 0usize;
    for k in 1..3 {
        if op[k] < op[argmin] {
            argmin = k;
        }
    }
    let opacity = op[argmin];
    if !(opacity >= R::of(settings.min_opacity)) {
        return None;
    }
    let pc = [
        (p[0][0] + p[1][0] + p[2][0]) / three,
        (p[0][1] + p[1][1] + p[2][1]) / three,
    ];
    let mut extent = R::zero();
    for pk in &p {
        let d = ((pk[0] - pc[0]).powi(2) + (pk[1] - pc[1]).powi(2)).sqrt();
        extent = extent.max(d);
    }
    if !(extent <= R::of(settings.max_screen_extent))
        || !(extent >= R::of(settings.min_screen_extent))
    {
        return None;
    }
    let origin = [pc[0].floor(), pc[1].floor()];
    let q = p.map(|pk| [pk[0] - origin[0], pk[1] - origin[1]]);
    let area2 = cross2(
        [q[1][0] - q[0][0], q[1][1] - q[0][1]],
        [q[2][0] - q[0][0], q[2][1] - q[0][1]],
    );
    let len = [0, 1, 2].map(|k| {
        let (a, b) = (q[(k + 1) % 3], q[(k + 2) % 3]);
        ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt()
    });
    let perimeter = len[0] + len[1] + len[2];
    let inradius = area2.abs() / perimeter;
    if !(inradius >= R::of(settings.min_inradius)) {
        return None;
    }
    let inv_area2 = R::one() / area2;
    let lam = [0, 1, 2].map(|k| {
        let (a, b) = (q[(k + 1) % 3], q[(k + 2) % 3]);
        // λ_k(q) = cross(a − q, b − q)/A2 = (cross(a, b) + cross(b − a, q))/A2.
        [
            -(b[1] - a[1]) * inv_area2,
            (b[0] - a[0]) * inv_area2,
            cross2(a, b) * inv_area2,
        ]
    });
    let scale = len.map(|l| perimeter / l);

    Some(ScreenFace {
        face: f as u32,
        origin,
        q,
        lam,
        scale,
        area2,
        inv_area2,
        len,
        perimeter,
        sigma: R::of(model.face_sigma.get(f).copied().unwrap_or(settings.sigma)),
        opacity,
        argmin_corner: argmin as u8,
        // Filled by `shade_vertices` once the visible faces are known.
        color: [[R::zero(); 3]; 3],
        z: [c[0][2], c[1][2], c[2][2]],
        depth: centroid[2],
        pixels: [x0 as u32, y0 as u32, x1 as u32, y1 as u32],
    })
}

/// Every model face that survives culling, in face order, as consecutive
/// runs (one per job, so each worker appends to its own): `visible` is
/// resized to the number of runs and keeps its allocations between calls.
/// Only the survivors are written; most faces of a room are outside a view.
pub fn preprocess_faces<R: Real>(
    model: &Model<R>,
    verts: &VertexData<R>,
    sides: &[u8],
    cam: &CameraParams<R>,
    settings: &RenderSettings,
    threads: usize,
    visible: &mut Vec<Vec<ScreenFace<R>>>,
) {
    let n = model.face_count();
    let run = chunk_size(n, threads, 4096);
    visible.resize_with(n.div_ceil(run), Vec::new);
    for_chunks_mut(threads, visible, 1, |index, out| {
        let out = &mut out[0];
        out.clear();
        let faces = index * run..((index + 1) * run).min(n);
        out.extend(faces.filter_map(|f| {
            let corners = model.faces[f].map(|v| sides[v as usize]);
            if outside(corners) {
                return None;
            }
            preprocess_face(model, verts, cam, settings, f)
        }));
    });
}

/// The bounding rectangle of the faces' pixel boxes (empty without faces).
pub fn footprint<'a, R: Real>(faces: impl Iterator<Item = &'a ScreenFace<R>>) -> PixelRect {
    faces.fold(PixelRect::default(), |r, f| {
        r.union(PixelRect {
            x0: f.pixels[0],
            y0: f.pixels[1],
            x1: f.pixels[2] + 1,
            y1: f.pixels[3] + 1,
        })
    })
}

/// Evaluates the SH colour of every vertex used by a visible face and copies
/// the corner colours into the faces. `used` is scratch.
pub fn shade_vertices<R: Real>(
    model: &Model<R>,
    verts: &mut VertexData<R>,
    faces: &mut [ScreenFace<R>],
    face_ids: &[u32],
    sh_degree: u32,
    threads: usize,
    used: &mut Vec<bool>,
) {
    used.clear();
    used.resize(verts.len(), false);
    for &f in face_ids {
        for &v in &model.faces[f as usize] {
            used[v as usize] = true;
        }
    }
    let n = verts.len();
    let used: &[bool] = used;
    for_chunks_mut(
        threads,
        verts,
        chunk_size(n, threads, 4096),
        |start, chunk| {
            for (i, row) in chunk.iter_mut().enumerate() {
                if used[start + i] {
                    let (color, clamped) =
                        sh::vertex_color(&model.sh[start + i], row.dir, sh_degree);
                    row.color = color;
                    row.clamped = clamped;
                }
            }
        },
    );
    let verts: &VertexData<R> = verts;
    let nf = faces.len();
    for_chunks_mut(threads, faces, chunk_size(nf, threads, 4096), |_, chunk| {
        for f in chunk {
            f.color = model.faces[f.face as usize].map(|v| verts[v as usize].color);
        }
    });
}

/// The faces that survived culling (`visible`, in face order) into `faces`
/// (and their model face indices into `face_ids`),
/// stably sorted by the tile of their pixel box's top-left corner (a counting
/// sort, one copy of each face), so a tile's faces sit close together in
/// memory. Row-major tile order restricted to a tile-aligned region is the
/// full grid's order, so a region's faces get the slots they would have in a
/// full render.
pub fn order_by_tile<R: Real>(
    visible: &[Vec<ScreenFace<R>>],
    grid: &TileGrid,
    faces: &mut Vec<ScreenFace<R>>,
    face_ids: &mut Vec<u32>,
    counts: &mut Vec<usize>,
) {
    let key = |f: &ScreenFace<R>| {
        grid.tile_range(f.pixels)
            .map_or(0, |(tx, ty, _, _)| (ty * grid.tiles_x + tx) as usize)
    };
    let buckets = grid.tile_count().max(1);
    counts.clear();
    counts.resize(buckets + 1, 0);
    for f in visible.iter().flatten() {
        counts[key(f) + 1] += 1;
    }
    for b in 0..buckets {
        counts[b + 1] += counts[b];
    }
    let Some(first) = visible.iter().flatten().next() else {
        faces.clear();
        face_ids.clear();
        return;
    };
    // Every position below `counts[buckets]` is written once by the loop, so
    // what the buffers held from the last render need not be cleared first
    // (refilling them was about 1 % of a background's step, on one core).
    faces.truncate(counts[buckets]);
    faces.resize(counts[buckets], *first);
    face_ids.truncate(counts[buckets]);
    face_ids.resize(counts[buckets], 0);
    for f in visible.iter().flatten() {
        let k = key(f);
        faces[counts[k]] = *f;
        face_ids[counts[k]] = f.face;
        counts[k] += 1;
    }
}
