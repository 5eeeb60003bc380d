//! Rotating view-dependent colour: the SH coefficients of a rotated object.
//!
//! A rotated object seen along world direction `d` must look like the original seen
//! along `Rᵀd`, so the new colour function is `f'(d) = f(Rᵀd)`. Rotations keep each
//! SH band closed, so per band l the new coefficients are `M_l · c_l`, where `M_l` is
//! found by least squares from basis values on a fixed set of directions spread over
//! the sphere (exact up to rounding: the system is consistent).

use anyhow::{Result, bail};
use glam::DMat3;
use objectsplat_raster::SH_COEFFS;
use objectsplat_raster::sh::basis;

/// Directions on a Fibonacci sphere; 64 of them over-determine every band up to l = 3.
const SAMPLE_DIRECTIONS: usize = 64;

fn fibonacci_direction(i: usize, n: usize) -> [f64; 3] {
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = golden * i as f64;
    [r * phi.cos(), r * phi.sin(), z]
}

/// The coefficient-index range of band `l` (`l² .. (l+1)²`).
fn band(l: usize) -> std::ops::Range<usize> {
    l * l..(l + 1) * (l + 1)
}

/// Solves `a · x = b` for a small square system (Gaussian elimination, partial pivoting).
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<Vec<f64>>) -> Result<Vec<Vec<f64>>> {
    let n = a.len();
    for col in 0..n {
        let pivot = (col..n)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .unwrap_or(col);
        if a[pivot][col].abs() < 1e-12 {
            bail!("the SH fitting system is singular (column {col})");
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        for row in 0..n {
            if row == col {
                continue;
            }
            let factor = a[row][col] / a[col][col];
            if factor == 0.0 {
                continue;
            }
            let (pivot_a, pivot_b) = (a[col].clone(), b[col].clone());
            for (x, p) in a[row].iter_mut().zip(&pivot_a).skip(col) {
                *x -= factor * p;
            }
            for (x, p) in b[row].iter_mut().zip(&pivot_b) {
                *x -= factor * p;
            }
        }
    }
    for row in 0..n {
        let d = a[row][row];
        for v in b[row].iter_mut() {
            *v /= d;
        }
    }
    Ok(b)
}

/// Per band l = 1..=3, the matrix taking old band coefficients to new ones under `rotation`.
pub struct ShRotation {
    bands: [Vec<Vec<f64>>; 3],
}

impl ShRotation {
    pub fn new(rotation: DMat3) -> Result<ShRotation> {
        let inverse = rotation.transpose();
        let dirs: Vec<[f64; 3]> = (0..SAMPLE_DIRECTIONS)
            .map(|i| fibonacci_direction(i, SAMPLE_DIRECTIONS))
            .collect();
        let at: Vec<[f64; SH_COEFFS]> = dirs.iter().map(|&d| basis(d, 3)).collect();
        let rotated: Vec<[f64; SH_COEFFS]> = dirs
            .iter()
            .map(|&d| {
                let r = inverse * glam::DVec3::from_array(d);
                basis(r.to_array(), 3)
            })
            .collect();
        let mut bands: [Vec<Vec<f64>>; 3] = Default::default();
        for l in 1..=3 {
            let range = band(l);
            let n = range.len();
            // Normal equations: (AᵀA) M = AᵀB with A = basis(d), B = basis(Rᵀd).
            let mut ata = vec![vec![0.0; n]; n];
            let mut atb = vec![vec![0.0; n]; n];
            for (a, b) in at.iter().zip(&rotated) {
                for i in 0..n {
                    for j in 0..n {
                        ata[i][j] += a[range.start + i] * a[range.start + j];
                        atb[i][j] += a[range.start + i] * b[range.start + j];
                    }
                }
            }
            bands[l - 1] = solve(ata, atb)?;
        }
        Ok(ShRotation { bands })
    }

    /// Rotates one vertex's coefficients (the DC term is rotation-invariant).
    pub fn apply(&self, rows: &[[f32; 3]; SH_COEFFS]) -> [[f32; 3]; SH_COEFFS] {
        let mut out = *rows;
        for l in 1..=3 {
            let range = band(l);
            let m = &self.bands[l - 1];
            for (i, target) in range.clone().enumerate() {
                for ch in 0..3 {
                    let value: f64 = range
                        .clone()
                        .enumerate()
                        .map(|(j, source)| m[i][j] * f64::from(rows[source][ch]))
                        .sum();
                    out[target][ch] = value as f32;
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Colour of the rotated coefficients along R·d equals the original along d,
    /// for random-ish coefficients and an arbitrary rotation.
    #[test]
    fn rotated_coefficients_reproduce_the_rotated_colour_function() {
        let rotation = DMat3::from_axis_angle(glam::DVec3::new(0.3, -0.5, 0.8).normalize(), 1.1);
        let rot = ShRotation::new(rotation).unwrap();
        let mut rows = [[0.0f32; 3]; SH_COEFFS];
        for (k, row) in rows.iter_mut().enumerate() {
            for (ch, v) in row.iter_mut().enumerate() {
                *v = ((k * 7 + ch * 3) as f32 * 0.37).sin() * 0.5;
            }
        }
        let new_rows = rot.apply(&rows);
        let colour = |rows: &[[f32; 3]; SH_COEFFS], d: [f64; 3], ch: usize| -> f64 {
            let y = basis(d, 3);
            (0..SH_COEFFS).map(|k| y[k] * f64::from(rows[k][ch])).sum()
        };
        for i in 0..20 {
            // Directions not among the fitting set.
            let d = glam::DVec3::new(
                (i as f64).sin(),
                (i as f64 * 1.7).cos(),
                0.3 - i as f64 * 0.05,
            )
            .normalize();
            let rd = rotation * d;
            for ch in 0..3 {
                let want = colour(&rows, d.to_array(), ch);
                let got = colour(&new_rows, rd.to_array(), ch);
                assert!(
                    (want - got).abs() < 1e-5,
                    "dir {i} ch {ch}: {want} vs {got}"
                );
            }
        }
    }
}
