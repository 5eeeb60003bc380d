//! Scene and per-object mesh F-score on shapes whose answer is known analytically.
use objectsplat_core::Mesh;
use objectsplat_metrics::{MeshEvalParams, SampleCount, evaluate_mesh, mesh_points};

/// Axis-aligned square [x0, x0+size]² at height z, as two triangles, tagged with `object`.
fn square(mesh: &mut Mesh, x0: f32, size: f32, z: f32, object: i32) {
    let base = mesh.positions.len() as u32;
    mesh.positions.extend([
        [x0, 0.0, z],
        [x0 + size, 0.0, z],
        [x0 + size, size, z],
        [x0, size, z],
    ]);
    mesh.faces
        .extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
    mesh.object_ids
        .get_or_insert_with(Vec::new)
        .extend([object; 4]);
}

fn params() -> MeshEvalParams {
    MeshEvalParams {
        tau: 0.05,
        voxel: 0.02,
        samples: SampleCount::PerArea(20_000.0),
        seed: 1,
        ..MeshEvalParams::default()
    }
}

#[test]
fn a_copy_offset_less_than_tau_scores_one_and_more_than_tau_scores_zero() {
    let mut gt = Mesh::default();
    square(&mut gt, 0.0, 1.0, 0.0, 1);
    for (offset, expected) in [(0.03f32, 1.0), (0.08, 0.0)] {
        let mut pred = Mesh::default();
        square(&mut pred, 0.0, 1.0, offset, 1);
        let pred_points = mesh_points(
            &pred,
            &MeshEvalParams {
                seed: 9,
                ..params()
            },
        )
        .unwrap();
        let r = evaluate_mesh(&gt, &pred_points, &[], &[], &params(), None, &[]).unwrap();
        assert_eq!(r.scene.precision, expected, "offset {offset}");
        assert_eq!(r.scene.recall, expected, "offset {offset}");
        // Nearest distance is the plane gap plus at most a voxel-scale lateral offset.
        let acc = r.scene.accuracy.unwrap();
        assert!(
            acc >= offset as f64 - 1e-6 && acc < offset as f64 + 0.01,
            "offset {offset}: accuracy {acc}"
        );
    }
}

#[test]
fn per_object_scores_use_the_faces_of_each_object() {
    // Object 1: a 1 m square at x ∈ [0, 1]; object 2: a 1 m square at x ∈ [2, 3].
    let mut gt = Mesh::default();
    square(&mut gt, 0.0, 1.0, 0.0, 1);
    square(&mut gt, 2.0, 1.0, 0.0, 2);
    let p = params();
    let mut pred_1 = Mesh::default();
    square(&mut pred_1, 0.0, 1.0, 0.01, 1);
    // Object 2 is reconstructed only on its left half.
    let mut pred_2 = Mesh::default();
    square(&mut pred_2, 2.0, 0.5, 0.0, 2);
    let pts_1 = mesh_points(&pred_1, &p).unwrap();
    let pts_2 = mesh_points(&pred_2, &p).unwrap();
    let scene: Vec<[f64; 3]> = pts_1.iter().chain(&pts_2).copied().collect();
    let r = evaluate_mesh(
        &gt,
        &scene,
        &[(1, pts_1.clone()), (2, pts_2)],
        &[1, 2, 3],
        &p,
        None,
        &[],
    )
    .unwrap();
    let o1 = r.objects[0].fscore.unwrap();
    assert_eq!((o1.precision, o1.recall), (1.0, 1.0));
    let o2 = r.objects[1].fscore.unwrap();
    assert_eq!(o2.precision, 1.0);
    // Recall of object 2: its GT square is 1 m × 1 m but the half-size prediction covers
    // [2, 2.5] × [0, 0.5] plus a τ-wide band: area (0.5 + 0.05)² of 1 m².
    assert!(
        (o2.recall - 0.55 * 0.55).abs() < 0.03,
        "recall {}",
        o2.recall
    );
    assert_eq!(
        r.objects[2].fscore, None,
        "object 3 has no ground-truth faces"
    );
    // An id with ground truth but no member in the scene (a label of the background
    // component) has no score of its own; the scene's score counts its surface.
    let r = evaluate_mesh(&gt, &pts_1, &[(1, pts_1.clone())], &[1, 2], &p, None, &[]).unwrap();
    assert!(r.objects[0].fscore.is_some());
    assert_eq!(r.objects[1].fscore, None);
    assert!(
        r.scene.recall < 0.6,
        "object 2's surface still counts in the scene"
    );
}

#[test]
fn per_object_scores_at_extra_thresholds_see_a_gap_between_them() {
    // Object 1 is reconstructed 3 cm above its ground truth: inside τ = 5 cm, outside 2 cm.
    let mut gt = Mesh::default();
    square(&mut gt, 0.0, 1.0, 0.0, 1);
    let mut pred = Mesh::default();
    square(&mut pred, 0.0, 1.0, 0.03, 1);
    let p = params();
    let points = mesh_points(&pred, &p).unwrap();
    let r = evaluate_mesh(
        &gt,
        &points,
        &[(1, points.clone())],
        &[1, 2],
        &p,
        None,
        &[0.05, 0.02],
    )
    .unwrap();
    let at: Vec<(f64, f64, f64)> = r.objects[0]
        .thresholds
        .iter()
        .map(|s| (s.tau, s.precision, s.recall))
        .collect();
    assert_eq!(at, [(0.05, 1.0, 1.0), (0.02, 0.0, 0.0)]);
    assert_eq!(r.objects[0].fscore.unwrap().recall, 1.0);
    // No ground truth, no scores at any threshold.
    assert!(r.objects[1].thresholds.is_empty());
    // Without extra thresholds nothing changes.
    let plain = evaluate_mesh(&gt, &points, &[(1, points.clone())], &[1], &p, None, &[]).unwrap();
    assert!(plain.objects[0].thresholds.is_empty());
    assert_eq!(plain.objects[0].fscore, r.objects[0].fscore);
}
