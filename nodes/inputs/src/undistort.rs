//! Lens distortion and its removal: distorted captures become pinhole frames.
//!
//! Models (normalised camera coordinates `(u, v) = (x/z, y/z)`):
//! - [`Distortion::Brown`]: OpenCV's radial–tangential model with the rational radial
//!   term, `radial = (1 + k1 r² + k2 r⁴ + k3 r⁶) / (1 + k4 r² + k5 r⁴ + k6 r⁶)`,
//!   `u' = u·radial + 2 p1 u v + p2 (r² + 2u²)`, `v' = v·radial + p1 (r² + 2v²) + 2 p2 u v`.
//!   COLMAP's SIMPLE_RADIAL (`k1`), RADIAL (`k1, k2`), OPENCV (`k1, k2, p1, p2`) and
//!   FULL_OPENCV (all eight) are special cases, as is nerfstudio's OPENCV (`k1, k2, k3, p1, p2`).
//! - [`Distortion::Fisheye`]: the equidistant (Kannala–Brandt) model of OpenCV's
//!   `cv2.fisheye` and COLMAP's OPENCV_FISHEYE: `θ = atan r`,
//!   `θd = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸)`, `(u', v') = (u, v)·θd / r`.
//!   COLMAP's SIMPLE_RADIAL_FISHEYE (`k1`) and RADIAL_FISHEYE (`k1, k2`) are special cases.
//!
//! The pinhole camera an image is undistorted to is chosen as COLMAP's
//! `image_undistorter` does with its default options (`blank_pixels 0`, `min_scale 0.2`,
//! `max_scale 2`): focal lengths and principal point are kept; every pixel centre on
//! the image border is undistorted, and the output size is scaled per axis so that the
//! undistorted image shows no blank pixels, its principal point scaled with it. (A
//! radial–tangential camera whose coefficients are all zero is kept as it is; COLMAP
//! would run the same rule and shrink the image by about a pixel.) Images
//! are resampled bilinearly at each output pixel's centre (pixel centres at +0.5, the
//! COLMAP convention of our cameras); source pixels outside the image count as black,
//! as in OpenCV's `remap` with a constant border.

use anyhow::{Result, bail};
use objectsplat_core::Image;

/// A lens distortion model with its coefficients.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Distortion {
    /// `k = [k1..k6]` (rational radial term), `p = [p1, p2]` (tangential).
    Brown { k: [f64; 6], p: [f64; 2] },
    /// `k = [k1..k4]` (equidistant fisheye).
    Fisheye { k: [f64; 4] },
}

/// The pinhole part of a camera: image size, focal lengths and principal point
/// (pixel centres at +0.5).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    pub width: u32,
    pub height: u32,
    pub fx: f64,
    pub fy: f64,
    pub cx: f64,
    pub cy: f64,
}

/// Newton iterations allowed when inverting a distortion.
const MAX_ITERATIONS: usize = 100;

impl Distortion {
    /// True when the model leaves every point where it is: a radial–tangential model
    /// with all coefficients zero. (A fisheye lens never does: with zero coefficients it
    /// is still the equidistant projection `θd = θ`.)
    pub fn is_identity(&self) -> bool {
        match self {
            Distortion::Brown { k, p } => k.iter().chain(p).all(|&c| c == 0.0),
            Distortion::Fisheye { .. } => false,
        }
    }

