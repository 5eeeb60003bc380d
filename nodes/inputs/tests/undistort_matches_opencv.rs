//! Distorted captures become pinhole frames: the pinhole camera is the one COLMAP's
//! undistorter chooses (pycolmap.undistort_camera) and the resampled image agrees with
//! OpenCV's undistortion onto that camera (cv2.initUndistortRectifyMap + remap, as in
//! cv2.undistort, and cv2.fisheye.undistortImage). Fixtures: tests/fixtures/undistort
//! (make_fixtures.py).

use objectsplat_core::{Frames, Image};
use objectsplat_inputs::nodes::{ColmapScene, NerfstudioScene};
use objectsplat_runtime::testing::run_node;
use serde_json::Value;
use std::path::{Path, PathBuf};

mod common;

fn fixture(name: &str) -> PathBuf {
    common::fixture("undistort").join(name)
}

fn expected() -> Value {
    common::read_json(&fixture("expected.json"))
}

/// Pixels this far from the output border are compared (OpenCV and we both blend
/// with black where a bilinear tap leaves the source image).
const MARGIN: u32 = 2;

/// Asserts the frame's intrinsics equal COLMAP's choice and its image OpenCV's.
fn assert_matches(model: &str, frames_dir: &Path) {
    let want = &expected()[model]["undistorted"];
    let frames = Frames::read(frames_dir).unwrap();
    assert_eq!(frames.frames.len(), 1, "{model}");
    let f = &frames.frames[0];
    assert_eq!(
        (f.camera.width as u64, f.camera.height as u64),
        (
            want["width"].as_u64().unwrap(),
            want["height"].as_u64().unwrap()
        ),
        "{model}: size"
    );
    for (got, key) in [
        (f.camera.fx, "fx"),
        (f.camera.fy, "fy"),
        (f.camera.cx, "cx"),
        (f.camera.cy, "cy"),
    ] {
        let w = want[key].as_f64().unwrap();
        assert!((got - w).abs() < 1e-9, "{model}: {key} = {got}, COLMAP {w}");
    }
    let ours = frames.load_rgb(f).unwrap();
    let theirs = Image::load(&fixture(&format!("expected/{model}.png"))).unwrap();
    assert_eq!((ours.width, ours.height), (theirs.width, theirs.height));
    let (mut compared, mut close, mut worst) = (0usize, 0usize, 0.0f32);
    for y in MARGIN..ours.height - MARGIN {
        for x in MARGIN..ours.width - MARGIN {
            for c in 0..3 {
                let d = (ours.get(x, y, c) - theirs.get(x, y, c)).abs() * 255.0;
                compared += 1;
                close += usize::from(d <= 2.0 + 1e-3);
                worst = worst.max(d);
            }
        }
    }
    let share = close as f64 / compared as f64;
    assert!(
        share >= 0.99,
        "{model}: {:.2}% of {compared} values within 2 grey levels of OpenCV (worst {worst})",
        share * 100.0
    );
}

/// `colmap_scene` params for the fixture model of camera `model` and the fixture images.
fn colmap_params(model: &str, rest: &str) -> String {
    common::params_with_images(
        &fixture(&format!("sparse_{model}")),
        &fixture("images"),
        rest,
    )
}

fn colmap_frames(model: &str, out: &Path) -> PathBuf {
    let params = colmap_params(model, ", split: \"all\"");
    let run = run_node(&ColmapScene, &[], &params, out, None).unwrap();
    assert!(
        common::has_note(&run.notes, "undistorted", "1 frames; 96×72 → pinhole"),
        "{model}: {:?}",
        run.notes
    );
    run.outputs["frames"].clone()
}

#[test]
fn opencv_fisheye_colmap_model_gives_colmaps_pinhole_camera_and_opencvs_image() {
    let out = tempfile::tempdir().unwrap();
    assert_matches(
        "OPENCV_FISHEYE",
        &colmap_frames("OPENCV_FISHEYE", out.path()),
    );
}

#[test]
fn every_supported_colmap_model_matches() {
    let all = expected();
    let models: Vec<&String> = all.as_object().unwrap().keys().collect();
    assert_eq!(models.len(), 7, "{models:?}");
    for model in models {
        let out = tempfile::tempdir().unwrap();
        assert_matches(model, &colmap_frames(model, out.path()));
    }
}

#[test]
fn nerfstudio_distortion_keys_give_the_same_frames() {
    for model in ["OPENCV", "OPENCV_FISHEYE"] {
        let out = tempfile::tempdir().unwrap();
        let params = format!(
            "(path: {:?}, split: \"all\")",
            fixture(&format!("nerfstudio_{model}.json"))
                .display()
                .to_string()
        );
        let run = run_node(&NerfstudioScene, &[], &params, out.path(), None).unwrap();
        assert_matches(model, &run.outputs["frames"]);
    }
}

#[test]
fn downscaling_follows_undistortion() {
    let params = colmap_params("OPENCV_FISHEYE", ", split: \"all\", resolution: 3");
    let (_out, run) = common::run_source(&ColmapScene, &params);
    let frames = Frames::read(&run.outputs["frames"]).unwrap();
    let f = &frames.frames[0];
    let want = &expected()["OPENCV_FISHEYE"]["undistorted"];
    // 135×84 → 45×28: intrinsics follow the pixel grid of the undistorted camera.
    assert_eq!((f.camera.width, f.camera.height), (45, 28));
    assert!((f.camera.fx - want["fx"].as_f64().unwrap() / 3.0).abs() < 1e-9);
    assert!((f.camera.cx - want["cx"].as_f64().unwrap() * 45.0 / 135.0).abs() < 1e-9);
}

#[test]
fn an_unusable_lens_is_an_error_naming_the_camera() {
    // k1 = -2 folds the image back on itself before its border: no inverse there.
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("cameras.txt"),
        "1 SIMPLE_RADIAL 96 72 40 48 36 -2.0\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("images.txt"),
        "1 1 0 0 0 0 0 0 1 view.png\n\n",
    )
    .unwrap();
    std::fs::write(dir.path().join("points3D.txt"), "").unwrap();
    let params = common::params_with_images(dir.path(), &fixture("images"), "");
    let e = common::node_error(&ColmapScene, &[], &params);
    common::assert_mentions(
        &e,
        &[
            "camera 1 (SIMPLE_RADIAL)",
            "cannot be inverted along the image border",
        ],
    );
}
