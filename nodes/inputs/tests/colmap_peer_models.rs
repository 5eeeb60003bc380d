//! COLMAP text and binary readers, classic and rig/frame layouts, agree with the models
//! pycolmap wrote (tests/fixtures/colmap/make_fixtures.py): every camera, pose and point.

use objectsplat_inputs::colmap::{self, ColmapModel, Encoding};
use serde_json::Value;
use std::path::PathBuf;

mod common;
use common::{floats as f64s, read_json};

fn fixture(name: &str) -> PathBuf {
    common::fixture("colmap").join(name)
}

/// The expected `key` entries, after asserting the model has `count` of them.
fn listed<'a>(exp: &'a Value, key: &str, count: usize, what: &str) -> &'a [Value] {
    let all = exp[key].as_array().unwrap();
    assert_eq!(count, all.len(), "{what}");
    all
}

fn assert_matches_pycolmap(model: &ColmapModel, what: &str) {
    let exp = read_json(&fixture("expected.json"));
    for c in listed(&exp, "cameras", model.cameras.len(), what) {
        let got = &model.cameras[&(c["id"].as_u64().unwrap() as u32)];
        assert_eq!(got.model, c["model"].as_str().unwrap(), "{what}");
        assert_eq!(
            (got.width as u64, got.height as u64),
            (c["width"].as_u64().unwrap(), c["height"].as_u64().unwrap())
        );
        assert_eq!(got.params, f64s(&c["params"]), "{what}: camera {}", got.id);
    }
    for i in listed(&exp, "images", model.images.len(), what) {
        let got = &model.images[&(i["id"].as_u64().unwrap() as u32)];
        assert_eq!(got.name, i["name"].as_str().unwrap(), "{what}");
        assert_eq!(
            got.camera_id as u64,
            i["camera_id"].as_u64().unwrap(),
            "{what}"
        );
        assert_eq!(
            got.pose.qvec.to_vec(),
            f64s(&i["qvec"]),
            "{what}: image {} qvec",
            got.id
        );
        assert_eq!(
            got.pose.tvec.to_vec(),
            f64s(&i["tvec"]),
            "{what}: image {} tvec",
            got.id
        );
        // Our quaternion → matrix conversion against Eigen's, to rounding.
        let m = got.pose.matrix();
        for (r, row) in i["rotation"].as_array().unwrap().iter().enumerate() {
            for (c, v) in f64s(row).iter().enumerate() {
                assert!(
                    (m[r][c] - v).abs() < 1e-14,
                    "{what}: image {} R[{r}][{c}] {} vs {v}",
                    got.id,
                    m[r][c]
                );
            }
        }
        let p2d: Vec<Vec<f64>> = i["points2d"].as_array().unwrap().iter().map(f64s).collect();
        let ours: Vec<Vec<f64>> = got
            .points2d
            .iter()
            .map(|(xy, id)| vec![xy[0], xy[1], *id as f64])
            .collect();
        assert_eq!(ours, p2d, "{what}: image {} keypoints", got.id);
    }
    for p in listed(&exp, "points", model.points.len(), what) {
        let got = &model.points[&p["id"].as_u64().unwrap()];
        assert_eq!(
            got.xyz.to_vec(),
            f64s(&p["xyz"]),
            "{what}: point {}",
            got.id
        );
        assert_eq!(
            got.rgb.map(f64::from).to_vec(),
            f64s(&p["rgb"]),
            "{what}: point {}",
            got.id
        );
        assert_eq!(
            got.error,
            p["error"].as_f64().unwrap(),
            "{what}: point {}",
            got.id
        );
        let track: Vec<Vec<f64>> = p["track"].as_array().unwrap().iter().map(f64s).collect();
        let ours: Vec<Vec<f64>> = got
            .track
            .iter()
            .map(|&(i, k)| vec![i as f64, k as f64])
            .collect();
        assert_eq!(ours, track, "{what}: point {} track", got.id);
    }
}

#[test]
fn binary_and_text_in_both_layouts_match_pycolmap() {
    for (dir, encoding, has_rigs) in [
        ("rig_bin", Encoding::Binary, true),
        ("rig_txt", Encoding::Text, true),
        ("classic_bin", Encoding::Binary, false),
        ("classic_txt", Encoding::Text, false),
    ] {
        let model = colmap::read_model(&fixture(dir)).unwrap();
        assert_eq!(model.encoding, encoding, "{dir}");
        assert_eq!(
            model.rigs.is_some() && model.frames.is_some(),
            has_rigs,
            "{dir}"
        );
        assert_matches_pycolmap(&model, dir);
    }
}

#[test]
fn text_and_binary_rig_files_agree() {
    let bin = colmap::read_model(&fixture("rig_bin")).unwrap();
    let txt = colmap::read_model(&fixture("rig_txt")).unwrap();
    assert_eq!(bin.rigs, txt.rigs);
    assert_eq!(bin.frames, txt.frames);
    let frames = bin.frames.unwrap();
    assert_eq!(frames.len(), 3);
    assert!(
        frames
            .values()
            .all(|f| f.data.len() == 2 && f.data.iter().all(|(s, _)| s.0 == "CAMERA"))
    );
}
