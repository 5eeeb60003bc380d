//! Surface sampling is bounded by `max_samples`: a surface whose area exploded (a
//! diverged model) fails at once with its area named, instead of asking for tens of
//! gigabytes and aborting the process; counts up to the cap are drawn in full.

use objectsplat_core::Mesh;
use objectsplat_metrics::{MeshEvalParams, SampleCount, mesh_points, sample_surface};

/// One right triangle with legs of `leg` units: area leg²/2.
fn triangle(leg: f32) -> Mesh {
    Mesh {
        positions: vec![[0.0, 0.0, 0.0], [leg, 0.0, 0.0], [0.0, leg, 0.0]],
        faces: vec![[0, 1, 2]],
        ..Default::default()
    }
}

#[test]
fn an_exploded_surface_fails_with_its_area_instead_of_exhausting_memory() {
    // 5·10¹¹ m²: at the default 10⁴ samples/m² that would be 5·10¹⁵ points.
    let exploded = triangle(1.0e6);
    let e = mesh_points(&exploded, &MeshEvalParams::default())
        .expect_err("refused")
        .to_string();
    assert!(e.contains("exceeds max_samples = 10000000"), "{e}");
    assert!(e.contains("surface of area 5.000e11"), "{e}");
    assert!(e.contains("diverged"), "{e}");
}

#[test]
fn the_cap_is_inclusive_for_totals_and_densities() {
    let unit = triangle(2.0); // area 2
    let cap = 1000;
    assert_eq!(
        sample_surface(&unit, SampleCount::Total(cap), 1, cap)
            .unwrap()
            .points
            .len(),
        cap
    );
    assert!(sample_surface(&unit, SampleCount::Total(cap + 1), 1, cap).is_err());
    // 500 per unit² × 2 unit² = exactly the cap.
    assert_eq!(
        sample_surface(&unit, SampleCount::PerArea(500.0), 1, cap)
            .unwrap()
            .points
            .len(),
        cap
    );
    assert!(sample_surface(&unit, SampleCount::PerArea(501.0), 1, cap).is_err());
    // A density so high that area × density overflows to infinity is refused too.
    assert!(sample_surface(&unit, SampleCount::PerArea(f64::MAX), 1, usize::MAX).is_err());
}
