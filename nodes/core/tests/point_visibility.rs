//! Which sparse points a camera sees: points behind a nearer cluster of points
//! are hidden, points beside it are not, whatever the gaps between points.

use glam::DVec3;
use objectsplat_core::Camera;
use objectsplat_core::visibility::{neighbour_spacing, visible_pixels};

#[test]
fn points_behind_a_nearer_surface_are_hidden() {
    let camera = Camera::look_at(
        64,
        48,
        50.0,
        50.0,
        DVec3::ZERO,
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(0.0, -1.0, 0.0),
    );
    // A "table top" at z = 1 over x < 0 (spacing 2 cm), a "floor" at z = 3
    // (spacing 6 cm, the same angular spacing) across the whole view.
    let mut points = Vec::new();
    for i in -15..0 {
        for j in -10..=10 {
            points.push(DVec3::new(0.02 * i as f64, 0.02 * j as f64, 1.0));
        }
    }
    let table = points.len();
    for i in -15..=15 {
        for j in -10..=10 {
            points.push(DVec3::new(0.06 * i as f64, 0.06 * j as f64, 3.0));
        }
    }
    let spacing = neighbour_spacing(&points);
    assert!((0.019..=0.061).contains(&spacing), "spacing {spacing}");
    let seen = visible_pixels(&points, spacing, &camera);
    assert!(
        seen[..table].iter().all(Option::is_some),
        "the table is in front"
    );
    for (p, s) in points[table..].iter().zip(&seen[table..]) {
        // Behind the table top (x < −0.06, |y| < 0.6 at z = 3): hidden. Clear of
        // it by more than the splat (the median spacing, 6 cm, is 3 px at the
        // table; x > 0.15): visible.
        if p.x < -0.12 && p.y.abs() < 0.5 {
            assert!(s.is_none(), "floor point {p} behind the table is visible");
        }
        if p.x > 0.15 {
            assert!(s.is_some(), "floor point {p} beside the table is hidden");
        }
    }
    // A point behind the camera or outside the image is never seen.
    let outside = visible_pixels(
        &[DVec3::new(0.0, 0.0, -1.0), DVec3::new(10.0, 0.0, 1.0)],
        0.05,
        &camera,
    );
    assert_eq!(outside, vec![None, None]);
}