    /// Distorts a normalised point. `None` where the model has no value (a rational
    /// term whose denominator vanishes).
    pub fn distort(&self, u: f64, v: f64) -> Option<(f64, f64)> {
        match *self {
            Distortion::Brown { k, p } => {
                let r2 = u * u + v * v;
                let num = 1.0 + r2 * (k[0] + r2 * (k[1] + r2 * k[2]));
                let den = 1.0 + r2 * (k[3] + r2 * (k[4] + r2 * k[5]));
                if den.abs() < 1e-12 {
                    return None;
                }
                let radial = num / den;
                let uv = u * v;
                Some((
                    u * radial + 2.0 * p[0] * uv + p[1] * (r2 + 2.0 * u * u),
                    v * radial + p[0] * (r2 + 2.0 * v * v) + 2.0 * p[1] * uv,
                ))
            }
            Distortion::Fisheye { k } => {
                let r = (u * u + v * v).sqrt();
                if r < f64::EPSILON {
                    return Some((u, v));
                }
                let theta = r.atan();
                let t2 = theta * theta;
                let theta_d = theta * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))));
                let s = theta_d / r;
                Some((u * s, v * s))
            }
        }
    }

    /// The normalised point that distorts to `(ud, vd)`; `None` when the iteration
    /// does not converge or the point lies outside the model's valid field of view.
    pub fn undistort(&self, ud: f64, vd: f64) -> Option<(f64, f64)> {
        match *self {
            Distortion::Brown { .. } => self.undistort_brown(ud, vd),
            Distortion::Fisheye { k } => undistort_fisheye(k, ud, vd),
        }
    }

    /// The Jacobian of `distort` at `(u, v)` by central differences: `[[∂u'/∂u, ∂u'/∂v], [∂v'/∂u, ∂v'/∂v]]`.
    fn jacobian(&self, u: f64, v: f64) -> Option<[[f64; 2]; 2]> {
        let h = 1e-7 * (1.0 + u.abs().max(v.abs()));
        let (a1, a2) = self.distort(u + h, v)?;
        let (b1, b2) = self.distort(u - h, v)?;
        let (c1, c2) = self.distort(u, v + h)?;
        let (d1, d2) = self.distort(u, v - h)?;
        Some([
            [(a1 - b1) / (2.0 * h), (c1 - d1) / (2.0 * h)],
            [(a2 - b2) / (2.0 * h), (c2 - d2) / (2.0 * h)],
        ])
    }

    /// Newton's method on `distort(x) − target`. Only a solution where the lens is
    /// locally one-to-one and orientation-preserving (positive Jacobian) and that lies on
    /// the distorted point's side of the centre counts: past the fold of a strongly
    /// distorting lens a mirrored solution exists, and a pixel there is no view of the scene.
    fn undistort_brown(&self, ud: f64, vd: f64) -> Option<(f64, f64)> {
        let (mut u, mut v) = (ud, vd);
        let tolerance = 1e-14 * (1.0 + ud.abs().max(vd.abs()));
        for _ in 0..MAX_ITERATIONS {
            let (fu, fv) = self.distort(u, v)?;
            let (ru, rv) = (fu - ud, fv - vd);
            let [[j11, j12], [j21, j22]] = self.jacobian(u, v)?;
            let det = j11 * j22 - j12 * j21;
            if ru.abs().max(rv.abs()) <= tolerance {
                return (det > 0.0 && u * ud + v * vd >= 0.0).then_some((u, v));
            }
            if !det.is_finite() || det.abs() < 1e-12 {
                return None;
            }
            u -= (j22 * ru - j12 * rv) / det;
            v -= (-j21 * ru + j11 * rv) / det;
            if !(u.is_finite() && v.is_finite()) {
                return None;
            }
        }
        let (fu, fv) = self.distort(u, v)?;
        let [[j11, j12], [j21, j22]] = self.jacobian(u, v)?;
        ((fu - ud).abs().max((fv - vd).abs()) <= 1e-9 * (1.0 + ud.abs().max(vd.abs()))
            && j11 * j22 - j12 * j21 > 0.0
            && u * ud + v * vd >= 0.0)
            .then_some((u, v))
    }
}

