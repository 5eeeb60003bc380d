//! A component is seeded by the points inside its own mask in most training views.

use glam::DVec3;
use objectsplat_core::component::{self, IGNORE, OTHER, OWN};
use objectsplat_core::visibility::Visibility;
use objectsplat_core::{Camera, ComponentInfo, Frame, Frames, Points, Split};
use objectsplat_train::trainer::ComponentData;
use std::path::Path;

const W: u32 = 40;
const H: u32 = 30;

fn camera() -> Camera {
    let eye = DVec3::new(0.0, -4.0, 0.0);
    Camera::look_at(W, H, 30.0, 30.0, eye, DVec3::ZERO, DVec3::Z)
}

/// Writes a component whose frames all share one camera; `masks[i]` gives the
/// label of the left and right image halves in frame i.
fn write_component(dir: &Path, masks: &[(u8, u8, Split)]) {
    let info = ComponentInfo::object(3, "chair");
    info.write(dir).unwrap();
    let cam = camera();
    let mut frames = Vec::new();
    for (i, &(left, right, split)) in masks.iter().enumerate() {
        let name = format!("f{i}");
        let frame = Frame::new(&name, format!("images/{name}.png"), &cam, split);
        let mask: Vec<u8> = (0..H)
            .flat_map(|_| (0..W).map(|x| if x < W / 2 { left } else { right }))
            .collect();
        component::write_mask(dir, &frame, &mask).unwrap();
        std::fs::create_dir_all(dir.join("images")).unwrap();
        image::RgbImage::new(W, H)
            .save(dir.join(format!("images/{name}.png")))
            .unwrap();
        frames.push(frame);
    }
    Frames::write_json(dir, &frames).unwrap();
}

/// [`write_component`] into a temporary folder, read back as training data.
fn read_component(masks: &[(u8, u8, Split)]) -> (tempfile::TempDir, ComponentData) {
    let dir = tempfile::tempdir().unwrap();
    write_component(dir.path(), masks);
    let component = ComponentData::read(dir.path(), 2).unwrap();
    (dir, component)
}

/// One point projecting into the left half, one into the right, one behind the camera.
fn points() -> Points {
    let cam = camera();
    let left = [-0.5f32, 0.0, 0.0];
    let right = [0.5f32, 0.0, 0.0];
    let (ul, ..) = cam.project(DVec3::new(-0.5, 0.0, 0.0)).unwrap();
    let (ur, ..) = cam.project(DVec3::new(0.5, 0.0, 0.0)).unwrap();
    let (left, right) = if ul < ur {
        (left, right)
    } else {
        (right, left)
    };
    Points {
        positions: vec![left, right, [0.0, -10.0, 0.0]],
        colors: vec![[255, 0, 0], [0, 255, 0], [0, 0, 255]],
    }
}

#[test]
fn majority_of_training_views_decides() {
    // Left half owned in 2 of 3 training views; the test view disagrees and must not count.
    let (_dir, c) = read_component(&[
        (OWN, OTHER, Split::Train),
        (OWN, OTHER, Split::Train),
        (OTHER, OWN, Split::Train),
        (OTHER, OWN, Split::Test),
        (OTHER, OWN, Split::Test),
    ]);
    assert_eq!(c.name, "obj_3_chair");
    assert_eq!(c.select_points(&points(), None).unwrap(), vec![0]);
    let chosen = c.component_points(&points(), None).unwrap();
    assert_eq!(chosen.colors, vec![[255, 0, 0]]);
    // The rest are the other components' (the free-space rule's), the unseen one too.
    let p = points();
    let (own, others) = c.partition_points(&p, None).unwrap();
    assert_eq!(own.positions, chosen.positions);
    assert_eq!(others, vec![p.positions[1], p.positions[2]]);
}

#[test]
fn ignored_pixels_do_not_count_as_visible() {
    // Left: own once, other once, ignored once → 1 of 2 visible views is not a majority.
    // Right: ignored twice, own once → 1 of 1.
    let views = [
        (OWN, IGNORE, Split::Train),
        (OTHER, IGNORE, Split::Train),
        (IGNORE, OWN, Split::Train),
    ];
    let (_dir, c) = read_component(&views);
    assert_eq!(c.select_points(&points(), None).unwrap(), vec![1]);
}

#[test]
fn a_component_without_points_is_a_clear_error() {
    let (_dir, c) = read_component(&[(OTHER, OTHER, Split::Train)]);
    let err = c.component_points(&points(), None).unwrap_err();
    assert!(format!("{err}").contains("obj_3_chair"), "{err}");
}

#[test]
fn a_missing_or_mis_sized_mask_names_the_file() {
    let dir = tempfile::tempdir().unwrap();
    write_component(dir.path(), &[(OWN, OTHER, Split::Train)]);
    image::GrayImage::new(5, 5)
        .save(dir.path().join("masks/f0.png"))
        .unwrap();
    let err = ComponentData::read(dir.path(), 1).err().unwrap();
    assert!(format!("{err:#}").contains("f0.png"), "{err:#}");
    std::fs::remove_file(dir.path().join("masks/f0.png")).unwrap();
    let err = ComponentData::read(dir.path(), 1).err().unwrap();
    assert!(format!("{err:#}").contains("f0.png"), "{err:#}");
}

#[test]
fn the_scenes_visibility_selects_what_the_trainer_would_compute() {
    let (dir, c) = read_component(&[
        (OWN, OTHER, Split::Train),
        (OWN, OTHER, Split::Train),
        (OTHER, OWN, Split::Train),
        (OTHER, OWN, Split::Test),
    ]);
    let frames = Frames::read(dir.path()).unwrap();
    let visibility = Visibility::compute(&points(), &frames.frames, 2).unwrap();
    assert_eq!(
        c.select_points(&points(), Some(&visibility)).unwrap(),
        c.select_points(&points(), None).unwrap()
    );
    // A visibility of another capture is refused, naming what does not match.
    let other = Visibility::compute(&points(), &frames.frames[..1], 1).unwrap();
    let err = c.select_points(&points(), Some(&other)).unwrap_err();
    assert!(format!("{err:#}").contains("no frame"), "{err:#}");
    let fewer = Points {
        positions: points().positions[..2].to_vec(),
        colors: points().colors[..2].to_vec(),
    };
    assert!(c.select_points(&fewer, Some(&visibility)).is_err());
}
