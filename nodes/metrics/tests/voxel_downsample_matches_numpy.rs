//! Voxel down-sampling follows Open3D's grid and mean rule, as the numpy oracle.
mod common;

use common::{fixture_json, points};
use objectsplat_metrics::voxel_downsample;

#[test]
fn voxel_downsample_matches_numpy_oracle() {
    let fx = fixture_json("fscore.json");
    let input = points(fx["voxel_input"].as_str().unwrap());
    let expected = points(fx["voxel_output"].as_str().unwrap());
    let ours = voxel_downsample(&input, fx["voxel"].as_f64().unwrap()).unwrap();
    assert_eq!(ours.len(), expected.len());
    assert!(ours.len() < input.len());
    for (a, b) in ours.iter().zip(&expected) {
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() < 1e-12, "{a:?} vs {b:?}");
        }
    }
}

#[test]
fn points_in_one_voxel_collapse_to_their_mean() {
    // Grid origin = min − voxel/2 = (−0.5, −0.5, −0.5): 0.0 and 0.4 share voxel 0, 0.6 is in voxel 1.
    let pts = [[0.0, 0.0, 0.0], [0.4, 0.2, 0.0], [0.6, 0.0, 0.0]];
    let out = voxel_downsample(&pts, 1.0).unwrap();
    assert_eq!(out, vec![[0.2, 0.1, 0.0], [0.6, 0.0, 0.0]]);
    assert!(voxel_downsample(&pts, 0.0).is_err());
}
