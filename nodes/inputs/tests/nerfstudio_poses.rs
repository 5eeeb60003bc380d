//! transforms.json poses (OpenGL camera-to-world) become OpenCV world-to-camera poses that
//! project like the cameras they were made from; inconsistent lens keys are refused.

use glam::DVec3;
use objectsplat_core::Camera;
use objectsplat_inputs::nerfstudio::{self, Roots};
use serde_json::json;

mod common;
use common::{assert_mentions, write_json};

/// The OpenGL camera-to-world of `cam`, built by hand: invert the pose, then flip the
/// camera's y and z axes (columns 1 and 2).
fn c2w_gl(cam: &Camera) -> Vec<Vec<f64>> {
    let r = cam.rotation();
    let c = cam.center();
    let rt = r.transpose();
    (0..3)
        .map(|i| vec![rt.col(0)[i], -rt.col(1)[i], -rt.col(2)[i], c[i]])
        .chain(std::iter::once(vec![0.0, 0.0, 0.0, 1.0]))
        .collect()
}

fn cameras() -> Vec<Camera> {
    [
        (DVec3::new(2.0, -3.0, 1.5), DVec3::ZERO),
        (DVec3::new(-1.0, 2.0, 0.5), DVec3::new(0.5, 0.0, 0.2)),
    ]
    .iter()
    .map(|&(eye, target)| Camera::look_at(16, 12, 14.0, 15.0, eye, target, DVec3::Z))
    .collect()
}

#[test]
fn opengl_camera_to_world_becomes_opencv_world_to_camera() {
    let dir = tempfile::tempdir().unwrap();
    let cams = cameras();
    let frames: Vec<_> = cams
        .iter()
        .enumerate()
        .map(|(i, c)| json!({"file_path": format!("images/f{i}.png"), "transform_matrix": c2w_gl(c), "mask_path": format!("masks/f{i}.png")}))
        .collect();
    let doc = json!({"fl_x": 14.0, "fl_y": 15.0, "cx": 8.0, "cy": 6.0, "w": 16, "h": 12, "camera_model": "OPENCV",
        "k1": 0.0, "k2": 0.0, "p1": 0.0, "p2": 0.0, "frames": frames});
    let path = dir.path().join("transforms.json");
    write_json(&path, &doc);
    let t = nerfstudio::read(&path, &Roots::default()).unwrap();
    let views = t.views(glam::DMat4::IDENTITY).unwrap();
    for (v, want) in views.iter().zip(&cams) {
        for (a, b) in v
            .camera
            .world_to_camera
            .iter()
            .flatten()
            .zip(want.world_to_camera.iter().flatten())
        {
            assert!(
                (a - b).abs() < 1e-12,
                "{:?} vs {:?}",
                v.camera.world_to_camera,
                want.world_to_camera
            );
        }
        // The looked-at point projects to the principal point, in front of the camera.
        let p = want.center() + (want.rotation().transpose() * DVec3::Z) * 2.0;
        let (u, w, z) = v.camera.project(p).unwrap();
        assert!((u - 8.0).abs() < 1e-9 && (w - 6.0).abs() < 1e-9 && (z - 2.0).abs() < 1e-9);
        assert_eq!(
            v.valid_mask.as_ref().unwrap(),
            &dir.path()
                .join(format!("masks/{}", v.name.replace("images/", "")))
        );
    }
}

#[test]
fn per_frame_intrinsics_override_and_bad_frames_are_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let cams = cameras();
    let doc = json!({"fl_x": 14.0, "cx": 8.0, "cy": 6.0, "w": 16, "h": 12,
        "frames": [{"file_path": "a.png", "transform_matrix": c2w_gl(&cams[0]), "fl_x": 20.0, "fl_y": 21.0},
                   {"file_path": "b.png", "transform_matrix": c2w_gl(&cams[1]), "is_bad": true}],
        "test_frames": [{"file_path": "c.png", "transform_matrix": c2w_gl(&cams[1])}]});
    let path = dir.path().join("t.json");
    write_json(&path, &doc);
    let t = nerfstudio::read(&path, &Roots::default()).unwrap();
    assert_eq!(t.skipped_bad, 1);
    let v = t.views(glam::DMat4::IDENTITY).unwrap();
    assert_eq!(
        v.iter().map(|v| v.name.as_str()).collect::<Vec<_>>(),
        ["a.png", "c.png"]
    );
    assert_eq!((v[0].camera.fx, v[0].camera.fy), (20.0, 21.0));
    assert_eq!((v[1].camera.fx, v[1].camera.fy), (14.0, 14.0));
}

