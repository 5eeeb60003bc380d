//! Puts the connected mesh's vertices and faces in the order of a
//! space-filling curve, so that what is close in space is close in memory.
//!
//! The restricted Delaunay step returns faces in the order of a randomized
//! tetrahedralization, and vertices sit in the order densification appended
//! them, so a face's corners and its neighbours lie anywhere in memory. Every
//! pass that walks the faces and reads their corners — the per-view
//! preprocessing and colour gather, the backward pass's vertex sums, the
//! surface filter's neighbourhoods — then misses the caches on nearly every
//! read; on the 640×480 background (a million faces) those passes took more
//! of a step than the tile kernels. After this step vertices follow a Morton
//! (Z-order) curve through the model's bounding box and faces follow their
//! lowest corner, so the passes read memory nearly in order. Nothing but the
//! order changes: the mesh, every vertex's parameters and optimizer moments
//! are the same, renumbered.

use anyhow::{Result, bail};
use objectsplat_core::geometry::{bounding_box, morton_code};
use objectsplat_raster::Model;

/// Bits of each coordinate in a key (three of them fill 63 bits).
const BITS: u32 = 21;

/// The Morton key of `p` in the box from `lo` with `1 / scale` per cell.
fn morton_key(p: [f32; 3], lo: [f32; 3], scale: [f32; 3]) -> u64 {
    morton_code(std::array::from_fn(|k| {
        let c = ((p[k] - lo[k]) * scale[k]).clamp(0.0, ((1u64 << BITS) - 1) as f32);
        // A NaN coordinate (never in a validated model) casts to cell 0.
        c as u64
    }))
}

/// Renumbers `model`'s vertices along a Morton curve and orders its faces by
/// their lowest corner (ties keep their order). Returns the vertex order:
/// vertex `i` now is vertex `order[i]` before, for the state kept per vertex
/// elsewhere (the optimizer's moments).
pub fn spatial_order(model: &mut Model<f32>) -> Result<Vec<u32>> {
    let n = model.vertices.len();
    if model.sh.len() != n || model.opacity_logits.len() != n {
        bail!(
            "a model of {n} vertices with {} SH rows and {} opacities",
            model.sh.len(),
            model.opacity_logits.len()
        );
    }
    if let Some(f) = model
        .faces
        .iter()
        .position(|f| f.iter().any(|&v| v as usize >= n))
    {
        bail!(
            "face {f} {:?} references a vertex beyond the {n} vertices",
            model.faces[f]
        );
    }
    // f32 → f64 → f32 is exact, so the box is the f32 vertices' own.
    let (lo, hi) = bounding_box(
        model
            .vertices
            .iter()
            .filter(|p| p.iter().all(|c| c.is_finite()))
            .map(|p| p.map(f64::from)),
    );
    let (lo, hi) = (lo.map(|c| c as f32), hi.map(|c| c as f32));
    // Cubic cells: the curve's blocks are cubes in space, whatever the box's shape.
    let extent = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f32, f32::max);
    let per_cell = if extent > 0.0 && extent.is_finite() {
        ((1u64 << BITS) - 1) as f32 / extent
    } else {
        0.0
    };
    let scale = [per_cell; 3];
    let lo = lo.map(|c| if c.is_finite() { c } else { 0.0 });
    let mut order: Vec<u32> = (0..n as u32).collect();
    // Stable: vertices in one cell keep their order.
    order.sort_by_cached_key(|&v| morton_key(model.vertices[v as usize], lo, scale));
    let mut renumber = vec![0u32; n];
    for (new, &old) in order.iter().enumerate() {
        renumber[old as usize] = new as u32;
    }
    permute(&mut model.vertices, &order);
    permute(&mut model.sh, &order);
    permute(&mut model.opacity_logits, &order);
    if model.flat_dc.len() == n {
        permute(&mut model.flat_dc, &order);
    }
    for face in &mut model.faces {
        *face = face.map(|v| renumber[v as usize]);
    }
    let mut face_order: Vec<u32> = (0..model.faces.len() as u32).collect();
    face_order.sort_by_key(|&f| model.faces[f as usize].iter().min().copied());
    permute(&mut model.faces, &face_order);
    if model.face_sigma.len() == face_order.len() {
        permute(&mut model.face_sigma, &face_order);
    }
    Ok(order)
}

/// `rows[i] = before[order[i]]` (`order` a permutation of the rows).
fn permute<T: Copy>(rows: &mut Vec<T>, order: &[u32]) {
    *rows = order.iter().map(|&i| rows[i as usize]).collect();
}

#[cfg(test)]
mod tests {
    use super::*;
    use objectsplat_raster::model::SH_COEFFS;

