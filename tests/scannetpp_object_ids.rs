//! The object ids of a ScanNet++ annotation (its `objectId`s, sparse and up to the
//! 16-bit limit) reach every consumer unchanged: the mesh, the gt_masks pixels and
//! objects.json, the partition's components, the composed scene, the metrics and the
//! glTF node names; a background label stays 0. A tiny scene built here in the ScanNet++
//! layout runs through `objectsplat run` (training 30 iterations per component).

use objectsplat_core::glam::{DMat4, DVec3};
use objectsplat_core::{Camera, Image, Mesh};
use serde_json::{Value, json};
use std::collections::BTreeSet;
use std::path::Path;

mod support;
use support::objectsplat::{assert_ok, objectsplat, read_json};

/// (objectId, label, lower corner, upper corner); the floor is a background label.
const OBJECTS: [(i64, &str, [f32; 3], [f32; 3]); 3] = [
    (3, "table", [-0.9, -0.5, 0.0], [-0.1, 0.3, 0.5]),
    (40000, "cup", [0.3, -0.6, 0.0], [0.8, -0.1, 0.4]),
    (65534, "chair", [0.2, 0.3, 0.0], [0.8, 0.9, 0.6]),
];
const FLOOR_ID: i64 = 1;
const VIEWS: usize = 8;
const W: u32 = 32;
const H: u32 = 24;

fn mesh() -> (Mesh, Vec<i64>) {
    let mut positions = vec![
        [-2.0, -2.0, 0.0],
        [2.0, -2.0, 0.0],
        [2.0, 2.0, 0.0],
        [-2.0, 2.0, 0.0],
    ];
    let mut faces = vec![[0, 1, 2], [0, 2, 3]];
    let mut owner = vec![FLOOR_ID; 4];
    for (id, _, lo, hi) in OBJECTS {
        let base = positions.len() as u32;
        for k in 0..8u32 {
            positions.push([
                if k & 1 == 0 { lo[0] } else { hi[0] },
                if k & 2 == 0 { lo[1] } else { hi[1] },
                if k & 4 == 0 { lo[2] } else { hi[2] },
            ]);
            owner.push(id);
        }
        // The six sides of the box as 12 triangles (corner k has bits x, y, z).
        for [a, b, c, d] in [
            [0, 1, 3, 2],
            [4, 6, 7, 5],
            [0, 4, 5, 1],
            [2, 3, 7, 6],
            [0, 2, 6, 4],
            [1, 5, 7, 3],
        ] {
            faces.push([base + a, base + b, base + c]);
            faces.push([base + a, base + c, base + d]);
        }
    }
    let colors = (0..positions.len())
        .map(|i| [(i * 37 % 200) as u8 + 40, 120, 90])
        .collect();
    (
        Mesh {
            positions,
            faces,
            colors: Some(colors),
            object_ids: None,
        },
        owner,
    )
}

/// The ScanNet++ toolkit's transform_matrix: inv(w2c), columns 1 and 2 negated, rows
/// permuted to [1, 0, 2], row 2 negated (the JSON world is M · mesh world).
fn toolkit_transform_matrix(cam: &Camera) -> Vec<Vec<f64>> {
    let c2w: DMat4 = cam.view().inverse();
    let mut m: Vec<Vec<f64>> = (0..4)
        .map(|r| (0..4).map(|c| c2w.col(c)[r]).collect())
        .collect();
    for row in m.iter_mut() {
        row[1] = -row[1];
        row[2] = -row[2];
    }
    m.swap(0, 1);
    for v in m[2].iter_mut() {
        *v = -*v;
    }
    m
}

fn build_scene(root: &Path) {
    let dslr = root.join("dslr");
    let images = dslr.join("resized_undistorted_images");
    std::fs::create_dir_all(&images).unwrap();
    std::fs::create_dir_all(dslr.join("nerfstudio")).unwrap();
    std::fs::create_dir_all(root.join("scans")).unwrap();
    let (mesh, owner) = mesh();
    mesh.write_ply(&root.join("scans/mesh_aligned_0.05.ply"))
        .unwrap();
    std::fs::write(
        root.join("scans/segments.json"),
        json!({"sceneId": "t", "segIndices": (0..owner.len()).collect::<Vec<_>>()}).to_string(),
    )
    .unwrap();
    let mut groups =
        vec![json!({"id": 0, "objectId": FLOOR_ID, "label": "floor", "segments": [0, 1, 2, 3]})];
    for (g, (id, label, _, _)) in OBJECTS.iter().enumerate() {
        let segments: Vec<usize> = (0..owner.len()).filter(|&v| owner[v] == *id).collect();
        groups.push(json!({"id": g + 1, "objectId": id, "label": label, "segments": segments}));
    }
    std::fs::write(
        root.join("scans/segments_anno.json"),
        json!({"sceneId": "t", "segGroups": groups}).to_string(),
    )
    .unwrap();
    let mut frames = Vec::new();
    for i in 0..VIEWS {
        let a = i as f64 / VIEWS as f64 * std::f64::consts::TAU;
        let eye = DVec3::new(2.2 * a.cos(), 2.2 * a.sin(), 1.4);
        let cam = Camera::look_at(W, H, 28.0, 28.0, eye, DVec3::new(0.0, 0.0, 0.2), DVec3::Z);
        let name = format!("DSC{i:05}.JPG");
        Image::from_fn(W, H, 3, |x, y, c| {
            ((x * 7 + y * 5 + c * 40 + i as u32 * 11) % 97) as f32 / 96.0
        })
        .save_png8(&images.join(&name))
        .unwrap();
        frames.push(json!({"file_path": name, "transform_matrix": toolkit_transform_matrix(&cam), "is_bad": false}));
    }
    std::fs::write(
        dslr.join("nerfstudio/transforms_undistorted.json"),
        json!({"camera_model": "PINHOLE", "fl_x": 28.0, "fl_y": 28.0, "cx": W as f64 / 2.0, "cy": H as f64 / 2.0,
               "w": W, "h": H, "frames": frames, "has_mask": false})
        .to_string(),
    )
    .unwrap();
}

