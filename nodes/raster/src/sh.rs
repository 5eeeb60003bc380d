//! Real spherical harmonics up to degree 3 (the 3DGS basis and sign
//! convention) evaluated along the camera→vertex direction, and their
//! gradients with respect to the coefficients and the vertex position.

use crate::model::SH_COEFFS;
use crate::real::Real;

const C0: f64 = 0.282_094_791_773_878_14;
const C1: f64 = 0.488_602_511_902_919_9;
const C2: [f64; 5] = [
    1.092_548_430_592_079_2,
    -1.092_548_430_592_079_2,
    0.315_391_565_252_520_05,
    -1.092_548_430_592_079_2,
    0.546_274_215_296_039_6,
];
const C3: [f64; 7] = [
    -0.590_043_589_926_643_5,
    2.890_611_442_640_554,
    -0.457_045_799_464_465_8,
    0.373_176_332_590_115_4,
    -0.457_045_799_464_465_8,
    1.445_305_721_320_277,
    -0.590_043_589_926_643_5,
];

/// The DC basis value; colour = `SH_DC · dc + 0.5` at degree 0.
pub const SH_DC: f64 = C0;

/// Number of active coefficients per channel at `degree`.
#[inline]
pub fn coeff_count(degree: u32) -> usize {
    ((degree + 1) * (degree + 1)) as usize
}

/// Basis values `Y_k(d)` for the unit direction `d`, k < `coeff_count(degree)`; the rest are 0.
pub fn basis<R: Real>(d: [R; 3], degree: u32) -> [R; SH_COEFFS] {
    let c = R::of;
    let [x, y, z] = d;
    let mut out = [R::zero(); SH_COEFFS];
    out[0] = c(C0);
    if degree >= 1 {
        out[1] = -c(C1) * y;
        out[2] = c(C1) * z;
        out[3] = -c(C1) * x;
    }
    if degree >= 2 {
        let (xx, yy, zz) = (x * x, y * y, z * z);
        out[4] = c(C2[0]) * x * y;
        out[5] = c(C2[1]) * y * z;
        out[6] = c(C2[2]) * (c(2.0) * zz - xx - yy);
        out[7] = c(C2[3]) * x * z;
        out[8] = c(C2[4]) * (xx - yy);
    }
    if degree >= 3 {
        let (xx, yy, zz) = (x * x, y * y, z * z);
        out[9] = c(C3[0]) * y * (c(3.0) * xx - yy);
        out[10] = c(C3[1]) * x * y * z;
        out[11] = c(C3[2]) * y * (c(4.0) * zz - xx - yy);
        out[12] = c(C3[3]) * z * (c(2.0) * zz - c(3.0) * xx - c(3.0) * yy);
        out[13] = c(C3[4]) * x * (c(4.0) * zz - xx - yy);
        out[14] = c(C3[5]) * z * (xx - yy);
        out[15] = c(C3[6]) * x * (xx - c(3.0) * yy);
    }
    out
}

/// Partial derivatives `∂Y_k/∂(x, y, z)` of the basis polynomials (not
/// restricted to the sphere; the caller projects through the normalisation).
pub fn basis_gradient<R: Real>(d: [R; 3], degree: u32) -> [[R; 3]; SH_COEFFS] {
    let c = R::of;
    let zero = R::zero();
    let [x, y, z] = d;
    let mut g = [[zero; 3]; SH_COEFFS];
    if degree >= 1 {
        g[1] = [zero, -c(C1), zero];
        g[2] = [zero, zero, c(C1)];
        g[3] = [-c(C1), zero, zero];
    }
    if degree >= 2 {
        g[4] = [c(C2[0]) * y, c(C2[0]) * x, zero];
        g[5] = [zero, c(C2[1]) * z, c(C2[1]) * y];
        g[6] = [c(-2.0 * C2[2]) * x, c(-2.0 * C2[2]) * y, c(4.0 * C2[2]) * z];
        g[7] = [c(C2[3]) * z, zero, c(C2[3]) * x];
        g[8] = [c(2.0 * C2[4]) * x, c(-2.0 * C2[4]) * y, zero];
    }
    if degree >= 3 {
        let (xx, yy, zz) = (x * x, y * y, z * z);
        g[9] = [c(6.0 * C3[0]) * x * y, c(3.0 * C3[0]) * (xx - yy), zero];
        g[10] = [c(C3[1]) * y * z, c(C3[1]) * x * z, c(C3[1]) * x * y];
        g[11] = [
            c(-2.0 * C3[2]) * x * y,
            c(C3[2]) * (c(4.0) * zz - xx - c(3.0) * yy),
            c(8.0 * C3[2]) * y * z,
        ];
        g[12] = [
            c(-6.0 * C3[3]) * x * z,
            c(-6.0 * C3[3]) * y * z,
            c(C3[3]) * (c(6.0) * zz - c(3.0) * xx - c(3.0) * yy),
        ];
        g[13] = [
            c(C3[4]) * (c(4.0) * zz - c(3.0) * xx - yy),
            c(-2.0 * C3[4]) * x * y,
            c(8.0 * C3[4]) * x * z,
        ];
        g[14] = [
            c(2.0 * C3[5]) * x * z,
            c(-2.0 * C3[5]) * y * z,
            c(C3[5]) * (xx - yy),
        ];
        g[15] = [c(3.0 * C3[6]) * (xx - yy), c(-6.0 * C3[6]) * x * y, zero];
    }
    g
}

