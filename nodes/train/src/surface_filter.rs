//! Keeps the connected mesh a surface: feature-preserving normal filtering
//! followed by a vertex update that fits the filtered normals (the two-step
//! mesh denoising of Sun et al., "Fast and effective feature-preserving mesh
//! denoising", 2007).
//!
//! After the connectivity step the photometric loss barely constrains where a
//! vertex sits along the surface's normal: on the team's room at 320×240 the
//! exported faces lie within 1–2 cm of the true surfaces but a third of the
//! table's and the background's area is tilted more than 45° from them
//! (shingles; normal consistency 0.81). A face's tilt is the difference of
//! its corners' offsets over its size, so millimetre offsets on centimetre
//! faces are enough. The filter averages each face's normal with those of the
//! faces sharing a vertex with it, each weighted by area and by how parallel
//! it already is, and faces at a crease (|cos| at or below the crease cosine)
//! take no part, so a wall meeting the floor or a table's edge stays sharp.
//! The vertex update then moves each vertex along the filtered normals of
//! its faces towards their planes (through the faces' centroids): it moves
//! vertices along normals only, so the mesh neither drifts nor shrinks the
//! way a Laplacian smoothing does.
//!
//! Normals are treated as axes (a neighbour's normal is flipped to agree in
//! sign): the restricted Delaunay faces carry no consistent orientation, and
//! two overlapping shingles are flattened into one plane rather than kept as
//! a fold.

use crate::vec3::{V3, dot, proper_cross, sub};
use objectsplat_raster::parallel::{chunk_size, for_chunks_mut};
use std::sync::atomic::{AtomicUsize, Ordering};

/// One pass's numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfaceFilter {
    /// Neighbours whose normal makes |cos| ≤ this with a face's take no part in its filtered normal.
    pub crease_cos: f64,
    /// Rounds of normal filtering.
    pub normal_rounds: usize,
    /// Rounds of the vertex update.
    pub vertex_rounds: usize,
}

/// What a pass changed.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FilterReport {
    /// Vertices that moved.
    pub moved: usize,
    /// The largest distance a vertex moved (world units).
    pub largest_move: f64,
    /// Vertex moves shortened to half the vertex's shortest edge.
    pub limited: usize,
}

fn to64(p: [f32; 3]) -> V3 {
    [p[0] as f64, p[1] as f64, p[2] as f64]
}

/// A face's unit normal and area, read together for every neighbour of
/// every face (so stored together); [`Facet::DEGENERATE`] for a degenerate
/// face (no normal to filter or fit). The rounds gather these at random from
/// arrays of a million faces: a NaN area marks a degenerate face, rather than
/// an `Option`, so that one takes 32 bytes, not 40, and two fill a cache line.
#[derive(Debug, Clone, Copy)]
struct Facet {
    normal: V3,
    area: f64,
}

impl Facet {
    const DEGENERATE: Facet = Facet {
        normal: [0.0; 3],
        area: f64::NAN,
    };

    /// A proper face's area is finite and positive, never NaN.
    fn is_proper(&self) -> bool {
        !self.area.is_nan()
    }
}

/// The unit normal and area of a face, [`Facet::DEGENERATE`] when degenerate.
fn facet(vertices: &[V3], face: [u32; 3]) -> Facet {
    match proper_cross(face.map(|v| vertices[v as usize])) {
        Some((m, twice_area)) => Facet {
            normal: m.map(|x| x / twice_area),
            area: 0.5 * twice_area,
        },
        None => Facet::DEGENERATE,
    }
}

/// What a vertex round needs of a face: its centroid (`None` when the face is
/// degenerate) and half the length of each edge `k → k + 1`.
#[derive(Debug, Clone, Copy, Default)]
struct RoundFace {
    centroid: Option<V3>,
    half_edges: [f64; 3],
}

