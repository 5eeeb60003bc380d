//! `register` adds the seven scene nodes, and the registry accepts their specs
//! (known types, unique ports, defaults that parse and fit their types).

use objectsplat_runtime::Registry;

#[test]
fn all_scene_nodes_register_with_checked_specs() {
    let mut reg = Registry::new();
    for t in [
        "Model", "Scene", "Images", "Frames", "Mesh", "Masks", "Metrics", "File",
    ] {
        reg.add_type(t, "test type");
    }
    objectsplat_scene::register(&mut reg);
    for kind in [
        "compose",
        "load_scene",
        "edit_scene",
        "render",
        "evaluate",
        "export_gltf",
        "viewer",
    ] {
        assert!(reg.get(kind).is_some(), "{kind} missing");
    }
}
