//! Scene sources read image files their `path` param does not name (COLMAP's image
//! folder found beside the model; the images a transforms.json lists). Replacing one
//! of those images reruns the source and the new pixels reach the output, through
//! the engine's cache, never the old image.

use objectsplat_core::Image;
use objectsplat_runtime::exec::{self, RunOptions, Silent};
use objectsplat_runtime::graph::GraphSource;
use objectsplat_runtime::plan::build_plan;
use objectsplat_runtime::report::Status;
use objectsplat_runtime::store::Store;
use std::path::Path;
use std::sync::Arc;

mod common;
use common::{copy_dir, fixture};

/// Runs `graph` and returns the source node's status and the first frame's image.
fn run(dir: &Path) -> (Status, Image) {
    let src = GraphSource::read(&dir.join("g.ron")).unwrap();
    let plan = build_plan(&src, &common::registry(), &[], &[]).unwrap_or_else(|d| panic!("{d}"));
    let store = Store::open(&dir.join("cache")).unwrap();
    let out = dir.join("out");
    let r = exec::run(
        &plan,
        &store,
        &RunOptions {
            jobs: 1,
            threads_per_job: None,
            out_dir: Some(out.clone()),
            observer: Arc::new(Silent),
        },
    )
    .unwrap();
    assert!(r.ok, "{}", r.render_table());
    let frames = objectsplat_core::Frames::read(&out.join("scene/frames")).unwrap();
    let first = frames.load_rgb(&frames.frames[0]).unwrap();
    (r.node("scene").unwrap().status, first)
}

/// Overwrites `path` with an image of the same size and a different colour.
fn repaint(path: &Path) {
    let old = Image::load(path).unwrap();
    let new = Image::from_fn(old.width, old.height, 3, |_, _, c| {
        [0.9, 0.1, 0.5][c as usize]
    });
    new.save_png8(path).unwrap();
}

/// Writes a graph of one source node `scene` with `params`, runs it twice (ran, then
/// cached), repaints the first image and asserts the rerun sees the new pixels.
fn assert_repainted_image_reruns(dir: &Path, kind: &str, params: &str) {
    std::fs::write(
        dir.join("g.ron"),
        format!(r#"(nodes: {{ "scene": (kind: "{kind}", params: {params}) }})"#),
    )
    .unwrap();
    let (status, before) = run(dir);
    assert_eq!(status, Status::Ran);
    assert_eq!(run(dir).0, Status::Cached);

    repaint(&dir.join("images/camera000001_frame000000.png"));
    let (status, after) = run(dir);
    assert_eq!(
        status,
        Status::Ran,
        "a replaced image must rerun the source"
    );
    assert_ne!(before.data, after.data);
    assert!((after.get(0, 0, 0) - 0.9).abs() < 0.01);
}

#[test]
fn colmap_images_beside_the_model_are_in_the_key() {
    let dir = tempfile::tempdir().unwrap();
    copy_dir(&fixture("colmap/classic_bin"), &dir.path().join("sparse/0"));
    copy_dir(&fixture("colmap/images"), &dir.path().join("images"));
    assert_repainted_image_reruns(
        dir.path(),
        "colmap_scene",
        r#"(path: "sparse/0", split: "all")"#,
    );
}

#[test]
fn nerfstudio_images_listed_in_the_json_are_in_the_key() {
    let dir = tempfile::tempdir().unwrap();
    copy_dir(&fixture("colmap/images"), &dir.path().join("images"));
    let pose = "[[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]]";
    std::fs::write(
        dir.path().join("transforms.json"),
        format!(
            r#"{{"fl_x": 40, "fl_y": 40, "cx": 32, "cy": 24, "w": 64, "h": 48, "frames": [
                {{"file_path": "images/camera000001_frame000000.png", "transform_matrix": {pose}}},
                {{"file_path": "images/camera000002_frame000000.png", "transform_matrix": {pose}}}]}}"#
        ),
    )
    .unwrap();
    assert_repainted_image_reruns(
        dir.path(),
        "nerfstudio_scene",
        r#"(path: "transforms.json", split: "all")"#,
    );
}
