//! `stereo_points` on the synthetic room, rendered from known cameras, against the
//! room's own mesh (an independent answer: the surface the renders were made from):
//! - the dense points lie on the true surface (median distance well under the
//!   matching resolution's pixel footprint) and cover several times more of the surface
//!   the cameras saw than the sparse points they started from;
//! - the sparse points come out first, unchanged;
//! - test views are never read: their images replaced by garbage change nothing;
//! - too few training views, or no sparse points, fail naming the problem.

mod common;
use common::{assert_mentions, node_error};
use objectsplat_core::{Frames, Mesh, Points, Split};
use objectsplat_inputs::stereo_points::StereoPoints;
use objectsplat_metrics::fscore::nearest_distances;
use objectsplat_metrics::surface::{SampleCount, sample_surface};
use objectsplat_runtime::testing::run_node;
use std::path::{Path, PathBuf};

/// Renders the synthetic room into `dir` with `points` noise-free sparse points.
fn render_room(dir: &Path, split: &str, points: usize) -> (PathBuf, PathBuf, PathBuf) {
    run_node(
        &objectsplat_synth::nodes::SyntheticSceneNode,
        &[],
        &format!(
            "(views: 24, width: 160, height: 120, split: \"{split}\", points: {points}, points_noise: 0.0)"
        ),
        dir,
        None,
    )
    .unwrap();
    (dir.join("frames"), dir.join("points"), dir.join("mesh"))
}

fn read_points(dir: &Path) -> Points {
    Points::read_ply(&dir.join("points.ply")).unwrap()
}

fn as_f64(points: &[[f32; 3]]) -> Vec<[f64; 3]> {
    points.iter().map(|p| p.map(f64::from)).collect()
}

fn quantile(mut values: Vec<f64>, q: f64) -> f64 {
    values.sort_by(f64::total_cmp);
    values[((values.len() - 1) as f64 * q).round() as usize]
}

#[test]
fn dense_points_lie_on_the_true_surface_and_cover_more_of_it() {
    let dir = tempfile::tempdir().unwrap();
    let (frames, sparse_dir, mesh_dir) = render_room(&dir.path().join("room"), "all", 300);
    let out = dir.path().join("stereo");
    run_node(
        &StereoPoints,
        &[("frames", &frames), ("points", &sparse_dir)],
        "()",
        &out,
        None,
    )
    .unwrap();
    let sparse = read_points(&sparse_dir);
    let all = read_points(&out.join("dense"));
    assert_eq!(
        all.positions[..sparse.positions.len()],
        sparse.positions[..]
    );
    assert_eq!(all.colors[..sparse.colors.len()], sparse.colors[..]);
    let dense = &all.positions[sparse.positions.len()..];
    assert!(
        dense.len() > 10 * sparse.positions.len(),
        "{} dense points",
        dense.len()
    );

    let mesh = Mesh::read_ply(&mesh_dir.join("mesh.ply")).unwrap();
    let surface = sample_surface(&mesh, SampleCount::PerArea(20_000.0), 0, 10_000_000)
        .unwrap()
        .points;
    let off_surface = nearest_distances(&as_f64(dense), &surface).unwrap();
    let (median, p90) = (
        quantile(off_surface.clone(), 0.5),
        quantile(off_surface, 0.9),
    );
    // A pixel at 160×120 spans about 1.5 cm at 2 m; the surface samples are ~7 mm apart.
    assert!(
        median < 0.02 && p90 < 0.06,
        "off the surface: median {median:.4} m, 90 % {p90:.4} m"
    );

    // The surface the cameras saw: the room's own noise-free samples seen by ≥ 2 cameras.
    let (_, seen_dir, _) = render_room(&dir.path().join("seen"), "all", 5000);
    let seen = as_f64(&read_points(&seen_dir).positions);
    let covered = |points: &[[f32; 3]]| {
        let d = nearest_distances(&seen, &as_f64(points)).unwrap();
        d.iter().filter(|d| **d < 0.05).count() as f64 / d.len() as f64
    };
    let (dense_cover, sparse_cover) = (covered(dense), covered(&sparse.positions));
    assert!(
        dense_cover > 0.4 && dense_cover > 3.0 * sparse_cover,
        "seen surface within 5 cm: dense {dense_cover:.3}, sparse {sparse_cover:.3}"
    );
}

#[test]
fn test_views_are_never_read() {
    let dir = tempfile::tempdir().unwrap();
    let (frames, sparse_dir, _) = render_room(&dir.path().join("room"), "dense", 300);
    let params = "(depth_planes: 48, max_points: 3000)";
    let first = dir.path().join("first");
    run_node(
        &StereoPoints,
        &[("frames", &frames), ("points", &sparse_dir)],
        params,
        &first,
        None,
    )
    .unwrap();
    let listed = Frames::read(&frames).unwrap();
    let test_views: Vec<_> = listed.by_split(Split::Test).collect();
    assert!(!test_views.is_empty());
    for frame in test_views {
        std::fs::write(listed.image_path(frame), b"not an image").unwrap();
    }
    let second = dir.path().join("second");
    run_node(
        &StereoPoints,
        &[("frames", &frames), ("points", &sparse_dir)],
        params,
        &second,
        None,
    )
    .unwrap();
    let bytes = |d: &Path| std::fs::read(d.join("dense/points.ply")).unwrap();
    assert_eq!(bytes(&first), bytes(&second));
}

#[test]
fn too_few_training_views_or_no_sparse_points_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let (frames, sparse_dir, _) = render_room(&dir.path().join("room"), "all", 300);

    let empty = dir.path().join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    Points::default()
        .write_ply(&empty.join("points.ply"))
        .unwrap();
    let e = node_error(
        &StereoPoints,
        &[("frames", &frames), ("points", &empty)],
        "()",
    );
    assert_mentions(&e, &["no sparse points", "depth range"]);

    // One training view: every frame but the first marked as a test view.
    let mut listed = Frames::read(&frames).unwrap();
    for frame in listed.frames.iter_mut().skip(1) {
        frame.split = Split::Test;
    }
    Frames::write_json(&frames, &listed.frames).unwrap();
    let e = node_error(
        &StereoPoints,
        &[("frames", &frames), ("points", &sparse_dir)],
        "()",
    );
    assert_mentions(&e, &["at least two training views", "have 1"]);
}
