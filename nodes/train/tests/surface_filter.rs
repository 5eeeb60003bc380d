//! The surface filter flattens shingles and keeps what is not noise: exact
//! planes and creases are fixed points, a noisy plane's and a noisy sphere's
//! faces turn to the analytic normals (the plane's axis, the sphere's radius)
//! without the surface moving away, and degenerate or non-finite input does
//! not spread.

mod common;

use common::normal_consistency as consistency;
use objectsplat_train::surface_filter::{SurfaceFilter, SurfaceScratch};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

const FILTER: SurfaceFilter = SurfaceFilter {
    crease_cos: 0.5,
    normal_rounds: 2,
    vertex_rounds: 5,
};

/// An `n × n` grid of squares of side `step`, two triangles each, over
/// `place(u, v)` (u, v in grid steps).
fn grid(n: usize, place: impl Fn(f64, f64) -> [f64; 3]) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut vertices = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let p = place(i as f64, j as f64);
            vertices.push(p.map(|c| c as f32));
        }
    }
    let at = |i: usize, j: usize| (j * (n + 1) + i) as u32;
    let mut faces = Vec::new();
    for j in 0..n {
        for i in 0..n {
            // Alternating diagonals and orientations: no consistent winding to rely on.
            if (i + j) % 2 == 0 {
                faces.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                faces.push([at(i, j), at(i, j + 1), at(i + 1, j + 1)]);
            } else {
                faces.push([at(i + 1, j), at(i, j), at(i, j + 1)]);
                faces.push([at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
    }
    (vertices, faces)
}

/// The plane z = 0 as an `n × n` grid of 1 cm squares, each vertex offset by up
/// to ±4 mm along the normal (seeded): faces tilted by up to ~40°.
fn shingled_plane(n: usize, seed: u64) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let (mut vertices, faces) = grid(n, |u, v| [0.01 * u, 0.01 * v, 0.0]);
    for p in &mut vertices {
        p[2] = (rng.random::<f64>() * 0.008 - 0.004) as f32;
    }
    (vertices, faces)
}

/// The largest coordinate change between two vertex lists.
fn largest_move(before: &[[f32; 3]], after: &[[f32; 3]]) -> f32 {
    before
        .iter()
        .zip(after)
        .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
        .fold(0.0, f32::max)
}

#[test]
fn an_exact_plane_and_an_exact_crease_do_not_move() {
    // A tilted plane.
    let (mut vertices, faces) = grid(12, |u, v| [0.01 * u, 0.01 * v, 0.3 + 0.004 * u - 0.002 * v]);
    let before = vertices.clone();
    let report = FILTER.apply(&mut vertices, &faces, 1, &mut SurfaceScratch::default());
    let moved = largest_move(&before, &vertices);
    assert!(moved <= 1e-7, "a plane moved by {moved} ({report:?})");
    // A floor meeting a wall at 90° along u = 6.
    let (mut vertices, faces) = grid(12, |u, v| {
        if u <= 6.0 {
            [0.01 * u, 0.01 * v, 0.0]
        } else {
            [0.06, 0.01 * v, 0.01 * (u - 6.0)]
        }
    });
    let before = vertices.clone();
    FILTER.apply(&mut vertices, &faces, 1, &mut SurfaceScratch::default());
    let moved = largest_move(&before, &vertices);
    assert!(moved <= 1e-7, "the crease moved by {moved}");
}

#[test]
fn a_shingled_plane_turns_flat_in_place() {
    let (mut vertices, faces) = shingled_plane(30, 3);
    let up = |_| [0.0, 0.0, 1.0];
    let before = consistency(&vertices, &faces, up);
    let xy: Vec<[f32; 2]> = vertices.iter().map(|p| [p[0], p[1]]).collect();
    // One scratch for every pass, as the trainer keeps it.
    let mut scratch = SurfaceScratch::default();
    for _ in 0..20 {
        FILTER.apply(&mut vertices, &faces, 1, &mut scratch);
    }
    let after = consistency(&vertices, &faces, up);
    eprintln!("plane: normal consistency {before:.4} -> {after:.4}");
    assert!(before < 0.95, "the noise should tilt the faces ({before})");
    assert!(after > 0.995, "still shingled: {after}");
    // The surface stays where it was: within the noise band, and moves along
    // the filtered normals (tilted only while the noise is) drift sideways by
    // less than the noise's amplitude.
    for (p, q) in vertices.iter().zip(&xy) {
        assert!(p[2].abs() <= 0.004 + 1e-6, "left the noise band: {p:?}");
        assert!(
            (p[0] - q[0]).abs() <= 4e-3 && (p[1] - q[1]).abs() <= 4e-3,
            "drifted: {p:?} from {q:?}"
        );
    }
}

/// An icosahedron subdivided `levels` times, on the unit sphere.
fn icosphere(levels: usize) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let mut points: Vec<[f64; 3]> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .to_vec();
    let mut faces: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut middle = std::collections::HashMap::new();
        let mut next = Vec::new();
        for [a, b, c] in faces {
            let mut mid = |u: u32, v: u32| {
                *middle.entry((u.min(v), u.max(v))).or_insert_with(|| {
                    let (p, q) = (points[u as usize], points[v as usize]);
                    points.push([0, 1, 2].map(|k| (p[k] + q[k]) / 2.0));
                    points.len() as u32 - 1
                })
            };
            let (ab, bc, ca) = (mid(a, b), mid(b, c), mid(c, a));
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        faces = next;
    }
    for p in &mut points {
        let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
        *p = p.map(|x| x / l);
    }
    (points, faces)
}

#[test]
fn a_noisy_sphere_keeps_its_radius() {
    let mut rng = Pcg64Mcg::seed_from_u64(5);
    // A ball of radius 10 cm, 5120 faces of about 7 mm, ±1 mm radial noise.
    let (unit, faces) = icosphere(4);
    let mut vertices: Vec<[f32; 3]> = unit
        .iter()
        .map(|p| {
            let r = 0.1 + rng.random::<f64>() * 0.002 - 0.001;
            p.map(|c| (r * c) as f32)
        })
        .collect();
    let radial = |c: [f64; 3]| {
        let l = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
        c.map(|x| x / l)
    };
    let radius = |p: &[f32; 3]| p.iter().map(|&c| (c as f64).powi(2)).sum::<f64>().sqrt();
    let mean_radius = |vs: &[[f32; 3]]| vs.iter().map(radius).sum::<f64>() / vs.len() as f64;
    let (before, r0) = (
        consistency(&vertices, &faces, radial),
        mean_radius(&vertices),
    );
    // One scratch for every pass, as the trainer keeps it.
    let mut scratch = SurfaceScratch::default();
    for _ in 0..20 {
        FILTER.apply(&mut vertices, &faces, 1, &mut scratch);
    }
    let (after, r1) = (
        consistency(&vertices, &faces, radial),
        mean_radius(&vertices),
    );
    let spread = vertices
        .iter()
        .map(|p| (radius(p) - r1).abs())
        .fold(0.0, f64::max);
    eprintln!(
        "sphere: normal consistency {before:.4} -> {after:.4}, mean radius {r0:.5} -> {r1:.5}, largest deviation {spread:.5}"
    );
    assert!(before < 0.99, "the noise should tilt the faces ({before})");
    assert!(after > 0.998, "{after}");
    // Twenty passes shrink or swell a 10 cm ball by less than the noise's amplitude.
    assert!((r1 - r0).abs() < 1e-3, "radius {r0} -> {r1}");
    assert!(spread < 1e-3, "vertices {spread} from the mean radius");
}

#[test]
fn degenerate_and_non_finite_input_does_not_spread() {
    let (mut vertices, mut faces) = grid(6, |u, v| [0.01 * u, 0.01 * v, 0.001 * ((u * v) % 3.0)]);
    let n = vertices.len() as u32;
    // A repeated corner, a zero-area face of three collinear points, a sliver.
    vertices.extend([
        [0.0, 0.0, 0.0],
        [0.01, 0.0, 0.0],
        [0.02, 0.0, 0.0],
        [0.02, 1e-9, 0.0],
    ]);
    faces.extend([[0, 0, 1], [n, n + 1, n + 2], [n, n + 2, n + 3]]);
    // A vertex at NaN and one at infinity, each in a face beside the grid.
    vertices.extend([[f32::NAN, 0.0, 0.0], [f32::INFINITY, 0.0, 0.0]]);
    faces.extend([[0, 1, n + 4], [1, 2, n + 5]]);
    FILTER.apply(&mut vertices, &faces, 1, &mut SurfaceScratch::default());
    for (v, p) in vertices.iter().enumerate().take(n as usize + 4) {
        assert!(p.iter().all(|c| c.is_finite()), "vertex {v} became {p:?}");
    }
    assert!(vertices[n as usize + 4][0].is_nan() && vertices[n as usize + 5][0].is_infinite());
}

#[test]
fn several_threads_move_the_vertices_exactly_as_one() {
    // 20 000 faces and 10 201 vertices: several chunks of work per pass.
    let (mut one, faces) = shingled_plane(100, 9);
    let mut three = one.clone();
    let (a, b) = (
        FILTER.apply(&mut one, &faces, 1, &mut SurfaceScratch::default()),
        FILTER.apply(&mut three, &faces, 3, &mut SurfaceScratch::default()),
    );
    assert!(a.moved > 10_000 - 1000, "{a:?}");
    assert_eq!(a, b);
    assert!(one == three, "the vertices differ between 1 and 3 threads");
}

#[test]
fn a_scratch_left_by_another_mesh_filters_exactly_as_a_fresh_one() {
    // A larger mesh first leaves longer arrays (and other values) behind:
    // the next pass must read none of them.
    let mut scratch = SurfaceScratch::default();
    let (mut large, large_faces) = shingled_plane(40, 3);
    FILTER.apply(&mut large, &large_faces, 2, &mut scratch);
    let (mut reused, faces) = shingled_plane(12, 5);
    let mut fresh = reused.clone();
    let (a, b) = (
        FILTER.apply(&mut reused, &faces, 2, &mut scratch),
        FILTER.apply(&mut fresh, &faces, 2, &mut SurfaceScratch::default()),
    );
    assert!(a.moved > 100, "{a:?}");
    assert_eq!(a, b);
    assert!(
        reused == fresh,
        "a reused scratch moved the vertices differently"
    );
    // And a smaller mesh before a larger one (arrays grow).
    let (mut grown, faces) = shingled_plane(60, 7);
    let mut fresh = grown.clone();
    FILTER.apply(&mut grown, &faces, 2, &mut scratch);
    FILTER.apply(&mut fresh, &faces, 2, &mut SurfaceScratch::default());
    assert!(
        grown == fresh,
        "a grown scratch moved the vertices differently"
    );
}
