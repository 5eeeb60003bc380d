//! The connectivity step turns a soup of small triangles on a sphere into one
//! connected, almost everywhere 2-manifold mesh over the same vertices.

use objectsplat_train::connectivity::{
    ConnectivityOptions, circumcenter, restricted_delaunay, segment_hits_triangle,
};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::collections::HashMap;

/// Fibonacci points on the unit sphere, each carrying a small randomly rotated
/// tangent triangle; radial noise on every vertex.
fn sphere_soup(n: usize, noise: f64, seed: u64, size: f64) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let spacing = (4.0 * std::f64::consts::PI / n as f64).sqrt();
    let mut verts = Vec::new();
    let mut faces = Vec::new();
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let r = (1.0 - z * z).sqrt();
        let p = [
            r * (golden * i as f64).cos(),
            r * (golden * i as f64).sin(),
            z,
        ];
        // Tangent basis.
        let a = if p[2].abs() < 0.9 {
            [0.0, 0.0, 1.0]
        } else {
            [1.0, 0.0, 0.0]
        };
        let t1 = normalize(cross(p, a));
        let t2 = cross(p, t1);
        let phase: f64 = rng.random::<f64>() * std::f64::consts::TAU;
        let base = verts.len() as u32;
        for k in 0..3 {
            let ang = phase + k as f64 * std::f64::consts::TAU / 3.0;
            let q =
                [0, 1, 2].map(|c| p[c] + size * spacing * (ang.cos() * t1[c] + ang.sin() * t2[c]));
            let s = 1.0 + noise * (rng.random::<f64>() * 2.0 - 1.0);
            let q = normalize(q).map(|c| (c * s) as f32);
            verts.push(q);
        }
        faces.push([base, base + 1, base + 2]);
    }
    (verts, faces)
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn normalize(a: [f64; 3]) -> [f64; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    a.map(|c| c / l)
}

fn components(n: usize, faces: &[[u32; 3]]) -> usize {
    let mut parent: Vec<usize> = (0..n).collect();
    fn find(p: &mut [usize], x: usize) -> usize {
        let mut r = x;
        while p[r] != r {
            r = p[r];
        }
        let mut y = x;
        while p[y] != r {
            let next = p[y];
            p[y] = r;
            y = next;
        }
        r
    }
    for f in faces {
        for k in 1..3 {
            let (a, b) = (
                find(&mut parent, f[0] as usize),
                find(&mut parent, f[k] as usize),
            );
            parent[a] = b;
        }
    }
    let used: std::collections::HashSet<usize> =
        faces.iter().flatten().map(|&v| v as usize).collect();
    let roots: std::collections::HashSet<usize> =
        used.iter().map(|&v| find(&mut parent, v)).collect();
    roots.len()
}

#[test]
fn noisy_sphere_soup_becomes_one_manifold_mesh() {
    let (verts, soup) = sphere_soup(300, 0.01, 4, 1.2);
    let faces = restricted_delaunay(
        &verts,
        &soup,
        ConnectivityOptions {
            include_hull_faces: true,
            seed: 9,
        },
    )
    .unwrap();
    assert!(
        faces.len() > 2 * verts.len() * 8 / 10,
        "{} faces for {} vertices",
        faces.len(),
        verts.len()
    );
    assert_eq!(components(verts.len(), &faces), 1);
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for f in &faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let hist: Vec<usize> = (1..6)
        .map(|k| edges.values().filter(|&&c| c == k).count())
        .collect();
    let two = edges.values().filter(|&&c| c == 2).count();
    let ratio = two as f64 / edges.len() as f64;
    assert!(
        ratio > 0.95,
        "only {ratio:.3} of {} edges are shared by exactly two faces (uses 1..5: {hist:?})",
        edges.len()
    );
    // A closed surface of V vertices has 2V − 4 faces.
    assert!(
        faces.len().abs_diff(2 * verts.len() - 4) < verts.len() / 20,
        "{} faces",
        faces.len()
    );
    // Every vertex keeps its index; the output refers only to existing vertices.
    assert!(faces.iter().flatten().all(|&v| (v as usize) < verts.len()));
    let used: std::collections::HashSet<u32> = faces.iter().flatten().copied().collect();
    assert!(used.len() as f64 > 0.95 * verts.len() as f64);
}

/// The reference keeps interior faces only; on a convex surface most surface
/// faces are hull faces, so that rule loses most of the mesh.
#[test]
fn interior_faces_alone_miss_the_hull_surface() {
    let (verts, soup) = sphere_soup(300, 0.01, 4, 1.2);
    let interior = ConnectivityOptions {
        include_hull_faces: false,
        seed: 9,
    };
    let all = ConnectivityOptions {
        include_hull_faces: true,
        seed: 9,
    };
    let a = restricted_delaunay(&verts, &soup, interior).unwrap();
    let b = restricted_delaunay(&verts, &soup, all).unwrap();
    assert!(
        a.iter().all(|f| b.binary_search(f).is_ok()),
        "interior faces are a subset"
    );
    assert!(a.len() < b.len());
}

#[test]
fn an_empty_soup_gives_no_faces_and_bad_indices_are_refused() {
    let (verts, soup) = sphere_soup(40, 0.0, 1, 1.2);
    assert!(
        restricted_delaunay(&verts, &[], ConnectivityOptions::default())
            .unwrap()
            .is_empty()
    );
    let mut bad = soup.clone();
    bad[0][1] = 10_000;
    assert!(restricted_delaunay(&verts, &bad, ConnectivityOptions::default()).is_err());
    // Degenerate vertex sets do not panic.
    let flat: Vec<[f32; 3]> = (0..30)
        .map(|i| [(i % 6) as f32, (i / 6) as f32, 0.0])
        .collect();
    let flat_faces: Vec<[u32; 3]> = (0..5).map(|i| [i, i + 1, i + 6]).collect();
    restricted_delaunay(&flat, &flat_faces, ConnectivityOptions::default()).unwrap();
}

#[test]
fn segment_test_and_circumcentre_agree_with_hand_cases() {
    let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let segments = [
        ([0.2, 0.2, -1.0], [0.2, 0.2, 1.0], true),
        // Boundaries are inclusive: through a vertex, along an edge's line, touching at t = 1.
        ([0.0, 0.0, -1.0], [0.0, 0.0, 1.0], true),
        ([0.5, 0.5, -1.0], [0.5, 0.5, 1.0], true),
        ([0.2, 0.2, -1.0], [0.2, 0.2, 0.0], true),
        ([0.2, 0.2, -1.0], [0.2, 0.2, -0.1], false),
    ];
    for (from, to, hits) in segments {
        assert_eq!(
            segment_hits_triangle(from, to, tri),
            hits,
            "{from:?} → {to:?}"
        );
    }
    assert!(!segment_hits_triangle(
        [0.6, 0.6, -1.0],
        [0.6, 0.6, 1.0],
        tri
    ));
    let c = circumcenter(
        [0.0, 0.0, 0.0],
        [2.0, 0.0, 0.0],
        [0.0, 2.0, 0.0],
        [0.0, 0.0, 2.0],
    );
    for k in 0..3 {
        assert!((c[k] - 1.0).abs() < 1e-12, "{c:?}");
    }
}
