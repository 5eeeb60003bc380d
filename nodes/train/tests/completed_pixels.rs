//! The own pixels whose targets surface completion inpainted are known to the
//! trainer: those where `targets/` differs from the frame image, and only own ones.

use glam::DVec3;
use objectsplat_core::component::{self, OTHER, OWN};
use objectsplat_core::{Camera, ComponentInfo, Frame, Frames, Split};
use objectsplat_train::trainer::ComponentData;

const W: u32 = 12;
const H: u32 = 8;

/// A table component's description in `dir` and its one frame.
fn table_frame(dir: &std::path::Path) -> Frame {
    ComponentInfo::object(7, "table").write(dir).unwrap();
    let camera = Camera::look_at(
        W,
        H,
        10.0,
        10.0,
        DVec3::new(0.0, -4.0, 0.0),
        DVec3::ZERO,
        DVec3::Z,
    );
    Frame::new("f0", "images/f0.png".to_string(), &camera, Split::Train)
}

#[test]
fn inpainted_own_pixels_are_the_completed_ones() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let frame = table_frame(dir);
    // Own left of column 9, other from it on.
    let mask: Vec<u8> = (0..W * H)
        .map(|p| if p % W < 9 { OWN } else { OTHER })
        .collect();
    component::write_mask(dir, &frame, &mask).unwrap();
    let image: Vec<u8> = (0..W * H)
        .flat_map(|p| [(p % W * 20) as u8, (p / W * 30) as u8, 100])
        .collect();
    std::fs::create_dir_all(dir.join("images")).unwrap();
    image::RgbImage::from_raw(W, H, image.clone())
        .unwrap()
        .save(dir.join("images/f0.png"))
        .unwrap();
    // Inpainted: a 3×2 block of own pixels (one channel off by one), and two
    // pixels the component does not own.
    let changed = [
        (3, 2),
        (4, 2),
        (5, 2),
        (3, 3),
        (4, 3),
        (5, 3),
        (10, 1),
        (11, 6),
    ];
    let mut targets = image.clone();
    for (k, &(x, y)) in changed.iter().enumerate() {
        let p = 3 * (y * W + x) as usize;
        targets[p + k % 3] = targets[p + k % 3].wrapping_add(1);
    }
    component::write_target(dir, &frame, &targets).unwrap();
    Frames::write_json(dir, &[frame]).unwrap();

    let data = ComponentData::read(dir, 1).unwrap();
    let completed = data.views[0].completed.as_ref().expect("completed pixels");
    for y in 0..H {
        for x in 0..W {
            let want = x < 9 && changed.contains(&(x, y));
            assert_eq!(completed.get(x, y) != 0, want, "pixel ({x}, {y})");
        }
    }
}

#[test]
fn a_component_without_targets_has_no_completed_pixels() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let frame = table_frame(dir);
    component::write_mask(dir, &frame, &vec![OWN; (W * H) as usize]).unwrap();
    std::fs::create_dir_all(dir.join("images")).unwrap();
    image::RgbImage::new(W, H)
        .save(dir.join("images/f0.png"))
        .unwrap();
    Frames::write_json(dir, &[frame]).unwrap();
    let data = ComponentData::read(dir, 1).unwrap();
    assert!(data.views[0].completed.is_none());
}
