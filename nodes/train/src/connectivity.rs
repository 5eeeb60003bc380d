//! The connectivity step (restricted Delaunay triangulation): turns the
//! triangle soup into a connected mesh over the same vertices.
//!
//! Tetrahedralize all vertices; keep each interior face (shared by two
//! tetrahedra) whose dual Voronoi edge, the segment between the two
//! circumcentres, hits the current soup. Vertices keep their indices, so
//! their parameters and optimizer state survive; only the faces change.
//!
//! Unlike the reference, faces on the convex hull are tested too (their dual
//! edge is a ray along the outward normal): the surface of an object trained
//! alone is largely its own convex hull, and interior faces alone lose it.

use crate::delaunay::{NO_TET, tetrahedralize};
use crate::vec3::{V3, cross, dot, sub};
use anyhow::{Result, bail};

/// Hit tolerance of the segment–triangle test (barycentric and segment parameter), inclusive.
const HIT_EPS: f64 = 1e-9;

fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}

/// Circumcentre of a tetrahedron; its centroid when the tetrahedron is so flat
/// that the circumcentre is numerically meaningless.
pub fn circumcenter(a: V3, b: V3, c: V3, d: V3) -> V3 {
    let (u, v, w) = (sub(b, a), sub(c, a), sub(d, a));
    let det = dot(u, cross(v, w));
    let longest = norm(u)
        .max(norm(v))
        .max(norm(w))
        .max(norm(sub(c, b)))
        .max(norm(sub(d, b)))
        .max(norm(sub(d, c)));
    if !(det.abs() > 1e-12 * longest.powi(3)) {
        return [0, 1, 2].map(|k| 0.25 * (a[k] + b[k] + c[k] + d[k]));
    }
    let (vw, wu, uv) = (cross(v, w), cross(w, u), cross(u, v));
    let (uu, vv, ww) = (dot(u, u), dot(v, v), dot(w, w));
    [0, 1, 2].map(|k| a[k] + (uu * vw[k] + vv * wu[k] + ww * uv[k]) / (2.0 * det))
}

/// Möller–Trumbore segment `p → q` against a triangle, boundaries inclusive.
pub fn segment_hits_triangle(p: V3, q: V3, tri: [V3; 3]) -> bool {
    let d = sub(q, p);
    let e1 = sub(tri[1], tri[0]);
    let e2 = sub(tri[2], tri[0]);
    let pvec = cross(d, e2);
    let det = dot(e1, pvec);
    let scale = norm(d) * norm(e1) * norm(e2);
    if !(det.abs() > 1e-12 * scale) {
        // Parallel (or degenerate): a segment in the triangle's plane is not a crossing.
        return false;
    }
    let inv = 1.0 / det;
    let tvec = sub(p, tri[0]);
    let u = dot(tvec, pvec) * inv;
    if !(-HIT_EPS..=1.0 + HIT_EPS).contains(&u) {
        return false;
    }
    let qvec = cross(tvec, e1);
    let v = dot(d, qvec) * inv;
    if v < -HIT_EPS || u + v > 1.0 + HIT_EPS {
        return false;
    }
    let t = dot(e2, qvec) * inv;
    (-HIT_EPS..=1.0 + HIT_EPS).contains(&t)
}

/// A bounding-volume hierarchy over triangles for segment any-hit queries.
pub struct TriangleBvh {
    triangles: Vec<[V3; 3]>,
    /// Node: box, then either children (left, right) or a leaf range of `order`.
    nodes: Vec<BvhNode>,
    order: Vec<u32>,
}

struct BvhNode {
    lo: V3,
    hi: V3,
    /// Leaf: `start..end` in `order`; inner: `start` = left child, `end` = right child.
    start: u32,
    end: u32,
    leaf: bool,
}

const LEAF_SIZE: usize = 4;

impl TriangleBvh {
    pub fn new(triangles: Vec<[V3; 3]>) -> TriangleBvh {
        let mut bvh = TriangleBvh {
            order: (0..triangles.len() as u32).collect(),
            triangles,
            nodes: Vec::new(),
        };
        if !bvh.triangles.is_empty() {
            let n = bvh.order.len();
            bvh.build(0, n);
        }
        bvh
    }

    fn bounds(&self, start: usize, end: usize) -> (V3, V3) {
        objectsplat_core::geometry::bounding_box(
            self.order[start..end]
                .iter()
                .flat_map(|&t| self.triangles[t as usize]),
        )
    }

    fn build(&mut self, start: usize, end: usize) -> u32 {
        let (lo, hi) = self.bounds(start, end);
        let id = self.nodes.len() as u32;
        self.nodes.push(BvhNode {
            lo,
            hi,
            start: start as u32,
            end: end as u32,
            leaf: true,
        });
        if end - start <= LEAF_SIZE {
            return id;
        }
        let axis = (0..3)
            .max_by(|&a, &b| (hi[a] - lo[a]).total_cmp(&(hi[b] - lo[b])))
            .unwrap_or(0);
        let tris = &self.triangles;
        let centroid = |t: u32| -> f64 { tris[t as usize].iter().map(|p| p[axis]).sum::<f64>() };
        let mid = (start + end) / 2;
        self.order[start..end]
            .select_nth_unstable_by(mid - start, |&a, &b| centroid(a).total_cmp(&centroid(b)));
        let left = self.build(start, mid);
        let right = self.build(mid, end);
        let node = &mut self.nodes[id as usize];
        node.leaf = false;
        node.start = left;
        node.end = right;
        id
    }

