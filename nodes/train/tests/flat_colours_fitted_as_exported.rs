//! After the bake, the flat colours are fitted to the training views as the
//! export draws them (opaque, hard-edged, one colour per vertex): the exported
//! plate's error against the red it photographs falls below the bake's, on the
//! training views and on the held-out one, and nothing but the flat colours
//! changes.

mod common;

use common::{RED, cameras, parameter_bits, pixel_sees_square};
use objectsplat_core::{Camera, Split};
use objectsplat_raster::exported::exported_model;
use objectsplat_raster::{CpuBackend, Model, render_model};
use objectsplat_train::trainer::train_component;

/// Mean squared error of the exported model's render against the plate's red,
/// over the pixels that see the plate in `cameras` and that the model covers
/// (the same colour over black and over white: what a colour can change).
fn exported_error(model: &Model<f32>, cameras: &[Camera]) -> f64 {
    let exported = exported_model(model);
    let (mut sum, mut count) = (0.0, 0usize);
    for cam in cameras {
        let img = render_model(&exported, cam, [0.0; 3], 1).unwrap();
        let over_white = render_model(&exported, cam, [1.0; 3], 1).unwrap();
        for j in 0..cam.height {
            for i in 0..cam.width {
                let covered =
                    (0..3).all(|c| (img.get(i, j, c) - over_white.get(i, j, c)).abs() < 1e-4);
                if !covered || !pixel_sees_square(cam, i, j) {
                    continue;
                }
                for c in 0..3 {
                    let d = (img.get(i, j, c) - RED[c as usize]) as f64;
                    sum += d * d;
                }
                count += 3;
            }
        }
    }
    assert!(count > 300, "the model covers {} plate pixels", count / 3);
    sum / count as f64
}

fn trained(fit_epochs: u64) -> Model<f32> {
    let (_dir, data, points) = common::plate();
    let backend = CpuBackend::new(2);
    // A soft, view-dependent colour at the end of a short run: what the bake averages.
    let settings = common::short_run_settings(
        150,
        1,
        serde_json::json!({"flat_fit_epochs": fit_epochs, "flat_fit_lr": 0.02}),
    );
    let report = train_component(&backend, &data, &points, &settings, |_, _| true).unwrap();
    let fitted = report
        .notes
        .iter()
        .any(|n| n.starts_with("flat colours fitted"));
    assert_eq!(fitted, fit_epochs > 0, "{:?}", report.notes);
    report.model
}

#[test]
fn the_fit_brings_the_export_closer_to_the_photos_and_changes_only_flat_colours() {
    let baked = trained(0);
    let fitted = trained(8);
    // The training itself is the same run: every parameter and face bit for bit.
    assert_eq!(parameter_bits(&baked), parameter_bits(&fitted));
    assert_eq!(baked.faces, fitted.faces);
    assert_eq!(fitted.flat_dc.len(), fitted.vertex_count());
    assert_ne!(baked.flat_dc, fitted.flat_dc);
    let views = |split: Split| -> Vec<Camera> {
        cameras()
            .into_iter()
            .filter(|(_, s)| *s == split)
            .map(|(c, _)| c)
            .collect()
    };
    for split in [Split::Train, Split::Test] {
        let (before, after) = (
            exported_error(&baked, &views(split)),
            exported_error(&fitted, &views(split)),
        );
        assert!(
            after < 0.8 * before,
            "{split:?} views: exported MSE {before:.3e} after the bake, {after:.3e} after the fit"
        );
    }
}
