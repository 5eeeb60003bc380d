//! Voxel-grid down-sampling of point clouds.

use anyhow::{Result, bail};
use std::collections::BTreeMap;

/// Keeps one point per occupied voxel: the mean of the points inside it (as
/// Open3D's `voxel_down_sample`). The grid is Open3D's too: its origin is the
/// cloud's minimum corner minus half a voxel, and a point `p` falls in voxel
/// `floor((p − origin) / voxel)`. Output is ordered by voxel index (x, then y, then z).
pub fn voxel_downsample(points: &[[f64; 3]], voxel: f64) -> Result<Vec<[f64; 3]>> {
    if !(voxel.is_finite() && voxel > 0.0) {
        bail!("voxel size must be a positive number, got {voxel}");
    }
    if let Some(i) = points.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
        bail!("point {i} has a non-finite coordinate");
    }
    if points.is_empty() {
        return Ok(Vec::new());
    }
    let mut min = [f64::INFINITY; 3];
    for p in points {
        min.iter_mut().zip(p).for_each(|(m, v)| *m = m.min(*v));
    }
    let origin = min.map(|m| m - 0.5 * voxel);
    let mut cells: BTreeMap<[i64; 3], ([f64; 3], usize)> = BTreeMap::new();
    for p in points {
        let key = std::array::from_fn(|k| ((p[k] - origin[k]) / voxel).floor() as i64);
        let cell = cells.entry(key).or_insert(([0.0; 3], 0));
        cell.0.iter_mut().zip(p).for_each(|(s, v)| *s += v);
        cell.1 += 1;
    }
    Ok(cells
        .into_values()
        .map(|(sum, n)| sum.map(|s| s / n as f64))
        .collect())
}
