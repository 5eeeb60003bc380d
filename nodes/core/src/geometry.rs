//! In-memory meshes and point clouds (their PLY encoding lives in `ply` / `mesh_io`).
//!
//! Mesh artifact (a folder): `mesh.ply` — binary PLY with vertex `x,y,z` (float),
//! optional `red,green,blue` (uchar) and, when annotated, `object_id` (int, −1 =
//! none); faces as `vertex_indices` lists — plus `objects.json` (id → label) when
//! annotated. Points artifact (a folder): `points.ply` with `x,y,z` + `red,green,blue`.

/// The cross product of a triangle's edges `b − a` and `c − a`: its normal, as long as
/// twice its area (exactly zero for collinear corners).
pub fn triangle_cross([a, b, c]: &[[f64; 3]; 3]) -> [f64; 3] {
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
    [
        u[1] * v[2] - u[2] * v[1],
        u[2] * v[0] - u[0] * v[2],
        u[0] * v[1] - u[1] * v[0],
    ]
}

/// A triangle's area.
pub fn triangle_area(corners: &[[f64; 3]; 3]) -> f64 {
    let n = triangle_cross(corners);
    0.5 * (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt()
}

/// The axis-aligned bounding box of `points` as (min corner, max corner); (+∞, −∞) when
/// there are none.
pub fn bounding_box(points: impl IntoIterator<Item = [f64; 3]>) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

/// The Morton (Z-order) code of a grid cell: bit `b` of `cell[k]` goes to bit
/// `3b + k` (21 bits per axis; higher bits are dropped). Sorting by it walks the
/// grid block by block, so what is close in space ends up close in the order.
pub fn morton_code(cell: [u64; 3]) -> u64 {
    spread_bits(cell[0]) | spread_bits(cell[1]) << 1 | spread_bits(cell[2]) << 2
}

/// Moves bit b of a 21-bit value to bit 3b.
fn spread_bits(v: u64) -> u64 {
    let mut x = v & 0x1f_ffff;
    x = (x | x << 32) & 0x1f_0000_0000_ffff;
    x = (x | x << 16) & 0x1f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// A triangle mesh, optionally annotated with a per-vertex object id.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    pub positions: Vec<[f32; 3]>,
    pub faces: Vec<[u32; 3]>,
    pub colors: Option<Vec<[u8; 3]>>,
    /// Per-vertex object id; −1 = not part of any object.
    pub object_ids: Option<Vec<i32>>,
}

impl Mesh {
    /// Checks indices and finiteness; the error names the first offender.
    pub fn validate(&self) -> Result<(), String> {
        let n = self.positions.len();
        if let Some(i) = self
            .positions
            .iter()
            .position(|p| p.iter().any(|v| !v.is_finite()))
        {
            return Err(format!("vertex {i} has a non-finite coordinate"));
        }
        if let Some((i, f)) = self
            .faces
            .iter()
            .enumerate()
            .find(|(_, f)| f.iter().any(|&v| v as usize >= n))
        {
            return Err(format!(
                "face {i} refers to vertex {:?} but there are only {n} vertices",
                f
            ));
        }
        for (name, len) in [
            ("colors", self.colors.as_ref().map(Vec::len)),
            ("object_ids", self.object_ids.as_ref().map(Vec::len)),
        ] {
            if let Some(len) = len
                && len != n
            {
                return Err(format!("{name} has {len} entries for {n} vertices"));
            }
        }
        Ok(())
    }

    /// The object owning a face: the object of its first vertex (the ScanNet++ toolkit rule).
    pub fn face_object(&self, face: usize) -> i32 {
        match &self.object_ids {
            Some(ids) => ids[self.faces[face][0] as usize],
            None => -1,
        }
    }
}

/// A coloured point cloud (e.g. SfM points).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Points {
    pub positions: Vec<[f32; 3]>,
    pub colors: Vec<[u8; 3]>,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_right_triangle_has_half_the_product_of_its_legs_and_collinear_corners_none() {
        let t = [[1.0, 1.0, 1.0], [4.0, 1.0, 1.0], [1.0, 5.0, 1.0]];
        assert_eq!(triangle_cross(&t), [0.0, 0.0, 12.0]);
        assert_eq!(triangle_area(&t), 6.0);
        let line = [[0.0, 0.0, 0.0], [1.0, 2.0, 3.0], [2.0, 4.0, 6.0]];
        assert_eq!(triangle_cross(&line), [0.0; 3]);
    }

    #[test]
    fn the_morton_code_interleaves_the_cells_bits() {
        // x bit b → code bit 3b, y → 3b + 1, z → 3b + 2.
        assert_eq!(morton_code([1, 0, 0]), 1);
        assert_eq!(morton_code([0, 1, 0]), 2);
        assert_eq!(morton_code([0, 0, 1]), 4);
        assert_eq!(morton_code([2, 0, 0]), 8);
        assert_eq!(morton_code([0b1011, 0, 0]), 0b001_000_001_001);
        let all = (1 << 21) - 1;
        assert_eq!(morton_code([all, all, all]), u64::MAX >> 1);
        assert_eq!(morton_code([1 << 21, 0, 0]), 0, "bits above 21 are dropped");
    }
}
