//! Binary glTF 2.0 (`.glb`) export of a decomposed scene: one node and one mesh per object.
//!
//! Layout (docs/artifacts.md, "glTF export"): a root node `scene` carrying the Z-up→Y-up rotation,
//! one child node per component named `obj_<id>_<label>` (or `background`) with `extras`
//! `{"kind", "object_id", "label", "num_faces", "num_vertices"}` and the component's
//! [`Placement`](crate::Placement) as its translation / rotation / scale (vertices relative
//! to the pivot, so the node's origin is the object's centre), vertex colours as linear
//! `COLOR_0` (f32 VEC3), `u32` indices, a single unlit material listed in `extensionsUsed`
//! only, and scene metadata in `asset.extras`. A component with view-dependent colour also
//! carries its spherical-harmonics coefficients as application-specific attributes
//! `_SH_0` … `_SH_{(d+1)²−1}` (f32 VEC3 each, the 3DGS basis in the node's frame, sRGB
//! display space; see [`ShColors`](crate::ShColors)) and `sh_degree` d in the node's
//! extras: other glTF viewers show `COLOR_0`, ours the trained appearance.

use crate::color::{srgb_to_linear, srgb8_to_linear};
use crate::object::{CleanMesh, ExportObject, SrgbColors, clean_mesh, ensure_unique_names};
use anyhow::{Context, Result, ensure};
use gltf_json as json;
use json::validation::Checked::Valid;
use json::validation::USize64;
use objectsplat_core::ComponentKind;
use std::collections::BTreeMap;
use std::path::Path;

/// Rotation (xyzw) taking the capture's Z-up world to glTF's Y-up: −90° about +X.
pub const Z_UP_TO_Y_UP: [f32; 4] = [
    -std::f32::consts::FRAC_1_SQRT_2,
    0.0,
    0.0,
    std::f32::consts::FRAC_1_SQRT_2,
];

/// Name of the root node that carries the axis change.
pub const ROOT_NODE_NAME: &str = "scene";

/// What was written for one component.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExportedComponent {
    pub name: String,
    pub triangles: usize,
    pub vertices: usize,
    /// Faces dropped because two corners share an index or the three corners are collinear.
    pub degenerate_faces_dropped: usize,
}

/// Accumulates the BIN chunk; every view starts on a 4-byte boundary (all data is 4-byte).
struct BinWriter {
    bytes: Vec<u8>,
}

impl BinWriter {
    fn push_view(
        &mut self,
        root: &mut json::Root,
        data: &[u8],
        target: json::buffer::Target,
    ) -> json::Index<json::buffer::View> {
        debug_assert!(self.bytes.len().is_multiple_of(4));
        let offset = self.bytes.len();
        self.bytes.extend_from_slice(data);
        root.push(json::buffer::View {
            buffer: json::Index::new(0),
            byte_length: USize64::from(data.len()),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            name: None,
            target: Some(Valid(target)),
            extensions: None,
            extras: None,
        })
    }
}

fn vec3_bytes(values: &[[f32; 3]]) -> Vec<u8> {
    values
        .iter()
        .flatten()
        .flat_map(|v| v.to_le_bytes())
        .collect()
}

fn bounds(values: &[[f32; 3]]) -> ([f32; 3], [f32; 3]) {
    // Exact: every f32 is an f64, and the min and max are among the inputs.
    let (lo, hi) =
        objectsplat_core::geometry::bounding_box(values.iter().map(|p| p.map(f64::from)));
    (lo.map(|v| v as f32), hi.map(|v| v as f32))
}

fn float_accessor(
    root: &mut json::Root,
    view: json::Index<json::buffer::View>,
    count: usize,
    min_max: Option<([f32; 3], [f32; 3])>,
) -> json::Index<json::Accessor> {
    let (min, max) = match min_max {
        Some((lo, hi)) => (Some(serde_json::json!(lo)), Some(serde_json::json!(hi))),
        None => (None, None),
    };
    root.push(json::Accessor {
        buffer_view: Some(view),
        byte_offset: None,
        count: USize64::from(count),
        component_type: Valid(json::accessor::GenericComponentType(
            json::accessor::ComponentType::F32,
        )),
        extensions: None,
        extras: None,
        type_: Valid(json::accessor::Type::Vec3),
        min,
        max,
        name: None,
        normalized: false,
        sparse: None,
    })
}

fn raw_extras(value: &serde_json::Value) -> Result<json::Extras> {
    Ok(Some(
        serde_json::value::to_raw_value(value).context("cannot encode extras as JSON")?,
    ))
}

