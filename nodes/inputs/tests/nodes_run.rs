//! The dataflow nodes run on fixture inputs and write artifacts in the documented encodings.

use objectsplat_core::artifact::{OBJECTS_JSON, POINTS_PLY};
use objectsplat_core::{Frames, IdMap, Points, Split};
use objectsplat_inputs::nodes::{ColmapScene, ImportMasks, NerfstudioScene, ScannetppScene};
use objectsplat_runtime::Outcome;
use objectsplat_runtime::testing::run_node;

mod common;
use common::{fixture, node_error};

#[test]
fn register_declares_all_four_kinds_with_valid_specs() {
    let kinds = [
        "colmap_scene",
        "nerfstudio_scene",
        "scannetpp_scene",
        "import_masks",
    ];
    let reg = common::registry();
    for kind in kinds {
        assert!(reg.get(kind).is_some(), "{kind}");
    }
}

#[test]
fn colmap_scene_writes_frames_and_points() {
    let params = common::params_with_images(
        &fixture("colmap/rig_bin"),
        &fixture("colmap/images"),
        ", split: \"dense\", max_width: Some(32)",
    );
    let (_out, run) = common::run_source(&ColmapScene, &params);
    assert_eq!(run.outcome, Outcome::Done);
    let frames = Frames::read(&run.outputs["frames"]).unwrap();
    assert_eq!(frames.frames.len(), 6);
    assert_eq!(frames.by_split(Split::Test).count(), 1);
    assert!(
        frames
            .frames
            .iter()
            .all(|f| (f.camera.width, f.camera.height) == (32, 24))
    );
    let pts = Points::read_ply(&run.outputs["points"].join(POINTS_PLY)).unwrap();
    assert_eq!(pts.positions.len(), 6);
    assert!(
        run.notes
            .iter()
            .any(|(k, v)| k == "layout" && v == "rigs/frames")
    );
}

#[test]
fn import_masks_writes_id_maps_and_reports_objects() {
    let out = tempfile::tempdir().unwrap();
    let params = format!(
        "(path: {:?}, format: \"grounded_sam2\")",
        fixture("masks/gsam").display().to_string()
    );
    let run = run_node(
        &ImportMasks,
        &[("frames", &fixture("masks/frames"))],
        &params,
        out.path(),
        None,
    )
    .unwrap();
    let dir = &run.outputs["masks"];
    let map = IdMap::load(&dir.join("f001.png")).unwrap();
    assert_eq!((map.width, map.height), (16, 12));
    assert!(
        map.data.iter().all(|&v| v == 0 || v == 2),
        "frame f001 has only the chair"
    );
    assert_eq!(objectsplat_core::masks::read_objects(dir).unwrap().len(), 2);
    let line = &run.notes.iter().find(|(k, _)| k == "object 1").unwrap().1;
    assert!(line.starts_with("lamp: in 2/3 frames"), "{line}");
}

#[test]
fn bad_params_are_errors_not_panics() {
    let cases: [(&dyn objectsplat_runtime::Node, &str, &str); 3] = [
        (
            &NerfstudioScene,
            "(path: \"/nonexistent/transforms.json\")",
            "/nonexistent/transforms.json: cannot read",
        ),
        (
            &ScannetppScene,
            "(path: \"/nonexistent\", overlap: \"biggest\")",
            "biggest",
        ),
        (
            &ColmapScene,
            "(path: \"/nonexistent\", resolution: 0)",
            "resolution",
        ),
    ];
    for (node, params, want) in cases {
        let e = node_error(node, &[], params);
        assert!(e.contains(want), "{e}");
    }
}

#[test]
fn import_masks_reads_a_wired_source_or_a_path_never_both() {
    let gsam = fixture("masks/gsam");
    let frames = fixture("masks/frames");
    let from_path = tempfile::tempdir().unwrap();
    let params = format!(
        "(path: {:?}, format: \"grounded_sam2\")",
        gsam.display().to_string()
    );
    run_node(
        &ImportMasks,
        &[("frames", &frames)],
        &params,
        from_path.path(),
        None,
    )
    .unwrap();
    let from_source = tempfile::tempdir().unwrap();
    run_node(
        &ImportMasks,
        &[("frames", &frames), ("source", &gsam)],
        "(format: \"grounded_sam2\")",
        from_source.path(),
        None,
    )
    .unwrap();
    for f in ["f000.png", "f001.png", OBJECTS_JSON] {
        assert_eq!(
            std::fs::read(from_path.path().join("masks").join(f)).unwrap(),
            std::fs::read(from_source.path().join("masks").join(f)).unwrap(),
            "{f}"
        );
    }
    let both = node_error(
        &ImportMasks,
        &[("frames", &frames), ("source", &gsam)],
        &params,
    );
    assert!(both.contains("both the `source` input and `path`"));
    let neither = node_error(&ImportMasks, &[("frames", &frames)], "(format: \"davis\")");
    assert!(neither.contains("no masks: set `path`"));
}
