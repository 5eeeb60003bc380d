//! 3D Delaunay tetrahedralization by incremental Bowyer–Watson insertion with
//! exact orientation and in-sphere predicates (`robust`).
//!
//! Exact degeneracies (coplanar, cospherical, collinear inputs) are broken by a
//! tiny seeded jitter applied to the copy the predicates see, so the output
//! refers to the caller's points by index and never to moved coordinates.
//! Exact duplicates are inserted once; the others are reported as skipped.

use anyhow::{Result, bail};
use objectsplat_core::geometry::morton_code;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use robust::{Coord3D, insphere, orient3d};
use std::collections::HashMap;

/// No neighbour across this face (the hull of the input, or the enclosing super-tetrahedron).
pub const NO_TET: u32 = u32::MAX;

/// Relative size of the symbolic-perturbation jitter (of the bounding-box diagonal).
const JITTER: f64 = 1e-9;
/// The enclosing tetrahedron's size in bounding-box diagonals: large, so that
/// it barely changes which hull faces come out.
const SUPER_SCALE: f64 = 1e4;

/// A tetrahedralization of a point set, in input indices.
#[derive(Debug, Clone, PartialEq)]
pub struct Tetrahedralization {
    /// Positively oriented tetrahedra (`orient3d > 0` on the jittered points).
    pub tets: Vec<[u32; 4]>,
    /// `neighbors[t][k]`: the tetrahedron across the face opposite corner `k`, or [`NO_TET`].
    pub neighbors: Vec<[u32; 4]>,
    /// Input points not inserted: exact duplicates of an earlier point, and points whose
    /// insertion was refused as numerically degenerate.
    pub skipped: Vec<u32>,
}

fn c3(p: [f64; 3]) -> Coord3D<f64> {
    Coord3D {
        x: p[0],
        y: p[1],
        z: p[2],
    }
}

struct Mesh {
    points: Vec<[f64; 3]>,
    verts: Vec<[u32; 4]>,
    nbrs: Vec<[u32; 4]>,
    alive: Vec<bool>,
    stamp: Vec<u32>,
    generation: u32,
    free: Vec<u32>,
}

/// One face of the cavity's boundary: the cavity tet's corners with corner `k`
/// to be replaced by the new point, and the outside tet (with the index of the
/// face through which it sees the cavity).
struct BoundaryFace {
    verts: [u32; 4],
    k: usize,
    outer: u32,
    outer_face: usize,
}

impl Mesh {
    fn orient(&self, v: [u32; 4]) -> f64 {
        let p = |i: u32| c3(self.points[i as usize]);
        orient3d(p(v[0]), p(v[1]), p(v[2]), p(v[3]))
    }

    /// > 0 when point `q` lies strictly inside the circumsphere of tet `t`.
    fn in_sphere(&self, t: u32, q: u32) -> f64 {
        let v = self.verts[t as usize];
        let p = |i: u32| c3(self.points[i as usize]);
        insphere(p(v[0]), p(v[1]), p(v[2]), p(v[3]), p(q))
    }

    fn alloc(&mut self, v: [u32; 4]) -> u32 {
        if let Some(t) = self.free.pop() {
            let i = t as usize;
            self.verts[i] = v;
            self.nbrs[i] = [NO_TET; 4];
            self.alive[i] = true;
            t
        } else {
            self.verts.push(v);
            self.nbrs.push([NO_TET; 4]);
            self.alive.push(true);
            self.stamp.push(0);
            (self.verts.len() - 1) as u32
        }
    }

    /// Visibility walk from `start` to a tet containing point `q` (on its boundary allowed).
    fn locate(&self, start: u32, q: u32, rng: &mut Pcg64Mcg) -> Result<u32> {
        let mut t = start;
        let limit = 4 * self.verts.len() + 1000;
        for _ in 0..limit {
            let v = self.verts[t as usize];
            let offset = rng.random_range(0..4usize);
            let mut next = None;
            for j in 0..4 {
                let k = (j + offset) % 4;
                let mut w = v;
                w[k] = q;
                if self.orient(w) < 0.0 {
                    next = Some(self.nbrs[t as usize][k]);
                    break;
                }
            }
            match next {
                None => return Ok(t),
                Some(NO_TET) => bail!("point {q} lies outside the enclosing tetrahedron"),
                Some(n) => t = n,
            }
        }
        bail!("point location for point {q} did not terminate (degenerate triangulation)")
    }

