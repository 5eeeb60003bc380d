//! A tiny synthetic scene in the ScanNet++ layout (built here): COLMAP poses in the mesh
//! frame, the nerfstudio JSON fallback with the documented frame change, segment
//! annotations with overlapping groups resolved by an explicit policy and the
//! annotation's own objectIds kept, the same JSON read by `nerfstudio_scene` with an
//! `images` folder, and the splits (`test_frames`, `train_test_lists.json`).

use glam::{DQuat, DVec3};
use objectsplat_core::{Camera, Frames, Image, Mesh, Split};
use objectsplat_inputs::nodes::{NerfstudioScene, ScannetppScene};
use objectsplat_inputs::scannetpp::{self, GroupOverlap, PoseSource};
use objectsplat_inputs::undistort;
use objectsplat_runtime::testing::run_node;
use serde_json::json;
use std::path::{Path, PathBuf};

mod common;
use common::{assert_mentions, node_error, write_json};

const NAMES: [&str; 3] = ["DSC00001.JPG", "DSC00002.JPG", "DSC00003.JPG"];

fn cameras() -> Vec<Camera> {
    // A 4 × 3 × 2.5 m room with its corner at the origin; cameras inside looking around.
    [
        (DVec3::new(3.5, 0.5, 1.5), DVec3::new(1.0, 2.0, 0.5)),
        (DVec3::new(0.5, 0.5, 1.2), DVec3::new(3.0, 2.5, 0.8)),
        (DVec3::new(2.0, 2.5, 1.8), DVec3::new(2.0, 0.0, 0.5)),
    ]
    .iter()
    .map(|&(eye, target)| {
        let mut c = Camera::look_at(16, 12, 12.0, 12.5, eye, target, DVec3::Z);
        c.cx = 8.0;
        c.cy = 6.0;
        c
    })
    .collect()
}

/// The toolkit generator's steps, literally: inv(w2c), negate columns 1 and 2,
/// permute rows to [1, 0, 2], negate row 2.
fn toolkit_transform_matrix(cam: &Camera, apply_frame_change: bool) -> Vec<Vec<f64>> {
    let c2w = cam.view().inverse();
    let mut m: Vec<Vec<f64>> = (0..4)
        .map(|r| (0..4).map(|c| c2w.col(c)[r]).collect())
        .collect();
    for row in m.iter_mut() {
        row[1] = -row[1];
        row[2] = -row[2];
    }
    if apply_frame_change {
        m.swap(0, 1);
        for v in m[2].iter_mut() {
            *v = -*v;
        }
    }
    m
}

/// 10 vertices: 8 room corners (segments 0–7) and 2 object vertices (segments 8, 9).
fn mesh() -> Mesh {
    let mut positions = Vec::new();
    for &x in &[0.0f32, 4.0] {
        for &y in &[0.0f32, 3.0] {
            for &z in &[0.0f32, 2.5] {
                positions.push([x, y, z]);
            }
        }
    }
    positions.push([2.0, 1.5, 0.5]);
    positions.push([2.2, 1.4, 0.7]);
    let colors = (0..10).map(|i| [i as u8 * 20, 100, 200]).collect();
    Mesh {
        positions,
        faces: vec![[0, 1, 2], [8, 9, 3]],
        colors: Some(colors),
        object_ids: None,
    }
}

