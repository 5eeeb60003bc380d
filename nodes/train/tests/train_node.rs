//! The `train` node reads a Component and Points and writes a loadable Model.

mod common;

use objectsplat_core::artifact::POINTS_PLY;
use objectsplat_core::{TRAINING_TIMES, TrainingTimes};
use objectsplat_runtime::testing::{NodeRun, run_node};
use objectsplat_train::node::TrainNode;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Every file of a folder (name → bytes).
fn folder_bytes(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            let name = e.file_name().to_string_lossy().into_owned();
            (name, std::fs::read(e.path()).unwrap())
        })
        .collect()
}

/// The node's two input folders, holding the plate, in a temporary folder that
/// also takes the outputs.
struct PlateInputs {
    dir: tempfile::TempDir,
    component: PathBuf,
    points: PathBuf,
}

impl PlateInputs {
    fn write() -> Self {
        let dir = tempfile::tempdir().unwrap();
        let component = dir.path().join("component");
        let points = dir.path().join("points");
        std::fs::create_dir_all(&component).unwrap();
        std::fs::create_dir_all(&points).unwrap();
        common::write_component(&component);
        common::points()
            .write_ply(&points.join(POINTS_PLY))
            .unwrap();
        PlateInputs {
            dir,
            component,
            points,
        }
    }

    /// Runs the node with `params`, writing under the folder `out`.
    fn train(&self, params: &str, out: &str) -> anyhow::Result<NodeRun> {
        let inputs = [
            ("component", self.component.as_path()),
            ("points", self.points.as_path()),
        ];
        run_node(
            &TrainNode,
            &inputs,
            params,
            &self.dir.path().join(out),
            None,
        )
    }

    /// The full error chain of a run that must fail.
    fn refusal(&self, params: &str, out: &str) -> String {
        let err = self.train(params, out).err().unwrap();
        format!("{err:#}")
    }
}

#[test]
fn train_node_writes_a_model_and_its_training_log() {
    let plate = PlateInputs::write();
    let run = plate
        .train(
            "(iterations: 30, seed: 1, schedule: {\"lr_sh_dc\": 0.03, \"patience\": 10})",
            "out",
        )
        .unwrap();
    let model = objectsplat_raster::load_model(&run.outputs["model"]).unwrap();
    assert!(model.face_count() > 0);
    // The training log travels with the model.
    let log = objectsplat_core::TrainingLog::load(&run.outputs["model"])
        .unwrap()
        .expect("training.json next to the model");
    assert_eq!(log.iterations_budget, 30);
    assert_eq!(log.final_faces, model.face_count());
    assert!(!log.steps.is_empty() && !log.evals.is_empty());
    // When training reached each step and evaluation is a measurement of the run, beside
    // the log's records, not in them.
    let times = TrainingTimes::from_json(&run.measurements[TRAINING_TIMES]).unwrap();
    let iterations = |points: &[(u64, f64)]| points.iter().map(|p| p.0).collect::<Vec<_>>();
    assert_eq!(
        iterations(&times.steps),
        log.steps.iter().map(|s| s.iteration).collect::<Vec<_>>()
    );
    assert_eq!(
        iterations(&times.evals),
        log.evals.iter().map(|e| e.iteration).collect::<Vec<_>>()
    );
    assert_eq!(times.iterations, log.iterations_run);
    let last = times.steps.iter().chain(&times.evals).map(|p| p.1);
    assert!(last.fold(0.0, f64::max) <= times.seconds);
    // So the model folder is a function of the inputs: a second run writes the same bytes.
    let again = plate
        .train(
            "(iterations: 30, seed: 1, schedule: {\"lr_sh_dc\": 0.03, \"patience\": 10})",
            "again",
        )
        .unwrap();
    assert_eq!(
        folder_bytes(&run.outputs["model"]),
        folder_bytes(&again.outputs["model"])
    );
    assert!(
        run.notes
            .iter()
            .any(|(k, v)| k == "backend" && v.contains("cpu"))
    );
    // Forcing wgpu runs on the adapter there is (lavapipe in CI) or fails saying why.
    match plate.train("(iterations: 30, backend: \"wgpu\")", "out2") {
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
    let err = plate.refusal("(iterations: 30, schedule: {\"no_such\": 1})", "out4");
    assert!(err.contains("no_such"), "{err}");
    // A component with no usable points is a clear error naming it.
    let empty = plate.dir.path().join("empty_points");
    std::fs::create_dir_all(&empty).unwrap();
    objectsplat_core::Points {
        positions: vec![[5.0, 5.0, 0.0]],
        colors: vec![[0, 0, 0]],
    }
    .write_ply(&empty.join(POINTS_PLY))
    .unwrap();
    let plate = PlateInputs {
        points: empty,
        ..plate
    };
    let err = plate.refusal("(iterations: 30)", "out3");
    assert!(err.contains("obj_1_plate"), "{err}");
}

#[test]
fn a_component_unseen_in_every_training_view_is_skipped_with_a_reason() {
    let plate = PlateInputs::write();
    // Give every pixel of every mask to other components.
    for entry in std::fs::read_dir(plate.component.join("masks")).unwrap() {
        let path = entry.unwrap().path();
        let img = image::open(&path).unwrap().to_luma8();
        let blank = image::GrayImage::new(img.width(), img.height());
        blank.save(&path).unwrap();
    }
    let run = plate.train("(iterations: 30)", "out").unwrap();
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

/// `components: "supports"` trains the objects surface completion completed
/// (`completion.json`), `"non_supports"` every other object.
#[test]
fn supports_are_the_completed_objects() {
    let plate = PlateInputs::write();
    let trains = |components: &str, out: &str| {
        let run = plate
            .train(
                &format!("(iterations: 30, components: \"{components}\")"),
                out,
            )
            .unwrap();
        match run.outcome {
            objectsplat_runtime::Outcome::Done => true,
            objectsplat_runtime::Outcome::Skipped(reason) => {
                assert!(reason.contains("not among the components"), "{reason}");
                false
            }
        }
    };
    assert!(!trains("supports", "a"));
    assert!(trains("non_supports", "b"));
    std::fs::write(plate.component.join("completion.json"), "{}").unwrap();
    assert!(trains("supports", "c"));
    assert!(!trains("non_supports", "d"));
    assert!(trains("objects", "e"));
}