/// Solves `θd = θ (1 + k1 θ² + …)` for `θ ∈ [0, π/2)` by Newton's method.
fn undistort_fisheye(k: [f64; 4], ud: f64, vd: f64) -> Option<(f64, f64)> {
    let theta_d = (ud * ud + vd * vd).sqrt();
    if theta_d < f64::EPSILON {
        return Some((ud, vd));
    }
    let f = |t: f64| {
        let t2 = t * t;
        t * (1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3]))))
    };
    let df = |t: f64| {
        let t2 = t * t;
        1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])))
    };
    let mut theta = theta_d;
    let mut converged = false;
    for _ in 0..MAX_ITERATIONS {
        let slope = df(theta);
        if !slope.is_finite() || slope <= 0.0 {
            return None;
        }
        let step = (f(theta) - theta_d) / slope;
        theta -= step;
        if !theta.is_finite() {
            return None;
        }
        if step.abs() <= 1e-15 * (1.0 + theta.abs()) {
            converged = true;
            break;
        }
    }
    // The model must be monotonic at the solution and the ray in front of the camera.
    if !converged || !(0.0..std::f64::consts::FRAC_PI_2).contains(&theta) || df(theta) <= 0.0 {
        return None;
    }
    let s = theta.tan() / theta_d;
    Some((ud * s, vd * s))
}

impl Intrinsics {
    /// Continuous pixel position → normalised camera coordinates (no distortion).
    fn to_normalised(self, x: f64, y: f64) -> (f64, f64) {
        ((x - self.cx) / self.fx, (y - self.cy) / self.fy)
    }

    fn to_pixel(self, u: f64, v: f64) -> (f64, f64) {
        (self.fx * u + self.cx, self.fy * v + self.cy)
    }
}

/// The pinhole camera COLMAP's undistorter gives `camera` (see the module doc).
/// Errors when the distortion cannot be inverted along the image border.
pub fn undistorted_camera(camera: &Intrinsics, distortion: &Distortion) -> Result<Intrinsics> {
    if distortion.is_identity() {
        return Ok(*camera);
    }
    let (w, h) = (camera.width as f64, camera.height as f64);
    // An undistorted border point, as a pixel of the pinhole camera with the same intrinsics.
    let border = |x: f64, y: f64| {
        let (ud, vd) = camera.to_normalised(x, y);
        distortion
            .undistort(ud, vd)
            .map(|(u, v)| camera.to_pixel(u, v))
    };
    let mut extent = Extent::default();
    for row in 0..camera.height {
        let y = row as f64 + 0.5;
        if let Some((x, _)) = border(0.5, y) {
            extent.left.add(x);
        }
        if let Some((x, _)) = border(w - 0.5, y) {
            extent.right.add(x);
        }
    }
    for col in 0..camera.width {
        let x = col as f64 + 0.5;
        if let Some((_, y)) = border(x, 0.5) {
            extent.top.add(y);
        }
        if let Some((_, y)) = border(x, h - 0.5) {
            extent.bottom.add(y);
        }
    }
    let (cx, cy) = (camera.cx, camera.cy);
    let max_scale_x = (cx / (cx - extent.left.max)).max((w - 0.5 - cx) / (extent.right.min - cx));
    let max_scale_y = (cy / (cy - extent.top.max)).max((h - 0.5 - cy) / (extent.bottom.min - cy));
    let sides = [extent.left, extent.right, extent.top, extent.bottom];
    let usable = |scale: f64| scale.is_finite() && scale > 0.0;
    if sides.iter().any(|r| r.min > r.max) || !usable(max_scale_x) || !usable(max_scale_y) {
        bail!(
            "the distortion {distortion:?} cannot be inverted along the image border of a {}×{} camera \
             (fx {}, fy {}, cx {}, cy {}); its coefficients do not describe a usable lens",
            camera.width,
            camera.height,
            camera.fx,
            camera.fy,
            camera.cx,
            camera.cy
        );
    }
    // COLMAP's defaults: no blank pixels, the scale clamped to [0.2, 2].
    let scale_x = (1.0 / max_scale_x).clamp(MIN_SCALE, MAX_SCALE);
    let scale_y = (1.0 / max_scale_y).clamp(MIN_SCALE, MAX_SCALE);
    // Truncation, as COLMAP converts the scaled size to an integer.
    let width = (scale_x * w).max(1.0) as u32;
    let height = (scale_y * h).max(1.0) as u32;
    Ok(Intrinsics {
        width,
        height,
        fx: camera.fx,
        fy: camera.fy,
        cx: cx * width as f64 / w,
        cy: cy * height as f64 / h,
    })
}

