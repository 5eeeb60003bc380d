//! `register` adds the four scene nodes, and the registry accepts their specs
//! (known types, unique ports, defaults that parse and fit their types).

mod common;

#[test]
fn all_scene_nodes_register_with_checked_specs() {
    let reg = common::registry();
    let missing: Vec<&str> = ["compose", "load_scene", "edit_scene", "render"]
        .into_iter()
        .filter(|kind| reg.get(kind).is_none())
        .collect();
    assert!(missing.is_empty(), "{missing:?} missing");
    // Exporting is the export crate's.
    assert!(reg.get("export_gltf").is_none() && reg.get("viewer").is_none());
}
