//! Node wrappers: `synthetic_scene`, `gt_masks`, `partition`.
//!
//! The artifact types they speak (Frames, Mesh, Points, Masks, Component) are
//! registered by the catalogue crate; [`register`] adds only the node kinds.

use crate::gpu_raster::IdRasterizer;
use crate::gt_masks::{GtMaskParams, drop_small_objects, face_mask_values, frame_mask};
use crate::partition::{PartitionParams, partition_folders};
use crate::raster::RasterOptions;
use crate::scene::{SyntheticParams, generate};
use anyhow::{Result, anyhow, bail};
use objectsplat_core::artifact::{FRAMES_JSON, MESH_PLY, OBJECTS_JSON};
use objectsplat_core::frames::frame_stem;
use objectsplat_core::masks::{NO_OBJECT, UNOWNED};
use objectsplat_core::{Frames, SplitPolicy, read_mesh_artifact};
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, ParamType, Registry};
use objectsplat_wgpu::device::{AdapterChoice, GpuContext};
use std::collections::BTreeSet;
use std::sync::Arc;

/// Adds the three node kinds to `reg` (its types must be registered already).
pub fn register(reg: &mut Registry) {
    for node in [
        Arc::new(SyntheticSceneNode) as Arc<dyn Node>,
        Arc::new(GtMasksNode),
        Arc::new(PartitionNode),
    ] {
        // The kinds are distinct constants; a clash is a programming error the registry tests catch.
        reg.add_node(node).expect("synth node kinds are unique");
    }
}

fn int_param(ctx: &Context, name: &str) -> Result<i64> {
    ctx.param::<i64>(name)
}

/// Converts a validated integer parameter; the schema's range makes failure a schema bug.
fn to_u32(ctx: &Context, name: &str) -> Result<u32> {
    let v = int_param(ctx, name)?;
    u32::try_from(v).map_err(|_| anyhow!("parameter `{name}` = {v} does not fit 0..=4294967295"))
}

pub struct SyntheticSceneNode;

impl Node for SyntheticSceneNode {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("synthetic_scene", "1")
            .doc(
                "Procedural room (floor, walls, ceiling, a table, box, cup, ball, chair, bin) with textured surfaces and \
                 baked lighting, rendered from an orbit of cameras around the table; the annotated ground-truth mesh; \
                 and SfM-like sparse points (surface samples seen by ≥ 2 cameras, with Gaussian noise). Deterministic \
                 from its seed.",
            )
            .output("frames", "Frames", "rendered views, frame_000… (8-bit PNG)")
            .output("mesh", "Mesh", "the complete annotated mesh (per-vertex object_id, objects.json)")
            .output("points", "Points", "sparse coloured points")
            .param("seed", ParamType::Int { min: Some(0), max: None }, Some("7"), "layout, colours and noise")
            .param("views", ParamType::int_range(1, 10_000), Some("24"), "number of frames")
            .param("width", ParamType::int_range(8, 8192), Some("160"), "image width in pixels")
            .param("height", ParamType::int_range(8, 8192), Some("120"), "image height in pixels")
            .param(
                "split",
                ParamType::enumeration(&["sparse", "dense", "all"]),
                Some("\"sparse\""),
                "sparse: train 1 of 8 frames; dense: train 7 of 8; all: train on every frame",
            )
            .param("resolution", ParamType::int_range(1, 64), Some("1"), "integer downscale factor of width×height")
            .param(
                "max_width",
                ParamType::optional(ParamType::int_range(8, 8192)),
                Some("None"),
                "cap on the image width in pixels, after `resolution` (aspect kept)",
            )
            .param("table", ParamType::Bool, Some("true"), "false: no table, the small objects stand on the floor")
            .param("points", ParamType::int_range(0, 10_000_000), Some("4000"), "number of sparse points")
            .param("points_noise", ParamType::float_range(0.0, 0.5), Some("0.01"), "point noise standard deviation (m)")
            .param("supersample", ParamType::int_range(1, 8), Some("2"), "anti-aliasing samples per pixel per axis")
            .param("fov", ParamType::float_range(20.0, 120.0), Some("60.0"), "horizontal field of view (degrees)")
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let split = match ctx.param::<String>("split")?.as_str() {
            "sparse" => SplitPolicy::Sparse,
            "dense" => SplitPolicy::Dense,
            "all" => SplitPolicy::All,
            other => bail!("split {other:?} is not one of \"sparse\", \"dense\", \"all\""),
        };
        let params = SyntheticParams {
            seed: int_param(ctx, "seed")? as u64,
            views: to_u32(ctx, "views")? as usize,
            width: to_u32(ctx, "width")?,
            height: to_u32(ctx, "height")?,
            split,
            resolution: to_u32(ctx, "resolution")?,
            max_width: ctx
                .param::<Option<i64>>("max_width")?
                .map(|w| w.clamp(8, 8192) as u32),
            table: ctx.param("table")?,
            points: to_u32(ctx, "points")? as usize,
            points_noise: ctx.param("points_noise")?,
            supersample: to_u32(ctx, "supersample")?,
            fov_degrees: ctx.param("fov")?,
            threads: ctx.threads().max(1),
        };
        let scene = generate(&params)?;
        scene.write(
            &ctx.output("frames")?,
            &ctx.output("mesh")?,
            &ctx.output("points")?,
        )?;
        let (w, h) = params.image_size();
        ctx.note("frames", format!("{} at {w}×{h}", scene.frames.len()));
        ctx.note(
            "mesh",
            format!(
                "{} faces, {} objects",
                scene.mesh.faces.len(),
                scene.labels.len()
            ),
        );
        ctx.note("points", scene.points.positions.len());
        Ok(Outcome::Done)
    }
}

