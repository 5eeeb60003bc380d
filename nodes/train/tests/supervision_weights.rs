//! What each pixel is supervised toward: objects pull OTHER pixels to the
//! background colour; the background component ignores them; IGNORE never counts.

use glam::DVec3;
use objectsplat_core::component::{IGNORE, OTHER, OWN};
use objectsplat_core::{Camera, ComponentKind, Split};
use objectsplat_train::trainer::{View, supervision};

const TARGET: [f32; 12] = [
    0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 0.15, 0.25, 0.35,
];

fn view() -> View {
    let camera = Camera::look_at(
        4,
        1,
        4.0,
        4.0,
        DVec3::new(0.0, 0.0, -2.0),
        DVec3::ZERO,
        DVec3::Y,
    );
    View::from_planes(
        "v",
        camera,
        &TARGET,
        &[OWN, OTHER, IGNORE, 77],
        Split::Train,
    )
    .unwrap()
}

#[test]
fn objects_supervise_other_pixels_toward_the_background_colour() {
    let b = [0.9, 0.05, 0.6];
    let (target, weights) = supervision(&view(), ComponentKind::Object, b);
    assert_eq!(weights, vec![1.0, 1.0, 0.0, 0.0]);
    assert_eq!(&target[0..3], &[0.1, 0.2, 0.3], "own pixels keep the image");
    assert_eq!(&target[3..6], &b, "other pixels are pulled to b");
}

#[test]
fn the_background_component_gives_other_pixels_no_weight() {
    let (target, weights) = supervision(&view(), ComponentKind::Background, [0.9, 0.05, 0.6]);
    assert_eq!(weights, vec![1.0, 0.0, 0.0, 0.0]);
    assert_eq!(target, TARGET);
}