    fn segment_hits_box(p: V3, q: V3, lo: V3, hi: V3) -> bool {
        let (mut t0, mut t1) = (0.0f64, 1.0f64);
        for k in 0..3 {
            let d = q[k] - p[k];
            let pad = HIT_EPS * (1.0 + hi[k].abs().max(lo[k].abs()));
            if d == 0.0 {
                if p[k] < lo[k] - pad || p[k] > hi[k] + pad {
                    return false;
                }
                continue;
            }
            let (a, b) = ((lo[k] - pad - p[k]) / d, (hi[k] + pad - p[k]) / d);
            t0 = t0.max(a.min(b));
            t1 = t1.min(a.max(b));
            if t0 > t1 {
                return false;
            }
        }
        true
    }

    /// Whether the segment `p → q` touches any triangle.
    pub fn any_hit(&self, p: V3, q: V3) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let mut stack = vec![0u32];
        while let Some(id) = stack.pop() {
            let node = &self.nodes[id as usize];
            if !Self::segment_hits_box(p, q, node.lo, node.hi) {
                continue;
            }
            if node.leaf {
                let hit = self.order[node.start as usize..node.end as usize]
                    .iter()
                    .any(|&t| segment_hits_triangle(p, q, self.triangles[t as usize]));
                if hit {
                    return true;
                }
            } else {
                stack.push(node.start);
                stack.push(node.end);
            }
        }
        false
    }
}

/// Options of the connectivity step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ConnectivityOptions {
    /// Also test faces on the convex hull, whose dual Voronoi edge is a ray. The
    /// reference keeps interior faces only, which drops most of a convex
    /// object's surface (its faces are hull faces); on by default.
    pub include_hull_faces: bool,
    /// Seed of the tetrahedralization's tie-breaking jitter.
    pub seed: u64,
}

impl Default for ConnectivityOptions {
    fn default() -> Self {
        ConnectivityOptions {
            include_hull_faces: true,
            seed: 0,
        }
    }
}

/// The restricted Delaunay faces of `vertices` with respect to the soup `faces`
/// (unoriented, indices into `vertices`, sorted).
pub fn restricted_delaunay(
    vertices: &[[f32; 3]],
    faces: &[[u32; 3]],
    options: ConnectivityOptions,
) -> Result<Vec<[u32; 3]>> {
    let seed = options.seed;
    let points: Vec<V3> = vertices.iter().map(|p| p.map(f64::from)).collect();
    if let Some(i) = faces
        .iter()
        .position(|f| f.iter().any(|&v| v as usize >= points.len()))
    {
        bail!(
            "face {i} {:?} references a vertex beyond the {} vertices",
            faces[i],
            points.len()
        );
    }
    let tet = tetrahedralize(&points, seed)?;
    let bvh = TriangleBvh::new(
        faces
            .iter()
            .map(|f| f.map(|v| points[v as usize]))
            .collect(),
    );
    let centres: Vec<V3> = tet
        .tets
        .iter()
        .map(|t| {
            let [a, b, c, d] = t.map(|v| points[v as usize]);
            circumcenter(a, b, c, d)
        })
        .collect();
    // A hull face's dual Voronoi edge is a ray from its tetrahedron's circumcentre
    // along the outward face normal; a segment this long reaches past every triangle.
    let (lo, hi) = points.iter().fold(
        ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]),
        |(lo, hi), p| {
            (
                [0, 1, 2].map(|k| lo[k].min(p[k])),
                [0, 1, 2].map(|k| hi[k].max(p[k])),
            )
        },
    );
    let middle = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let reach = 4.0 * norm(sub(hi, lo));
    let mut out = Vec::new();
    for (t, nbrs) in tet.neighbors.iter().enumerate() {
        for (k, &o) in nbrs.iter().enumerate() {
            let v = tet.tets[t];
            let mut face: Vec<u32> = (0..4).filter(|&i| i != k).map(|i| v[i]).collect();
            let far = if o == NO_TET {
                if !options.include_hull_faces {
                    continue;
                }
                let [a, b, c] = [face[0], face[1], face[2]].map(|i| points[i as usize]);
                let mut n = cross(sub(b, a), sub(c, a));
                if dot(n, sub(points[v[k] as usize], a)) > 0.0 {
                    n = n.map(|x| -x);
                }
                let len = norm(n);
                if !(len > 0.0) {
                    continue;
                }
                let l = reach + norm(sub(centres[t], middle));
                [0, 1, 2].map(|i| centres[t][i] + n[i] / len * l)
            } else if (o as usize) < t {
                // Each interior face is seen from both sides; take it from the lower index.
                continue;
            } else {
                centres[o as usize]
            };
            if bvh.any_hit(centres[t], far) {
                face.sort_unstable();
                out.push([face[0], face[1], face[2]]);
            }
        }
    }
    out.sort_unstable();
    Ok(out)
}
