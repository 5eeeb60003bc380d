//! A COLMAP model becomes a Frames artifact (split, downscaled, intrinsics scaled with
//! the pixel grid) and a Points artifact with the model's colours.

use objectsplat_core::artifact::POINTS_PLY;
use objectsplat_core::{Frames, Points, Split, SplitPolicy};
use objectsplat_inputs::scene::{self, Resolution, SplitChoice};
use objectsplat_inputs::{colmap, colmap_scene};
use std::path::PathBuf;

mod common;

fn fixture(name: &str) -> PathBuf {
    common::fixture("colmap").join(name)
}

#[test]
fn frames_are_sorted_split_and_downscaled() {
    let model = colmap::read_model(&fixture("classic_bin")).unwrap();
    let out = tempfile::tempdir().unwrap();
    let views = colmap_scene::views(&model, &fixture("images")).unwrap();
    scene::write_frames(
        out.path(),
        views,
        &SplitChoice::Rule(SplitPolicy::Sparse),
        Resolution::new(2, None).unwrap(),
        2,
    )
    .unwrap();
    let frames = Frames::read(out.path()).unwrap();
    let names: Vec<&str> = frames.frames.iter().map(|f| f.name.as_str()).collect();
    let mut sorted = names.clone();
    sorted.sort();
    assert_eq!(names, sorted);
    // 6 frames (< 8): the middle one trains.
    let train: Vec<&str> = frames
        .by_split(Split::Train)
        .map(|f| f.name.as_str())
        .collect();
    assert_eq!(train, [names[3]]);
    for f in &frames.frames {
        let img = model.images.values().find(|i| i.name == f.name).unwrap();
        let cam = &model.cameras[&img.camera_id];
        let (lens, distortion) = cam.lens().unwrap();
        assert_eq!(distortion, None);
        let (fx, fy, cx, cy) = (lens.fx, lens.fy, lens.cx, lens.cy);
        assert_eq!((f.camera.width, f.camera.height), (32, 24));
        assert_eq!(
            (f.camera.fx, f.camera.fy, f.camera.cx, f.camera.cy),
            (fx / 2.0, fy / 2.0, cx / 2.0, cy / 2.0),
            "{}",
            f.name
        );
        assert_eq!(f.camera.world_to_camera, img.pose.matrix());
        // A 2×2 box average of the source image.
        let src = objectsplat_core::Image::load(&fixture("images").join(&f.name)).unwrap();
        let got = frames.load_rgb(f).unwrap();
        let want =
            (src.get(2, 2, 0) + src.get(3, 2, 0) + src.get(2, 3, 0) + src.get(3, 3, 0)) / 4.0;
        assert!(
            (got.get(1, 1, 0) - want).abs() <= 0.5 / 255.0 + 1e-6,
            "{}",
            f.name
        );
    }
}

#[test]
fn max_width_caps_the_width_and_keeps_aspect() {
    assert_eq!(
        Resolution::new(1, Some(40)).unwrap().target(64, 48),
        (40, 30)
    );
    assert_eq!(
        Resolution::new(2, Some(40)).unwrap().target(64, 48),
        (32, 24)
    );
    assert_eq!(Resolution::new(3, None).unwrap().target(64, 48), (21, 16));
    assert!(Resolution::new(0, None).is_err());
}

#[test]
fn points_keep_positions_and_colours() {
    let model = colmap::read_model(&fixture("rig_txt")).unwrap();
    let out = tempfile::tempdir().unwrap();
    scene::write_points(out.path(), &colmap_scene::points(&model)).unwrap();
    let pts = Points::read_ply(&out.path().join(POINTS_PLY)).unwrap();
    assert_eq!(pts.positions.len(), model.points.len());
    for (p, (got, col)) in model
        .points
        .values()
        .zip(pts.positions.iter().zip(&pts.colors))
    {
        assert_eq!(*got, p.xyz.map(|v| v as f32));
        assert_eq!(*col, p.rgb);
    }
}

#[test]
fn image_of_the_wrong_size_names_the_file() {
    let model = colmap::read_model(&fixture("classic_txt")).unwrap();
    let images = tempfile::tempdir().unwrap();
    for img in model.images.values() {
        std::fs::copy(
            fixture("images").join(&img.name),
            images.path().join(&img.name),
        )
        .unwrap();
    }
    let bad = &model.images.values().next().unwrap().name;
    objectsplat_core::Image::new(10, 10, 3)
        .save_png8(&images.path().join(bad))
        .unwrap();
    let out = tempfile::tempdir().unwrap();
    let views = colmap_scene::views(&model, images.path()).unwrap();
    let e = scene::write_frames(
        out.path(),
        views,
        &SplitChoice::Rule(SplitPolicy::All),
        Resolution::FULL,
        2,
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains(bad.as_str()) && e.contains("image is 10×10 but its camera says 64×48"),
        "{e}"
    );
}
