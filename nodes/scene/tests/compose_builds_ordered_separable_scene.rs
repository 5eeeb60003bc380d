//! `compose` turns a `[Model]` collection into a scene: background first, objects by id,
//! ids and labels from the item names (or model.json metadata), models unchanged.

mod common;

use objectsplat_core::ComponentKind;
use objectsplat_core::artifact::SCENE_JSON;
use objectsplat_raster::{load_model, save_model};
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
    let json = common::read_json(&scene_dir.join(SCENE_JSON));
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
    let run = common::run(
        &Compose,
        &[("models", &models)],
        "()",
        &tmp.path().join("out"),
    );
    let scene = load_scene(&run.outputs["scene"]).unwrap();
    assert_eq!(scene.objects[0].entry.name, "obj_7_desk_lamp");
    assert_eq!(scene.objects[0].entry.label.as_deref(), Some("desk lamp"));
    assert_eq!(scene.objects[0].entry.source, "component_a");
}

#[test]
fn unrecognised_item_names_and_duplicate_ids_are_errors() {
    let tmp = tempfile::tempdir().unwrap();
    // Grey squares, side by side, one per item name; `compose` must refuse the collection.
    let compose_error = |collection: &str, items: &[&str]| {
        let models = tmp.path().join(collection);
        for (i, item) in items.iter().enumerate() {
            let square = common::square([i as f32, 0.0, 0.0], 0.5, [0.5; 3]);
            save_model(&square, &models.join(item)).unwrap();
        }
        let out = tmp.path().join(collection).with_extension("out");
        common::run_error(&Compose, &[("models", &models)], "()", &out)
    };
    let err = compose_error("models", &["table"]);
    assert!(err.contains("\"table\""), "{err}");
    let err = compose_error("models2", &["obj_3_chair", "obj_3_stool"]);
    assert!(err.contains("object id 3"), "{err}");
}
