//! Densification: weighted sampling without replacement and midpoint subdivision.

use objectsplat_raster::Model;
use objectsplat_raster::model::SH_COEFFS;
use objectsplat_train::densify::{
    DensifyPolicy, sample_without_replacement, select_faces_to_split, subdivide_faces,
};
use rand::SeedableRng;
use rand_pcg::Pcg64Mcg;

fn two_triangles() -> Model<f32> {
    let mut m = Model::<f32>::empty();
    m.vertices = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ];
    m.faces = vec![[0, 1, 2], [1, 3, 2]];
    m.sh = (0..4)
        .map(|v| {
            let mut s = [[0.0f32; 3]; SH_COEFFS];
            s[0] = [v as f32, 2.0 * v as f32, -(v as f32)];
            s[5] = [0.1 * v as f32; 3];
            s
        })
        .collect();
    m.opacity_logits = vec![-1.0, 0.0, 1.0, 2.0];
    m
}

#[test]
fn never_more_samples_than_nonzero_candidates() {
    let mut rng = Pcg64Mcg::seed_from_u64(1);
    let w = [0.0f32, 0.3, 0.0, 0.9, 0.0];
    let picked = sample_without_replacement(&w, 10, &mut rng).unwrap();
    assert_eq!(picked, vec![1, 3]);
    let none = sample_without_replacement(&[0.0f32; 4], 3, &mut rng).unwrap();
    assert!(none.is_empty());
    assert!(sample_without_replacement(&[1.0, f32::NAN], 1, &mut rng).is_err());
    assert!(sample_without_replacement(&[1.0, -0.5], 1, &mut rng).is_err());
}

/// One draw from weights (1, 3) picks the second with probability 3/4.
#[test]
fn samples_are_proportional_to_weight() {
    let mut rng = Pcg64Mcg::seed_from_u64(7);
    let trials = 20_000;
    let hits = (0..trials)
        .filter(|_| sample_without_replacement(&[1.0, 3.0], 1, &mut rng).unwrap() == vec![1])
        .count();
    let freq = hits as f64 / trials as f64;
    // Binomial standard deviation √(0.75·0.25/20000) ≈ 0.003; allow 5σ.
    assert!((freq - 0.75).abs() < 0.015, "frequency {freq}");
}

#[test]
fn selection_guards_and_forces_the_largest() {
    let mut m = two_triangles();
    m.vertices[3] = [3.0, 3.0, 0.0]; // face 1 becomes the larger one
    let mut rng = Pcg64Mcg::seed_from_u64(3);
    let forced = DensifyPolicy {
        count: 5,
        min_area: 0.0,
        always_largest: 1,
    };
    let chosen = select_faces_to_split(&m, &[0.0, 0.0], None, forced, &mut rng).unwrap();
    assert_eq!(
        chosen,
        vec![1],
        "only the forced largest face; zero weights are not drawn"
    );
    let policy = DensifyPolicy {
        min_area: 10.0,
        always_largest: 0,
        ..forced
    };
    let chosen = select_faces_to_split(&m, &[1.0, 1.0], None, policy, &mut rng).unwrap();
    assert!(
        chosen.is_empty(),
        "faces under the area floor are not candidates"
    );
    assert!(select_faces_to_split(&m, &[1.0], None, policy, &mut rng).is_err());
}

#[test]
fn neighbouring_selected_faces_share_their_edge_midpoint() {
    let mut m = two_triangles();
    let edit = subdivide_faces(&mut m, &[0, 1]).unwrap();
    // 4 corners + 5 distinct edges (the diagonal 1–2 is shared).
    assert_eq!(m.vertices.len(), 9);
    assert_eq!(edit.appended, 5);
    assert_eq!(m.faces.len(), 8);
    m.validate().unwrap();
    let area = |f: [u32; 3]| {
        let [a, b, c] = f.map(|i| m.vertices[i as usize]);
        0.5 * ((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).abs()
    };
    let total: f32 = m.faces.iter().map(|&f| area(f)).sum();
    assert!(
        (total - 1.0).abs() < 1e-6,
        "children tile the parents: {total}"
    );
    assert!(m.faces.iter().all(|&f| (area(f) - 0.125).abs() < 1e-6));
    // Every edge of the refined square is used by ≤ 2 faces and the mesh has no T-junction.
    let mut edges = std::collections::HashMap::new();
    for f in &m.faces {
        for k in 0..3 {
            let (a, b) = (f[k], f[(k + 1) % 3]);
            *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    assert_eq!(edges.values().filter(|&&c| c == 2).count(), 8);
    assert_eq!(edges.values().filter(|&&c| c == 1).count(), 8);
}

#[test]
fn midpoints_inherit_the_mean_of_their_endpoints() {
    let mut m = two_triangles();
    m.set_opacity_floor(0.3).unwrap();
    let o1 = m.vertex_opacity(1) as f64;
    let o2 = m.vertex_opacity(2) as f64;
    subdivide_faces(&mut m, &[0]).unwrap();
    assert_eq!(m.faces.len(), 1 + 4);
    assert_eq!(m.faces[0], [1, 3, 2], "the unselected face stays");
    let mid = (4..m.vertices.len())
        .find(|&v| m.vertices[v] == [0.5, 0.5, 0.0])
        .expect("midpoint of edge 1–2");
    assert_eq!(m.sh[mid][0], [1.5, 3.0, -1.5]);
    assert!((m.sh[mid][5][0] - 0.15).abs() < 1e-7);
    let o = m.vertex_opacity(mid) as f64;
    assert!(
        (o - 0.5 * (o1 + o2)).abs() < 1e-6,
        "{o} vs mean {}",
        0.5 * (o1 + o2)
    );
    assert!(subdivide_faces(&mut m, &[99]).is_err());
}