const GRAPH: &str = r#"(
  nodes: {
    "scene":    (kind: "scannetpp_scene", params: (path: "scene", split: "dense")),
    "masks":    (kind: "gt_masks", inputs: (frames: "scene.frames", mesh: "scene.mesh")),
    "parts":    (kind: "partition", inputs: (frames: "scene.frames", masks: "masks.masks")),
    "train":    (kind: "train", inputs: (component: each("parts.components"), points: "scene.points"),
                 params: (iterations: 30, backend: "cpu")),
    "composed": (kind: "compose", inputs: (models: "train.model")),
    "renders":  (kind: "render", inputs: (scene: "composed.scene", frames: "scene.frames"), params: (views: "test")),
    "metrics":  (kind: "evaluate", inputs: (images: "renders.images", frames: "scene.frames", scene: "composed.scene",
                 mesh: "scene.mesh", masks: "masks.masks")),
    "glb":      (kind: "export_gltf", inputs: (scene: "composed.scene")),
  },
  targets: ["scene", "masks", "parts", "composed", "metrics", "glb"],
)"#;

#[test]
fn annotation_object_ids_reach_masks_components_scene_metrics_and_gltf() {
    let dir = tempfile::tempdir().unwrap();
    build_scene(&dir.path().join("scene"));
    std::fs::write(dir.path().join("g.ron"), GRAPH).unwrap();
    let run = objectsplat(
        dir.path(),
        &[
            "run", "g.ron", "--cache", "cache", "--out", "out", "-j", "1",
        ],
    );
    assert_ok(&run, "the run");
    let out = dir.path().join("out");
    let ids: BTreeSet<u64> = OBJECTS.iter().map(|o| o.0 as u64).collect();
    let keys = |v: &Value| -> BTreeSet<u64> {
        v.as_object()
            .unwrap()
            .keys()
            .map(|k| k.parse().unwrap())
            .collect()
    };

    // The mesh carries the objectIds; the floor (a background label) none.
    assert_eq!(keys(&read_json(&out.join("scene/mesh/objects.json"))), ids);

    // Masks: pixels hold the objectIds (the floor is 0, the sky 65535 = no surface).
    assert_eq!(keys(&read_json(&out.join("masks/masks/objects.json"))), ids);
    let mut seen = BTreeSet::new();
    for e in std::fs::read_dir(out.join("masks/masks")).unwrap() {
        let path = e.unwrap().path();
        if path.extension().is_some_and(|x| x == "png") {
            let map = objectsplat_core::IdMap::load(&path).unwrap();
            seen.extend(map.data.iter().map(|&v| v as u64));
        }
    }
    assert!(seen.contains(&0), "the floor is background (0)");
    let objects_seen: BTreeSet<u64> = seen
        .iter()
        .copied()
        .filter(|v| *v != 0 && *v != 65535)
        .collect();
    assert_eq!(objects_seen, ids, "mask pixel values");

    // Components, the composed scene and the glTF nodes are named by the objectIds.
    let names: BTreeSet<String> = OBJECTS
        .iter()
        .map(|(id, label, _, _)| format!("obj_{id}_{label}"))
        .chain(["background".to_string()])
        .collect();
    let components: BTreeSet<String> = std::fs::read_dir(out.join("parts/components"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(components, names);
    for (id, label, _, _) in OBJECTS {
        let info =
            read_json(&out.join(format!("parts/components/obj_{id}_{label}/component.json")));
        assert_eq!(info["object_id"], json!(id));
    }
    let scene = read_json(&out.join("composed/scene/scene.json"));
    let members: BTreeSet<(String, Option<u64>)> = scene["objects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| (m["name"].as_str().unwrap().to_string(), m["id"].as_u64()))
        .collect();
    for (id, label, _, _) in OBJECTS {
        assert!(
            members.contains(&(format!("obj_{id}_{label}"), Some(id as u64))),
            "{members:?}"
        );
    }
    let glb = gltf::Gltf::open(out.join("glb/file/scene.glb")).unwrap();
    let node_names: BTreeSet<String> = glb
        .nodes()
        .filter_map(|n| n.name().map(str::to_string))
        .collect();
    for name in &names {
        assert!(node_names.contains(name), "{name} not in {node_names:?}");
    }

    // Metrics: one entry per object, by objectId.
    let metrics = read_json(&out.join("metrics/metrics/metrics.json"));
    let metric_ids: BTreeSet<u64> = metrics["objects"]
        .as_array()
        .unwrap()
        .iter()
        .map(|o| o["id"].as_u64().unwrap())
        .collect();
    assert_eq!(metric_ids, ids);
}
