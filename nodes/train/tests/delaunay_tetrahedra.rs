//! The tetrahedralization is Delaunay, fills the convex hull, and survives degenerate input.

use objectsplat_train::delaunay::{NO_TET, tetrahedralize};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use robust::{Coord3D, insphere, orient3d};

fn c(p: [f64; 3]) -> Coord3D<f64> {
    Coord3D {
        x: p[0],
        y: p[1],
        z: p[2],
    }
}

fn volume(p: &[[f64; 3]], t: [u32; 4]) -> f64 {
    let [a, b, cc, d] = t.map(|i| p[i as usize]);
    let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let v = [cc[0] - a[0], cc[1] - a[1], cc[2] - a[2]];
    let w = [d[0] - a[0], d[1] - a[1], d[2] - a[2]];
    (u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0])
        + u[2] * (v[0] * w[1] - v[1] * w[0]))
        .abs()
        / 6.0
}

/// Unit-cube corners plus random interior points: no point lies strictly inside
/// any tetrahedron's circumsphere (checked exactly, brute force), and the
/// tetrahedra fill the cube exactly once.
#[test]
fn random_points_satisfy_the_empty_sphere_property() {
    let mut rng = Pcg64Mcg::seed_from_u64(11);
    let mut pts: Vec<[f64; 3]> = (0..8)
        .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
        .collect();
    pts.extend((0..150).map(|_| {
        [
            0.05 + 0.9 * rng.random::<f64>(),
            0.05 + 0.9 * rng.random::<f64>(),
            0.05 + 0.9 * rng.random::<f64>(),
        ]
    }));
    let t = tetrahedralize(&pts, 5).unwrap();
    assert!(t.skipped.is_empty());
    let total: f64 = t.tets.iter().map(|&tt| volume(&pts, tt)).sum();
    assert!((total - 1.0).abs() < 1e-9, "volume {total}");
    for &tt in &t.tets {
        let [a, b, cc, d] = tt.map(|i| pts[i as usize]);
        let o = orient3d(c(a), c(b), c(cc), c(d));
        assert!(o != 0.0);
        for (i, &p) in pts.iter().enumerate() {
            if tt.contains(&(i as u32)) {
                continue;
            }
            let s = insphere(c(a), c(b), c(cc), c(d), c(p)) * o.signum();
            assert!(s <= 0.0, "point {i} inside the circumsphere of {tt:?}");
        }
    }
    // Neighbour links are symmetric and share exactly three corners.
    for (ti, nb) in t.neighbors.iter().enumerate() {
        for (k, &o) in nb.iter().enumerate() {
            if o == NO_TET {
                continue;
            }
            assert!(t.neighbors[o as usize].contains(&(ti as u32)));
            let shared = t.tets[ti]
                .iter()
                .filter(|v| t.tets[o as usize].contains(v))
                .count();
            assert_eq!(shared, 3);
            assert!(!t.tets[o as usize].contains(&t.tets[ti][k]));
        }
    }
}

/// A lattice is maximally degenerate (cospherical and coplanar everywhere).
#[test]
fn lattice_points_tile_their_box() {
    let mut pts = Vec::new();
    for x in 0..5 {
        for y in 0..4 {
            for z in 0..3 {
                pts.push([x as f64, y as f64, z as f64]);
            }
        }
    }
    let t = tetrahedralize(&pts, 1).unwrap();
    let total: f64 = t.tets.iter().map(|&tt| volume(&pts, tt)).sum();
    assert!((total - 24.0).abs() < 1e-6, "volume {total}");
    assert!(t.skipped.is_empty());
}

#[test]
fn degenerate_inputs_neither_hang_nor_panic() {
    // Coplanar grid: every tetrahedron is flat (volume ~ jitter).
    let plane: Vec<[f64; 3]> = (0..100)
        .map(|i| [(i % 10) as f64, (i / 10) as f64, 0.0])
        .collect();
    let t = tetrahedralize(&plane, 2).unwrap();
    let vol: f64 = t.tets.iter().map(|&tt| volume(&plane, tt)).sum();
    assert!(vol < 1e-9);
    // Collinear points.
    let line: Vec<[f64; 3]> = (0..50).map(|i| [i as f64, 2.0 * i as f64, 0.0]).collect();
    tetrahedralize(&line, 2).unwrap();
    // Duplicates are inserted once and reported.
    let mut dup: Vec<[f64; 3]> = (0..8)
        .map(|i| [(i & 1) as f64, ((i >> 1) & 1) as f64, ((i >> 2) & 1) as f64])
        .collect();
    dup.extend(dup.clone());
    dup.push([-0.0, 0.0, 0.0]);
    let t = tetrahedralize(&dup, 2).unwrap();
    assert_eq!(t.skipped, (8..17).collect::<Vec<u32>>());
    let total: f64 = t.tets.iter().map(|&tt| volume(&dup, tt)).sum();
    assert!((total - 1.0).abs() < 1e-9);
    // All identical, too few points, empty.
    assert!(
        tetrahedralize(&[[1.0, 2.0, 3.0]; 10], 0)
            .unwrap()
            .tets
            .is_empty()
    );
    assert!(
        tetrahedralize(&[[0.0; 3], [1.0, 0.0, 0.0]], 0)
            .unwrap()
            .tets
            .is_empty()
    );
    assert!(tetrahedralize(&[], 0).unwrap().tets.is_empty());
    // Non-finite input is an error, not a panic.
    let err = tetrahedralize(&[[0.0; 3], [f64::NAN, 0.0, 0.0]], 0).unwrap_err();
    assert!(format!("{err}").contains("point 1"));
}
