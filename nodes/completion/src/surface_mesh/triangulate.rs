//! Triangulating a set of grid cells with a constrained Delaunay triangulation
//! (`spade`): every edge between a cell of the set and one outside it is a constraint,
//! so no triangle crosses the set's boundary, and a triangle belongs to the set exactly
//! when its centroid lies in a set cell.

use super::grid::Grid;
use anyhow::{Context, Result, bail};
use glam::DVec2;
use spade::handles::FixedVertexHandle;
use spade::{ConstrainedDelaunayTriangulation, Point2, Triangulation};
use std::collections::HashMap;

/// A triangulation in continuous cell coordinates.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CellMesh {
    pub vertices: Vec<DVec2>,
    /// Counter-clockwise in cell coordinates.
    pub faces: Vec<[u32; 3]>,
}

/// Triangulates the cells of `set`: its boundary (cell edges to unset cells) as
/// constraints, plus interior grid corners every `step` cells so colours can vary inside.
pub fn triangulate_cells(grid: &Grid, set: &[bool], step: usize) -> Result<CellMesh> {
    if set.len() != grid.len() {
        bail!(
            "cell set has {} entries for a {}×{} grid",
            set.len(),
            grid.width,
            grid.height
        );
    }
    let (w, h) = (grid.width, grid.height);
    let is_set = |i: isize, j: isize| {
        i >= 0 && j >= 0 && (i as usize) < w && (j as usize) < h && set[j as usize * w + i as usize]
    };
    let mut cdt = ConstrainedDelaunayTriangulation::<Point2<f64>>::new();
    let mut handles: HashMap<(usize, usize), FixedVertexHandle> = HashMap::new();
    let mut corner = |cdt: &mut ConstrainedDelaunayTriangulation<Point2<f64>>,
                      i: usize,
                      j: usize|
     -> Result<FixedVertexHandle> {
        if let Some(&v) = handles.get(&(i, j)) {
            return Ok(v);
        }
        let v = cdt
            .insert(Point2::new(i as f64, j as f64))
            .map_err(|e| anyhow::anyhow!("inserting grid corner ({i}, {j}): {e:?}"))?;
        handles.insert((i, j), v);
        Ok(v)
    };
    let mut edges = Vec::new();
    for j in 0..h {
        for i in 0..w {
            if !set[j * w + i] {
                continue;
            }
            let (x, y) = (i as isize, j as isize);
            // The four sides of the cell, as corner pairs, where the neighbour is unset.
            if !is_set(x, y - 1) {
                edges.push(((i, j), (i + 1, j)));
            }
            if !is_set(x, y + 1) {
                edges.push(((i, j + 1), (i + 1, j + 1)));
            }
            if !is_set(x - 1, y) {
                edges.push(((i, j), (i, j + 1)));
            }
            if !is_set(x + 1, y) {
                edges.push(((i + 1, j), (i + 1, j + 1)));
            }
        }
    }
    for &(a, b) in &edges {
        let va = corner(&mut cdt, a.0, a.1)?;
        let vb = corner(&mut cdt, b.0, b.1)?;
        // Boundary edges are unit cell sides that meet only at corners, so none can cross
        // another; an empty result would mean a crossing, which the check reports.
        if cdt.try_add_constraint(va, vb).is_empty() {
            bail!("boundary edge {a:?}–{b:?} crosses another boundary edge");
        }
    }
    // Interior corners: all four cells around them set, so no boundary edge touches them.
    let step = step.max(1);
    for j in (step..h).step_by(step) {
        for i in (step..w).step_by(step) {
            let (x, y) = (i as isize, j as isize);
            if is_set(x - 1, y - 1) && is_set(x, y - 1) && is_set(x - 1, y) && is_set(x, y) {
                corner(&mut cdt, i, j)?;
            }
        }
    }

    let mut index: HashMap<usize, u32> = HashMap::new();
    let mut mesh = CellMesh::default();
    for face in cdt.inner_faces() {
        let vs = face.vertices();
        let p = vs.map(|v| {
            let q = v.position();
            DVec2::new(q.x, q.y)
        });
        let centroid = (p[0] + p[1] + p[2]) / 3.0;
        let (ci, cj) = (centroid.x.floor() as isize, centroid.y.floor() as isize);
        if !is_set(ci, cj) {
            continue;
        }
        let mut tri = [0u32; 3];
        for (k, v) in vs.iter().enumerate() {
            let next = mesh.vertices.len() as u32;
            tri[k] = *index.entry(v.fix().index()).or_insert_with(|| {
                mesh.vertices.push(p[k]);
                next
            });
        }
        mesh.faces.push(tri);
    }
    let covered: f64 = mesh
        .faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|v| mesh.vertices[v as usize]);
            0.5 * ((b - a).perp_dot(c - a)).abs()
        })
        .sum();
    let wanted = set.iter().filter(|&&s| s).count() as f64;
    // Every set cell is covered exactly once; anything else is a triangulation bug.
    if (covered - wanted).abs() > 1e-6 * wanted.max(1.0) {
        return Err(anyhow::anyhow!(
            "triangles cover {covered} cells of a set of {wanted}"
        ))
        .context("triangulating the hole");
    }
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(w: usize, h: usize) -> Grid {
        Grid {
            min: DVec2::ZERO,
            cell: 1.0,
            width: w,
            height: h,
        }
    }

    #[test]
    fn an_annulus_is_covered_exactly_and_its_hole_stays_open() {
        let g = grid(12, 12);
        let mut set = vec![false; 144];
        for j in 2..10 {
            for i in 2..10 {
                set[j * 12 + i] = !(5..7).contains(&i) || !(5..7).contains(&j);
            }
        }
        let mesh = triangulate_cells(&g, &set, 2).unwrap();
        assert!(!mesh.faces.is_empty());
        for f in &mesh.faces {
            let c = f
                .iter()
                .map(|&v| mesh.vertices[v as usize])
                .fold(DVec2::ZERO, |a, b| a + b)
                / 3.0;
            let inside_hole = (5.0..7.0).contains(&c.x) && (5.0..7.0).contains(&c.y);
            assert!(!inside_hole, "a triangle fills the annulus' hole: {c:?}");
        }
    }

    #[test]
    fn two_separate_blobs_and_an_empty_set() {
        let g = grid(10, 4);
        let mut set = vec![false; 40];
        for i in [1, 2, 6, 7, 8] {
            set[10 + i] = true;
            set[20 + i] = true;
        }
        let mesh = triangulate_cells(&g, &set, 1).unwrap();
        assert!(mesh.faces.len() >= 4);
        let empty = triangulate_cells(&g, &[false; 40], 1).unwrap();
        assert!(empty.faces.is_empty());
    }
}
