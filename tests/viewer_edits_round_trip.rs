//! Edits done in the viewer page round-trip exactly through the graph: the page's
//! exported RON, fed back with `objectsplat run --set edited.edits=…`, gives a `.glb`
//! whose node for every member carries the transform the page shows (f32-exact), the
//! same members, and the recolored colours.
//!
//! The graph's `edit_scene` already has an edit, so the page starts from an edited scene
//! and its exported list must carry that earlier edit too.

mod support;

use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::path::Path;
use support::chromium::{Browser, numbers, strings};
use support::objectsplat::{assert_ok, objectsplat};

const GRAPH: &str = r#"(
  nodes: {
    "base":   (kind: "load_scene", params: (path: "scene")),
    "edited": (kind: "edit_scene", inputs: (scene: "base.scene"),
               params: (edits: [Move(target: Label("cup"), by: (0.1, -0.05, 0))])),
    "glb":    (kind: "export_gltf", inputs: (scene: "edited.scene")),
    "viewer": (kind: "viewer", inputs: (scene: "edited.scene")),
  },
  targets: ["glb", "viewer"],
)"#;

fn run(dir: &Path, extra: &[&str]) {
    let mut args = vec!["run", "graph.ron", "--cache", "cache", "--out", "out"];
    args.extend(extra);
    assert_ok(&objectsplat(dir, &args), "objectsplat run");
}

type Trs = ([f32; 3], [f32; 4], [f32; 3]);

/// Each child of the root node: its transform and its first vertex colour.
fn glb_nodes(path: &Path) -> BTreeMap<String, (Trs, [f32; 3])> {
    let doc = gltf::Gltf::from_slice(&std::fs::read(path).unwrap()).unwrap();
    let blob = doc.blob.as_deref().unwrap();
    let root = doc.default_scene().unwrap().nodes().next().unwrap();
    root.children()
        .map(|node| {
            let mesh = node.mesh().unwrap();
            let primitive = mesh.primitives().next().unwrap();
            let reader = primitive.reader(|_| Some(blob));
            let colour = reader
                .read_colors(0)
                .unwrap()
                .into_rgb_f32()
                .next()
                .unwrap();
            (
                node.name().unwrap().to_string(),
                (node.transform().decomposed(), colour),
            )
        })
        .collect()
}

fn f32s<const N: usize>(v: &Value) -> [f32; N] {
    numbers::<N>(v).map(|x| x as f32)
}

#[test]
fn exported_edits_rebuild_the_same_node_transforms() {
    let Some(mut browser) = Browser::launch("exported_edits_rebuild_the_same_node_transforms")
    else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    support::small_scene::write(&dir.join("scene"));
    std::fs::write(dir.join("graph.ron"), GRAPH).unwrap();
    run(dir, &[]);
    let page_path = dir.join("out/viewer/file/index.html");
    let mut page = browser.open(&page_path, 900, 600);
    page.eval("window.objectsplat.ready");
    for edit in [
        json!({"op": "move", "target": "obj_7_desk_lamp", "by": [0.123456789, -0.3, 0.05]}),
        json!({"op": "rotate", "target": "obj_7_desk_lamp", "axis": [1, 2, 3], "degrees": 33.3}),
        json!({"op": "scale", "target": "obj_7_desk_lamp", "factor": 0.7}),
        json!({"op": "rotate", "target": "obj_3_chair", "axis": [0, 0, 1], "degrees": -72.5}),
        json!({"op": "duplicate", "target": "obj_7_desk_lamp", "offset": [0.4, 0.1, 0]}),
        json!({"op": "rotate", "target": "obj_8_desk_lamp", "axis": [0, 1, 0], "degrees": 90}),
        json!({"op": "move", "target": "obj_5_cup", "by": [1e-7, 2.5e-3, 0]}),
        json!({"op": "scale", "target": "background", "factor": 1.1}),
        json!({"op": "recolor", "target": "obj_3_chair", "rgb": [0.9, 0.5, 0.1]}),
        json!({"op": "duplicate", "target": "obj_5_cup", "offset": [-0.2, 0, 0.3]}),
        json!({"op": "remove", "target": "obj_9_cup"}),
    ] {
        page.eval(&format!("window.objectsplat.apply({edit})"));
    }
    // One edit by hand as well: pick the lamp copy in the panel's list, turn it with a key.
    page.eval("[...document.querySelectorAll('.osv-item')].find(li => li.textContent.includes('obj_8_desk_lamp')).click()");
    page.key("e", "KeyE", 69);
    let edits = page.eval("window.objectsplat.edits()");
    let edits = edits.as_str().unwrap().to_string();
    assert!(
        edits.ends_with(
            "    Rotate(target: Name(\"obj_8_desk_lamp\"), axis: (0, 0, 1), degrees: -15),\n]"
        ),
        "{edits}"
    );
    assert!(
        edits.starts_with("[\n    Move(target: Label(\"cup\"), by: (0.1, -0.05, 0)),\n"),
        "the scene's own edit comes first: {edits}"
    );
    let names = strings(&page.eval("window.objectsplat.objects().map(o => o.name)"));
    let mut shown = BTreeMap::new();
    for name in &names {
        let t = page.eval(&format!("window.objectsplat.transform({name:?})"));
        let scale = t["scale"].as_f64().unwrap() as f32;
        shown.insert(
            name.clone(),
            (
                f32s::<3>(&t["translation"]),
                f32s::<4>(&t["rotation"]),
                [scale; 3],
            ),
        );
    }
    page.eval("1");
    assert!(page.errors().is_empty(), "{:#?}", page.errors());

    run(dir, &["--set", &format!("edited.edits={edits}")]);
    let nodes = glb_nodes(&dir.join("out/glb/file/scene.glb"));
    assert_eq!(
        nodes.keys().collect::<Vec<_>>(),
        shown.keys().collect::<Vec<_>>(),
        "the same members"
    );
    for (name, trs) in &shown {
        assert_eq!(&nodes[name].0, trs, "node {name}: .glb vs page");
    }
    // Independent of the page: the cup moved by the graph's edit plus the page's.
    let cup = objectsplat_scene::scene::model_centroid(&support::small_scene::cuboid(
        support::small_scene::BOXES[1].2,
        support::small_scene::BOXES[1].3,
        [0.0; 3],
    ));
    let want = [cup[0] + 0.1 + 1e-7, cup[1] - 0.05 + 2.5e-3, cup[2]].map(|v| v as f32);
    assert_eq!(nodes["obj_5_cup"].0.0, want);
    // The recolor reached the .glb: linear values of sRGB (0.9, 0.5, 0.1).
    let chair = nodes["obj_3_chair"].1;
    let linear = [0.787_412_3, 0.214_041_14, 0.010_022_93];
    for k in 0..3 {
        assert!((chair[k] - linear[k]).abs() < 1e-5, "{chair:?}");
    }
}
