//! Dataflow nodes: `compose`, `load_scene`, `edit_scene` and `render`.
//!
//! (`export_gltf` and `viewer` are registered by `objectsplat-export`, `evaluate` by
//! `objectsplat-evaluate`, `report` by `objectsplat-report`.)

use crate::edit::{apply_edits, edit_item_problem, parse_edits};
use crate::render::{Backdrop, orbit_cameras, render_view};
use crate::scene::{Scene, SceneEntry, SceneObject, component_of_item, load_scene, save_scene};
use crate::surface::exported_model;
use anyhow::{Context as _, Result, bail};
use objectsplat_core::artifact::SCENE_FILLS_DIR;
use objectsplat_core::frames::frame_stem;
use objectsplat_core::{Frames, Image, Split};
use objectsplat_raster::load_model;
use objectsplat_runtime::{
    CheckedInput, Context, Node, NodeSpec, Outcome, ParamError, ParamType, Params, Registry, Value,
    node_ports,
};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn check_cancel(ctx: &Context) -> Result<()> {
    if ctx.cancelled() {
        bail!("interrupted");
    }
    Ok(())
}

/// `compose`: the trained components side by side, as one separable scene.
pub struct Compose;

node_ports! {
    struct ComposePorts {
        /// one trained model per component; items named `background` or `obj_<id>_<label>` (or model.json metadata.component says which)
        models: items "Model",
        /// scene.json + objects/<name>/ (one Model folder per member)
        scene: output "Scene",
    }
}

impl Node for Compose {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("compose", "1")
            .doc("The union of the trained component models in the shared world frame: one scene member per component (object id, label), no re-optimization.")
            .ports::<ComposePorts>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: ComposePorts = ctx.ports_as()?;
        let items = ports.models;
        if items.is_empty() {
            bail!("the models collection is empty; there is nothing to compose");
        }
        let mut objects = Vec::with_capacity(items.len());
        for (k, (item, dir)) in items.iter().enumerate() {
            check_cancel(ctx)?;
            ctx.progress(k as u64, items.len() as u64, "composing");
            let model = load_model(dir).with_context(|| format!("models item {item:?}"))?;
            let info = component_of_item(item, &model)?;
            objects.push(SceneObject {
                entry: SceneEntry::from_component(&info, item),
                model,
            });
        }
        let scene = Scene::new(objects)?;
        save_scene(&scene, &ports.scene)?;
        ctx.progress(items.len() as u64, items.len() as u64, "composing");
        ctx.note("members", scene.objects.len());
        ctx.note("triangles", scene.face_count());
        Ok(Outcome::Done)
    }
}

objectsplat_runtime::node_params! {
    /// The parameters of `load_scene`.
    pub struct LoadSceneParams {
        /// the Scene folder, relative to the graph file
        path: String = required as ParamType::Path,
    }
}

/// `load_scene`: a Scene folder from disk, e.g. one a previous run materialized.
pub struct LoadScene;

node_ports! {
    struct LoadScenePorts {
        /// the scene as read
        scene: output "Scene",
    }
}

impl Node for LoadScene {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("load_scene", "1")
            .doc("Reads a Scene folder (scene.json + objects/<name>/ + optional fills/) from disk, e.g. one a previous run wrote under OUT/<node>/scene/, and checks it.")
            .ports::<LoadScenePorts>()
            .params::<LoadSceneParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: LoadScenePorts = ctx.ports_as()?;
        let p: LoadSceneParams = ctx.params_as()?;
        let path: String = p.path;
        let dir = PathBuf::from(&path);
        let scene = load_scene(&dir)?;
        let out = ports.scene;
        save_scene(&scene, &out)?;
        if dir.join(SCENE_FILLS_DIR).is_dir() {
            let fills = copy_pngs(&dir.join(SCENE_FILLS_DIR), &out.join(SCENE_FILLS_DIR))?;
            ctx.note("background fills", fills);
        }
        ctx.note("members", scene.objects.len());
        ctx.note("triangles", scene.face_count());
        Ok(Outcome::Done)
    }
}

