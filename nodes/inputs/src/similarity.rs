//! Similarity transforms (scale, rotation, translation) fitted between two sets of
//! corresponding points by least squares (Umeyama 1991), and the pose errors that
//! remain after one: how a structure-from-motion model, in its own arbitrary frame
//! and scale, is brought into a known frame and compared with it.

use anyhow::{Result, bail};
use glam::{DMat3, DVec3};
use nalgebra::{Matrix3, Vector3};

/// `x ↦ scale · rotation · x + translation`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Similarity {
    pub scale: f64,
    pub rotation: DMat3,
    pub translation: DVec3,
}

/// The smallest ratio of the source points' variance along their second main axis to
/// that along their first for which the rotation about the first is taken as
/// determined; below it the points lie (nearly) on a line and the fit refuses.
const MIN_SPREAD_RATIO: f64 = 1e-3;

impl Similarity {
    pub fn apply(&self, p: DVec3) -> DVec3 {
        self.scale * (self.rotation * p) + self.translation
    }

    /// The 3×4 matrix `[scale·R | t]`, row-major (what `colmap model_transformer` reads).
    pub fn matrix_3x4(&self) -> [[f64; 4]; 3] {
        let m = self.rotation * self.scale;
        let row = |i: usize| [m.col(0)[i], m.col(1)[i], m.col(2)[i], self.translation[i]];
        [row(0), row(1), row(2)]
    }

    /// The similarity that maps `source[i]` closest to `target[i]` in the least-squares
    /// sense. Needs three or more pairs whose source points do not lie on one line
    /// (then the rotation about that line is undetermined) and do not coincide.
    pub fn fit(source: &[DVec3], target: &[DVec3]) -> Result<Similarity> {
        if source.len() != target.len() {
            bail!(
                "{} source points but {} target points: a similarity needs pairs",
                source.len(),
                target.len()
            );
        }
        if source.len() < 3 {
            bail!(
                "{} point pairs: a similarity needs at least 3",
                source.len()
            );
        }
        let n = source.len() as f64;
        let mean = |ps: &[DVec3]| ps.iter().copied().sum::<DVec3>() / n;
        let (mean_s, mean_t) = (mean(source), mean(target));
        let to_na = |v: DVec3| Vector3::new(v.x, v.y, v.z);
        let mut covariance = Matrix3::zeros();
        let mut source_scatter = Matrix3::zeros();
        let mut source_variance = 0.0;
        for (s, t) in source.iter().zip(target) {
            let (ds, dt) = (to_na(*s - mean_s), to_na(*t - mean_t));
            covariance += dt * ds.transpose();
            source_scatter += ds * ds.transpose();
            source_variance += ds.norm_squared();
        }
        covariance /= n;
        source_variance /= n;
        let spread = source_scatter.symmetric_eigenvalues();
        let mut spread: Vec<f64> = spread.iter().copied().collect();
        spread.sort_by(|a, b| b.total_cmp(a));
        if spread[0].is_nan() || spread[0] <= 0.0 || !source_variance.is_finite() {
            bail!("the source points coincide: no scale or rotation can be fitted");
        }
        if spread[1] < MIN_SPREAD_RATIO * spread[0] {
            bail!(
                "the source points lie on a line (spreads {:.3e} and {:.3e} along their two main axes): \
                 the rotation about it cannot be fitted",
                spread[0].sqrt(),
                spread[1].sqrt()
            );
        }
        let svd = covariance.svd(true, true);
        // Both factors were requested above, so they are present.
        let (u, v_t) = (svd.u.expect("requested"), svd.v_t.expect("requested"));
        // A reflection is the best fit only for mirrored data; the nearest rotation
        // flips the axis of the smallest singular value.
        let mut signs = Vector3::new(1.0, 1.0, 1.0);
        if u.determinant() * v_t.determinant() < 0.0 {
            let smallest = svd.singular_values.imin();
            signs[smallest] = -1.0;
        }
        let r = u * Matrix3::from_diagonal(&signs) * v_t;
        let scale = svd.singular_values.dot(&signs) / source_variance;
        let rotation = DMat3::from_cols(
            DVec3::new(r[(0, 0)], r[(1, 0)], r[(2, 0)]),
            DVec3::new(r[(0, 1)], r[(1, 1)], r[(2, 1)]),
            DVec3::new(r[(0, 2)], r[(1, 2)], r[(2, 2)]),
        );
        let translation = mean_t - scale * (rotation * mean_s);
        if scale.is_nan() || scale <= 0.0 || !translation.is_finite() {
            bail!("no similarity fits these points (scale {scale})");
        }
        Ok(Similarity {
            scale,
            rotation,
            translation,
        })
    }
}