const MIN_SCALE: f64 = 0.2;
const MAX_SCALE: f64 = 2.0;

#[derive(Debug, Clone, Copy)]
struct Range {
    min: f64,
    max: f64,
}

impl Default for Range {
    fn default() -> Self {
        Range {
            min: f64::INFINITY,
            max: f64::NEG_INFINITY,
        }
    }
}

impl Range {
    fn add(&mut self, v: f64) {
        self.min = self.min.min(v);
        self.max = self.max.max(v);
    }
}

#[derive(Debug, Default)]
struct Extent {
    left: Range,
    right: Range,
    top: Range,
    bottom: Range,
}

/// Where every output pixel samples the distorted image: source positions with pixel
/// centres at integers (`NaN` where the distortion has no value).
#[derive(Debug, Clone)]
pub struct UndistortMap {
    pub source: Intrinsics,
    pub target: Intrinsics,
    positions: Vec<(f32, f32)>,
}

impl UndistortMap {
    pub fn new(source: Intrinsics, distortion: &Distortion, target: Intrinsics) -> UndistortMap {
        let mut positions = Vec::with_capacity((target.width * target.height) as usize);
        for row in 0..target.height {
            for col in 0..target.width {
                let (u, v) = target.to_normalised(col as f64 + 0.5, row as f64 + 0.5);
                let p = distortion
                    .distort(u, v)
                    .map(|(ud, vd)| source.to_pixel(ud, vd))
                    .filter(|(x, y)| x.is_finite() && y.is_finite())
                    .map(|(x, y)| ((x - 0.5) as f32, (y - 0.5) as f32))
                    .unwrap_or((f32::NAN, f32::NAN));
                positions.push(p);
            }
        }
        UndistortMap {
            source,
            target,
            positions,
        }
    }

    /// The undistorted image: bilinear samples, source pixels outside the image black.
    pub fn apply(&self, img: &Image) -> Result<Image> {
        self.check_size(img)?;
        let c = img.channels as usize;
        let (w, h) = (img.width as usize, img.height as usize);
        let mut out = Image::new(self.target.width, self.target.height, img.channels);
        for (p, &(x, y)) in self.positions.iter().enumerate() {
            let dst = &mut out.data[p * c..(p + 1) * c];
            let (x0, y0) = (x.floor(), y.floor());
            // Most pixels sample well inside the image: four taps, no bounds to test.
            if x0 >= 0.0 && y0 >= 0.0 && (x0 as usize) + 1 < w && (y0 as usize) + 1 < h {
                let (fx, fy) = (x - x0, y - y0);
                let i = (y0 as usize * w + x0 as usize) * c;
                let j = i + w * c;
                let (a, b) = (&img.data[i..i + 2 * c], &img.data[j..j + 2 * c]);
                for ch in 0..c {
                    let top = a[ch] + fx * (a[c + ch] - a[ch]);
                    let bottom = b[ch] + fx * (b[c + ch] - b[ch]);
                    dst[ch] = top + fy * (bottom - top);
                }
                continue;
            }
            for (tap, weight) in taps(x, y, img.width, img.height) {
                let src = &img.data[tap * c..(tap + 1) * c];
                for (d, s) in dst.iter_mut().zip(src) {
                    *d += weight * s;
                }
            }
        }
        Ok(out)
    }