#[test]
fn distortion_and_bad_matrices_are_errors_naming_the_frame() {
    let dir = tempfile::tempdir().unwrap();
    let cams = cameras();
    let path = dir.path().join("t.json");
    for (model, key, want) in [
        (
            "PINHOLE",
            "k1",
            "(a.png): camera model PINHOLE has distortion k1 = 0.1; a pinhole camera has none",
        ),
        (
            "OPENCV",
            "k4",
            "(a.png): camera model OPENCV has k4 = 0.1, which its radial–tangential model",
        ),
        (
            "OPENCV_FISHEYE",
            "p2",
            "(a.png): camera model OPENCV_FISHEYE has p2 = 0.1, which its fisheye model",
        ),
    ] {
        let doc = json!({"fl_x": 14.0, "w": 16, "h": 12, "camera_model": model, key: 0.1,
            "frames": [{"file_path": "a.png", "transform_matrix": c2w_gl(&cams[0])}]});
        write_json(&path, &doc);
        let e = nerfstudio::read(&path, &Roots::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("t.json: frame 0") && e.contains(want), "{e}");
    }
    let mut scaled = c2w_gl(&cams[0]);
    for row in scaled.iter_mut().take(3) {
        row[0] *= 2.0;
    }
    let doc = json!({"fl_x": 14.0, "w": 16, "h": 12, "frames": [{"file_path": "a.png", "transform_matrix": scaled}]});
    write_json(&path, &doc);
    let e = format!(
        "{:#}",
        nerfstudio::read(&path, &Roots::default())
            .unwrap()
            .views(glam::DMat4::IDENTITY)
            .unwrap_err()
    );
    assert!(e.contains("(a.png)") && e.contains("not a rotation"), "{e}");
    std::fs::write(&path, "{\"frames\": [{\"file_path\": \"a.png\"}]}").unwrap();
    let e = format!(
        "{:#}",
        nerfstudio::read(&path, &Roots::default()).unwrap_err()
    );
    assert!(e.contains("neither fl_x nor camera_angle_x"), "{e}");
}

#[test]
fn nerfstudio_filename_lists_give_the_split_and_their_absence_is_named() {
    use objectsplat_core::{Frames, Image, Split};
    use objectsplat_inputs::nodes::NerfstudioScene;
    use objectsplat_runtime::testing::run_node;
    let dir = tempfile::tempdir().unwrap();
    let cams = cameras();
    std::fs::create_dir_all(dir.path().join("images")).unwrap();
    let mut frames = Vec::new();
    for i in 0..3 {
        Image::new(16, 12, 3)
            .save_png8(&dir.path().join(format!("images/f{i}.png")))
            .unwrap();
        frames.push(json!({"file_path": format!("./images/f{i}.png"), "transform_matrix": c2w_gl(&cams[i % 2])}));
    }
    let path = dir.path().join("transforms.json");
    let mut doc = json!({"fl_x": 14.0, "w": 16, "h": 12, "frames": frames,
        "train_filenames": ["images/f0.png", "images/f2.png"], "test_filenames": ["images/f1.png"]});
    write_json(&path, &doc);
    let params = format!("(path: {:?}, split: \"lists\")", path.display().to_string());
    let out = tempfile::tempdir().unwrap();
    let run = run_node(&NerfstudioScene, &[], &params, out.path(), None).unwrap();
    let got: Vec<Split> = Frames::read(&run.outputs["frames"])
        .unwrap()
        .frames
        .iter()
        .map(|f| f.split)
        .collect();
    assert_eq!(got, [Split::Train, Split::Test, Split::Train]);
    doc.as_object_mut().unwrap().remove("train_filenames");
    doc.as_object_mut().unwrap().remove("test_filenames");
    write_json(&path, &doc);
    let e = common::node_error(&NerfstudioScene, &[], &params);
    assert_mentions(
        &e,
        &["transforms.json: split \"lists\" needs the JSON's own split"],
    );
}