fn round_face(vertices: &[V3], face: [u32; 3]) -> RoundFace {
    let corners = face.map(|v| vertices[v as usize]);
    let [a, b, c] = corners;
    RoundFace {
        centroid: proper_cross(corners).map(|_| [0, 1, 2].map(|k| (a[k] + b[k] + c[k]) / 3.0)),
        half_edges: [0, 1, 2].map(|k| {
            let e = sub(corners[k], corners[(k + 1) % 3]);
            0.5 * dot(e, e).sqrt()
        }),
    }
}

/// For each vertex, the faces that use it, in compressed rows
/// (`faces_of[start[v]..start[v + 1]]`), built in buffers kept between passes.
#[derive(Debug, Default)]
struct VertexFaces {
    start: Vec<usize>,
    cursor: Vec<usize>,
    faces_of: Vec<u32>,
}

impl VertexFaces {
    fn rebuild(&mut self, vertex_count: usize, faces: &[[u32; 3]]) {
        let start = &mut self.start;
        start.clear();
        start.resize(vertex_count + 1, 0);
        for face in faces {
            for &v in face {
                start[v as usize + 1] += 1;
            }
        }
        for v in 0..vertex_count {
            start[v + 1] += start[v];
        }
        self.cursor.clear();
        self.cursor.extend_from_slice(start);
        self.faces_of.clear();
        self.faces_of.resize(start[vertex_count], 0);
        for (f, face) in faces.iter().enumerate() {
            for &v in face {
                let slot = &mut self.cursor[v as usize];
                self.faces_of[*slot] = f as u32;
                *slot += 1;
            }
        }
    }

    fn at(&self, v: usize) -> &[u32] {
        &self.faces_of[self.start[v]..self.start[v + 1]]
    }
}

/// The working arrays of [`SurfaceFilter::apply`], kept by the caller between
/// passes: on a background of a million faces they are ~150 MB, and
/// allocating them anew every pass cost more in page faults and zeroing than
/// some of the rounds that fill them. Their contents never carry over from
/// one pass to the next (every pass rewrites what it reads).
#[derive(Debug, Default)]
pub struct SurfaceScratch {
    points: Vec<V3>,
    vertex_faces: VertexFaces,
    facets: Vec<Facet>,
    filtered: Vec<Facet>,
    round_faces: Vec<RoundFace>,
}

/// `out[i] = value(i)` for every `i`, spread over `threads` (each value
/// depends only on its index, so the result does not depend on the thread count).
fn fill<T: Send>(threads: usize, out: &mut [T], value: impl Fn(usize) -> T + Sync) {
    let chunk = chunk_size(out.len(), threads, 4096);
    for_chunks_mut(threads, out, chunk, |first, part| {
        for (i, slot) in part.iter_mut().enumerate() {
            *slot = value(first + i);
        }
    });
}

