//! Dataflow nodes: `export_gltf` (the scene as one `.glb` and a PLY per member) and
//! `viewer` (the scene as an interactive page).

use crate::viewer::{ViewerCamera, ViewerMember, ViewerScene, write_viewer};
use crate::{ExportObject, ExportedComponent, ShColors, SrgbColors, build_glb};
use anyhow::{Context as _, Result};
use objectsplat_core::Frames;
use objectsplat_core::artifact::SCENE_GLB;
use objectsplat_raster::Model;
use objectsplat_raster::sh::{SH_DC, coeff_count};
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, ParamType, Registry, node_ports};
use objectsplat_scene::render::focus_bounds;
use objectsplat_scene::surface::visible_faces;
use objectsplat_scene::{Scene, load_scene};
use std::sync::Arc;

/// The scene as `.glb` bytes (what `export_gltf` writes) and what each node holds.
pub fn scene_glb(scene: &Scene) -> Result<(Vec<u8>, Vec<ExportedComponent>)> {
    glb_of(scene, &export_objects(scene))
}

/// The `.glb` of `objects`, the scene's members as [`export_objects`] gives them.
fn glb_of(scene: &Scene, objects: &[ExportObject]) -> Result<(Vec<u8>, Vec<ExportedComponent>)> {
    let extras = serde_json::json!({
        "generator": "objectsplat export_gltf",
        "members": scene.objects.len(),
    });
    build_glb(objects, Some(&extras))
}

/// `export_gltf`: the scene as one .glb plus one PLY per member.
pub struct ExportGltf;

pub const PLY_DIR: &str = "ply";

/// The scene's members as export objects: model-frame vertices with the member's
/// placement (the node transform, pivot on the centroid), visible faces, display colours (sRGB).
pub fn export_objects(scene: &Scene) -> Vec<ExportObject> {
    scene
        .objects
        .iter()
        .map(|o| ExportObject {
            component: o.entry.component(),
            positions: o.model.vertices.clone(),
            faces: visible_faces(&o.model),
            colors_srgb: SrgbColors::F32(display_colors(&o.model)),
            placement: o.placement(),
            sh: sh_colors(&o.model),
        })
        .collect()
}

node_ports! {
    struct ExportGltfPorts {
        /// the scene to export
        scene: input "Scene",
        /// scene.glb + ply/<member>.ply
        file: output "File",
    }
}

impl Node for ExportGltf {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("export_gltf", "3")
            .doc("Exports the scene as scene.glb (a node per member named obj_<id>_<label> or background, its origin on the member's centre and its placement — edits included — as the node's translation / rotation / scale, vertices in the object's frame, extras with id and label, linear vertex colours from each vertex's flat colour (fitted to its training views as this export draws them), the view-dependent SH coefficients as _SH_0 … _SH_15 attributes (sh_degree in the extras) for viewers that evaluate them, unlit material, Z-up → Y-up root) and ply/<member>.ply (capture frame, 8-bit sRGB). Faces too faint for the renderer to draw (opacity < 0.01) are left out.")
            .ports::<ExportGltfPorts>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: ExportGltfPorts = ctx.ports_as()?;
        let scene = load_scene(&ports.scene)?;
        let objects = export_objects(&scene);
        let out = ports.file;
        ctx.progress(0, 2, "writing scene.glb");
        let glb_path = out.join(SCENE_GLB);
        let (bytes, written) = glb_of(&scene, &objects)
            .with_context(|| format!("{}: cannot export the scene", glb_path.display()))?;
        std::fs::write(&glb_path, bytes)
            .with_context(|| format!("{}: cannot write .glb", glb_path.display()))?;
        ctx.progress(1, 2, "writing PLYs");
        crate::ply::write_component_plys(&out.join(PLY_DIR), &objects)?;
        ctx.progress(2, 2, "exported");
        ctx.note("members", written.len());
        ctx.note(
            "triangles",
            written.iter().map(|c| c.triangles).sum::<usize>(),
        );
        let dropped: usize = written.iter().map(|c| c.degenerate_faces_dropped).sum();
        if dropped > 0 {
            ctx.note("degenerate faces dropped", dropped);
        }
        Ok(Outcome::Done)
    }
}

/// `viewer`: the scene as an interactive page.
pub struct Viewer;