/// Copies the PNGs of `from` into `to` (created), returning how many.
fn copy_pngs(from: &Path, to: &Path) -> Result<usize> {
    let mut names: Vec<PathBuf> = std::fs::read_dir(from)
        .with_context(|| format!("{}: cannot list", from.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file() && p.extension().is_some_and(|x| x.eq_ignore_ascii_case("png")))
        .collect();
    names.sort();
    std::fs::create_dir_all(to).with_context(|| format!("{}: cannot create", to.display()))?;
    for p in &names {
        // `names` holds files listed by read_dir, so each has a file name.
        let name = p.file_name().unwrap_or_default();
        std::fs::copy(p, to.join(name)).with_context(|| format!("{}: cannot copy", p.display()))?;
    }
    Ok(names.len())
}

/// `edit_scene`: move / rotate / scale / duplicate / remove / recolor members.
pub struct EditScene;

const EDITS_DOC: &str = "list of edits applied in order, e.g. [Move(target: Id(3), by: (0.5, 0, 0)), Rotate(target: Label(\"chair\"), axis: (0, 0, 1), degrees: 90), Scale(target: Id(2), factor: 1.5), Duplicate(target: Id(4), offset: (1, 0, 0)), Remove(target: Label(\"cup\")), Recolor(target: Id(3), rgb: (1, 0, 0))]; targets Id(n), Label(\"…\") (all objects with it) or Name(\"…\") (a member, e.g. \"background\")";

node_ports! {
    struct EditScenePorts {
        /// the scene to edit
        scene: input "Scene",
        /// per-frame inpainted background images (<frame stem>.png)
        fills: optional "Images",
        /// the edited scene
        scene_out: output "Scene" as "scene",
    }
}

impl Node for EditScene {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("edit_scene", "2")
            .doc("Edits a composed scene. Rigid edits (move, rotate, scale, a duplicate's offset) change the member's placement, not its model, so the exported .glb node carries them as its transform; rotation and scale act about the member's pivot (its centroid); a duplicate gets the next free id. The scene records the edits it has been through (scene.json `edits`). When `fills` (inpainted background views) is wired, it is stored with the scene and `render` shows it wherever no triangle covers a pixel, e.g. where a moved object used to be.")
            .ports::<EditScenePorts>()
            .param("edits", ParamType::Ron("list of edits".into()), Some("[]"), EDITS_DOC)
    }

    /// Every edit's kind and fields, before anything runs.
    fn check_params(&self, params: &Params) -> Vec<ParamError> {
        match params.value("edits") {
            Some(Value::List(items)) => items
                .iter()
                .enumerate()
                .filter_map(|(i, item)| {
                    let (field, message) = edit_item_problem(item)?;
                    let path = std::iter::once(i.to_string()).chain(field);
                    Some(ParamError::new("edits", message).at(path))
                })
                .collect(),
            Some(other) => vec![ParamError::new(
                "edits",
                format!("expected a list of edits, found {}", other.shape()),
            )],
            None => Vec::new(),
        }
    }

    fn checked_inputs(&self) -> Vec<CheckedInput> {
        vec![CheckedInput {
            port: "scene".into(),
            what: "edit targets (ids, labels, member names)".into(),
        }]
    }

    /// Each edit's target against the scene as the edits before it leave it.
    fn check_with_inputs(
        &self,
        params: &Params,
        inputs: &BTreeMap<String, PathBuf>,
    ) -> Result<Vec<ParamError>> {
        let (Some(Value::List(items)), Some(dir)) = (params.value("edits"), inputs.get("scene"))
        else {
            return Ok(Vec::new());
        };
        let Ok(edits) = parse_edits(items) else {
            // check_params reports malformed edits.
            return Ok(Vec::new());
        };
        let mut scene = load_scene(dir)?;
        for (i, edit) in edits.iter().enumerate() {
            if let Err(e) = apply_edits(&mut scene, std::slice::from_ref(edit)) {
                let message = format!("{} (in the cached scene)", e.root_cause());
                return Ok(vec![
                    ParamError::new("edits", message).at([i.to_string(), "target".into()]),
                ]);
            }
        }
        Ok(Vec::new())
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: EditScenePorts = ctx.ports_as()?;
        let items = match ctx.params().value("edits") {
            Some(Value::List(items)) => items.clone(),
            Some(other) => bail!(
                "parameter `edits` must be a list of edits, found {}",
                other.shape()
            ),
            None => bail!("parameter `edits` is not declared"),
        };
        let edits = parse_edits(&items)?;
        let input = ports.scene;
        if edits.is_empty() && ports.fills.is_none() {
            ctx.forward("scene", "scene")?;
            return Ok(Outcome::Skipped(
                "no edits given; the scene is passed on unchanged".into(),
            ));
        }
        let mut scene = load_scene(&input)?;
        let log = apply_edits(&mut scene, &edits)?;
        let out = ports.scene_out;
        save_scene(&scene, &out)?;
        let fills = match ports.fills.as_deref() {
            Some(dir) => Some(dir.to_path_buf()),
            None => Some(input.join(SCENE_FILLS_DIR)).filter(|d| d.is_dir()),
        };
        let fill_count = match &fills {
            Some(dir) => copy_pngs(dir, &out.join(SCENE_FILLS_DIR))?,
            None => 0,
        };
        ctx.note("edits", edits.len());
        ctx.note("members", scene.objects.len());
        if !log.added.is_empty() {
            ctx.note("added", log.added.join(", "));
        }
        if !log.removed.is_empty() {
            ctx.note("removed", log.removed.join(", "));
        }
        if !log.displaced.is_empty() {
            ctx.note("displaced", log.displaced.join(", "));
            if fill_count == 0 {
                ctx.note(
                    "revealed areas",
                    "no background fills wired: uncovered pixels show the render's backdrop colour",
                );
            }
        }
        if fill_count > 0 {
            ctx.note("background fills", fill_count);
        }
        Ok(Outcome::Done)
    }
}