impl SurfaceFilter {
    /// Filters the normals of `faces` and moves `vertices` to fit them (see
    /// the module docs), on up to `threads` threads (the result does not
    /// depend on how many, nor on what `scratch` held before). Vertices of no
    /// non-degenerate face stay where they are; a move that is not finite is
    /// not made. Face indices must be in range (a validated model's are).
    pub fn apply(
        &self,
        vertices: &mut [[f32; 3]],
        faces: &[[u32; 3]],
        threads: usize,
        scratch: &mut SurfaceScratch,
    ) -> FilterReport {
        let SurfaceScratch {
            points,
            vertex_faces,
            facets,
            filtered,
            round_faces,
        } = scratch;
        // Every element of each array is written by `fill` before it is read,
        // so resizing (which keeps a previous pass's values) is enough.
        points.resize(vertices.len(), [0.0; 3]);
        fill(threads, points, |v| to64(vertices[v]));
        vertex_faces.rebuild(points.len(), faces);
        let faces_at = |v: usize| vertex_faces.at(v);
        facets.resize(faces.len(), Facet::DEGENERATE);
        fill(threads, facets, |f| facet(points, faces[f]));
        filtered.resize(faces.len(), Facet::DEGENERATE);
        for _ in 0..self.normal_rounds {
            let facets_now: &[Facet] = facets;
            fill(threads, filtered, |f| {
                let own = facets_now[f];
                if !own.is_proper() {
                    return Facet::DEGENERATE;
                }
                let mut sum = [0.0; 3];
                // A neighbour sharing an edge is reached through two
                // vertices and counts twice: it is the closer one.
                for &v in &faces[f] {
                    for &g in faces_at(v as usize) {
                        let neighbour = facets_now[g as usize];
                        if !neighbour.is_proper() {
                            continue;
                        }
                        let n = neighbour.normal;
                        let cos = dot(own.normal, n);
                        let parallel = cos.abs() - self.crease_cos;
                        if parallel <= 0.0 {
                            continue;
                        }
                        let w = neighbour.area * parallel * parallel * cos.signum();
                        for k in 0..3 {
                            sum[k] += w * n[k];
                        }
                    }
                }
                let length = dot(sum, sum).sqrt();
                // The face itself always takes part (cos 1), so only
                // cancelling neighbours leave no direction: keep its own.
                Facet {
                    normal: if length > 0.0 && length.is_finite() {
                        sum.map(|x| x / length)
                    } else {
                        own.normal
                    },
                    area: own.area,
                }
            });
            std::mem::swap(facets, filtered);
        }
        let limited = AtomicUsize::new(0);
        round_faces.resize(faces.len(), RoundFace::default());
        for _ in 0..self.vertex_rounds {
            fill(threads, round_faces, |f| round_face(points, faces[f]));
            let (facets, round_faces): (&[Facet], &[RoundFace]) = (facets, round_faces);
            // Each vertex reads only its own position and the round's faces.
            let chunk = chunk_size(points.len(), threads, 4096);
            for_chunks_mut(threads, points, chunk, |first, part| {
                let mut shortened = 0;
                for (i, x) in part.iter_mut().enumerate() {
                    let v = first + i;
                    let (mut shift, mut weight) = ([0.0; 3], 0.0);
                    // A vertex that moves further than half its shortest edge can fold
                    // its faces over one another: a large face whose filtered normal
                    // turned by θ asks its corners to move by up to its size × sin θ.
                    let mut reach = f64::INFINITY;
                    for &f in faces_at(v) {
                        let f = f as usize;
                        let round = &round_faces[f];
                        for k in 0..3 {
                            let touches =
                                faces[f][k] as usize == v || faces[f][(k + 1) % 3] as usize == v;
                            if touches && round.half_edges[k] > 0.0 {
                                reach = reach.min(round.half_edges[k]);
                            }
                        }
                        let facet = facets[f];
                        let Some(c) = round.centroid.filter(|_| facet.is_proper()) else {
                            continue;
                        };
                        let n = facet.normal;
                        let along = dot(n, sub(c, *x));
                        for k in 0..3 {
                            shift[k] += facet.area * along * n[k];
                        }
                        weight += facet.area;
                    }
                    if weight > 0.0 {
                        let mut step = shift.map(|c| c / weight);
                        let length = dot(step, step).sqrt();
                        if length > reach {
                            step = step.map(|c| c * reach / length);
                            shortened += 1;
                        }
                        let moved = [0, 1, 2].map(|k| x[k] + step[k]);
                        if moved.iter().all(|c| c.is_finite()) {
                            *x = moved;
                        }
                    }
                }
                limited.fetch_add(shortened, Ordering::Relaxed);
            });
        }
        let mut report = FilterReport {
            limited: limited.into_inner(),
            ..FilterReport::default()
        };
        for (v, p) in points.iter().enumerate() {
            // The pass started from the model's own positions (`to64` is exact).
            let d = sub(*p, to64(vertices[v]));
            let distance = dot(d, d).sqrt();
            if distance > 0.0 {
                let narrowed = p.map(|c| c as f32);
                // The f32 model cannot hold a position beyond its range.
                if narrowed.iter().all(|c| c.is_finite()) && narrowed != vertices[v] {
                    vertices[v] = narrowed;
                    report.moved += 1;
                    report.largest_move = report.largest_move.max(distance);
                }
            }
        }
        report
    }
}