/// Unit direction from the camera centre to `position` and the distance;
/// a vertex exactly at the centre gets the zero direction (only the DC term
/// survives) and distance 0.
#[inline]
pub fn view_direction<R: Real>(position: [R; 3], camera_center: [R; 3]) -> ([R; 3], R) {
    let v = [
        position[0] - camera_center[0],
        position[1] - camera_center[1],
        position[2] - camera_center[2],
    ];
    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if len > R::zero() {
        ([v[0] / len, v[1] / len, v[2] / len], len)
    } else {
        ([R::zero(); 3], R::zero())
    }
}

/// The vertex colour `max(0, Σ_k Y_k(d)·sh_k + 0.5)` per channel, and which
/// channels were clamped (their gradient is zero).
pub fn vertex_color<R: Real>(
    sh: &[[R; 3]; SH_COEFFS],
    dir: [R; 3],
    degree: u32,
) -> ([R; 3], [bool; 3]) {
    let y = basis(dir, degree);
    let mut rgb = [R::of(0.5); 3];
    for (k, yk) in y.iter().enumerate().take(coeff_count(degree)) {
        for ch in 0..3 {
            rgb[ch] += *yk * sh[k][ch];
        }
    }
    let clamped = rgb.map(|v| v < R::zero());
    (rgb.map(|v| v.max(R::zero())), clamped)
}

/// Back-propagates `d_color` through [`vertex_color`]: adds into `d_sh` and
/// returns dL/d(position) through the view direction.
pub fn vertex_color_backward<R: Real>(
    sh: &[[R; 3]; SH_COEFFS],
    dir: [R; 3],
    distance: R,
    degree: u32,
    clamped: [bool; 3],
    d_color: [R; 3],
    d_sh: &mut [[R; 3]; SH_COEFFS],
) -> [R; 3] {
    let dc = [0, 1, 2].map(|ch| if clamped[ch] { R::zero() } else { d_color[ch] });
    if dc.iter().all(|&g| g == R::zero()) {
        // Nothing to propagate (a vertex whose faces never reached a pixel).
        return [R::zero(); 3];
    }
    let n = coeff_count(degree);
    let y = basis(dir, degree);
    for k in 0..n {
        for ch in 0..3 {
            d_sh[k][ch] += y[k] * dc[ch];
        }
    }
    if degree == 0 || distance <= R::zero() {
        return [R::zero(); 3];
    }
    let gy = basis_gradient(dir, degree);
    let mut d_dir = [R::zero(); 3];
    for k in 1..n {
        let w = sh[k][0] * dc[0] + sh[k][1] * dc[1] + sh[k][2] * dc[2];
        for a in 0..3 {
            d_dir[a] += w * gy[k][a];
        }
    }
    // d = v/|v|  ⇒  dL/dv = (g − d(d·g)) / |v|.
    let dot = d_dir[0] * dir[0] + d_dir[1] * dir[1] + d_dir[2] * dir[2];
    [0, 1, 2].map(|a| (d_dir[a] - dir[a] * dot) / distance)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 16 basis functions are orthonormal over the sphere (checked with a
    /// Fibonacci-lattice quadrature), which pins every constant and sign-free
    /// polynomial independently of the 3DGS source.
    #[test]
    fn basis_is_orthonormal_on_the_sphere() {
        let n = 200_000;
        let mut gram = [[0.0f64; SH_COEFFS]; SH_COEFFS];
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        for i in 0..n {
            let z = 1.0 - (2.0 * i as f64 + 1.0) / n as f64;
            let r = (1.0 - z * z).sqrt();
            let th = golden * i as f64;
            let y = basis([r * th.cos(), r * th.sin(), z], 3);
            for a in 0..SH_COEFFS {
                for b in 0..SH_COEFFS {
                    gram[a][b] += y[a] * y[b] * 4.0 * std::f64::consts::PI / n as f64;
                }
            }
        }
        for a in 0..SH_COEFFS {
            for b in 0..SH_COEFFS {
                let want = if a == b { 1.0 } else { 0.0 };
                assert!(
                    (gram[a][b] - want).abs() < 1e-3,
                    "⟨Y{a},Y{b}⟩ = {}",
                    gram[a][b]
                );
            }
        }
    }

    /// The polynomial gradients agree with central differences.
    #[test]
    fn basis_gradient_matches_finite_differences() {
        let d: [f64; 3] = [0.3, -0.5, 0.7];
        let g = basis_gradient(d, 3);
        let h = 1e-6;
        for a in 0..3 {
            let mut p = d;
            let mut m = d;
            p[a] += h;
            m[a] -= h;
            let (yp, ym) = (basis(p, 3), basis(m, 3));
            for k in 0..SH_COEFFS {
                let fd = (yp[k] - ym[k]) / (2.0 * h);
                assert!(
                    (fd - g[k][a]).abs() < 1e-8,
                    "Y{k} d/d{a}: fd {fd} analytic {}",
                    g[k][a]
                );
            }
        }
    }
}
