//! A scene as the `viewer` page shows it, for tests that compare the page with the
//! project's renderer: edits applied, one capture frame to start the view from, and the
//! pinhole camera of the page's starting view.

use objectsplat_core::{Camera, Frame, Frames, Image, Split, glam};
use objectsplat_export::viewer::ViewerCamera;
use objectsplat_runtime::testing::run_node;
use objectsplat_scene::Scene;
use std::path::{Path, PathBuf};

/// `scene` with `edits` (each one RON edit) applied.
pub fn edited(mut scene: Scene, edits: &[&str]) -> Scene {
    let values: Vec<objectsplat_runtime::Value> = edits
        .iter()
        .map(|t| objectsplat_runtime::syntax::parse(t).unwrap().to_value())
        .collect();
    objectsplat_scene::apply_edits(
        &mut scene,
        &objectsplat_scene::parse_edits(&values).unwrap(),
    )
    .unwrap();
    scene
}

/// Writes `scene` and one 320×240 frame looking at it under `tmp`, runs `viewer` on
/// them and returns the page's folder and its starting view (from that frame).
pub fn viewer_of(scene: &Scene, tmp: &Path) -> (PathBuf, ViewerCamera) {
    let scene_dir = tmp.join("scene");
    objectsplat_scene::save_scene(scene, &scene_dir).unwrap();
    let frames = tmp.join("frames");
    let capture = Camera::look_at(
        320,
        240,
        300.0,
        300.0,
        glam::DVec3::new(1.2, -2.4, 1.6),
        glam::DVec3::new(0.0, 0.0, 0.3),
        glam::DVec3::Z,
    );
    std::fs::create_dir_all(frames.join("images")).unwrap();
    Image::from_fn(320, 240, 3, |_, _, _| 0.5)
        .save_png8(&frames.join("images/f0.png"))
        .unwrap();
    Frames::write_json(
        &frames,
        &[Frame::new("f0", "images/f0.png", &capture, Split::Train)],
    )
    .unwrap();
    let run = run_node(
        &objectsplat_export::nodes::Viewer,
        &[("scene", &scene_dir), ("frames", &frames)],
        "()",
        &tmp.join("viewer"),
        None,
    )
    .unwrap();
    let dir = run.outputs["file"].clone();
    let (_, view) = objectsplat_export::viewer::read_viewer(&dir).unwrap();
    (dir, view.camera.unwrap())
}

/// The pinhole camera of the page's view `start` for a `width`×`height` screenshot:
/// its eye, target and vertical field of view.
pub fn page_camera(start: &ViewerCamera, width: u32, height: u32) -> Camera {
    let fy = height as f64 / 2.0 / (start.fov_y_degrees.to_radians() / 2.0).tan();
    Camera::look_at(
        width,
        height,
        fy,
        fy,
        glam::DVec3::from_array(start.eye),
        glam::DVec3::from_array(start.target),
        glam::DVec3::Z,
    )
}
