//! The planarity test for support surfaces: a RANSAC plane fit to points.
//!
//! The tolerance is relative to the size of the point set (the diagonal of its
//! bounding box) so one number works for scenes in any unit. The sampling is
//! deterministic (a fixed-seed generator), so the same points always give the same
//! verdict — required for cached, byte-identical node outputs.

use glam::DVec3;

/// The best plane found and how well the points agree with it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlaneFit {
    /// Unit normal.
    pub normal: DVec3,
    /// Plane: `normal · p = offset`.
    pub offset: f64,
    /// Fraction of the points within the absolute tolerance of the plane.
    pub inlier_fraction: f64,
    /// The absolute tolerance used: `tolerance × bounding-box diagonal`.
    pub tolerance: f64,
}

/// Fits a plane to `points` with RANSAC (`iterations` random triples); `None` with
/// fewer than three points or when every triple is degenerate (collinear points).
pub fn fit_plane(points: &[DVec3], relative_tolerance: f64, iterations: usize) -> Option<PlaneFit> {
    if points.len() < 3 {
        return None;
    }
    let (lo, hi) = points.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    );
    let tolerance = relative_tolerance * (hi - lo).length();
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = |n: usize| {
        // xorshift64*: enough for choosing sample indices.
        state ^= state >> 12;
        state ^= state << 25;
        state ^= state >> 27;
        (state.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 33) as usize % n
    };
    let mut best: Option<PlaneFit> = None;
    for _ in 0..iterations {
        let (a, b, c) = (
            points[next(points.len())],
            points[next(points.len())],
            points[next(points.len())],
        );
        let normal = (b - a).cross(c - a);
        if normal.length_squared()
            <= f64::EPSILON * (b - a).length_squared() * (c - a).length_squared()
        {
            continue;
        }
        let normal = normal.normalize();
        let offset = normal.dot(a);
        let inliers = points
            .iter()
            .filter(|p| (normal.dot(**p) - offset).abs() <= tolerance)
            .count();
        let inlier_fraction = inliers as f64 / points.len() as f64;
        if best.is_none_or(|b| inlier_fraction > b.inlier_fraction) {
            best = Some(PlaneFit {
                normal,
                offset,
                inlier_fraction,
                tolerance,
            });
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(height: impl Fn(f64, f64) -> f64) -> Vec<DVec3> {
        (0..20)
            .flat_map(|i| (0..20).map(move |j| (i as f64 * 0.1, j as f64 * 0.1)))
            .map(|(x, y)| DVec3::new(x, y, height(x, y)))
            .collect()
    }

    #[test]
    fn a_tilted_plane_is_found_with_all_points_inliers() {
        let fit = fit_plane(&grid(|x, y| 0.3 * x - 0.2 * y + 1.0), 0.01, 100).unwrap();
        assert_eq!(fit.inlier_fraction, 1.0);
        let expected = DVec3::new(0.3, -0.2, -1.0).normalize();
        assert!(fit.normal.dot(expected).abs() > 1.0 - 1e-9);
    }

    #[test]
    fn a_bowl_is_not_planar() {
        let fit = fit_plane(
            &grid(|x, y| (x - 1.0).powi(2) + (y - 1.0).powi(2)),
            0.01,
            200,
        )
        .unwrap();
        assert!(fit.inlier_fraction < 0.5, "{fit:?}");
    }

    #[test]
    fn collinear_points_have_no_plane() {
        let line: Vec<DVec3> = (0..10).map(|i| DVec3::splat(i as f64)).collect();
        assert!(fit_plane(&line, 0.01, 50).is_none());
    }
}
