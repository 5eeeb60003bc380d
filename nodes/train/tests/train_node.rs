//! The `train` node reads a Component and Points and writes a loadable Model.

mod common;

use objectsplat_core::artifact::POINTS_PLY;
use objectsplat_runtime::testing::run_node;
use objectsplat_train::node::TrainNode;

#[test]
fn train_node_writes_a_model_and_its_training_log() {
    let dir = tempfile::tempdir().unwrap();
    let component = dir.path().join("component");
    let points = dir.path().join("points");
    std::fs::create_dir_all(&component).unwrap();
    std::fs::create_dir_all(&points).unwrap();
    common::write_component(&component);
    common::points()
        .write_ply(&points.join(POINTS_PLY))
        .unwrap();
    let inputs = [
        ("component", component.as_path()),
        ("points", points.as_path()),
    ];
    let out = dir.path().join("out");
    let run = run_node(
        &TrainNode,
        &inputs,
        "(iterations: 30, seed: 1, schedule: {\"lr_sh_dc\": 0.03, \"patience\": 10})",
        &out,
        None,
    )
    .unwrap();
    let model = objectsplat_raster::load_model(&run.outputs["model"]).unwrap();
    assert!(model.face_count() > 0);
    // The training log travels with the model.
    let log = objectsplat_raster::TrainingLog::load(&run.outputs["model"])
        .unwrap()
        .expect("training.json next to the model");
    assert_eq!(log.iterations_budget, 30);
    assert_eq!(log.final_faces, model.face_count());
    assert!(!log.steps.is_empty() && !log.evals.is_empty());
    assert!(
        run.notes
            .iter()
            .any(|(k, v)| k == "backend" && v.contains("cpu"))
    );
    // Forcing wgpu runs on the adapter there is (lavapipe in CI) or fails saying why.
    match run_node(
        &TrainNode,
        &inputs,
        "(iterations: 30, backend: \"wgpu\")",
        &dir.path().join("out2"),
        None,
    ) {
        Ok(run) => assert!(
            run.notes
                .iter()
                .any(|(k, v)| k == "backend" && v.starts_with("wgpu on ")),
            "{:?}",
            run.notes
        ),
        Err(err) => assert!(format!("{err:#}").contains("no usable adapter"), "{err:#}"),
    }
    // Unknown schedule settings are refused by name.
    let err = run_node(
        &TrainNode,
        &inputs,
        "(iterations: 30, schedule: {\"no_such\": 1})",
        &dir.path().join("out4"),
        None,
    )
    .err()
    .unwrap();
    assert!(format!("{err:#}").contains("no_such"), "{err:#}");
    // A component with no usable points is a clear error naming it.
    let empty = dir.path().join("empty_points");
    std::fs::create_dir_all(&empty).unwrap();
    objectsplat_core::Points {
        positions: vec![[5.0, 5.0, 0.0]],
        colors: vec![[0, 0, 0]],
    }
    .write_ply(&empty.join(POINTS_PLY))
    .unwrap();
    let inputs = [
        ("component", component.as_path()),
        ("points", empty.as_path()),
    ];
    let err = run_node(
        &TrainNode,
        &inputs,
        "(iterations: 30)",
        &dir.path().join("out3"),
        None,
    )
    .err()
    .unwrap();
    assert!(format!("{err:#}").contains("obj_1_plate"), "{err:#}");
}

#[test]
fn a_component_unseen_in_every_training_view_is_skipped_with_a_reason() {
    let dir = tempfile::tempdir().unwrap();
    let component = dir.path().join("component");
    let points = dir.path().join("points");
    std::fs::create_dir_all(&component).unwrap();
    std::fs::create_dir_all(&points).unwrap();
    common::write_component(&component);
    common::points()
        .write_ply(&points.join(POINTS_PLY))
        .unwrap();
    // Give every pixel of every mask to other components.
    for entry in std::fs::read_dir(component.join("masks")).unwrap() {
        let path = entry.unwrap().path();
        let img = image::open(&path).unwrap().to_luma8();
        let blank = image::GrayImage::new(img.width(), img.height());
        blank.save(&path).unwrap();
    }
    let inputs = [
        ("component", component.as_path()),
        ("points", points.as_path()),
    ];
    let run = run_node(
        &TrainNode,
        &inputs,
        "(iterations: 30)",
        &dir.path().join("out"),
        None,
    )
    .unwrap();
    match run.outcome {
        objectsplat_runtime::Outcome::Skipped(reason) => {
            assert!(
                reason.contains("obj_1_plate") && reason.contains("no pixel in any training view"),
                "{reason}"
            )
        }
        other => panic!("expected a skip, got {other:?}"),
    }
}