fn build(root: &Path, with_colmap: bool, frame_change_in_json: bool) {
    let cams = cameras();
    let dslr = root.join("dslr");
    std::fs::create_dir_all(dslr.join("resized_undistorted_images")).unwrap();
    std::fs::create_dir_all(dslr.join("nerfstudio")).unwrap();
    std::fs::create_dir_all(root.join("scans")).unwrap();
    for n in NAMES {
        Image::from_fn(16, 12, 3, |x, y, c| ((x + y + c) % 5) as f32 / 4.0)
            .save_png8(&dslr.join("resized_undistorted_images").join(n))
            .unwrap();
    }
    let frames: Vec<_> = NAMES
        .iter()
        .zip(&cams)
        .map(|(n, c)| json!({"file_path": n, "transform_matrix": toolkit_transform_matrix(c, frame_change_in_json), "is_bad": false}))
        .collect();
    let bad = json!({"file_path": "DSC09999.JPG", "transform_matrix": toolkit_transform_matrix(&cams[0], true), "is_bad": true});
    let doc = json!({"camera_model": "PINHOLE", "fl_x": 12.0, "fl_y": 12.5, "cx": 8.0, "cy": 6.0, "w": 16, "h": 12,
        "k1": 0.0, "k2": 0.0, "k3": 0.0, "k4": 0.0, "frames": [frames[0], frames[1], bad], "test_frames": [frames[2]], "has_mask": false});
    std::fs::write(
        dslr.join("nerfstudio/transforms_undistorted.json"),
        doc.to_string(),
    )
    .unwrap();
    if with_colmap {
        let colmap = dslr.join("colmap");
        std::fs::create_dir_all(&colmap).unwrap();
        // The DSLR COLMAP camera is the distorted fisheye one; only its poses are used.
        std::fs::write(
            colmap.join("cameras.txt"),
            "1 OPENCV_FISHEYE 32 24 20 20 16 12 0.1 0.01 0 0\n",
        )
        .unwrap();
        let mut images = String::from("# images\n");
        for (i, (n, c)) in NAMES.iter().zip(&cams).enumerate() {
            let q = DQuat::from_mat3(&c.rotation());
            let t = c.translation();
            images += &format!(
                "{} {} {} {} {} {} {} {} 1 {n}\n\n",
                i + 1,
                q.w,
                q.x,
                q.y,
                q.z,
                t.x,
                t.y,
                t.z
            );
        }
        std::fs::write(colmap.join("images.txt"), images).unwrap();
        std::fs::write(
            colmap.join("points3D.txt"),
            "1 1.0 1.0 1.0 10 20 30 0.5 1 0\n2 2.0 1.5 0.5 40 50 60 0.5\n",
        )
        .unwrap();
    }
    mesh().write_ply(&root.join(scannetpp::MESH_FILE)).unwrap();
    std::fs::write(
        root.join("scans/segments.json"),
        json!({"sceneId": "t", "segIndices": (0..10).collect::<Vec<_>>()}).to_string(),
    )
    .unwrap();
    let anno = json!({"sceneId": "t", "segGroups": [
        {"id": 0, "objectId": 40, "label": "Wall", "segments": [0, 1, 2, 3]},
        {"id": 1, "objectId": 12, "label": "table", "segments": [4, 5, 8]},
        {"id": 2, "objectId": 3, "label": "cup", "segments": [8, 9]},
    ]});
    std::fs::write(root.join("scans/segments_anno.json"), anno.to_string()).unwrap();
}

/// The error `scannetpp::load` gives for the scene at `root`, without background labels.
fn load_error(root: &Path, overlap: GroupOverlap) -> anyhow::Error {
    scannetpp::load(root, overlap, &[]).err().unwrap()
}

fn assert_poses(views: &[objectsplat_inputs::scene::SourceView], tolerance: f64) {
    for (v, want) in views.iter().zip(cameras()) {
        let d = (v.camera.view() - want.view())
            .to_cols_array()
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(d < tolerance, "{}: pose off by {d:e}", v.name);
        assert_eq!((v.camera.fx, v.camera.fy, v.camera.width), (12.0, 12.5, 16));
    }
}

#[test]
fn colmap_poses_are_used_and_json_centres_agree() {
    let dir = tempfile::tempdir().unwrap();
    build(dir.path(), true, true);
    let s = scannetpp::load(dir.path(), GroupOverlap::Smallest, &["wall".into()]).unwrap();
    assert_eq!(s.pose_source, PoseSource::Colmap);
    assert_eq!(s.skipped_bad, 1);
    assert_eq!(
        s.views.iter().map(|v| v.name.as_str()).collect::<Vec<_>>(),
        NAMES
    );
    assert_poses(&s.views, 1e-12);
    assert_eq!(s.points.positions, [[1.0, 1.0, 1.0], [2.0, 1.5, 0.5]]);
    assert_eq!(s.points.colors, [[10, 20, 30], [40, 50, 60]]);
}

#[test]
fn json_fallback_applies_the_frame_change() {
    let dir = tempfile::tempdir().unwrap();
    build(dir.path(), false, true);
    let s = scannetpp::load(dir.path(), GroupOverlap::Smallest, &[]).unwrap();
    assert_eq!(s.pose_source, PoseSource::NerfstudioJson);
    assert_poses(&s.views, 1e-9);
    assert_eq!(
        s.points.positions,
        mesh().positions,
        "without COLMAP points the mesh vertices seed"
    );
}

