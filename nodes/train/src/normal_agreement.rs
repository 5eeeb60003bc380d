//! Agreement of the normals of faces that share an edge: a prior against shingles.
//!
//! After the connectivity step a component is a mesh whose faces share edges,
//! but the photometric loss barely fixes how a face is tilted inside its
//! footprint: an object's exported faces stand 45° or more off the true
//! surface over a third of their area (normal consistency 0.63–0.74), a roof
//! of shingles. The planarity prior on the rendered depth flattens them but
//! is linear in the depth's curvature, so a ball pays for being round.
//!
//! This loss is `λ · mean (1 − (n₁·n₂)²)` over every pair of faces sharing an
//! edge, the mean of sin² of their dihedral angle's bend away from flat:
//! - quadratic in small bends, so a finely tessellated curved surface pays
//!   little (a bend of 10° costs 0.03);
//! - at most 1, so a true crease (a box's edge) costs one pair's worth
//!   however sharp it is, where a shingle field pays at every edge;
//! - blind to the winding (n and −n agree): the restricted Delaunay mesh's
//!   faces are not consistently oriented. A fold (two faces back to back) is
//!   flat to it, and on the demo's cup it made fins. A winding-aware
//!   `1 − n₁·n₂` (the windings made to agree per pair) was measured too and
//!   hardly moved the objects' normal consistency (demo, weight 0.003: the
//!   table 0.71 → 0.71, the chair 0.70 → 0.71, where this form gives 0.85
//!   and 0.82) for the same loss of appearance; a reading, not verified: the
//!   shingles are pairs bent past 90°, which that form must unfold through
//!   its steepest cost, while this one lays them on each other.
//!
//! Gradients go to the vertex positions only; a face without a proper normal
//! (the surface filter's test: twice its area at most 1e-9 of its longer
//! edge from the first corner, squared) takes no part.

use crate::vec3::{V3, cross, dot, proper_cross, sub};

fn scale(a: V3, s: f64) -> V3 {
    a.map(|x| x * s)
}

/// Adds the gradient of `weight · mean (1 − (n₁·n₂)²)` over the pairs of faces
/// sharing an edge (see the module docs) to `d_vertices` (indexed like
/// `vertices`; it may be longer) and returns the loss (0 when no pair has two
/// normals).
pub fn add_gradient(
    vertices: &[[f32; 3]],
    faces: &[[u32; 3]],
    weight: f64,
    d_vertices: &mut [[f32; 3]],
) -> f64 {
    let corners = |f: &[u32; 3]| f.map(|v| vertices[v as usize].map(f64::from));
    // Unit normal and the length of the cross product, per face with a normal.
    let normals: Vec<Option<(V3, f64)>> = faces
        .iter()
        .map(|f| proper_cross(corners(f)).map(|(m, len)| (scale(m, 1.0 / len), len)))
        .collect();
    let pairs = shared_edge_pairs(faces);
    let counted: Vec<(usize, usize)> = pairs
        .into_iter()
        .filter(|&(f, g)| normals[f].is_some() && normals[g].is_some())
        .collect();
    if counted.is_empty() {
        return 0.0;
    }
    let per_pair = weight / counted.len() as f64;
    let mut d_normal = vec![[0.0f64; 3]; faces.len()];
    let mut loss = 0.0;
    for (f, g) in counted {
        // Both checked above.
        let ((nf, _), (ng, _)) = (normals[f].unwrap(), normals[g].unwrap());
        let c = dot(nf, ng);
        loss += per_pair * (1.0 - c * c);
        for k in 0..3 {
            d_normal[f][k] -= per_pair * 2.0 * c * ng[k];
            d_normal[g][k] -= per_pair * 2.0 * c * nf[k];
        }
    }
    for (face, (dn, normal)) in faces.iter().zip(d_normal.iter().zip(&normals)) {
        let Some((n, len)) = normal else { continue };
        // n = m/|m|: dL/dm = (dL/dn − n (n·dL/dn)) / |m|.
        let dm = scale(sub(*dn, scale(*n, dot(*n, *dn))), 1.0 / len);
        let [a, b, c] = corners(face);
        let (u, v) = (sub(b, a), sub(c, a));
        // m = u × v: dL/du = v × dL/dm, dL/dv = dL/dm × u.
        let (du, dv) = (cross(v, dm), cross(dm, u));
        for (vertex, d) in face.iter().zip([[0, 1, 2].map(|k| -du[k] - dv[k]), du, dv]) {
            let slot = &mut d_vertices[*vertex as usize];
            for k in 0..3 {
                slot[k] += d[k] as f32;
            }
        }
    }
    loss
}

/// Every pair of distinct faces that share an edge (all pairs at an edge of
/// more than two faces), each once.
pub fn shared_edge_pairs(faces: &[[u32; 3]]) -> Vec<(usize, usize)> {
    let mut edges: Vec<(u32, u32, usize)> = Vec::with_capacity(3 * faces.len());
    for (i, f) in faces.iter().enumerate() {
        for (a, b) in [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])] {
            if a != b {
                edges.push((a.min(b), a.max(b), i));
            }
        }
    }
    edges.sort_unstable();
    let mut pairs = Vec::new();
    for run in edges.chunk_by(|x, y| (x.0, x.1) == (y.0, y.1)) {
        for (i, x) in run.iter().enumerate() {
            for y in &run[i + 1..] {
                if x.2 != y.2 {
                    pairs.push((x.2, y.2));
                }
            }
        }
    }
    pairs
}