fn unlit_material() -> json::Material {
    // Set by field, not by struct literal: other crates may enable more gltf-json
    // extension features, which add fields to this struct.
    let mut extensions = json::extensions::material::Material::default();
    extensions.unlit = Some(json::extensions::material::Unlit {});
    json::Material {
        name: Some("unlit_vertex_color".into()),
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            base_color_factor: json::material::PbrBaseColorFactor([1.0, 1.0, 1.0, 1.0]),
            metallic_factor: json::material::StrengthFactor(0.0),
            roughness_factor: json::material::StrengthFactor(0.9),
            ..Default::default()
        },
        // Reconstructed surfaces are thin shells seen from both sides.
        double_sided: true,
        extensions: Some(extensions),
        ..Default::default()
    }
}

/// Builds the `.glb` bytes. `asset_extras`, when given, must be a JSON object.
pub fn build_glb(
    objects: &[ExportObject],
    asset_extras: Option<&serde_json::Value>,
) -> Result<(Vec<u8>, Vec<ExportedComponent>)> {
    ensure_unique_names(objects)?;
    let mut root = json::Root::default();
    root.asset.generator = Some(format!("objectsplat-export {}", env!("CARGO_PKG_VERSION")));
    if let Some(extras) = asset_extras {
        ensure!(
            extras.is_object(),
            "asset extras must be a JSON object, got {extras}"
        );
        root.asset.extras = raw_extras(extras)?;
    }
    let material = root.push(unlit_material());
    root.extensions_used.push("KHR_materials_unlit".into());

    let mut bin = BinWriter { bytes: Vec::new() };
    let mut children = Vec::with_capacity(objects.len());
    let mut summary = Vec::with_capacity(objects.len());
    for object in objects {
        let name = &object.component.name;
        let mesh: CleanMesh = clean_mesh(object)?;
        let positions_out: Vec<[f32; 3]> = mesh
            .vertex_source
            .iter()
            .map(|&v| object.local_position(v as usize))
            .collect();
        let linear_colors: Vec<[f32; 3]> = mesh
            .vertex_source
            .iter()
            .map(|&v| match &object.colors_srgb {
                SrgbColors::U8(c) => c[v as usize].map(srgb8_to_linear),
                SrgbColors::F32(c) => c[v as usize].map(srgb_to_linear),
            })
            .collect();
        let mut extras = serde_json::json!({
            "kind": match object.component.kind {
                ComponentKind::Object => "object",
                ComponentKind::Background => "background",
            },
            "object_id": object.component.object_id,
            "label": object.component.label,
            "num_faces": mesh.faces.len(),
            "num_vertices": positions_out.len(),
        });
        if let Some(sh) = &object.sh {
            extras["sh_degree"] = sh.degree.into();
        }
        // glTF forbids empty accessors, so a component with nothing left is a mesh-less node.
        let mesh_index = if mesh.faces.is_empty() {
            None
        } else {
            let position_view = bin.push_view(
                &mut root,
                &vec3_bytes(&positions_out),
                json::buffer::Target::ArrayBuffer,
            );
            let positions = float_accessor(
                &mut root,
                position_view,
                positions_out.len(),
                Some(bounds(&positions_out)),
            );
            let color_view = bin.push_view(
                &mut root,
                &vec3_bytes(&linear_colors),
                json::buffer::Target::ArrayBuffer,
            );
            let colors = float_accessor(&mut root, color_view, linear_colors.len(), None);
            let index_bytes: Vec<u8> = mesh
                .faces
                .iter()
                .flatten()
                .flat_map(|i| i.to_le_bytes())
                .collect();
            let index_view = bin.push_view(
                &mut root,
                &index_bytes,
                json::buffer::Target::ElementArrayBuffer,
            );
            let indices = root.push(json::Accessor {
                buffer_view: Some(index_view),
                byte_offset: None,
                count: USize64::from(mesh.faces.len() * 3),
                component_type: Valid(json::accessor::GenericComponentType(
                    json::accessor::ComponentType::U32,
                )),
                extensions: None,
                extras: None,
                type_: Valid(json::accessor::Type::Scalar),
                min: None,
                max: None,
                name: None,
                normalized: false,
                sparse: None,
            });
            let mut attributes = BTreeMap::new();
            attributes.insert(Valid(json::mesh::Semantic::Positions), positions);
            attributes.insert(Valid(json::mesh::Semantic::Colors(0)), colors);
            if let Some(sh) = &object.sh {
                let per_vertex = sh.per_vertex();
                for k in 0..per_vertex {
                    let values: Vec<[f32; 3]> = mesh
                        .vertex_source
                        .iter()
                        .map(|&v| sh.coefficients[v as usize * per_vertex + k])
                        .collect();
                    let view = bin.push_view(
                        &mut root,
                        &vec3_bytes(&values),
                        json::buffer::Target::ArrayBuffer,
                    );
                    let accessor = float_accessor(&mut root, view, values.len(), None);
                    attributes.insert(
                        Valid(json::mesh::Semantic::Extras(format!("SH_{k}"))),
                        accessor,
                    );
                }
            }
            Some(root.push(json::Mesh {
                extensions: None,
                extras: None,
                name: Some(name.clone()),
                primitives: vec![json::mesh::Primitive {
                    attributes,
                    extensions: None,
                    extras: None,
                    indices: Some(indices),
                    material: Some(material),
                    mode: Valid(json::mesh::Mode::Triangles),
                    targets: None,
                }],
                weights: None,
            }))
        };
        let (translation, rotation, scale) = object.placement.node_trs();
        children.push(root.push(json::Node {
            mesh: mesh_index,
            name: Some(name.clone()),
            extras: raw_extras(&extras)?,
            // Defaults are left out, as glTF writers customarily do.
            translation: (translation != [0.0; 3]).then_some(translation),
            rotation:
                (rotation != [0.0, 0.0, 0.0, 1.0]).then_some(json::scene::UnitQuaternion(rotation)),
            scale: (scale != [1.0; 3]).then_some(scale),
            ..Default::default()
        }));
        summary.push(ExportedComponent {
            name: name.clone(),
            triangles: mesh.faces.len(),
            vertices: positions_out.len(),
            degenerate_faces_dropped: mesh.degenerate_dropped,
        });
    }

    let scene_node = root.push(json::Node {
        name: Some(ROOT_NODE_NAME.into()),
        rotation: Some(json::scene::UnitQuaternion(Z_UP_TO_Y_UP)),
        children: if children.is_empty() {
            None
        } else {
            Some(children)
        },
        ..Default::default()
    });
    let scene = root.push(json::Scene {
        extensions: None,
        extras: None,
        name: Some("objectsplat".into()),
        nodes: vec![scene_node],
    });
    root.scene = Some(scene);

    // The GLB header stores the total length as u32.
    ensure!(
        bin.bytes.len() < (u32::MAX as usize) - (1 << 20),
        "scene geometry is {} bytes, too large for a .glb (4 GiB limit)",
        bin.bytes.len()
    );
    if !bin.bytes.is_empty() {
        root.push(json::Buffer {
            byte_length: USize64::from(bin.bytes.len()),
            name: None,
            uri: None,
            extensions: None,
            extras: None,
        });
    }
    let json_text = json::serialize::to_vec(&root).context("cannot serialise the glTF JSON")?;
    let glb = gltf::binary::Glb {
        header: gltf::binary::Header {
            magic: *b"glTF",
            version: 2,
            length: 0,
        },
        json: json_text.into(),
        bin: if bin.bytes.is_empty() {
            None
        } else {
            Some(bin.bytes.into())
        },
    };
    let bytes = glb.to_vec().context("cannot assemble the .glb")?;
    Ok((bytes, summary))
}