pub struct GtMasksNode;

impl Node for GtMasksNode {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("gt_masks", "2")
            .doc(
                "Rasterizes the annotated mesh into every frame (z-buffer: the nearest surface owns the pixel, so \
                 occlusion is resolved by depth and masks are mutually exclusive). Pixel = object id; 0 = a surface \
                 that is no kept object (background label, label not kept, or object below min_pixels in that \
                 frame); 65535 = no surface.",
            )
            .input("frames", "Frames", "cameras to rasterize into")
            .input("mesh", "Mesh", "annotated mesh (per-vertex object_id + objects.json)")
            .output("masks", "Masks", "one 16-bit id map per frame + objects.json")
            .param("keep_labels", ParamType::list(ParamType::Str), Some("[]"), "labels to keep (empty = all objects)")
            .param(
                "background_labels",
                ParamType::list(ParamType::Str),
                Some("[\"wall\", \"floor\", \"ceiling\"]"),
                "labels that belong to the background (id 0)",
            )
            .param(
                "min_pixels",
                ParamType::optional(ParamType::Int { min: Some(0), max: None }),
                Some("None"),
                "per-frame pixel count below which an object is dropped from that frame; None = min_fraction × frame area",
            )
            .param("min_fraction", ParamType::float_range(0.0, 1.0), Some("0.0005"), "used when min_pixels is None")
            .param(
                "backend",
                ParamType::enumeration(&["auto", "cpu", "wgpu"]),
                // Both give bit-identical masks; cpu is the default because lavapipe (the
                // wgpu adapter of GPU-less machines) is slower than it (docs/benchmarks).
                Some("\"cpu\""),
                "rasterizer: cpu; wgpu (a GPU, else Mesa lavapipe; bit-identical masks); auto = wgpu when an \
                 adapter is found, else cpu",
            )
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let frames_dir = ctx.input("frames")?.to_path_buf();
        let mesh_dir = ctx.input("mesh")?.to_path_buf();
        let frames = Frames::read(&frames_dir)?;
        let (mesh, labels) = read_mesh_artifact(&mesh_dir)?;
        let min_pixels: Option<i64> = ctx.param("min_pixels")?;
        let params = GtMaskParams {
            keep_labels: ctx.param("keep_labels")?,
            background_labels: ctx.param("background_labels")?,
            min_pixels: min_pixels.map(|v| v.max(0) as u64),
            min_fraction: ctx.param("min_fraction")?,
            raster: RasterOptions {
                near: 0.01,
                threads: ctx.threads().max(1),
            },
        };
        let backend: String = ctx.param("backend")?;
        let gpu = gpu_for_backend(ctx, &backend)?;
        let rasterizer = match &gpu {
            None => None,
            Some((device, why)) => match IdRasterizer::new(device) {
                Ok(r) => {
                    ctx.note("backend", format!("{why} (backend {backend:?})"));
                    Some(r)
                }
                Err(e) if backend == "auto" => {
                    ctx.note(
                        "backend",
                        format!("cpu (auto: the wgpu rasterizer does not build: {e:#})"),
                    );
                    None
                }
                Err(e) => return Err(e),
            },
        };
        let objects_json = mesh_dir.join(OBJECTS_JSON);
        let face_values = face_mask_values(&mesh, &labels, &params).map_err(|e| {
            anyhow!(
                "{} (with {}): {e}",
                mesh_dir.join(MESH_PLY).display(),
                objects_json.display()
            )
        })?;
        let out = ctx.output("masks")?;
        let mut stems = BTreeSet::new();
        let mut present = BTreeSet::new();
        let total = frames.frames.len() as u64;
        for (i, frame) in frames.frames.iter().enumerate() {
            if ctx.cancelled() {
                bail!("interrupted");
            }
            let stem = frame_stem(&frame.name);
            if !stems.insert(stem.to_string()) {
                bail!(
                    "{}: two frames share the mask name {stem}.png",
                    frames_dir.join(FRAMES_JSON).display()
                );
            }
            let camera = frame.camera();
            let mask = match &rasterizer {
                None => frame_mask(&mesh, &face_values, &camera, &params).map_err(|e| anyhow!(e)),
                Some(r) => r
                    .rasterize_ids(
                        &mesh.positions,
                        &mesh.faces,
                        &face_values,
                        &camera,
                        params.raster.near,
                    )
                    .map(|ids| drop_small_objects(camera.width, camera.height, ids, &params)),
            }
            .map_err(|e| {
                anyhow!(
                    "{}: frame {:?}: {e:#}",
                    frames_dir.join(FRAMES_JSON).display(),
                    frame.name
                )
            })?;
            present.extend(
                mask.data
                    .iter()
                    .copied()
                    .filter(|&v| v != NO_OBJECT && v != UNOWNED),
            );
            mask.save(&out.join(format!("{stem}.png")))?;
            ctx.progress(i as u64 + 1, total, "rasterizing frames");
        }
        let kept: objectsplat_core::ObjectLabels = present
            .into_iter()
            .map(|id| (id, labels[&id].clone()))
            .collect();
        objectsplat_core::masks::write_objects(&out, &kept)?;
        ctx.note(
            "objects",
            kept.values().cloned().collect::<Vec<_>>().join(", "),
        );
        Ok(Outcome::Done)
    }
}