#[test]
fn json_in_the_wrong_frame_is_caught_both_ways() {
    let dir = tempfile::tempdir().unwrap();
    build(dir.path(), true, false);
    let e = load_error(dir.path(), GroupOverlap::Smallest).to_string();
    assert_mentions(&e, &["DSC00001.JPG", "the two pose sources disagree"]);
    std::fs::remove_dir_all(dir.path().join("dslr/colmap")).unwrap();
    let e = load_error(dir.path(), GroupOverlap::Smallest).to_string();
    assert!(e.contains("lies outside the mesh bounds"), "{e}");
}

#[test]
fn overlapping_groups_follow_the_policy_and_background_labels_stay_background() {
    let dir = tempfile::tempdir().unwrap();
    build(dir.path(), true, true);
    // Segment 8 is in both the table (3 vertices) and the cup (2 vertices). Ids are
    // the annotation's own objectIds: cup 3, table 12.
    let none = -1;
    for (policy, vertex8) in [
        (GroupOverlap::Smallest, 3),
        (GroupOverlap::First, 12),
        (GroupOverlap::Last, 3),
    ] {
        let s = scannetpp::load(dir.path(), policy, &["wall".into()]).unwrap();
        let ids = s.mesh.object_ids.as_ref().unwrap();
        assert_eq!(
            ids,
            &[none, none, none, none, 12, 12, none, none, vertex8, 3],
            "{policy:?}"
        );
        assert_eq!(s.contested_vertices, 1);
        assert_eq!(
            s.labels,
            [(3, "cup".to_string()), (12, "table".to_string())].into()
        );
    }
    let s = scannetpp::load(dir.path(), GroupOverlap::First, &[]).unwrap();
    assert_eq!(
        s.labels.keys().copied().collect::<Vec<_>>(),
        [3, 12, 40],
        "without background labels the wall is an object, with its objectId"
    );
}

#[test]
fn object_ids_are_the_annotations_and_must_fit_a_mask() {
    let dir = tempfile::tempdir().unwrap();
    build(dir.path(), true, true);
    let anno_path = dir.path().join("scans/segments_anno.json");
    let write = |cup_id: i64| {
        let anno = json!({"sceneId": "t", "segGroups": [
            {"id": 0, "objectId": 0, "label": "Wall", "segments": [0, 1, 2, 3]},
            {"id": 1, "objectId": 65534, "label": "table", "segments": [4, 5, 8]},
            {"id": 2, "objectId": cup_id, "label": "cup", "segments": [8, 9]},
        ]});
        std::fs::write(&anno_path, anno.to_string()).unwrap();
    };
    // objectId 0 is background (the toolkit's ids ≤ 0 rule), even without background labels;
    // the largest id a mask can hold is kept as it is.
    write(7);
    let s = scannetpp::load(dir.path(), GroupOverlap::First, &[]).unwrap();
    assert_eq!(s.nonpositive_object_ids, 1);
    assert_eq!(
        s.labels,
        [(7, "cup".to_string()), (65534, "table".to_string())].into()
    );
    assert_eq!(&s.mesh.object_ids.as_ref().unwrap()[..4], &[-1, -1, -1, -1]);
    write(65535);
    let e = format!("{:#}", load_error(dir.path(), GroupOverlap::First));
    assert_mentions(
        &e,
        &[
            "segments_anno.json: segGroups[2]: objectId 65535 (label \"cup\") does not fit a mask",
            "1..=65534",
        ],
    );
}

#[test]
fn missing_pieces_are_named() {
    let dir = tempfile::tempdir().unwrap();
    let e = load_error(dir.path(), GroupOverlap::Smallest).to_string();
    assert_mentions(
        &e,
        &["no dslr/resized_undistorted_images, dslr/undistorted_images or dslr/resized_images"],
    );
    build(dir.path(), true, true);
    write_json(
        &dir.path().join("scans/segments.json"),
        &json!({"segIndices": [0, 1]}),
    );
    let e = load_error(dir.path(), GroupOverlap::Smallest).to_string();
    assert_mentions(&e, &["segments.json: 2 segIndices for 10 mesh vertices"]);
}

