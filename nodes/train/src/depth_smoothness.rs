//! Planarity of the rendered depth on a component's own pixels.
//!
//! With few training views the photometric loss does not fix where a textured
//! floor is: a triangle 10 cm below it, tilted a little, paints the same
//! pixels in six views. The sparse split's background came out as a patchwork
//! of such shards (a third of its area more than 5 cm from the room, most of
//! it under a correct piece of floor), and the depth at the measured points
//! holds only the pieces a point lands on.
//!
//! A plane's inverse camera depth is affine in the pixel coordinates, so its
//! second difference along an image row or column is zero; a shard's edge is
//! not. The loss is `λ · mean |q₋ − 2q₀ + q₊| / q₀` over every horizontal and
//! vertical run of three of the component's own pixels that are each at least
//! half covered, with `q = α/D` the inverse depth of what covers the pixel
//! (`D` the rendered expected depth `Σ w_n z_n`, `α` the coverage `Σ w_n`).
//! Dividing by `q₀` makes it scale-free (the same in metres or millimetres).
//! L1, so true creases (a wall meeting the floor) cost one pixel each, not the
//! square of their height.
//!
//! It is a prior for a room's shell more than for objects: across an object's
//! silhouette the depth jumps, which is why it is off by default for object
//! components (their weight is a separate setting) and why a decomposed
//! background can carry it where a holistic model pays for it at every
//! object's outline.

/// Pixels covered less than this take no part (their depth is mostly the
/// absence of a surface).
const MIN_COVERAGE: f32 = 0.5;

/// One rendered region's depth planes and which of its pixels the loss may use.
pub struct DepthImage<'a> {
    pub width: usize,
    pub height: usize,
    /// Expected depth `Σ w_n z_n`, row-major.
    pub depth: &'a [f32],
    /// Coverage `Σ w_n`, row-major.
    pub alpha: &'a [f32],
}

/// Adds the gradient of `weight · mean |q₋ − 2q₀ + q₊| / q₀` (see the module
/// docs) over the runs of three pixels for which `own` holds to `d_depth` and
/// `d_alpha` and returns the loss (0 when no run qualifies).
pub fn add_gradient(
    image: &DepthImage,
    own: impl Fn(usize) -> bool,
    weight: f64,
    d_depth: &mut [f32],
    d_alpha: &mut [f32],
) -> f64 {
    let (w, h) = (image.width, image.height);
    // Inverse depth of the covering surface, or None where the pixel takes no part.
    let inverse: Vec<Option<f64>> = (0..w * h)
        .map(|i| {
            let (a, d) = (image.alpha[i], image.depth[i]);
            (own(i) && a >= MIN_COVERAGE && d > 0.0 && d.is_finite()).then(|| a as f64 / d as f64)
        })
        .collect();
    // Every run of three pixels along a row (step 1) or a column (step w).
    let mut runs: Vec<([usize; 3], [f64; 3])> = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            for (step, inside) in [(1, x >= 1 && x + 1 < w), (w, y >= 1 && y + 1 < h)] {
                if !inside {
                    continue;
                }
                let pixels = [i - step, i, i + step];
                if let [Some(a), Some(b), Some(c)] = pixels.map(|p| inverse[p]) {
                    runs.push((pixels, [a, b, c]));
                }
            }
        }
    }
    let count = runs.len();
    if count == 0 {
        return 0.0;
    }
    let scale = weight / count as f64;
    let mut d_inverse = vec![0.0f64; w * h];
    let mut loss = 0.0;
    for (pixels, [qa, qb, qc]) in runs {
        let s = qa - 2.0 * qb + qc;
        loss += s.abs() / qb;
        let sign = s.signum() * (s != 0.0) as i32 as f64;
        // d(|s|/qb)/dqa = sign/qb; /dqb = −2·sign/qb − |s|/qb²; /dqc = sign/qb.
        d_inverse[pixels[0]] += scale * sign / qb;
        d_inverse[pixels[1]] += scale * (-2.0 * sign / qb - s.abs() / (qb * qb));
        d_inverse[pixels[2]] += scale * sign / qb;
    }
    for (i, g) in d_inverse.into_iter().enumerate() {
        if g != 0.0 {
            // q = α/D: dq/dD = −α/D², dq/dα = 1/D.
            let (a, d) = (image.alpha[i] as f64, image.depth[i] as f64);
            d_depth[i] += (-g * a / (d * d)) as f32;
            d_alpha[i] += (g / d) as f32;
        }
    }
    scale * loss
}

#[cfg(test)]
mod tests {
    use super::*;

