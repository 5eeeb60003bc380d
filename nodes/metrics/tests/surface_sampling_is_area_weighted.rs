//! Surface samples are spread by area, lie on their faces, and repeat for a seed.
use objectsplat_core::Mesh;
use objectsplat_metrics::{SampleCount, sample_surface};

const LIMIT: usize = objectsplat_metrics::DEFAULT_MAX_SAMPLES;

/// Two triangles in z = 0 with areas 0.5 and 3.0.
fn two_triangles() -> Mesh {
    Mesh {
        positions: vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [3.0, 0.0, 0.0],
            [6.0, 0.0, 0.0],
            [3.0, 2.0, 0.0],
        ],
        faces: vec![[0, 1, 2], [3, 4, 5]],
        ..Default::default()
    }
}

#[test]
fn faces_are_chosen_in_proportion_to_area() {
    let n = 40_000;
    let s = sample_surface(&two_triangles(), SampleCount::Total(n), 11, LIMIT).unwrap();
    let first = s.faces.iter().filter(|&&f| f == 0).count() as f64;
    // Binomial(n, 0.5 / 3.5): standard deviation ≈ 70, allow 5σ.
    let p = 0.5 / 3.5;
    assert!(
        (first - n as f64 * p).abs() < 5.0 * (n as f64 * p * (1.0 - p)).sqrt(),
        "{first}"
    );
}

#[test]
fn samples_lie_uniformly_inside_their_triangle() {
    let s = sample_surface(&two_triangles(), SampleCount::Total(20_000), 3, LIMIT).unwrap();
    let mut centroid = [0.0; 2];
    let mut count = 0.0;
    for (p, &f) in s.points.iter().zip(&s.faces) {
        assert_eq!(p[2], 0.0);
        if f == 0 {
            assert!(
                p[0] >= 0.0 && p[1] >= 0.0 && p[0] + p[1] <= 1.0 + 1e-12,
                "{p:?}"
            );
            centroid[0] += p[0];
            centroid[1] += p[1];
            count += 1.0;
        }
    }
    // A uniform density has its mean at the centroid (1/3, 1/3); σ of the mean ≈ 0.0034.
    for c in centroid {
        assert!((c / count - 1.0 / 3.0).abs() < 0.02, "{}", c / count);
    }
}

#[test]
fn same_seed_same_samples_and_density_sets_the_count() {
    let m = two_triangles();
    let a = sample_surface(&m, SampleCount::PerArea(100.0), 5, LIMIT).unwrap();
    let b = sample_surface(&m, SampleCount::PerArea(100.0), 5, LIMIT).unwrap();
    let c = sample_surface(&m, SampleCount::PerArea(100.0), 6, LIMIT).unwrap();
    assert_eq!(a, b);
    assert_ne!(a.points, c.points);
    // Total area 0.5 + 3.0 = 3.5 → 350 points.
    assert_eq!(a.points.len(), 350);
}

#[test]
fn invalid_meshes_are_rejected() {
    let mut m = two_triangles();
    m.faces.push([0, 1, 9]);
    assert!(sample_surface(&m, SampleCount::Total(10), 0, LIMIT).is_err());
    let flat = Mesh {
        positions: vec![[0.0; 3]; 3],
        faces: vec![[0, 1, 2]],
        ..Default::default()
    };
    assert!(sample_surface(&flat, SampleCount::Total(10), 0, LIMIT).is_err());
}
