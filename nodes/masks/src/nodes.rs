//! The `gt_masks`, `partition` and `point_visibility` nodes.
//!
//! The artifact types they speak (Frames, Mesh, Masks, Component) are registered by the
//! catalogue crate; [`register`] adds only the node kinds.

use crate::gpu_raster::IdRasterizer;
use crate::gt_masks::{GtMaskParams, drop_small_objects, face_mask_values, frame_mask};
use crate::partition::{PartitionParams, partition_folders};
use crate::raster::RasterOptions;
use anyhow::{Result, anyhow, bail};
use objectsplat_core::artifact::{FRAMES_JSON, MESH_PLY, OBJECTS_JSON};
use objectsplat_core::frames::frame_stem;
use objectsplat_core::masks::{NO_OBJECT, UNOWNED};
use objectsplat_core::visibility::Visibility;
use objectsplat_core::{Frames, read_mesh_artifact};
use objectsplat_gpu::{AdapterChoice, GpuContext};
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, ParamType, Registry, node_ports};
use std::collections::BTreeSet;
use std::sync::Arc;

/// Adds `gt_masks`, `partition` and `point_visibility` to `reg` (its types must be registered already).
pub fn register(reg: &mut Registry) {
    for node in [
        Arc::new(GtMasksNode) as Arc<dyn Node>,
        Arc::new(PartitionNode),
        Arc::new(PointVisibilityNode),
    ] {
        // The kinds are distinct constants; a clash is a programming error the registry tests catch.
        reg.add_node(node).expect("mask node kinds are unique");
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

node_ports! {
    struct GtMasksNodePorts {
        /// cameras to rasterize into
        frames: input "Frames",
        /// annotated mesh (per-vertex object_id + objects.json)
        mesh: input "Mesh",
        /// one 16-bit id map per frame + objects.json
        masks: output "Masks",
    }
}

impl Node for GtMasksNode {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("gt_masks", "2")
            .doc(
                "Rasterizes the annotated mesh into every frame (z-buffer: the nearest surface owns the pixel, so \
                 occlusion is resolved by depth and masks are mutually exclusive). Pixel = object id; 0 = a surface \
                 that is no kept object (background label, label not kept, or object below min_pixels in that \
                 frame); 65535 = no surface.",
            )
            .ports::<GtMasksNodePorts>()
            .params::<GtMasksParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: GtMasksNodePorts = ctx.ports_as()?;
        let p: GtMasksParams = ctx.params_as()?;
        let frames_dir = ports.frames;
        let mesh_dir = ports.mesh;
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
        let out = ports.masks;
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

node_ports! {
    struct PartitionNodePorts {
        /// the capture
        frames: input "Frames",
        /// mutually exclusive object masks
        masks: input "Masks",
        /// one item per object + the background
        components: output "[Component]",
    }
}

impl Node for PartitionNode {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("partition", "1")
            .doc(
                "Every pixel of every frame to exactly one component: one per retained object (obj_<id>_<label>, the \
                 frames where it owns a pixel) plus `background` (all frames; object-less and unowned pixels, and \
                 objects below the budget, listed with a reason in background/dropped.json). holistic: true is the \
                 baseline — a single component `scene` (kind background) owning every pixel of every frame.",
            )
            .ports::<PartitionNodePorts>()
            .params::<PartitionNodeParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: PartitionNodePorts = ctx.ports_as()?;
        let p: PartitionNodeParams = ctx.params_as()?;
        let params = PartitionParams {
            min_pixels: p.min_pixels,
            holistic: p.holistic,
        };
        let plan = partition_folders(
            &ports.frames,
            &ports.masks,
            &ports.components,
            &params,
            ctx.threads(),
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

pub struct PointVisibilityNode;

node_ports! {
    struct PointVisibilityNodePorts {
        /// the capture
        frames: input "Frames",
        /// the scene's sparse points
        points: input "Points",
        /// per frame, the points it sees
        visibility: output "Visibility",
    }
}

impl Node for PointVisibilityNode {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("point_visibility", "1")
            .doc(
                "Which sparse points every frame sees — in front of it, inside the image, not hidden behind \
                 nearer points (each point splatted at the points' neighbour spacing) — computed once per scene \
                 for the stages that assign points to a surface (train's point selection, surface_completion's \
                 and complete_surfaces' plane fits), the frames spread over the run's threads.",
            )
            .ports::<PointVisibilityNodePorts>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: PointVisibilityNodePorts = ctx.ports_as()?;
        let frames = Frames::read(&ports.frames)?;
        let points = objectsplat_core::Points::read_ply(
            &ports.points.join(objectsplat_core::artifact::POINTS_PLY),
        )?;
        let visibility = Visibility::compute(&points, &frames.frames, ctx.threads())?;
        let seen: usize = visibility.frames.iter().map(|(_, s)| s.len()).sum();
        ctx.note(
            "visible",
            format!(
                "{:.0} of {} points per frame on average, over {} frames",
                seen as f64 / frames.frames.len().max(1) as f64,
                points.positions.len(),
                frames.frames.len()
            ),
        );
        visibility.write(&ports.visibility)?;
        Ok(Outcome::Done)
    }
}