    /// Which output pixels see the image fully: 1 where every bilinear tap lies inside
    /// the source and is valid in `valid` (non-zero = valid; all valid when `None`), else 0.
    pub fn coverage(&self, valid: Option<&Image>) -> Result<Image> {
        if let Some(m) = valid {
            self.check_size(m)?;
        }
        let (w, h) = (self.source.width, self.source.height);
        let mut out = Image::new(self.target.width, self.target.height, 1);
        for (p, &(x, y)) in self.positions.iter().enumerate() {
            let inside = x >= 0.0 && y >= 0.0 && x <= (w - 1) as f32 && y <= (h - 1) as f32;
            let ok = inside
                && taps(x, y, w, h).all(|(tap, weight)| {
                    weight == 0.0 || valid.is_none_or(|m| m.data[tap * m.channels as usize] > 0.0)
                });
            out.data[p] = if ok { 1.0 } else { 0.0 };
        }
        Ok(out)
    }

    fn check_size(&self, img: &Image) -> Result<()> {
        if (img.width, img.height) != (self.source.width, self.source.height) {
            bail!(
                "image is {}×{} but its distorted camera is {}×{}",
                img.width,
                img.height,
                self.source.width,
                self.source.height
            );
        }
        Ok(())
    }
}

/// The bilinear taps at `(x, y)` (pixel centres at integers) that fall inside a
/// `w × h` image: (pixel index, weight). Taps outside contribute nothing (black).
fn taps(x: f32, y: f32, w: u32, h: u32) -> impl Iterator<Item = (usize, f32)> {
    let valid = x.is_finite() && y.is_finite();
    let (x0, y0) = if valid {
        (x.floor(), y.floor())
    } else {
        (0.0, 0.0)
    };
    let (fx, fy) = (x - x0, y - y0);
    let corners = [
        (0.0, 0.0, (1.0 - fx) * (1.0 - fy)),
        (1.0, 0.0, fx * (1.0 - fy)),
        (0.0, 1.0, (1.0 - fx) * fy),
        (1.0, 1.0, fx * fy),
    ];
    corners.into_iter().filter_map(move |(dx, dy, weight)| {
        let (cx, cy) = (x0 + dx, y0 + dy);
        (valid && cx >= 0.0 && cy >= 0.0 && cx < w as f32 && cy < h as f32)
            .then(|| ((cy as usize) * w as usize + cx as usize, weight))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn undistort_inverts_distort() {
        let models = [
            Distortion::Brown {
                k: [-0.28, 0.07, 0.0, 0.0, 0.0, 0.0],
                p: [0.001, -0.0005],
            },
            Distortion::Brown {
                k: [0.1, -0.02, 0.003, 0.05, -0.01, 0.002],
                p: [0.0, 0.0],
            },
            Distortion::Fisheye {
                k: [-0.03, -0.005, 0.0007, -0.0002],
            },
        ];
        for d in models {
            for &(u, v) in &[(0.0, 0.0), (0.3, -0.2), (-0.6, 0.45), (1.2, 0.9)] {
                let (ud, vd) = d.distort(u, v).unwrap();
                let (bu, bv) = d.undistort(ud, vd).unwrap();
                assert!(
                    (bu - u).abs() < 1e-10 && (bv - v).abs() < 1e-10,
                    "{d:?}: ({u}, {v}) → ({ud}, {vd}) → ({bu}, {bv})"
                );
            }
        }
    }

    #[test]
    fn no_distortion_keeps_the_camera_and_the_pixels() {
        let cam = Intrinsics {
            width: 5,
            height: 4,
            fx: 4.0,
            fy: 4.0,
            cx: 2.5,
            cy: 2.0,
        };
        let d = Distortion::Brown {
            k: [0.0; 6],
            p: [0.0; 2],
        };
        assert_eq!(undistorted_camera(&cam, &d).unwrap(), cam);
        let img = Image::from_fn(5, 4, 1, |x, y, _| (x + 5 * y) as f32 / 20.0);
        let out = UndistortMap::new(cam, &d, cam).apply(&img).unwrap();
        for (a, b) in out.data.iter().zip(&img.data) {
            assert!((a - b).abs() < 1e-6);
        }
    }
}
