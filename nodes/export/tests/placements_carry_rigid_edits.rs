//! Rigid edits become placements: the models stay byte-identical and scene.json gains a
//! `placement` per edited member (pivot on the centroid, the analytic translation,
//! rotation and scale) plus the record of the edits; a scene without placements (every
//! scene written before them) loads and places its models exactly where they are; the
//! record replays to the same scene; `export_gltf` writes each placement as the node's
//! transform with the vertices relative to the pivot, and the PLYs in the world.

// The composed scenes these tests export are built as the scene crate's tests build them.
#[path = "../../scene/tests/common/mod.rs"]
mod common;

use objectsplat_core::Mesh;
use objectsplat_core::artifact::{MODEL_JSON, MODEL_PLY, SCENE_GLB, SCENE_JSON};
use objectsplat_export::Placement;
use objectsplat_export::nodes::ExportGltf;
use objectsplat_scene::{Scene, load_scene};
use serde_json::Value;
use std::path::Path;

const EDITS: &str = "[Move(target: Id(3), by: (0.5, 0, -1)), Rotate(target: Label(\"lamp\"), axis: (0, 0, 2), degrees: 90), Scale(target: Name(\"obj_5_cup\"), factor: 2), Duplicate(target: Id(4), offset: (0, 1, 0))]";

fn scene_json(dir: &Path) -> Value {
    common::read_json(&dir.join(SCENE_JSON))
}

fn placement(json: &Value, name: &str) -> Option<Placement> {
    let entry = json["objects"]
        .as_array()
        .unwrap()
        .iter()
        .find(|o| o["name"] == name)
        .unwrap();
    entry
        .get("placement")
        .map(|p| serde_json::from_value(p.clone()).unwrap())
}

#[test]
fn rigid_edits_change_placements_not_models() {
    let (_tmp, before, after) = common::composed_and_edited(EDITS);
    let old = common::files(&before.join("objects"));
    let new = common::files(&after.join("objects"));
    for (path, bytes) in &old {
        assert_eq!(&new[path], bytes, "{path} was rewritten");
    }
    // The copy's model is the lamp's, byte for byte.
    for file in [MODEL_PLY, MODEL_JSON] {
        assert_eq!(
            new[&format!("obj_6_lamp/{file}")],
            old[&format!("obj_4_lamp/{file}")]
        );
    }

    let json = scene_json(&after);
    assert_eq!(
        placement(&json, "background"),
        None,
        "unedited: no placement"
    );
    // Squares of common::write_models: chair centred at (−0.6, 0, 0), lamp at (0, 0.5, 0.6), cup at (0.6, 0, 0).
    let chair = placement(&json, "obj_3_chair").unwrap();
    assert_eq!(chair.pivot, [-0.6f32 as f64, 0.0, 0.0]);
    assert_eq!(chair.translation, [-0.6f32 as f64 + 0.5, 0.0, -1.0]);
    assert_eq!((chair.rotation, chair.scale), ([0.0, 0.0, 0.0, 1.0], 1.0));
    let lamp = placement(&json, "obj_4_lamp").unwrap();
    let half = std::f64::consts::FRAC_1_SQRT_2;
    assert!((lamp.rotation[2] - half).abs() < 1e-15 && (lamp.rotation[3] - half).abs() < 1e-15);
    assert_eq!(
        lamp.translation, lamp.pivot,
        "a rotation turns about the pivot"
    );
    let cup = placement(&json, "obj_5_cup").unwrap();
    assert_eq!((cup.scale, cup.translation), (2.0, cup.pivot));
    let copy = placement(&json, "obj_6_lamp").unwrap();
    assert_eq!(copy.rotation, lamp.rotation);
    assert_eq!(
        copy.translation,
        [
            lamp.translation[0],
            lamp.translation[1] + 1.0,
            lamp.translation[2]
        ]
    );
    assert_eq!(
        json["edits"],
        serde_json::json!([
            "Move(target: Id(3), by: (0.5, 0, -1))",
            "Rotate(target: Label(\"lamp\"), axis: (0, 0, 2), degrees: 90)",
            "Scale(target: Name(\"obj_5_cup\"), factor: 2)",
            "Duplicate(target: Id(4), offset: (0, 1, 0))",
        ])
    );
}