    fn model(vertices: Vec<[f32; 3]>, faces: Vec<[u32; 3]>) -> Model<f32> {
        let n = vertices.len();
        Model {
            vertices,
            faces,
            sh: (0..n).map(|v| [[v as f32; 3]; SH_COEFFS]).collect(),
            opacity_logits: (0..n).map(|v| -(v as f32)).collect(),
            ..Model::empty()
        }
    }

    #[test]
    fn vertices_follow_the_z_order_curve() {
        // A 4×4 grid in the plane z = 0, shuffled; the Z-order visits 2×2
        // blocks in turn: (0,0) (1,0) (0,1) (1,1) (2,0) (3,0) (2,1) (3,1) (0,2) …
        let z_order = [
            (0, 0),
            (1, 0),
            (0, 1),
            (1, 1),
            (2, 0),
            (3, 0),
            (2, 1),
            (3, 1),
            (0, 2),
            (1, 2),
            (0, 3),
            (1, 3),
            (2, 2),
            (3, 2),
            (2, 3),
            (3, 3),
        ];
        let shuffled = [5, 12, 0, 9, 3, 14, 7, 1, 10, 15, 4, 8, 2, 13, 6, 11];
        let vertices: Vec<[f32; 3]> = shuffled
            .iter()
            .map(|&i| {
                let (x, y) = z_order[i];
                [x as f32, y as f32, 0.0]
            })
            .collect();
        let mut m = model(vertices, vec![[0, 1, 2]]);
        spatial_order(&mut m).expect("a valid model");
        let visited: Vec<(i32, i32)> = m
            .vertices
            .iter()
            .map(|p| (p[0] as i32, p[1] as i32))
            .collect();
        assert_eq!(visited, z_order.to_vec());
    }

    #[test]
    fn renumbering_keeps_every_face_and_every_vertex_parameter() {
        // A strip of quads along x, its vertices shuffled.
        let xs = [7.0, 2.0, 5.0, 0.0, 3.0, 6.0, 1.0, 4.0];
        let mut vertices = Vec::new();
        for &x in &xs {
            vertices.push([x, 0.0, 0.0]);
            vertices.push([x, 1.0, 0.0]);
        }
        let at = |x: f32, y: u32| {
            2 * xs.iter().position(|&v| v == x).expect("a strip column") as u32 + y
        };
        let mut faces = Vec::new();
        for x in [3.0, 1.0, 6.0, 0.0, 4.0, 2.0, 5.0] {
            faces.push([at(x, 0), at(x + 1.0, 0), at(x, 1)]);
            faces.push([at(x + 1.0, 0), at(x + 1.0, 1), at(x, 1)]);
        }
        let before = model(vertices, faces);
        let mut after = before.clone();
        let order = spatial_order(&mut after).expect("a valid model");

        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..16).collect::<Vec<u32>>(), "a permutation");
        for (new, &old) in order.iter().enumerate() {
            let old = old as usize;
            assert_eq!(after.vertices[new], before.vertices[old]);
            assert_eq!(after.sh[new], before.sh[old]);
            assert_eq!(after.opacity_logits[new], before.opacity_logits[old]);
        }
        // The same triangles (as corner positions, in corner order).
        let corners = |m: &Model<f32>| {
            let mut all: Vec<[[u32; 3]; 3]> = m
                .faces
                .iter()
                .map(|f| f.map(|v| m.vertices[v as usize].map(|c| c.to_bits())))
                .collect();
            all.sort_unstable();
            all
        };
        assert_eq!(corners(&after), corners(&before));
        // Faces follow their lowest corner.
        let lowest: Vec<u32> = after
            .faces
            .iter()
            .map(|f| f[0].min(f[1]).min(f[2]))
            .collect();
        assert!(lowest.windows(2).all(|w| w[0] <= w[1]), "{lowest:?}");
    }

    #[test]
    fn a_flat_or_degenerate_model_keeps_a_valid_order() {
        let mut m = model(vec![[1.0, 1.0, 1.0]; 4], vec![[0, 1, 2], [1, 2, 3]]);
        let order = spatial_order(&mut m).expect("a valid model");
        assert_eq!(order, vec![0, 1, 2, 3], "one cell: the order kept");
        assert_eq!(m.faces, vec![[0, 1, 2], [1, 2, 3]]);
    }

    #[test]
    fn a_face_beyond_the_vertices_is_an_error() {
        let mut m = model(vec![[0.0; 3]; 3], vec![[0, 1, 2]]);
        m.faces.push([0, 1, 3]);
        let err = spatial_order(&mut m).expect_err("a face out of range");
        assert!(err.to_string().contains("face 1"), "{err}");
    }
}