fn run_scene(
    node: &dyn objectsplat_runtime::Node,
    params: &str,
) -> (Frames, Vec<(String, String)>) {
    let out = tempfile::tempdir().unwrap();
    let run = run_node(node, &[], params, out.path(), None).unwrap();
    let frames = Frames::read(&run.outputs["frames"]).unwrap();
    // Keep the frames readable after the temporary folder goes: copy what the tests need.
    let frames = Frames {
        root: PathBuf::new(),
        frames: frames.frames,
    };
    (frames, run.notes)
}

/// A full scene (COLMAP poses, JSON in the mesh frame) and its root as text.
fn built_scene() -> (tempfile::TempDir, String) {
    let dir = tempfile::tempdir().unwrap();
    build(dir.path(), true, true);
    let root = dir.path().display().to_string();
    (dir, root)
}

fn split_of(frames: &Frames) -> Vec<(&str, Split)> {
    frames
        .frames
        .iter()
        .map(|f| (f.name.as_str(), f.split))
        .collect()
}

#[test]
fn nerfstudio_scene_reads_the_scannetpp_json_with_an_images_folder() {
    let (_scene, root) = built_scene();
    let json = format!("{root}/dslr/nerfstudio/transforms_undistorted.json");
    let images = format!("{root}/dslr/resized_undistorted_images");
    let (ours, _) = run_scene(
        &NerfstudioScene,
        &format!("(path: {json:?}, images: Some({images:?}), world: \"scannetpp_mesh\")"),
    );
    let (reference, _) = run_scene(&ScannetppScene, &format!("(path: {root:?})"));
    assert_eq!(ours.frames.len(), 3);
    for (a, b) in ours.frames.iter().zip(&reference.frames) {
        assert_eq!((&a.name, a.split), (&b.name, b.split));
        assert_eq!(
            (a.camera.fx, a.camera.fy, a.camera.cx, a.camera.cy),
            (b.camera.fx, b.camera.fy, b.camera.cx, b.camera.cy)
        );
        let gap = (a.camera().center() - b.camera().center()).length();
        assert!(gap < 1e-3, "{}: camera centres {gap} m apart", a.name);
        let turn = (a.camera().rotation() - b.camera().rotation())
            .to_cols_array()
            .iter()
            .fold(0.0f64, |m, x| m.max(x.abs()));
        assert!(turn < 1e-6, "{}: rotations differ by {turn}", a.name);
    }
    // Without `world`, the poses stay in the JSON's frame: the same cameras, M apart.
    let (as_stored, _) = run_scene(
        &NerfstudioScene,
        &format!("(path: {json:?}, images: Some({images:?}))"),
    );
    let m = glam::DMat3::from_cols_array_2d(&scannetpp::JSON_FROM_MESH).transpose();
    for (a, b) in as_stored.frames.iter().zip(&reference.frames) {
        let gap = (a.camera().center() - m * b.camera().center()).length();
        assert!(gap < 1e-3, "{}: {gap}", a.name);
    }
    // Without `images` the bare file names are looked up beside the JSON, and the error says so.
    let e = node_error(&NerfstudioScene, &[], &format!("(path: {json:?})"));
    assert_mentions(
        &e,
        &[
            "transforms_undistorted.json: frame 0: file_path \"DSC00001.JPG\"",
            "does not exist; set `images`",
        ],
    );
}

#[test]
fn test_frames_stay_test_frames_under_a_rule() {
    let (_scene, root) = built_scene();
    // `frames` holds DSC00001 and DSC00002, `test_frames` DSC00003. The rule splits the
    // two free frames (fewer than 8: the middle one, index 1, is marked).
    for (split, want) in [
        ("sparse", [Split::Test, Split::Train, Split::Test]),
        ("dense", [Split::Train, Split::Test, Split::Test]),
        ("all", [Split::Train, Split::Train, Split::Train]),
        ("lists", [Split::Train, Split::Train, Split::Test]),
    ] {
        let json = format!("{root}/dslr/nerfstudio/transforms_undistorted.json");
        let images = format!("{root}/dslr/resized_undistorted_images");
        let mut sources = vec![(
            "nerfstudio_scene",
            &NerfstudioScene as &dyn objectsplat_runtime::Node,
            format!("(path: {json:?}, images: Some({images:?}), split: {split:?})"),
        )];
        if split != "lists" {
            sources.push((
                "scannetpp_scene",
                &ScannetppScene,
                format!("(path: {root:?}, split: {split:?})"),
            ));
        }
        for (kind, node, params) in sources {
            let (frames, _) = run_scene(node, &params);
            assert_eq!(
                split_of(&frames),
                NAMES.iter().copied().zip(want).collect::<Vec<_>>(),
                "{kind} {split}"
            );
        }
    }
}