#[test]
fn scenes_without_placements_read_as_before() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = common::composed_scene(tmp.path());
    let json = scene_json(&dir);
    assert!(json.get("edits").is_none(), "{json}");
    for o in json["objects"].as_array().unwrap() {
        let keys: Vec<&String> = o.as_object().unwrap().keys().collect();
        assert_eq!(keys, ["id", "kind", "label", "name", "source"], "{o}");
    }
    // The merged model (what render and evaluate draw) is the models as stored, bit for bit.
    let scene = load_scene(&dir).unwrap();
    let merged = scene.merged_model().unwrap().model;
    let stored: Vec<[f32; 3]> = scene
        .objects
        .iter()
        .flat_map(|o| o.model.vertices.clone())
        .collect();
    assert_eq!(merged.vertices, stored);
}

#[test]
fn the_edit_record_replays_to_the_same_scene() {
    let tmp = tempfile::tempdir().unwrap();
    let composed = common::composed_scene(tmp.path());
    let once = common::edited(&composed, EDITS, &tmp.path().join("a")).unwrap();
    let twice = common::edited(
        &once,
        "[Rotate(target: Id(6), axis: (1, 1, 0), degrees: 30), Remove(target: Id(5))]",
        &tmp.path().join("b"),
    )
    .unwrap();
    let record: Vec<String> = serde_json::from_value(scene_json(&twice)["edits"].clone()).unwrap();
    assert_eq!(record.len(), 6);
    let replayed = common::edited(
        &composed,
        &format!("[{}]", record.join(", ")),
        &tmp.path().join("c"),
    )
    .unwrap();
    assert_eq!(common::files(&replayed), common::files(&twice));
}

#[test]
fn export_writes_placements_as_node_transforms() {
    let (tmp, _, edited) = common::composed_and_edited(EDITS);
    let scene: Scene = load_scene(&edited).unwrap();
    let run = common::run(
        &ExportGltf,
        &[("scene", &edited)],
        "()",
        &tmp.path().join("x"),
    );
    let dir = &run.outputs["file"];
    let doc = gltf::Gltf::from_slice(&std::fs::read(dir.join(SCENE_GLB)).unwrap()).unwrap();
    let blob = doc.blob.as_deref().unwrap();
    for o in &scene.objects {
        let node = doc
            .nodes()
            .find(|n| n.name() == Some(&o.entry.name))
            .unwrap();
        assert_eq!(
            node.transform().decomposed(),
            o.placement().node_trs(),
            "{}",
            o.entry.name
        );
        let primitive = node.mesh().unwrap().primitives().next().unwrap();
        let local: Vec<[f32; 3]> = primitive
            .reader(|_| Some(blob))
            .read_positions()
            .unwrap()
            .collect();
        // Vertices are relative to the pivot (the centroid): the node's origin is the object's centre.
        for k in 0..3 {
            let mean = local.iter().map(|p| p[k] as f64).sum::<f64>() / local.len() as f64;
            assert!(mean.abs() < 1e-6, "{}: mean {mean}", o.entry.name);
        }
        // Node transform ∘ local vertex = the member's world vertex.
        let m = node.transform().matrix();
        let world = o.world_model().unwrap();
        for p in &local {
            let w: Vec<f32> = (0..3)
                .map(|r| m[0][r] * p[0] + m[1][r] * p[1] + m[2][r] * p[2] + m[3][r])
                .collect();
            assert!(
                world
                    .vertices
                    .iter()
                    .any(|q| (0..3).all(|k| (q[k] - w[k]).abs() < 1e-5)),
                "{}: {w:?} is none of the world vertices",
                o.entry.name
            );
        }
        // The PLY is in the world frame, bit for bit the placed model.
        let ply = Mesh::read_ply(&dir.join("ply").join(format!("{}.ply", o.entry.name))).unwrap();
        let mut ply_points = ply.positions.clone();
        let mut want = world.vertices.clone();
        ply_points.sort_by(|a, b| a.partial_cmp(b).unwrap());
        want.sort_by(|a, b| a.partial_cmp(b).unwrap());
        assert_eq!(ply_points, want, "{}", o.entry.name);
    }
    // The unedited background's node only carries its centre.
    let background = doc
        .nodes()
        .find(|n| n.name() == Some("background"))
        .unwrap();
    let (t, r, s) = background.transform().decomposed();
    assert_eq!((t, r, s), ([0.0, 3.0, 0.0], [0.0, 0.0, 0.0, 1.0], [1.0; 3]));
}