/// The view from `frames`' first camera toward the centre of the scene's objects, with
/// that camera's vertical field of view; `None` without frames or vertices.
fn starting_camera(scene: &Scene, frames: Option<&Frames>) -> Result<Option<ViewerCamera>> {
    let Some(first) = frames.and_then(|f| f.frames.first()) else {
        return Ok(None);
    };
    let Some((lo, hi)) = focus_bounds(scene)? else {
        return Ok(None);
    };
    let camera = first.camera();
    let eye = camera.center();
    let target = (lo + hi) * 0.5;
    if (eye - target).length() < 1e-9 {
        return Ok(None);
    }
    let fov = 2.0 * (camera.height as f64 / (2.0 * camera.fy)).atan();
    Ok(Some(ViewerCamera {
        eye: eye.to_array(),
        target: target.to_array(),
        fov_y_degrees: fov.to_degrees(),
    }))
}

objectsplat_runtime::node_params! {
    /// The parameters of `viewer`.
    pub struct ViewerParams {
        /// page title
        title: String = "\"ObjectSplat scene\"" as ParamType::Str,
    }
}

node_ports! {
    struct ViewerPorts {
        /// the scene to show
        scene: input "Scene",
        /// the capture: the view starts from its first camera, looking at the objects
        frames: optional "Frames",
        /// index.html + scene.glb + viewer.json
        file: output "File",
    }
}

impl Node for Viewer {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("viewer", "2")
            .doc("The scene as an interactive page (index.html; opens from disk with no network; WebGL2): orbit / pan / zoom, click an object to select it (highlight + name and label), move / turn / scale it with the mouse or keys, duplicate, remove, recolor, undo; `Export edits` gives the RON list that edit_scene's `edits` takes (the scene's own earlier edits first), so a graph reproduces what was done by hand. Scripting surface window.objectsplat: ready, objects(), pick(x, y), apply(edit), edits(). Also writes scene.glb (as export_gltf) and viewer.json; the report embeds the view when given this folder.")
            .ports::<ViewerPorts>()
            .params::<ViewerParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: ViewerPorts = ctx.ports_as()?;
        let p: ViewerParams = ctx.params_as()?;
        let title: String = p.title;
        let scene = load_scene(&ports.scene)?;
        let frames = match ports.frames.as_deref() {
            Some(dir) => Some(Frames::read(dir)?),
            None => None,
        };
        ctx.progress(0, 1, "writing the viewer");
        let (glb, written) = scene_glb(&scene)?;
        let members = scene
            .objects
            .iter()
            .map(|o| ViewerMember {
                name: o.entry.name.clone(),
                kind: o.entry.kind,
                id: o.entry.id,
                label: o.entry.label.clone(),
                placement: o.placement(),
            })
            .collect();
        let view = ViewerScene {
            title,
            members,
            edits: scene.edits.clone(),
            camera: starting_camera(&scene, frames.as_ref())?,
        };
        write_viewer(&ports.file, &glb, &view)?;
        ctx.progress(1, 1, "viewer written");
        ctx.note("members", scene.objects.len());
        ctx.note(
            "triangles",
            written.iter().map(|c| c.triangles).sum::<usize>(),
        );
        if !scene.edits.is_empty() {
            ctx.note("earlier edits", scene.edits.len());
        }
        Ok(Outcome::Done)
    }
}

/// The display colour of each vertex (sRGB in [0, 1]): its flat colour
/// ([`Model::flat_dc`]), as `model.ply` shows it.
pub fn display_colors(model: &Model<f32>) -> Vec<[f32; 3]> {
    (0..model.vertex_count())
        .map(|v| {
            model
                .flat_dc(v)
                .map(|dc| (0.5 + SH_DC * f64::from(dc)).clamp(0.0, 1.0) as f32)
        })
        .collect()
}

/// The view-dependent colour of each vertex as an export carries it: the SH
/// coefficients up to the model's degree, in the model's frame (none at degree 0,
/// where the display colour says everything).
pub fn sh_colors(model: &Model<f32>) -> Option<ShColors> {
    if model.sh_degree == 0 {
        return None;
    }
    let per_vertex = coeff_count(model.sh_degree);
    Some(ShColors {
        degree: model.sh_degree,
        coefficients: model
            .sh
            .iter()
            .flat_map(|rows| rows[..per_vertex].iter().copied())
            .collect(),
    })
}

pub fn register(reg: &mut Registry) {
    // Each kind is registered once here; a clash means another crate took the same kind.
    reg.add_node(Arc::new(ExportGltf))
        .expect("node kind `export_gltf` is registered once");
    reg.add_node(Arc::new(Viewer))
        .expect("node kind `viewer` is registered once");
}
