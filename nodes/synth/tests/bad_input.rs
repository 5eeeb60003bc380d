//! Bad input never panics: errors name the file (or parameter) and the problem.

#[path = "../../masks/tests/common/mod.rs"]
mod common;

use common::{Aabb, boxes_mesh, camera, labels};
use glam::DVec3;
use objectsplat_core::artifact::OBJECTS_JSON;
use objectsplat_core::{Frame, Frames, IdMap, Image, Split, masks::write_objects};
use objectsplat_masks::partition::partition_folders;
use objectsplat_masks::raster::RasterOptions;
use objectsplat_masks::{GtMaskParams, PartitionParams, gt_masks, rasterize};
use objectsplat_synth::{SyntheticParams, scene};
use std::path::{Path, PathBuf};

fn one_box() -> (
    objectsplat_core::Mesh,
    objectsplat_core::ObjectLabels,
    objectsplat_core::Camera,
) {
    let mesh = boxes_mesh(&[Aabb {
        min: DVec3::splat(-0.5),
        max: DVec3::splat(0.5),
        id: 3,
    }]);
    (
        mesh,
        labels(&[(3, "chair")]),
        camera(16, 12, DVec3::new(0.5, -3.0, 1.0), DVec3::ZERO),
    )
}

/// What `gt_masks` says when it refuses to mask `mesh` seen by `cam`.
fn gt_masks_error(
    mesh: &objectsplat_core::Mesh,
    labels: &objectsplat_core::ObjectLabels,
    cam: objectsplat_core::Camera,
    params: &GtMaskParams,
) -> String {
    gt_masks(mesh, labels, &[cam], params)
        .unwrap_err()
        .to_string()
}

#[test]
fn unknown_keep_label_is_named() {
    let (mesh, labels, cam) = one_box();
    let params = GtMaskParams {
        keep_labels: vec!["sofa".into()],
        ..Default::default()
    };
    let err = gt_masks_error(&mesh, &labels, cam, &params);
    assert!(
        err.contains("\"sofa\"") && err.contains("\"chair\""),
        "{err}"
    );
}

#[test]
fn unlabelled_object_and_missing_annotation_are_refused() {
    let (mut mesh, _, cam) = one_box();
    let no_params = GtMaskParams::default();
    let err = gt_masks_error(&mesh, &labels(&[(4, "x")]), cam, &no_params);
    assert!(
        err.contains("object_id 3") && err.contains("no label"),
        "{err}"
    );
    mesh.object_ids = None;
    let err = gt_masks_error(&mesh, &labels(&[(3, "chair")]), cam, &no_params);
    assert!(err.contains("object_id"), "{err}");
}

#[test]
fn broken_meshes_and_cameras_are_errors() {
    let (mut mesh, labels, mut cam) = one_box();
    mesh.positions[2][1] = f32::NAN;
    let err = gt_masks_error(&mesh, &labels, cam, &GtMaskParams::default());
    assert!(
        err.contains("vertex 2") && err.contains("non-finite"),
        "{err}"
    );
    let err = rasterize(&[[0.0; 3]], &[[0, 1, 0]], &cam, &RasterOptions::default()).unwrap_err();
    assert!(err.contains("face 0") && err.contains("vertex"), "{err}");
    cam.fx = f64::INFINITY;
    let err = rasterize(&[[0.0; 3]], &[], &cam, &RasterOptions::default()).unwrap_err();
    assert!(err.contains("fx"), "{err}");
    let err = rasterize(
        &[[0.0; 3]],
        &[],
        &one_box().2,
        &RasterOptions {
            near: f64::NAN,
            threads: 1,
        },
    )
    .unwrap_err();
    assert!(err.contains("near"), "{err}");
}

fn write_frames(dir: &Path, sizes: &[(u32, u32)]) {
    std::fs::create_dir_all(dir.join("images")).unwrap();
    let mut frames = Vec::new();
    for (i, &(w, h)) in sizes.iter().enumerate() {
        let cam = camera(w, h, DVec3::new(0.0, -3.0, 1.0), DVec3::ZERO);
        let name = format!("f{i}");
        Image::new(w, h, 3)
            .save_png8(&dir.join(format!("images/{name}.png")))
            .unwrap();
        frames.push(Frame::new(
            name.clone(),
            format!("images/{name}.png"),
            &cam,
            Split::Train,
        ));
    }
    Frames::write_json(dir, &frames).unwrap();
}

/// Frames of the given sizes and a masks folder that knows one object but holds
/// no mask yet, in a temporary folder that also takes partition's output.
struct PartitionInputs {
    tmp: tempfile::TempDir,
    frames: PathBuf,
    masks: PathBuf,
}

impl PartitionInputs {
    fn write(sizes: &[(u32, u32)]) -> Self {
        let tmp = tempfile::tempdir().unwrap();
        let (frames, masks) = (tmp.path().join("frames"), tmp.path().join("masks"));
        write_frames(&frames, sizes);
        std::fs::create_dir_all(&masks).unwrap();
        write_objects(&masks, &labels(&[(1, "cup")])).unwrap();
        PartitionInputs { tmp, frames, masks }
    }

    /// What partition says when it refuses these folders.
    fn partition_error(&self) -> String {
        let out = self.tmp.path().join("out");
        partition_folders(
            &self.frames,
            &self.masks,
            &out,
            &PartitionParams::default(),
            2,
        )
        .unwrap_err()
        .to_string()
    }
}

#[test]
fn partition_names_a_mask_of_the_wrong_size() {
    let inputs = PartitionInputs::write(&[(8, 6), (8, 6)]);
    IdMap::new(8, 6).save(&inputs.masks.join("f0.png")).unwrap();
    IdMap::new(7, 6).save(&inputs.masks.join("f1.png")).unwrap();
    let err = inputs.partition_error();
    assert!(
        err.contains("f1.png") && err.contains("7×6") && err.contains("8×6"),
        "{err}"
    );
}

#[test]
fn partition_names_a_missing_mask_and_an_unknown_id() {
    let inputs = PartitionInputs::write(&[(8, 6)]);
    let masks = &inputs.masks;
    let err = inputs.partition_error();
    assert!(err.contains("f0.png") && err.contains("no mask"), "{err}");
    let mut m = IdMap::new(8, 6);
    m.data[5] = 9;
    m.save(&masks.join("f0.png")).unwrap();
    let err = inputs.partition_error();
    assert!(
        err.contains("id 9") && err.contains(&masks.display().to_string()),
        "{err}"
    );
    std::fs::remove_file(masks.join(OBJECTS_JSON)).unwrap();
    let err = inputs.partition_error();
    assert!(err.contains(OBJECTS_JSON), "{err}");
}

#[test]
fn synthetic_scene_rejects_bad_params_by_name() {
    for (params, word) in [
        (
            SyntheticParams {
                views: 0,
                ..Default::default()
            },
            "views",
        ),
        (
            SyntheticParams {
                points_noise: f64::NAN,
                ..Default::default()
            },
            "points_noise",
        ),
        (
            SyntheticParams {
                resolution: 0,
                ..Default::default()
            },
            "resolution",
        ),
        (
            SyntheticParams {
                width: 4,
                ..Default::default()
            },
            "image size",
        ),
    ] {
        let err = scene::generate(&params).unwrap_err().to_string();
        assert!(err.contains(word), "{err}");
    }
}
