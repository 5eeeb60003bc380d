//! The normal-agreement prior: its value against the dihedral angle it is
//! defined by, its gradient against central finite differences, and the
//! faces that take no part (degenerate ones, unshared edges).

use objectsplat_train::normal_agreement::{add_gradient, shared_edge_pairs};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

fn loss(vertices: &[[f32; 3]], faces: &[[u32; 3]], weight: f64) -> f64 {
    let mut scratch = vec![[0.0f32; 3]; vertices.len()];
    add_gradient(vertices, faces, weight, &mut scratch)
}

/// Two triangles on the edge (0,0,0)–(1,0,0), the second bent by `angle`
/// out of the first's plane.
fn hinge(angle: f64) -> Vec<[f32; 3]> {
    vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.5, 1.0, 0.0],
        [0.5, -angle.cos() as f32, angle.sin() as f32],
    ]
}

#[test]
fn a_hinge_costs_the_squared_sine_of_its_bend() {
    for degrees in [0.0f64, 10.0, 30.0, 45.0, 90.0, 135.0] {
        let angle = degrees.to_radians();
        let got = loss(&hinge(angle), &[[0, 1, 2], [1, 0, 3]], 2.5);
        let expected = 2.5 * angle.sin().powi(2);
        assert!(
            (got - expected).abs() < 1e-6,
            "bend {degrees}°: loss {got}, expected {expected}"
        );
    }
}

#[test]
fn either_winding_of_a_flat_pair_is_free() {
    let vertices = hinge(0.0);
    for faces in [[[0, 1, 2], [1, 0, 3]], [[0, 1, 2], [0, 1, 3]]] {
        let mut d = vec![[0.0f32; 3]; vertices.len()];
        assert_eq!(add_gradient(&vertices, &faces, 1.0, &mut d), 0.0);
        assert!(d.iter().flatten().all(|g| g.abs() < 1e-7), "{d:?}");
    }
}

#[test]
fn the_gradient_matches_central_differences() {
    let mut rng = Pcg64::seed_from_u64(31);
    // A fan of five faces around vertex 0, plus a third face on the edge 0–1
    // (an edge of three faces, as restricted Delaunay meshes have).
    let mut vertices = vec![[0.0f32, 0.0, 0.0]];
    for k in 0..5 {
        let a = k as f32 * 1.2;
        vertices.push([a.cos(), a.sin(), rng.random_range(-0.4..0.4)]);
    }
    vertices.push([0.3, 0.2, 0.9]);
    let faces = [
        [0, 1, 2],
        [0, 2, 3],
        [0, 3, 4],
        [0, 4, 5],
        [0, 5, 1],
        [0, 1, 6],
    ];
    let weight = 1.7;
    let mut analytic = vec![[0.0f32; 3]; vertices.len()];
    add_gradient(&vertices, &faces, weight, &mut analytic);
    let h = 1e-3f32;
    for v in 0..vertices.len() {
        for k in 0..3 {
            let mut plus = vertices.clone();
            plus[v][k] += h;
            let mut minus = vertices.clone();
            minus[v][k] -= h;
            let step = (plus[v][k] - minus[v][k]) as f64;
            let numeric = (loss(&plus, &faces, weight) - loss(&minus, &faces, weight)) / step;
            let got = analytic[v][k] as f64;
            assert!(
                (got - numeric).abs() <= 2e-3 * (1.0 + numeric.abs()),
                "vertex {v} axis {k}: analytic {got}, finite difference {numeric}"
            );
        }
    }
}

#[test]
fn gradients_add_to_what_is_there_and_reach_only_the_model_vertices() {
    let vertices = hinge(0.6);
    let faces = [[0, 1, 2], [1, 0, 3]];
    let mut fresh = vec![[0.0f32; 3]; 4];
    add_gradient(&vertices, &faces, 1.0, &mut fresh);
    // Longer than the model (a render with frozen occluders appended).
    let mut accumulated = vec![[1.0f32; 3]; 6];
    add_gradient(&vertices, &faces, 1.0, &mut accumulated);
    for v in 0..4 {
        for k in 0..3 {
            assert!((accumulated[v][k] - 1.0 - fresh[v][k]).abs() < 1e-6);
        }
    }
    assert_eq!(accumulated[4..], [[1.0f32; 3]; 2]);
}

#[test]
fn degenerate_faces_and_unshared_edges_take_no_part() {
    let mut vertices = hinge(0.8);
    // Face 2 is a sliver with all three corners on the shared edge's line.
    vertices.push([2.0, 0.0, 0.0]);
    let faces = [[0, 1, 2], [1, 0, 3], [0, 1, 4]];
    assert_eq!(shared_edge_pairs(&faces), vec![(0, 1), (0, 2), (1, 2)]);
    let mut d = vec![[0.0f32; 3]; vertices.len()];
    let got = add_gradient(&vertices, &faces, 1.0, &mut d);
    assert!((got - 0.8f64.sin().powi(2)).abs() < 1e-6, "{got}");
    assert_eq!(d[4], [0.0; 3]);
    assert!(d.iter().flatten().all(|g| g.is_finite()));
    // A lone face, and a mesh of only degenerate faces: no pair, no loss.
    assert_eq!(loss(&vertices, &[[0, 1, 2]], 1.0), 0.0);
    assert_eq!(loss(&vertices, &[[0, 1, 4], [1, 0, 4]], 1.0), 0.0);
    // Non-finite positions give no normal rather than a NaN loss.
    let mut broken = hinge(0.8);
    broken[3] = [f32::NAN, 0.0, 0.0];
    let mut d = vec![[0.0f32; 3]; 4];
    assert_eq!(add_gradient(&broken, &faces[..2], 1.0, &mut d), 0.0);
    assert!(d.iter().flatten().all(|g| g.is_finite()));
}