/// Writes `path` as a `.glb` (see [`build_glb`]).
pub fn write_glb(
    path: &Path,
    objects: &[ExportObject],
    asset_extras: Option<&serde_json::Value>,
) -> Result<Vec<ExportedComponent>> {
    let (bytes, summary) = build_glb(objects, asset_extras)
        .with_context(|| format!("{}: cannot export the scene", path.display()))?;
    std::fs::write(path, bytes)
        .with_context(|| format!("{}: cannot write .glb", path.display()))?;
    Ok(summary)
}

/// Triangles drawn under each named node of a `.glb` (read back through the `gltf` parser),
/// for tests that check what an export contains.
pub fn triangles_per_node(glb: &[u8]) -> Result<BTreeMap<String, usize>> {
    let document = gltf::Gltf::from_slice(glb).context("not a valid glTF binary")?;
    let mut out = BTreeMap::new();
    for node in document.nodes() {
        let Some(mesh) = node.mesh() else { continue };
        let mut triangles = 0;
        for primitive in mesh.primitives() {
            ensure!(
                primitive.mode() == gltf::mesh::Mode::Triangles,
                "mesh {:?} is not a triangle list",
                mesh.name()
            );
            let count = match primitive.indices() {
                Some(indices) => indices.count(),
                None => primitive
                    .get(&gltf::Semantic::Positions)
                    .map_or(0, |a| a.count()),
            };
            triangles += count / 3;
        }
        *out.entry(node.name().unwrap_or("").to_string())
            .or_insert(0) += triangles;
    }
    Ok(out)
}
