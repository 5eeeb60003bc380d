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

objectsplat_runtime::node_params! {
    /// The parameters of `synthetic_scene`.
    pub struct SyntheticSceneParams {
        /// layout, colours and noise
        seed: u64 = "7" as ParamType::Int { min: Some(0), max: None },
        /// number of frames
        views: usize = "24" as ParamType::int_range(1, 10_000),
        /// image width in pixels
        width: u32 = "160" as ParamType::int_range(8, 8192),
        /// image height in pixels
        height: u32 = "120" as ParamType::int_range(8, 8192),
        /// sparse: train 1 of 8 frames; dense: train 7 of 8; all: train on every frame
        split: String = "\"sparse\"" as ParamType::enumeration(&["sparse", "dense", "all"]),
        /// integer downscale factor of width×height
        resolution: u32 = "1" as ParamType::int_range(1, 64),
        /// cap on the image width in pixels, after `resolution` (aspect kept)
        max_width: Option<u32> = "None" as ParamType::optional(ParamType::int_range(8, 8192)),
        /// false: no table, the small objects stand on the floor
        table: bool = "true" as ParamType::Bool,
        /// number of sparse points
        points: usize = "4000" as ParamType::int_range(0, 10_000_000),
        /// point noise standard deviation (m)
        points_noise: f64 = "0.01" as ParamType::float_range(0.0, 0.5),
        /// anti-aliasing samples per pixel per axis
        supersample: u32 = "2" as ParamType::int_range(1, 8),
        /// horizontal field of view (degrees)
        fov: f64 = "60.0" as ParamType::float_range(20.0, 120.0),
    }
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
            .params::<SyntheticSceneParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let p: SyntheticSceneParams = ctx.params_as()?;
        let split = match p.split.as_str() {
            "sparse" => SplitPolicy::Sparse,
            "dense" => SplitPolicy::Dense,
            "all" => SplitPolicy::All,
            other => bail!("split {other:?} is not one of \"sparse\", \"dense\", \"all\""),
        };
        let params = SyntheticParams {
            seed: p.seed,
            views: p.views,
            width: p.width,
            height: p.height,
            split,
            resolution: p.resolution,
            max_width: p.max_width,
            table: p.table,
            points: p.points,
            points_noise: p.points_noise,
            supersample: p.supersample,
            fov_degrees: p.fov,
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

objectsplat_runtime::node_params! {
    /// The parameters of `gt_masks`.
    pub struct GtMasksParams {
        /// labels to keep (empty = all objects)
        keep_labels: Vec<String> = "[]" as ParamType::list(ParamType::Str),
        /// labels that belong to the background (id 0)
        background_labels: Vec<String> = "[\"wall\", \"floor\", \"ceiling\"]" as ParamType::list(ParamType::Str),
        /// per-frame pixel count below which an object is dropped from that frame; None =
        /// min_fraction × frame area
        min_pixels: Option<u64> = "None" as ParamType::optional(ParamType::Int { min: Some(0), max: None }),
        /// used when min_pixels is None
        min_fraction: f64 = "0.0005" as ParamType::float_range(0.0, 1.0),
        // Both give bit-identical masks; cpu is the default because lavapipe (the wgpu
        // adapter of GPU-less machines) is slower than it (docs/benchmarks).
        /// rasterizer: cpu; wgpu (a GPU, else Mesa lavapipe; bit-identical masks); auto = wgpu
        /// when an adapter is found, else cpu
        backend: String = "\"cpu\"" as ParamType::enumeration(&["auto", "cpu", "wgpu"]),
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
            .params::<GtMasksParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let p: GtMasksParams = ctx.params_as()?;
        let frames_dir = ctx.input("frames")?.to_path_buf();
        let mesh_dir = ctx.input("mesh")?.to_path_buf();
        let frames = Frames::read(&frames_dir)?;
        let (mesh, labels) = read_mesh_artifact(&mesh_dir)?;
        let params = GtMaskParams {
            keep_labels: p.keep_labels,
            background_labels: p.background_labels,
            min_pixels: p.min_pixels,
            min_fraction: p.min_fraction,
            raster: RasterOptions {
                near: 0.01,
                threads: ctx.threads().max(1),
            },
        };
        let backend = p.backend;
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

objectsplat_runtime::node_params! {
    /// The parameters of `partition`.
    pub struct PartitionNodeParams {
        /// whole-capture pixel budget for an object to become a component; None = 1% of the
        /// mean frame area
        min_pixels: Option<u64> = "None" as ParamType::optional(ParamType::Int { min: Some(0), max: None }),
        /// one component for the whole frame (the baseline)
        holistic: bool = "false" as ParamType::Bool,
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
            .params::<PartitionNodeParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let p: PartitionNodeParams = ctx.params_as()?;
        let params = PartitionParams {
            min_pixels: p.min_pixels,
            holistic: p.holistic,
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