    /// Inserts point `q`; returns a new tet, or None when the insertion was refused.
    fn insert(&mut self, q: u32, start: u32, rng: &mut Pcg64Mcg) -> Result<Option<u32>> {
        let t0 = self.locate(start, q, rng)?;
        if self.verts[t0 as usize]
            .iter()
            .any(|&v| self.points[v as usize] == self.points[q as usize])
        {
            return Ok(None);
        }
        self.generation += 1;
        let g = self.generation;
        let mut cavity = vec![t0];
        self.stamp[t0 as usize] = g;
        let mut i = 0;
        while i < cavity.len() {
            let t = cavity[i];
            i += 1;
            for k in 0..4 {
                let n = self.nbrs[t as usize][k];
                if n != NO_TET && self.stamp[n as usize] != g && self.in_sphere(n, q) > 0.0 {
                    self.stamp[n as usize] = g;
                    cavity.push(n);
                }
            }
        }
        // The cavity must be star-shaped from q: every boundary face strictly visible.
        // Exact predicates guarantee it for a Delaunay mesh; grow it if a face is flat.
        let boundary = loop {
            let mut faces = Vec::new();
            let mut grow = None;
            for &t in &cavity {
                for k in 0..4 {
                    let n = self.nbrs[t as usize][k];
                    if n != NO_TET && self.stamp[n as usize] == g {
                        continue;
                    }
                    let mut w = self.verts[t as usize];
                    w[k] = q;
                    if self.orient(w) <= 0.0 {
                        grow = Some(n);
                        break;
                    }
                    let outer_face = if n == NO_TET {
                        0
                    } else {
                        self.nbrs[n as usize]
                            .iter()
                            .position(|&b| b == t)
                            .ok_or_else(|| {
                                anyhow::anyhow!(
                                    "tetrahedra {t} and {n} are not mutual neighbours \
                                     (internal error in the tetrahedralization)"
                                )
                            })?
                    };
                    faces.push(BoundaryFace {
                        verts: self.verts[t as usize],
                        k,
                        outer: n,
                        outer_face,
                    });
                }
                if grow.is_some() {
                    break;
                }
            }
            match grow {
                None => break faces,
                Some(NO_TET) => return Ok(None),
                Some(n) => {
                    if cavity.len() > 64 * 1024 {
                        return Ok(None);
                    }
                    self.stamp[n as usize] = g;
                    cavity.push(n);
                }
            }
        };
        for &t in &cavity {
            self.alive[t as usize] = false;
            self.free.push(t);
        }
        let mut open: HashMap<(u32, u32), (u32, usize)> = HashMap::with_capacity(boundary.len());
        let mut last = NO_TET;
        for face in &boundary {
            let mut v = face.verts;
            v[face.k] = q;
            let t = self.alloc(v);
            last = t;
            self.nbrs[t as usize][face.k] = face.outer;
            if face.outer != NO_TET {
                self.nbrs[face.outer as usize][face.outer_face] = t;
            }
            for j in 0..4 {
                if j == face.k {
                    continue;
                }
                // The face opposite corner j contains q and the two other boundary corners.
                let others: Vec<u32> = (0..4)
                    .filter(|&i| i != j && i != face.k)
                    .map(|i| face.verts[i])
                    .collect();
                let key = (others[0].min(others[1]), others[0].max(others[1]));
                if let Some((u, uj)) = open.remove(&key) {
                    self.nbrs[t as usize][j] = u;
                    self.nbrs[u as usize][uj] = t;
                } else {
                    open.insert(key, (t, j));
                }
            }
        }
        if !open.is_empty() {
            bail!("cavity of point {q} is not closed (internal error in the tetrahedralization)");
        }
        Ok(Some(last))
    }
}

