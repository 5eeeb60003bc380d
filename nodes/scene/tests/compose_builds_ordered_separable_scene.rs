//! `compose` turns a `[Model]` collection into a scene: background first, objects by id,
//! ids and labels from the item names (or model.json metadata), models unchanged.

mod common;

use objectsplat_core::ComponentKind;
use objectsplat_core::artifact::SCENE_JSON;
use objectsplat_raster::{load_model, save_model};
use objectsplat_runtime::testing::run_node;
use objectsplat_scene::load_scene;
use objectsplat_scene::nodes::Compose;

#[test]
fn members_are_ordered_named_and_keep_their_models() {
    let tmp = tempfile::tempdir().unwrap();
    let scene_dir = common::composed_scene(tmp.path());
    let scene = load_scene(&scene_dir).unwrap();
    let names: Vec<&str> = scene
        .objects
        .iter()
        .map(|o| o.entry.name.as_str())
        .collect();
    assert_eq!(
        names,
        ["background", "obj_3_chair", "obj_4_lamp", "obj_5_cup"]
    );
    assert_eq!(scene.objects[0].entry.kind, ComponentKind::Background);
    assert_eq!(scene.objects[0].entry.id, None);
    assert_eq!(scene.objects[1].entry.id, Some(3));
    assert_eq!(scene.objects[1].entry.label.as_deref(), Some("chair"));
    assert_eq!(scene.objects[3].entry.source, "obj_5_cup");
    // No re-optimization: each member's model is the trained one, bit for bit.
    for o in &scene.objects {
        let trained = load_model(&tmp.path().join("models").join(&o.entry.source)).unwrap();
        assert_eq!(o.model, trained, "{}", o.entry.name);
    }
    // The union renders all triangles.
    let merged = scene.merged_model().unwrap();
    assert_eq!(merged.model.face_count(), 8);
    assert_eq!(merged.face_owner, [0, 0, 1, 1, 2, 2, 3, 3]);
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(scene_dir.join(SCENE_JSON)).unwrap())
            .unwrap();
    assert_eq!(json["objects"][1]["label"], "chair");
    assert_eq!(json["objects"][0]["kind"], "background");
}

#[test]
fn metadata_component_overrides_the_item_name() {
    let tmp = tempfile::tempdir().unwrap();
    let models = tmp.path().join("models");
    let mut m = common::square([0.0, 0.0, 0.0], 0.5, [0.5, 0.5, 0.5]);
    m.metadata.insert(
        "component".into(),
        serde_json::json!({"name": "obj_7_desk_lamp", "kind": "object", "object_id": 7, "label": "desk lamp"}),
    );
    save_model(&m, &models.join("component_a")).unwrap();
    let run = run_node(
        &Compose,
        &[("models", &models)],
        "()",
        &tmp.path().join("out"),
        None,
    )
    .unwrap();
    let scene = load_scene(&run.outputs["scene"]).unwrap();
    assert_eq!(scene.objects[0].entry.name, "obj_7_desk_lamp");
    assert_eq!(scene.objects[0].entry.label.as_deref(), Some("desk lamp"));
    assert_eq!(scene.objects[0].entry.source, "component_a");
}

#[test]
fn unrecognised_item_names_and_duplicate_ids_are_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let models = tmp.path().join("models");
    save_model(
        &common::square([0.0; 3], 0.5, [0.5; 3]),
        &models.join("table"),
    )
    .unwrap();
    let err = run_node(
        &Compose,
        &[("models", &models)],
        "()",
        &tmp.path().join("a"),
        None,
    )
    .err()
    .unwrap();
    assert!(format!("{err:#}").contains("\"table\""), "{err:#}");

    let models = tmp.path().join("models2");
    save_model(
        &common::square([0.0; 3], 0.5, [0.5; 3]),
        &models.join("obj_3_chair"),
    )
    .unwrap();
    save_model(
        &common::square([1.0, 0.0, 0.0], 0.5, [0.5; 3]),
        &models.join("obj_3_stool"),
    )
    .unwrap();
    let err = run_node(
        &Compose,
        &[("models", &models)],
        "()",
        &tmp.path().join("b"),
        None,
    )
    .err()
    .unwrap();
    assert!(format!("{err:#}").contains("object id 3"), "{err:#}");
}