objectsplat_runtime::node_params! {
    /// The parameters of `render`.
    pub struct RenderParams {
        /// which cameras to render
        views: String = "\"test\"" as ParamType::enumeration(&["test", "train", "all", "orbit"]),
        /// number of orbit views (views: "orbit")
        orbit_count: i64 = "36" as ParamType::int_range(1, 3600),
        /// render backend: auto = a hardware GPU through wgpu, else the CPU backend; wgpu = a
        /// GPU or lavapipe
        backend: String = "\"auto\"" as ParamType::enumeration(&["auto", "cpu", "wgpu"]),
        /// sRGB colour [r, g, b] where nothing (and no fill) covers a pixel
        background: Vec<f64> = "[0.0, 0.0, 0.0]" as ParamType::list(ParamType::float_range(0.0, 1.0)),
        /// trained: the models as trained (soft edges, view-dependent colour); exported:
        /// as the .glb holds them (visible faces only, opaque, hard-edged, flat colours)
        appearance: String = "\"trained\"" as ParamType::enumeration(&["trained", "exported"]),
        /// samples per pixel side (1, 2 or 4), box-filtered as a camera integrates over its
        /// pixels: hard-edged triangles at one sample alias
        supersample: i64 = "2" as ParamType::int_range(1, 4),
    }
}

/// `render`: the scene from the frames' cameras or an orbit, as PNGs.
pub struct Render;

node_ports! {
    struct RenderPorts {
        /// the scene to render
        scene: input "Scene",
        /// cameras (and intrinsics/scale for the orbit)
        frames: input "Frames",
        /// per-frame background images (<frame stem>.png), e.g. from inpaint_background
        fills: optional "Images",
        /// one PNG per view
        images: output "Images",
    }
}

