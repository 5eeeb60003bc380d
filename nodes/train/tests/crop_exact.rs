//! Cropping is exact: training an object on its footprint only (the default)
//! gives a bit-identical model to training on whole frames, while rendering a
//! fraction of each frame.

mod common;

use objectsplat_raster::CpuBackend;
use objectsplat_train::trainer::{TrainSettings, train_component};

#[test]
fn training_on_the_footprint_equals_training_on_whole_frames() {
    // Wide frames around the plate: it covers a small part of each.
    let (_dir, data, points) = common::plate_sized(128, 96);
    let backend = CpuBackend::new(2);
    let run = |crop: bool| {
        let settings = TrainSettings {
            crop,
            ..common::short_run_settings(160, 5, serde_json::json!({}))
        };
        train_component(&backend, &data, &points, &settings, |_, _| true).unwrap()
    };
    let (cropped, whole) = (run(true), run(false));
    let fraction = cropped.log.rendered_fraction.unwrap();
    eprintln!("rendered fraction with cropping: {fraction:.3}");
    assert!(
        fraction < 0.6,
        "the footprint is a fraction of the frame: {fraction}"
    );
    assert_eq!(whole.log.rendered_fraction, Some(1.0));
    assert!(cropped.model.face_count() > 0);
    assert_eq!(cropped.model.faces, whole.model.faces);
    assert_eq!(
        common::parameter_bits(&cropped.model),
        common::parameter_bits(&whole.model),
        "parameters differ"
    );
    assert_eq!(cropped.best_iteration, whole.best_iteration);
    assert!((cropped.best_score - whole.best_score).abs() < 1e-9);
}
