//! `export_gltf` writes one .glb node per member (named obj_<id>_<label>) and one PLY per
//! member; a duplicated object doubles its label's triangles, a removed one disappears
//! while the others keep their triangles.

// The composed scenes these tests export are built as the scene crate's tests build them.
#[path = "../../scene/tests/common/mod.rs"]
mod common;

use objectsplat_core::Mesh;
use objectsplat_core::artifact::SCENE_GLB;
use objectsplat_export::glb::triangles_per_node;
use objectsplat_export::nodes::ExportGltf;
use objectsplat_runtime::testing::run_node;
use std::collections::BTreeMap;
use std::path::Path;

fn export(scene: &Path, out: &Path) -> (BTreeMap<String, usize>, std::path::PathBuf) {
    let run = run_node(&ExportGltf, &[("scene", scene)], "()", out, None).unwrap();
    let dir = run.outputs["file"].clone();
    let glb = std::fs::read(dir.join(SCENE_GLB)).unwrap();
    (triangles_per_node(&glb).unwrap(), dir)
}

#[test]
fn duplicating_doubles_and_removing_drops_an_objects_triangles() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = common::composed_scene(tmp.path());
    let (base, dir) = export(&scene, &tmp.path().join("x0"));
    let want: BTreeMap<String, usize> = [
        ("background", 2),
        ("obj_3_chair", 2),
        ("obj_4_lamp", 2),
        ("obj_5_cup", 2),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect();
    assert_eq!(base, want);
    let ply = Mesh::read_ply(&dir.join("ply").join("obj_3_chair.ply")).unwrap();
    assert_eq!(ply.faces.len(), 2);
    let document = gltf::Gltf::from_slice(&std::fs::read(dir.join(SCENE_GLB)).unwrap()).unwrap();
    let chair = document
        .nodes()
        .find(|n| n.name() == Some("obj_3_chair"))
        .unwrap();
    let extras: serde_json::Value =
        serde_json::from_str(chair.extras().as_ref().unwrap().get()).unwrap();
    assert_eq!(extras["object_id"], 3);
    assert_eq!(extras["label"], "chair");

    let dup = common::edited(
        &scene,
        "[Duplicate(target: Label(\"lamp\"), offset: (0, 0, 1))]",
        &tmp.path().join("e1"),
    )
    .unwrap();
    let (doubled, _) = export(&dup, &tmp.path().join("x1"));
    let lamp_triangles = |m: &BTreeMap<String, usize>| -> usize {
        m.iter()
            .filter(|(k, _)| k.ends_with("_lamp"))
            .map(|(_, v)| v)
            .sum()
    };
    assert_eq!(lamp_triangles(&doubled), 2 * lamp_triangles(&base));
    assert_eq!(doubled["obj_6_lamp"], 2);

    let removed =
        common::edited(&scene, "[Remove(target: Id(5))]", &tmp.path().join("e2")).unwrap();
    let (after, dir) = export(&removed, &tmp.path().join("x2"));
    let mut expected = base.clone();
    expected.remove("obj_5_cup");
    assert_eq!(after, expected);
    assert!(!dir.join("ply").join("obj_5_cup.ply").exists());
}
