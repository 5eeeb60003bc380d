//! The `.glb` read back through the `gltf` crate: node tree, names, extras, material,
//! bounds, linear colours and triangles.

mod common;

use common::{CORNER_COLOURS, scene};
use objectsplat_export::glb::{ROOT_NODE_NAME, build_glb};
use serde_json::json;

fn parse(bytes: &[u8]) -> gltf::Gltf {
    gltf::Gltf::from_slice(bytes).expect("exported .glb must parse")
}

/// The test scene exported without asset extras, parsed back.
fn scene_document() -> gltf::Gltf {
    let (bytes, _) = build_glb(&scene(), None).unwrap();
    parse(&bytes)
}

fn node<'a>(doc: &'a gltf::Gltf, name: &str) -> gltf::Node<'a> {
    doc.nodes()
        .find(|n| n.name() == Some(name))
        .unwrap_or_else(|| panic!("no node {name}"))
}

fn extras(node: &gltf::Node) -> serde_json::Value {
    serde_json::from_str(node.extras().as_ref().expect("node has extras").get()).unwrap()
}

#[test]
fn root_node_rotates_z_up_to_y_up_and_holds_one_child_per_component() {
    let doc = scene_document();
    let scene = doc.default_scene().expect("default scene");
    let roots: Vec<_> = scene.nodes().collect();
    assert_eq!(roots.len(), 1);
    let root = &roots[0];
    assert_eq!(root.name(), Some(ROOT_NODE_NAME));
    let (_, rotation, _) = root.transform().decomposed();
    // −90° about +X: (sin(−45°), 0, 0, cos(−45°)).
    let expected = [-(0.5f32.sqrt()), 0.0, 0.0, 0.5f32.sqrt()];
    for k in 0..4 {
        assert!(
            (rotation[k] - expected[k]).abs() < 1e-7,
            "rotation {rotation:?}"
        );
    }
    // Rotating the Z-up vector (0,0,1) by this quaternion must give glTF's up, +Y.
    let m = root.transform().matrix();
    let up = [m[2][0], m[2][1], m[2][2]];
    assert!(
        (up[0]).abs() < 1e-6 && (up[1] - 1.0).abs() < 1e-6 && up[2].abs() < 1e-6,
        "Z maps to {up:?}"
    );
    let names: Vec<_> = root
        .children()
        .map(|c| c.name().unwrap().to_string())
        .collect();
    assert_eq!(names, ["obj_3_chair", "obj_7_desk_lamp", "background"]);
}

#[test]
fn node_extras_carry_id_label_and_counts() {
    let (bytes, summary) = build_glb(&scene(), None).unwrap();
    let doc = parse(&bytes);
    assert_eq!(
        extras(&node(&doc, "obj_7_desk_lamp")),
        json!({"kind": "object", "object_id": 7, "label": "desk lamp", "num_faces": 12, "num_vertices": 8})
    );
    assert_eq!(
        extras(&node(&doc, "background")),
        json!({"kind": "background", "object_id": null, "label": null, "num_faces": 2, "num_vertices": 4})
    );
    let lamp = summary
        .iter()
        .find(|s| s.name == "obj_7_desk_lamp")
        .unwrap();
    assert_eq!(
        (lamp.triangles, lamp.vertices, lamp.degenerate_faces_dropped),
        (12, 8, 2)
    );
}

#[test]
fn asset_extras_and_unlit_material_are_declared_but_not_required() {
    let meta = json!({"scene": "0a5c013435", "split": "sparse", "iterations": 30000});
    let (bytes, _) = build_glb(&scene(), Some(&meta)).unwrap();
    let doc = parse(&bytes);
    let asset_extras: serde_json::Value =
        serde_json::from_str(doc.as_json().asset.extras.as_ref().unwrap().get()).unwrap();
    assert_eq!(asset_extras, meta);
    assert_eq!(
        doc.extensions_used().collect::<Vec<_>>(),
        ["KHR_materials_unlit"]
    );
    assert_eq!(doc.extensions_required().count(), 0);
    let materials: Vec<_> = doc.materials().collect();
    assert_eq!(materials.len(), 1);
    assert!(materials[0].unlit());
    assert_eq!(
        materials[0].pbr_metallic_roughness().base_color_factor(),
        [1.0, 1.0, 1.0, 1.0]
    );
    assert_eq!(materials[0].pbr_metallic_roughness().metallic_factor(), 0.0);
    for mesh in doc.meshes() {
        for p in mesh.primitives() {
            assert_eq!(p.material().index(), Some(0));
        }
    }
}

struct PrimitiveData {
    positions: Vec<[f32; 3]>,
    colours: Vec<[f32; 3]>,
    indices: Vec<u32>,
    bounds: gltf::mesh::Bounds<[f32; 3]>,
}

/// The primitive of node `name` in the exported test scene.
fn scene_primitive(name: &str) -> PrimitiveData {
    primitive_data(&scene_document(), name)
}

fn primitive_data(doc: &gltf::Gltf, name: &str) -> PrimitiveData {
    let blob = doc.blob.as_deref().expect("GLB has a BIN chunk");
    let mesh = node(doc, name).mesh().expect("node has a mesh");
    let prim = mesh.primitives().next().unwrap();
    let reader = prim.reader(|_| Some(blob));
    let positions: Vec<_> = reader.read_positions().unwrap().collect();
    let colours: Vec<_> = reader.read_colors(0).unwrap().into_rgb_f32().collect();
    let indices: Vec<_> = reader.read_indices().unwrap().into_u32().collect();
    assert!(matches!(
        prim.indices().unwrap().data_type(),
        gltf::accessor::DataType::U32
    ));
    PrimitiveData {
        positions,
        colours,
        indices,
        bounds: prim.bounding_box(),
    }
}

