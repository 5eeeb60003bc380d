//! Normal consistency against analytic answers: faces along the true surface score 1 in
//! either winding, a face tilted by θ scores cos θ, mixtures weigh faces by area, and
//! what cannot be scored says so.
use objectsplat_core::Mesh;
use objectsplat_metrics::{MeshEvalParams, normal_consistency};

/// A square of side `side` centred on the origin, tilted by `tilt` radians about the x axis
/// (0: in z = 0).
fn square(side: f32, tilt: f32) -> Mesh {
    let h = side / 2.0;
    let (s, c) = tilt.sin_cos();
    let at = |x: f32, y: f32| [x, y * c, y * s];
    Mesh {
        positions: vec![at(-h, -h), at(h, -h), at(h, h), at(-h, h)],
        faces: vec![[0, 1, 2], [0, 2, 3]],
        ..Default::default()
    }
}

fn params() -> MeshEvalParams {
    MeshEvalParams {
        voxel: 0.01,
        ..Default::default()
    }
}

fn score(pred: &Mesh, truth: &Mesh) -> Option<f64> {
    normal_consistency(pred, truth, &params(), None).unwrap()
}

#[test]
fn faces_along_the_true_surface_score_one_in_either_winding() {
    let truth = square(2.0, 0.0);
    let along = square(0.5, 0.0);
    assert!((score(&along, &truth).unwrap() - 1.0).abs() < 1e-12);
    let mut flipped = along.clone();
    for f in &mut flipped.faces {
        f.swap(1, 2);
    }
    assert!((score(&flipped, &truth).unwrap() - 1.0).abs() < 1e-12);
}

#[test]
fn a_face_tilted_by_theta_scores_cos_theta() {
    let truth = square(4.0, 0.0);
    for degrees in [30.0f32, 45.0, 60.0, 90.0] {
        let theta = degrees.to_radians();
        // Small enough that every nearest true point is on the plane, away from its edge.
        let nc = score(&square(0.4, theta), &truth).unwrap();
        let expected = f64::from(theta).cos();
        assert!(
            (nc - expected).abs() < 1e-6,
            "{degrees}°: {nc} against {expected}"
        );
    }
}

#[test]
fn faces_are_weighed_by_their_area() {
    let truth = square(4.0, 0.0);
    // A flat square of area 0.36 and a vertical one of area 0.04 beside it: 0.9 of the
    // area lies along the surface, 0.1 across it.
    let mut pred = square(0.6, 0.0);
    let upright = square(0.2, std::f32::consts::FRAC_PI_2);
    let base = pred.positions.len() as u32;
    pred.positions
        .extend(upright.positions.iter().map(|p| [p[0] + 1.0, p[1], p[2]]));
    pred.faces
        .extend(upright.faces.iter().map(|f| f.map(|v| v + base)));
    let nc = score(&pred, &truth).unwrap();
    // 4 000 samples: the share on the upright square has a standard deviation of 0.005.
    assert!((nc - 0.9).abs() < 0.02, "{nc}");
}

#[test]
fn nothing_to_compare_gives_none_and_a_bad_spacing_an_error() {
    let truth = square(2.0, 0.0);
    assert_eq!(score(&Mesh::default(), &truth), None);
    assert_eq!(score(&square(0.5, 0.0), &Mesh::default()), None);
    // A true surface the filter keeps nothing of.
    let none = |_: &[f64; 3]| false;
    assert_eq!(
        normal_consistency(&square(0.5, 0.0), &truth, &params(), Some(&none)).unwrap(),
        None
    );
    for voxel in [0.0, -1.0, f64::NAN, f64::INFINITY] {
        let bad = MeshEvalParams {
            voxel,
            ..Default::default()
        };
        let err = normal_consistency(&square(0.5, 0.0), &truth, &bad, None).unwrap_err();
        assert!(err.to_string().contains("positive number"), "{err}");
    }
}