impl Node for Render {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("render", "4")
            .doc("Renders the (composed or edited) scene: all members' triangles in one pass, the renderer's depth order deciding; as trained, or (appearance: exported) as the .glb holds it — visible faces only, opaque, hard-edged, each vertex in its flat colour (fitted to its training views as the export draws them; the DC term for a model without one). Views: the frames' test/train/all cameras (PNG per frame, <frame stem>.png) or an orbit (orbit_000.png …) around the objects at the frames' mean height and distance. Where no triangle covers a pixel it shows the background fill of that frame (the `fills` input, else the scene's stored fills), else the `background` colour.")
            .ports::<RenderPorts>()
            .params::<RenderParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: RenderPorts = ctx.ports_as()?;
        let p: RenderParams = ctx.params_as()?;
        let views: String = p.views;
        let orbit_count: i64 = p.orbit_count;
        let backend: String = p.backend;
        let background: Vec<f64> = p.background;
        let supersample = p.supersample as u32;
        objectsplat_raster::supersample::validate(supersample)
            .context("parameter `supersample`")?;
        let (renderer, why) = objectsplat_raster_gpu::backend_for(&backend, ctx.threads())?;
        ctx.note("backend", why);
        let &[r, g, b] = background.as_slice() else {
            bail!(
                "parameter `background` must have 3 values [r, g, b], found {}",
                background.len()
            );
        };
        let uniform = [r as f32, g as f32, b as f32];
        let scene_dir = ports.scene;
        let scene = load_scene(&scene_dir)?;
        let frames = Frames::read(&ports.frames)?;
        let merged = scene.merged_model()?.model;
        let merged = match p.appearance.as_str() {
            "exported" => exported_model(&merged),
            _ => merged,
        };
        let fills = match ports.fills.as_deref() {
            Some(dir) => Some(dir.to_path_buf()),
            None => Some(scene_dir.join(SCENE_FILLS_DIR)).filter(|d| d.is_dir()),
        };
        let out = ports.images;

        let jobs: Vec<(String, objectsplat_core::Camera, Option<PathBuf>)> = if views == "orbit" {
            orbit_cameras(&scene, &frames.frames, orbit_count as usize)?
                .into_iter()
                .enumerate()
                .map(|(k, cam)| (format!("orbit_{k:03}"), cam, None))
                .collect()
        } else {
            let wanted = |s: Split| match views.as_str() {
                "test" => s == Split::Test,
                "train" => s == Split::Train,
                _ => true,
            };
            frames
                .frames
                .iter()
                .filter(|f| wanted(f.split))
                .map(|f| {
                    let stem = frame_stem(&f.name).to_string();
                    let fill = fills
                        .as_ref()
                        .map(|d| d.join(format!("{stem}.png")))
                        .filter(|p| p.is_file());
                    (stem, f.camera(), fill)
                })
                .collect()
        };
        if jobs.is_empty() {
            bail!(
                "{}: no frame has split {views:?}; nothing to render",
                frames.root.display()
            );
        }
        let mut filled = 0usize;
        for (k, (stem, camera, fill)) in jobs.iter().enumerate() {
            check_cancel(ctx)?;
            ctx.progress(k as u64, jobs.len() as u64, "rendering");
            let fill_image = match fill {
                Some(path) => Some(Image::load(path)?),
                None => None,
            };
            let backdrop = match &fill_image {
                Some(img) => {
                    filled += 1;
                    Backdrop::Image(img)
                }
                None => Backdrop::Uniform(uniform),
            };
            let image = render_view(&merged, camera, &backdrop, renderer.as_ref(), supersample)
                .with_context(|| match fill {
                    Some(p) => format!("view {stem} (background fill {})", p.display()),
                    None => format!("view {stem}"),
                })?;
            image.save_png8(&out.join(format!("{stem}.png")))?;
        }
        ctx.progress(jobs.len() as u64, jobs.len() as u64, "rendering");
        ctx.note("views", jobs.len());
        ctx.note("triangles", merged.face_count());
        if filled > 0 {
            ctx.note("views over a background fill", filled);
        }
        Ok(Outcome::Done)
    }
}

pub fn register(reg: &mut Registry) {
    // Each kind is registered once here; a clash means another crate took the same kind.
    reg.add_node(Arc::new(Compose))
        .expect("node kind `compose` is registered once");
    reg.add_node(Arc::new(EditScene))
        .expect("node kind `edit_scene` is registered once");
    reg.add_node(Arc::new(Render))
        .expect("node kind `render` is registered once");
    reg.add_node(Arc::new(LoadScene))
        .expect("node kind `load_scene` is registered once");
}