/// Interleaves the bits of three 10-bit grid coordinates (Morton order), so
/// consecutive insertions are spatially close and the walks stay short.
fn morton(p: [f64; 3], lo: [f64; 3], extent: f64) -> u32 {
    let cell = |k: usize| (((p[k] - lo[k]) / extent * 1023.0) as u64).min(1023);
    // Three 10-bit coordinates interleave into the low 30 bits.
    morton_code([cell(0), cell(1), cell(2)]) as u32
}

/// The Delaunay tetrahedralization of `points` (fewer than 4 distinct points,
/// or all points identical, give no tetrahedra).
pub fn tetrahedralize(points: &[[f64; 3]], seed: u64) -> Result<Tetrahedralization> {
    if let Some(i) = points.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
        bail!("point {i} {:?} is not finite", points[i]);
    }
    let n = points.len();
    if n >= (u32::MAX - 8) as usize {
        bail!("{n} points are more than the tetrahedralization can index");
    }
    let mut skipped = Vec::new();
    let mut first_of: HashMap<[u64; 3], u32> = HashMap::with_capacity(n);
    let mut order = Vec::with_capacity(n);
    for (i, p) in points.iter().enumerate() {
        // +0.0 and −0.0 are the same point.
        let key = p.map(|c| (c + 0.0).to_bits());
        if let std::collections::hash_map::Entry::Vacant(e) = first_of.entry(key) {
            e.insert(i as u32);
            order.push(i as u32);
        } else {
            skipped.push(i as u32);
        }
    }
    let empty = |skipped| Tetrahedralization {
        tets: vec![],
        neighbors: vec![],
        skipped,
    };
    if order.len() < 4 {
        return Ok(empty(skipped));
    }
    let (lo, hi) = objectsplat_core::geometry::bounding_box(points.iter().copied());
    let diag = ((hi[0] - lo[0]).powi(2) + (hi[1] - lo[1]).powi(2) + (hi[2] - lo[2]).powi(2)).sqrt();
    if diag == 0.0 {
        return Ok(empty(skipped));
    }
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut jittered: Vec<[f64; 3]> = points
        .iter()
        .map(|p| p.map(|c| c + (rng.random::<f64>() * 2.0 - 1.0) * JITTER * diag))
        .collect();
    let centre = [0, 1, 2].map(|k| 0.5 * (lo[k] + hi[k]));
    let s = 2.0 * SUPER_SCALE * diag;
    for corner in [
        [1.0, 1.0, 1.0],
        [1.0, -1.0, -1.0],
        [-1.0, 1.0, -1.0],
        [-1.0, -1.0, 1.0],
    ] {
        jittered.push([0, 1, 2].map(|k| centre[k] + s * corner[k]));
    }
    let sv = n as u32;
    let mut mesh = Mesh {
        points: jittered,
        verts: vec![],
        nbrs: vec![],
        alive: vec![],
        stamp: vec![],
        generation: 0,
        free: vec![],
    };
    let mut root = [sv, sv + 1, sv + 2, sv + 3];
    if mesh.orient(root) < 0.0 {
        root.swap(0, 1);
    }
    let mut last = mesh.alloc(root);
    order.sort_by_key(|&i| (morton(points[i as usize], lo, diag), i));
    for &q in &order {
        match mesh.insert(q, last, &mut rng)? {
            Some(t) => last = t,
            None => skipped.push(q),
        }
    }
    // Keep the tets made only of input points, renumbered densely.
    let mut new_id = vec![NO_TET; mesh.verts.len()];
    let mut tets = Vec::new();
    for t in 0..mesh.verts.len() {
        if mesh.alive[t] && mesh.verts[t].iter().all(|&v| v < sv) {
            new_id[t] = tets.len() as u32;
            tets.push(mesh.verts[t]);
        }
    }
    let neighbors = (0..mesh.verts.len())
        .filter(|&t| new_id[t] != NO_TET)
        .map(|t| {
            mesh.nbrs[t].map(|o| {
                if o == NO_TET {
                    NO_TET
                } else {
                    new_id[o as usize]
                }
            })
        })
        .collect();
    skipped.sort_unstable();
    Ok(Tetrahedralization {
        tets,
        neighbors,
        skipped,
    })
}
