//! gt_masks resolves occlusion by depth: checked pixel by pixel against brute-force
//! ray casting of the analytic boxes the mesh was built from.

mod common;

use common::{Aabb, boxes_mesh, camera, cast, labels};
use glam::DVec3;
use objectsplat_core::masks::{NO_OBJECT, UNOWNED};
use objectsplat_masks::raster::pixel_ray;
use objectsplat_masks::{GtMaskParams, gt_masks};

const FLOOR: i32 = 1;
const SMALL: i32 = 2;
const LARGE: i32 = 3;

fn scene() -> Vec<Aabb> {
    vec![
        Aabb {
            min: DVec3::new(-3.0, -3.0, -0.1),
            max: DVec3::new(3.0, 3.0, 0.0),
            id: FLOOR,
        },
        // A small box in front of a larger one, as seen from the cameras below.
        Aabb {
            min: DVec3::new(-0.2, -0.8, 0.0),
            max: DVec3::new(0.25, -0.4, 0.5),
            id: SMALL,
        },
        Aabb {
            min: DVec3::new(-0.6, 0.2, 0.0),
            max: DVec3::new(0.7, 0.9, 0.9),
            id: LARGE,
        },
    ]
}

#[test]
fn nearest_surface_owns_each_pixel_like_ray_casting() {
    let boxes = scene();
    let mesh = boxes_mesh(&boxes);
    let labels = labels(&[(1, "floor"), (2, "box"), (3, "cabinet")]);
    let cameras = [
        camera(
            96,
            72,
            DVec3::new(0.3, -3.0, 1.2),
            DVec3::new(0.0, 0.3, 0.3),
        ),
        camera(
            80,
            64,
            DVec3::new(-2.0, -2.2, 0.8),
            DVec3::new(0.0, 0.2, 0.4),
        ),
    ];
    let params = GtMaskParams {
        min_pixels: Some(0),
        ..GtMaskParams::default()
    };
    let out = gt_masks(&mesh, &labels, &cameras, &params).unwrap();
    let mut occluded_checked = 0;
    for (camera, mask) in cameras.iter().zip(&out.masks) {
        let mut certain = 0;
        for y in 0..camera.height {
            for x in 0..camera.width {
                let (origin, dir) = pixel_ray(camera, x as f64 + 0.5, y as f64 + 0.5);
                let (hit, sure) = cast(origin, dir, &boxes);
                if !sure {
                    continue;
                }
                certain += 1;
                let expected = match hit {
                    None => UNOWNED,
                    Some(FLOOR) => NO_OBJECT, // a background label
                    Some(id) => id as u16,
                };
                assert_eq!(mask.get(x, y), expected, "pixel ({x}, {y})");
                // Where the large box alone would be seen, the small box in front keeps the pixel.
                let behind = cast(origin, dir, &boxes[2..]).0 == Some(LARGE);
                if behind && hit == Some(SMALL) {
                    occluded_checked += 1;
                }
            }
        }
        assert!(
            certain as f64 > 0.95 * (camera.width * camera.height) as f64,
            "too few unambiguous pixels"
        );
    }
    assert!(
        occluded_checked > 50,
        "the scene must contain occlusion to test it ({occluded_checked} pixels)"
    );
    assert_eq!(out.labels, labels_of(&[(2, "box"), (3, "cabinet")]));
}

fn labels_of(pairs: &[(u16, &str)]) -> objectsplat_core::ObjectLabels {
    labels(pairs)
}