    fn loss(width: usize, height: usize, depth: &[f32], alpha: &[f32]) -> f64 {
        let image = DepthImage {
            width,
            height,
            depth,
            alpha,
        };
        let (mut dd, mut da) = (vec![0.0; depth.len()], vec![0.0; depth.len()]);
        add_gradient(&image, |i| i != 7, 0.7, &mut dd, &mut da)
    }

    /// A plane seen by a pinhole camera has an affine inverse depth: no loss.
    #[test]
    fn a_plane_costs_nothing() {
        let (w, h) = (6, 5);
        let depth: Vec<f32> = (0..w * h)
            .map(|i| 1.0 / (0.5 + 0.03 * (i % w) as f32 + 0.02 * (i / w) as f32))
            .collect();
        assert!(loss(w, h, &depth, &vec![1.0; w * h]).abs() < 1e-6);
    }

    /// Tiny and huge scene scales, infinite, NaN and zero depths, saturated and
    /// empty coverage: finite loss and gradients, and the loss is scale-free.
    #[test]
    fn fuzz_extreme_depths() {
        let (w, h) = (4, 4);
        let shape = |i: usize| 1.0 + 0.5 * ((i * 5) % 3) as f32;
        for scale in [1e-6f32, 1.0, 1e6] {
            let depth: Vec<f32> = (0..w * h).map(|i| scale * shape(i)).collect();
            let alpha = vec![1.0; w * h];
            let loss_here = loss(w, h, &depth, &alpha);
            let reference = loss(
                w,
                h,
                &depth.iter().map(|d| d / scale).collect::<Vec<_>>(),
                &alpha,
            );
            assert!(
                (loss_here - reference).abs() < 1e-4 * reference,
                "scale {scale}"
            );
        }
        // Neighbours 12 orders of magnitude apart (a render's near plane bounds depth below).
        let depth = [
            0.0,
            f32::NAN,
            f32::INFINITY,
            -1.0,
            1e-6,
            1e6,
            1.0,
            2.0,
            3.0,
            1.0,
            1.0,
            1.0,
            5.0,
            1.0,
            0.5,
            1.0,
        ];
        let alpha = [
            1.0,
            1.0,
            1.0,
            1.0,
            1.0,
            1.0,
            0.0,
            1.0,
            1.0,
            1.0,
            f32::NAN,
            1.0,
            1.0,
            1.0,
            1.0,
            1.0,
        ];
        let (mut dd, mut da) = (vec![0.0; 16], vec![0.0; 16]);
        let image = DepthImage {
            width: w,
            height: h,
            depth: &depth,
            alpha: &alpha,
        };
        let value = add_gradient(&image, |_| true, 1.0, &mut dd, &mut da);
        assert!(value.is_finite());
        assert!(dd.iter().chain(&da).all(|g| g.is_finite()), "{dd:?} {da:?}");
    }

    /// The analytic gradient against central differences of the loss, on a
    /// rough partly covered depth image (one pixel not the component's own).
    #[test]
    fn finite_diff() {
        let (w, h) = (5, 4);
        let depth: Vec<f32> = (0..w * h)
            .map(|i| 2.0 + 0.37 * ((i * 7919) % 13) as f32 / 13.0)
            .collect();
        let alpha: Vec<f32> = (0..w * h)
            .map(|i| {
                if i == 12 {
                    0.3
                } else {
                    0.6 + 0.4 * ((i * 31) % 7) as f32 / 7.0
                }
            })
            .collect();
        let (mut dd, mut da) = (vec![0.0; w * h], vec![0.0; w * h]);
        let image = DepthImage {
            width: w,
            height: h,
            depth: &depth,
            alpha: &alpha,
        };
        add_gradient(&image, |i| i != 7, 0.7, &mut dd, &mut da);
        let eps = 1e-3f32;
        for i in 0..w * h {
            for (plane, analytic) in [(0, dd[i]), (1, da[i])] {
                let (mut up, mut down) = (
                    (depth.clone(), alpha.clone()),
                    (depth.clone(), alpha.clone()),
                );
                if plane == 0 {
                    up.0[i] += eps;
                    down.0[i] -= eps;
                } else {
                    up.1[i] += eps;
                    down.1[i] -= eps;
                }
                let numeric =
                    (loss(w, h, &up.0, &up.1) - loss(w, h, &down.0, &down.1)) / (2.0 * eps as f64);
                assert!(
                    (numeric - analytic as f64).abs() < 2e-3 * (1.0 + numeric.abs()),
                    "pixel {i} plane {plane}: numeric {numeric} analytic {analytic}"
                );
            }
        }
        // The uncovered pixel and the foreign one carry no gradient.
        assert_eq!((dd[12], da[12], dd[7], da[7]), (0.0, 0.0, 0.0, 0.0));
    }
}
