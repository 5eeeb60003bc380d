//! gt_masks parameters: keep_labels, background_labels and the per-frame pixel threshold.

mod common;

use common::{Aabb, boxes_mesh, camera, labels};
use glam::DVec3;
use objectsplat_core::masks::{NO_OBJECT, UNOWNED};
use objectsplat_masks::{GtMaskParams, GtMasks, gt_masks};

/// A floor, a chair, a table and a tiny cup seen by one camera.
struct Scene {
    mesh: objectsplat_core::Mesh,
    labels: objectsplat_core::ObjectLabels,
    cam: objectsplat_core::Camera,
}

impl Scene {
    fn new() -> Self {
        let boxes = [
            Aabb {
                min: DVec3::new(-3.0, -3.0, -0.1),
                max: DVec3::new(3.0, 3.0, 0.0),
                id: 1,
            },
            Aabb {
                min: DVec3::new(-0.5, -0.3, 0.0),
                max: DVec3::new(0.0, 0.3, 0.6),
                id: 2,
            },
            Aabb {
                min: DVec3::new(0.3, -0.3, 0.0),
                max: DVec3::new(0.8, 0.3, 0.4),
                id: 3,
            },
            // A tiny object: a few pixels only.
            Aabb {
                min: DVec3::new(-1.0, -1.0, 0.0),
                max: DVec3::new(-0.97, -0.97, 0.03),
                id: 4,
            },
        ];
        let eye = DVec3::new(0.1, -3.0, 1.5);
        Scene {
            mesh: boxes_mesh(&boxes),
            labels: labels(&[(1, "floor"), (2, "chair"), (3, "table"), (4, "cup")]),
            cam: camera(64, 48, eye, DVec3::new(0.0, 0.0, 0.2)),
        }
    }

    fn masks(&self, params: &GtMaskParams) -> GtMasks {
        gt_masks(&self.mesh, &self.labels, &[self.cam], params).unwrap()
    }

    /// The masks with every object kept however few pixels it covers.
    fn unthresholded_masks(&self) -> GtMasks {
        self.masks(&GtMaskParams {
            min_pixels: Some(0),
            ..Default::default()
        })
    }
}

fn count(mask: &objectsplat_core::IdMap, v: u16) -> usize {
    mask.data.iter().filter(|&&x| x == v).count()
}

#[test]
fn keep_labels_turns_other_objects_into_background() {
    let scene = Scene::new();
    let all = scene.unthresholded_masks();
    let only_tables = scene.masks(&GtMaskParams {
        keep_labels: vec!["table".into()],
        min_pixels: Some(0),
        ..Default::default()
    });
    let (a, t) = (&all.masks[0], &only_tables.masks[0]);
    assert!(count(a, 2) > 0 && count(a, 3) > 0);
    assert_eq!(count(t, 2), 0);
    assert_eq!(count(t, 3), count(a, 3));
    // Exactly the chair pixels (and the cup's) changed, and they became 0.
    for (x, y) in a.data.iter().zip(&t.data) {
        if x != y {
            assert!((*x == 2 || *x == 4) && *y == NO_OBJECT);
        }
    }
    assert_eq!(only_tables.labels, common::labels(&[(3, "table")]));
}

#[test]
fn background_labels_map_to_zero_and_sky_stays_unowned() {
    let scene = Scene::new();
    let with_floor = scene.masks(&GtMaskParams {
        background_labels: vec![],
        min_pixels: Some(0),
        ..Default::default()
    });
    let default = scene.unthresholded_masks();
    let floor_pixels = count(&with_floor.masks[0], 1);
    assert!(floor_pixels > 0);
    assert_eq!(count(&default.masks[0], 1), 0);
    assert_eq!(count(&default.masks[0], NO_OBJECT), floor_pixels);
    // Above the horizon nothing is hit.
    assert!(count(&default.masks[0], UNOWNED) > 0);
    assert_eq!(
        count(&with_floor.masks[0], UNOWNED),
        count(&default.masks[0], UNOWNED)
    );
}

#[test]
fn objects_below_the_per_frame_threshold_are_dropped() {
    let scene = Scene::new();
    let all = scene.unthresholded_masks();
    let tiny = count(&all.masks[0], 4);
    assert!(
        tiny > 0 && tiny < 20,
        "the cup should cover a few pixels, covers {tiny}"
    );
    let dropped = scene.masks(&GtMaskParams {
        min_pixels: Some(tiny as u64 + 1),
        ..Default::default()
    });
    assert_eq!(count(&dropped.masks[0], 4), 0);
    assert_eq!(count(&dropped.masks[0], 2), count(&all.masks[0], 2));
    assert!(!dropped.labels.contains_key(&4));
    // The default threshold is a fraction of the frame area.
    let by_fraction = GtMaskParams {
        min_fraction: (tiny as f64 + 0.5) / (64.0 * 48.0),
        ..Default::default()
    };
    assert_eq!(count(&scene.masks(&by_fraction).masks[0], 4), 0);
}