#[test]
fn position_bounds_cover_exactly_the_drawn_vertices() {
    let PrimitiveData {
        positions, bounds, ..
    } = scene_primitive("obj_7_desk_lamp");
    // The unused vertex at (100,100,100) is gone; the box is [1,-1,0.7]–[1.2,-0.8,1.3].
    assert_eq!(positions.len(), 8);
    assert_eq!(bounds.min, [1.0, -1.0, 0.7]);
    assert_eq!(bounds.max, [1.2, -0.8, 1.3]);
}

/// Published sRGB→linear values (IEC 61966-2-1), independent of the exporter's formula.
const LINEAR_OF_SRGB8: [(u8, f32); 5] = [
    (0, 0.0),
    (10, 0.003_035_27),
    (64, 0.051_269_46),
    (128, 0.215_860_5),
    (255, 1.0),
];

#[test]
fn vertex_colours_are_linear() {
    let chair = &scene()[0];
    let PrimitiveData {
        positions, colours, ..
    } = scene_primitive("obj_3_chair");
    for (p, c) in positions.iter().zip(&colours) {
        // Find the input vertex by position (the exporter may reorder vertices).
        let v = chair
            .positions
            .iter()
            .position(|q| q == p)
            .expect("written vertex comes from the input");
        for k in 0..3 {
            let srgb = CORNER_COLOURS[v][k];
            let expected = LINEAR_OF_SRGB8
                .iter()
                .find(|(s, _)| *s == srgb)
                .map(|(_, l)| *l);
            if let Some(expected) = expected {
                assert!(
                    (c[k] - expected).abs() < 2e-6,
                    "sRGB {srgb} → {} (expected {expected})",
                    c[k]
                );
            }
        }
    }
    // Float input: 0.5 sRGB is 0.214041 linear; the knee value 0.04045 is 0.0031308.
    let floor_colours = scene_primitive("background").colours;
    assert!((floor_colours[0][0] - 0.214_041_14).abs() < 1e-6);
    assert!((floor_colours[3][2] - 0.003_130_8).abs() < 1e-6);
}

#[test]
fn triangles_are_the_input_faces_minus_degenerate_ones() {
    let PrimitiveData {
        positions, indices, ..
    } = scene_primitive("obj_7_desk_lamp");
    let lamp = &scene()[1];
    let written: Vec<[[f32; 3]; 3]> = indices
        .chunks(3)
        .map(|t| {
            [
                positions[t[0] as usize],
                positions[t[1] as usize],
                positions[t[2] as usize],
            ]
        })
        .collect();
    let expected: Vec<[[f32; 3]; 3]> = lamp.faces[..12]
        .iter()
        .map(|f| f.map(|v| lamp.positions[v as usize]))
        .collect();
    // Same triangles with the same winding, in order.
    assert_eq!(written, expected);
}

#[test]
fn a_component_with_no_faces_left_is_a_mesh_less_node() {
    let mut objects = scene();
    objects[0].faces = vec![[0, 0, 0]];
    let (bytes, summary) = build_glb(&objects, None).unwrap();
    let doc = parse(&bytes);
    let chair = node(&doc, "obj_3_chair");
    assert!(chair.mesh().is_none());
    assert_eq!(extras(&chair)["num_faces"], 0);
    assert_eq!(summary[0].triangles, 0);
}

#[test]
fn a_placed_object_is_a_node_transform_over_pivot_relative_vertices() {
    let mut objects = scene();
    let placement = objectsplat_export::Placement::at([0.25, 0.25, 0.45])
        .rotated([0.0, 0.0, 1.0], 90.0)
        .scaled(2.0)
        .moved([1.0, 0.0, 0.0]);
    objects[0] = objects[0].clone().placed(placement);
    let (bytes, _) = build_glb(&objects, None).unwrap();
    let doc = parse(&bytes);
    let chair = node(&doc, "obj_3_chair");
    let (t, r, s) = chair.transform().decomposed();
    assert_eq!(t, [1.25, 0.25, 0.45]);
    assert_eq!(s, [2.0; 3]);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    assert!(r[0] == 0.0 && r[1] == 0.0 && (r[2] - h).abs() < 1e-7 && (r[3] - h).abs() < 1e-7);
    // The box [0, 0.5]×[0, 0.5]×[0, 0.9] around its pivot (0.25, 0.25, 0.45).
    let data = primitive_data(&doc, "obj_3_chair");
    assert_eq!(data.bounds.min, [-0.25, -0.25, -0.45]);
    assert_eq!(data.bounds.max, [0.25, 0.25, 0.45]);
    // The node puts local corner (0.25, 0, 0) (+X of the pivot) at pivot-in-world + 2·(+Y)·0.25.
    let m = chair.transform().matrix();
    let p = [0.25f32, 0.0, 0.0];
    let world: Vec<f32> = (0..3)
        .map(|k| m[0][k] * p[0] + m[1][k] * p[1] + m[2][k] * p[2] + m[3][k])
        .collect();
    let want = [1.25, 0.75, 0.45];
    for k in 0..3 {
        assert!((world[k] - want[k]).abs() < 1e-6, "{world:?}");
    }
    // Unplaced components keep world coordinates under an untransformed node.
    let lamp = node(&doc, "obj_7_desk_lamp");
    assert_eq!(
        lamp.transform().decomposed(),
        ([0.0; 3], [0.0, 0.0, 0.0, 1.0], [1.0; 3])
    );
}
