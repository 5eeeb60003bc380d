//! Cropping is exact: training an object on its footprint only (the default)
//! gives a bit-identical model to training on whole frames, while rendering a
//! fraction of each frame.

mod common;

use objectsplat_raster::CpuBackend;
use objectsplat_train::init::ComponentMasks;
use objectsplat_train::trainer::{ComponentData, TrainSettings, train_component};

#[test]
fn training_on_the_footprint_equals_training_on_whole_frames() {
    let dir = tempfile::tempdir().unwrap();
    // Wide frames around the plate: it covers a small part of each.
    common::write_component_sized(dir.path(), 128, 96);
    let masks = ComponentMasks::read(dir.path()).unwrap();
    let points = masks.component_points(&common::points()).unwrap();
    let data = ComponentData::read(dir.path()).unwrap();
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
    let bits = |m: &objectsplat_raster::Model<f32>| -> Vec<u32> {
        m.vertices
            .iter()
            .flatten()
            .chain(m.sh.iter().flatten().flatten())
            .chain(&m.opacity_logits)
            .map(|x| x.to_bits())
            .collect()
    };
    assert!(cropped.model.face_count() > 0);
    assert_eq!(cropped.model.faces, whole.model.faces);
    assert_eq!(
        bits(&cropped.model),
        bits(&whole.model),
        "parameters differ"
    );
    assert_eq!(cropped.best_iteration, whole.best_iteration);
    assert!((cropped.best_score - whole.best_score).abs() < 1e-9);
}