/// The wgpu device for the `backend` param and why it was chosen, or `None` for the
/// CPU rasterizer (noted here, with the reason).
fn gpu_for_backend(ctx: &mut Context, backend: &str) -> Result<Option<(Arc<GpuContext>, String)>> {
    let found = match backend {
        "cpu" => {
            ctx.note("backend", "cpu (requested)");
            return Ok(None);
        }
        "wgpu" | "auto" => GpuContext::shared(AdapterChoice::Auto),
        other => bail!("backend {other:?} is not one of \"auto\", \"cpu\", \"wgpu\""),
    };
    match found {
        Ok(gpu) => Ok(Some(gpu)),
        Err(e) if backend == "auto" => {
            ctx.note("backend", format!("cpu (auto: no wgpu adapter: {e:#})"));
            Ok(None)
        }
        Err(e) => Err(e.context("backend \"wgpu\" was requested but no wgpu adapter is usable")),
    }
}

pub struct PartitionNode;

impl Node for PartitionNode {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("partition", "1")
            .doc(
                "Every pixel of every frame to exactly one component: one per retained object (obj_<id>_<label>, the \
                 frames where it owns a pixel) plus `background` (all frames; object-less and unowned pixels, and \
                 objects below the budget, listed with a reason in background/dropped.json). holistic: true is the \
                 baseline — a single component `scene` (kind background) owning every pixel of every frame.",
            )
            .input("frames", "Frames", "the capture")
            .input("masks", "Masks", "mutually exclusive object masks")
            .output("components", "[Component]", "one item per object + the background")
            .param(
                "min_pixels",
                ParamType::optional(ParamType::Int { min: Some(0), max: None }),
                Some("None"),
                "whole-capture pixel budget for an object to become a component; None = 1% of the mean frame area",
            )
            .param("holistic", ParamType::Bool, Some("false"), "one component for the whole frame (the baseline)")
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let min_pixels: Option<i64> = ctx.param("min_pixels")?;
        let params = PartitionParams {
            min_pixels: min_pixels.map(|v| v.max(0) as u64),
            holistic: ctx.param("holistic")?,
        };
        let plan = partition_folders(
            ctx.input("frames")?,
            ctx.input("masks")?,
            &ctx.output("components")?,
            &params,
        )?;
        let names: Vec<&str> = plan
            .components
            .iter()
            .map(|c| c.info.name.as_str())
            .collect();
        ctx.note("components", names.join(", "));
        for d in &plan.dropped {
            ctx.warn(format!(
                "object {} ({}) dropped: {}",
                d.object_id, d.label, d.reason
            ));
        }
        Ok(Outcome::Done)
    }
}