/// The angle in degrees of the rotation taking `a` to `b`.
pub fn rotation_angle_degrees(a: DMat3, b: DMat3) -> f64 {
    let d = b * a.transpose();
    let cos = ((d.x_axis.x + d.y_axis.y + d.z_axis.z - 1.0) / 2.0).clamp(-1.0, 1.0);
    cos.acos().to_degrees()
}

/// The size of a set of points: the diagonal of their bounding box.
pub fn extent(points: &[DVec3]) -> f64 {
    let Some(first) = points.first() else {
        return 0.0;
    };
    let (lo, hi) = points
        .iter()
        .fold((*first, *first), |(lo, hi), p| (lo.min(*p), hi.max(*p)));
    (hi - lo).length()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DQuat;

    fn ring(n: usize) -> Vec<DVec3> {
        (0..n)
            .map(|i| {
                let a = i as f64 * 0.7;
                DVec3::new(a.cos() * 2.0, a.sin() * 1.5, 0.3 * (2.0 * a).sin())
            })
            .collect()
    }

    #[test]
    fn recovers_a_known_similarity() {
        let truth = Similarity {
            scale: 3.7,
            rotation: DMat3::from_quat(DQuat::from_axis_angle(
                DVec3::new(1.0, -2.0, 0.5).normalize(),
                2.1,
            )),
            translation: DVec3::new(-4.0, 0.5, 9.0),
        };
        let source = ring(9);
        let target: Vec<DVec3> = source.iter().map(|p| truth.apply(*p)).collect();
        let fit = Similarity::fit(&source, &target).unwrap();
        assert!((fit.scale - truth.scale).abs() < 1e-12, "{fit:?}");
        assert!(rotation_angle_degrees(fit.rotation, truth.rotation) < 1e-9);
        assert!((fit.translation - truth.translation).length() < 1e-10);
        let m = fit.matrix_3x4();
        let p = DVec3::new(0.3, -1.0, 2.0);
        let by_matrix = DVec3::from_array(std::array::from_fn(|i| {
            m[i][0] * p.x + m[i][1] * p.y + m[i][2] * p.z + m[i][3]
        }));
        assert!((by_matrix - truth.apply(p)).length() < 1e-12);
    }

    #[test]
    fn a_mirrored_target_still_gets_a_rotation() {
        let source = ring(7);
        let target: Vec<DVec3> = source.iter().map(|p| DVec3::new(-p.x, p.y, p.z)).collect();
        let fit = Similarity::fit(&source, &target).unwrap();
        assert!((fit.rotation.determinant() - 1.0).abs() < 1e-12);
    }

    #[test]
    fn degenerate_inputs_are_refused_by_name() {
        let line: Vec<DVec3> = (0..5).map(|i| DVec3::X * i as f64).collect();
        let e = Similarity::fit(&line, &line).unwrap_err().to_string();
        assert!(e.contains("lie on a line"), "{e}");
        let same = vec![DVec3::ONE; 4];
        let e = Similarity::fit(&same, &same).unwrap_err().to_string();
        assert!(e.contains("coincide"), "{e}");
        let e = Similarity::fit(&line[..2], &line[..2])
            .unwrap_err()
            .to_string();
        assert!(e.contains("at least 3"), "{e}");
    }
}
