//! `register` adds `export_gltf` and `viewer` beside the scene's nodes, and the registry
//! accepts their specs (known types, unique ports, defaults that parse and fit their types).

#[path = "../../scene/tests/common/mod.rs"]
mod common;

#[test]
fn both_export_nodes_register_with_checked_specs() {
    let mut reg = common::registry();
    assert!(reg.get("export_gltf").is_none());
    objectsplat_export::register(&mut reg);
    for kind in ["export_gltf", "viewer"] {
        assert!(reg.get(kind).is_some(), "{kind} missing");
    }
}