#[test]
fn split_lists_reads_train_test_lists_json() {
    let (dir, root) = built_scene();
    let params = format!("(path: {root:?}, split: \"lists\")");
    let e = node_error(&ScannetppScene, &[], &params);
    assert_mentions(
        &e,
        &["dslr/train_test_lists.json: not found; split \"lists\""],
    );
    let lists = dir.path().join(scannetpp::TRAIN_TEST_LISTS);
    // The official lists disagree with the JSON's test_frames on purpose; they win. The
    // is_bad frame is listed but not loaded.
    write_json(
        &lists,
        &json!({"train": ["DSC00001.JPG", "DSC00003.JPG"], "test": ["DSC00002.JPG", "DSC09999.JPG"]}),
    );
    let (frames, notes) = run_scene(&ScannetppScene, &params);
    assert_eq!(
        split_of(&frames),
        [
            ("DSC00001.JPG", Split::Train),
            ("DSC00002.JPG", Split::Test),
            ("DSC00003.JPG", Split::Train)
        ]
    );
    assert!(
        notes
            .iter()
            .any(|(k, v)| k.starts_with("list entries without a loaded frame") && v == "1"),
        "{notes:?}"
    );
    // A loaded frame in neither list, and a malformed list, are errors naming the file.
    for (doc, want) in [
        (
            json!({"train": ["DSC00001.JPG"], "test": ["DSC00002.JPG"]}),
            "train_test_lists.json: frame \"DSC00003.JPG\" is in neither the train nor the test list",
        ),
        (
            json!({"train": ["DSC00001.JPG", 7], "test": []}),
            "train_test_lists.json: train[1] is not an image name",
        ),
    ] {
        write_json(&lists, &doc);
        assert_mentions(&node_error(&ScannetppScene, &[], &params), &[want]);
    }
}

#[test]
fn without_undistorted_images_the_fisheye_ones_are_undistorted_here() {
    let dir = tempfile::tempdir().unwrap();
    build(dir.path(), true, true);
    let dslr = dir.path().join("dslr");
    std::fs::rename(
        dslr.join("resized_undistorted_images"),
        dslr.join("resized_images"),
    )
    .unwrap();
    let undistorted = dslr.join("nerfstudio/transforms_undistorted.json");
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&undistorted).unwrap()).unwrap();
    let k = [-0.03, -0.005, 0.0007, -0.0002];
    doc["camera_model"] = json!("OPENCV_FISHEYE");
    for (i, v) in k.iter().enumerate() {
        doc[format!("k{}", i + 1)] = json!(v);
    }
    std::fs::write(dslr.join("nerfstudio/transforms.json"), doc.to_string()).unwrap();
    std::fs::remove_file(&undistorted).unwrap();
    let root = dir.path().display().to_string();
    let (frames, notes) = run_scene(&ScannetppScene, &format!("(path: {root:?})"));
    let want = undistort::undistorted_camera(
        &undistort::Intrinsics {
            width: 16,
            height: 12,
            fx: 12.0,
            fy: 12.5,
            cx: 8.0,
            cy: 6.0,
        },
        &undistort::Distortion::Fisheye { k },
    )
    .unwrap();
    for f in &frames.frames {
        assert_eq!(
            (
                f.camera.width,
                f.camera.height,
                f.camera.fx,
                f.camera.fy,
                f.camera.cx,
                f.camera.cy
            ),
            (want.width, want.height, want.fx, want.fy, want.cx, want.cy)
        );
    }
    assert!(
        want.width > 16,
        "a fisheye undistorts to a wider pinhole image"
    );
    assert!(
        notes
            .iter()
            .any(|(k, v)| k == "images" && v == "dslr/resized_images (fisheye, undistorted here)"),
        "{notes:?}"
    );
}
