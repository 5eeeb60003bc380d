//! The node wrappers end to end: synthetic_scene → gt_masks → partition, through the
//! runtime's single-node runner, checking the documented encodings on disk.

use objectsplat_core::artifact::{COMPONENT_JSON, OBJECTS_JSON, POINTS_PLY};
use objectsplat_core::component::{OTHER, OWN};
use objectsplat_core::masks::read_objects;
use objectsplat_core::{ComponentInfo, ComponentKind, Frames, IdMap, Image, read_mesh_artifact};
use objectsplat_masks::nodes::{GtMasksNode, PartitionNode};
use objectsplat_runtime::testing::{NodeRun, run_node};
use objectsplat_runtime::{Node, Registry};
use objectsplat_synth::nodes::SyntheticSceneNode;
use std::path::Path;

/// A temporary folder that takes the outputs of each node run.
struct Workspace(tempfile::TempDir);

impl Workspace {
    fn new() -> Self {
        Workspace(tempfile::tempdir().unwrap())
    }

    /// Runs `node`, writing its outputs under the folder `out`; it must succeed.
    fn run(&self, node: &dyn Node, inputs: &[(&str, &Path)], params: &str, out: &str) -> NodeRun {
        run_node(node, inputs, params, &self.0.path().join(out), None).unwrap()
    }
}

fn component_dirs(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn register_adds_the_four_kinds() {
    let mut reg = Registry::new();
    for t in [
        "Frames",
        "Mesh",
        "Points",
        "Masks",
        "Component",
        "Visibility",
    ] {
        reg.add_type(t, "test");
    }
    objectsplat_synth::register(&mut reg);
    objectsplat_masks::register(&mut reg);
    for kind in [
        "synthetic_scene",
        "gt_masks",
        "partition",
        "point_visibility",
    ] {
        assert!(reg.get(kind).is_some(), "{kind}");
    }
}

#[test]
fn scene_masks_and_partition_chain_through_folders() {
    let work = Workspace::new();
    let scene_params = "(views: 9, width: 96, height: 72, resolution: 1, max_width: Some(48), points: 200, split: \"sparse\")";
    let scene = work.run(&SyntheticSceneNode, &[], scene_params, "scene");
    let (frames_dir, mesh_dir) = (&scene.outputs["frames"], &scene.outputs["mesh"]);
    let frames = Frames::read(frames_dir).unwrap();
    assert_eq!(frames.frames.len(), 9);
    assert_eq!(frames.load_rgb(&frames.frames[0]).unwrap().width, 48);
    let (mesh, labels) = read_mesh_artifact(mesh_dir).unwrap();
    assert!(mesh.faces.len() > 1000 && labels.len() >= 9);
    let points =
        objectsplat_core::Points::read_ply(&scene.outputs["points"].join(POINTS_PLY)).unwrap();
    assert_eq!(points.positions.len(), 200);

    let frames_and_mesh = [("frames", frames_dir.as_path()), ("mesh", mesh_dir)];
    let every_object = "(min_pixels: Some(0))";
    let masks = work.run(&GtMasksNode, &frames_and_mesh, every_object, "masks");
    let masks_dir = &masks.outputs["masks"];
    let objects = read_objects(masks_dir).unwrap();
    assert!(objects.values().any(|l| l == "table") && !objects.values().any(|l| l == "wall"));
    for f in &frames.frames {
        let m = IdMap::load(&masks_dir.join(format!("{}.png", f.name))).unwrap();
        assert_eq!((m.width, m.height), (48, 36));
    }

    let frames_and_masks = [("frames", frames_dir.as_path()), ("masks", masks_dir)];
    let any_pixel = "(min_pixels: Some(1))";
    let parts = work.run(&PartitionNode, &frames_and_masks, any_pixel, "parts");
    let out = &parts.outputs["components"];
    let names = component_dirs(out);
    assert!(names.contains(&"background".to_string()));
    for (id, label) in &objects {
        assert!(names.contains(&format!("obj_{id}_{label}")), "{names:?}");
    }
    // Per frame, exactly one component owns each pixel.
    for f in &frames.frames {
        let mut owners = vec![0u32; 48 * 36];
        for name in &names {
            let info: ComponentInfo = serde_json::from_str(
                &std::fs::read_to_string(out.join(name).join(COMPONENT_JSON)).unwrap(),
            )
            .unwrap();
            assert_eq!(info.kind == ComponentKind::Background, name == "background");
            let comp_frames = Frames::read(&out.join(name)).unwrap();
            let Some(cf) = comp_frames.frames.iter().find(|g| g.name == f.name) else {
                continue;
            };
            assert_eq!(cf.split, f.split);
            assert_eq!(
                comp_frames.load_rgb(cf).unwrap(),
                frames.load_rgb(f).unwrap()
            );
            let mask = Image::load(&out.join(name).join(format!("masks/{}.png", f.name))).unwrap();
            for (o, v) in owners.iter_mut().zip(&mask.data) {
                let v = (v * 255.0).round() as u8;
                assert!(v == OWN || v == OTHER);
                *o += u32::from(v == OWN);
            }
        }
        assert!(owners.iter().all(|&n| n == 1), "frame {}", f.name);
    }

    let holistic = work.run(
        &PartitionNode,
        &frames_and_masks,
        "(holistic: true)",
        "holistic",
    );
    let out = &holistic.outputs["components"];
    assert_eq!(component_dirs(out), vec!["scene".to_string()]);
    let mask = Image::load(&out.join("scene/masks/frame_000.png")).unwrap();
    assert!(mask.data.iter().all(|&v| v == 1.0));
    assert_eq!(Frames::read(&out.join("scene")).unwrap().frames.len(), 9);
}

#[test]
fn node_errors_name_the_file() {
    let work = Workspace::new();
    let scene_params = "(views: 4, width: 16, height: 12, points: 10)";
    let scene = work.run(&SyntheticSceneNode, &[], scene_params, "scene");
    let err = run_node(
        &GtMasksNode,
        &[
            ("frames", &scene.outputs["frames"]),
            ("mesh", &scene.outputs["mesh"]),
        ],
        "(keep_labels: [\"sofa\"])",
        &work.0.path().join("masks"),
        None,
    )
    .err()
    .expect("an unknown label is an error")
    .to_string();
    assert!(
        err.contains(OBJECTS_JSON) && err.contains("\"sofa\""),
        "{err}"
    );
}
