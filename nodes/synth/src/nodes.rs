//! The `synthetic_scene` node.
//!
//! The artifact types it writes (Frames, Mesh, Points) are registered by the catalogue
//! crate; [`register`] adds only the node kind.

use crate::scene::{CameraPath, Surfaces, SyntheticParams, generate};
use anyhow::{Result, bail};
use objectsplat_core::SplitPolicy;
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, ParamType, Registry, node_ports};
use std::sync::Arc;

/// Adds `synthetic_scene` to `reg` (its types must be registered already).
pub fn register(reg: &mut Registry) {
    // A clash means another crate registered the kind first, which the catalogue's tests catch.
    reg.add_node(Arc::new(SyntheticSceneNode) as Arc<dyn Node>)
        .expect("synthetic_scene is registered once");
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
        /// how the cameras move: orbit around the table; walk a loop along the walls
        /// looking across the room; inside: stand by the table and turn, looking out;
        /// tabletop: a close orbit over the objects on the table
        cameras: String = "\"orbit\"" as ParamType::enumeration(&["orbit", "walk", "inside", "tabletop"]),
        /// what covers the room's shell: plain (wooden planks, striped wallpaper) or
        /// fine (a brick wainscot, a notice of text-like glyphs on every wall, a tiled
        /// floor and a rug: detail a few pixels wide and finer)
        surfaces: String = "\"plain\"" as ParamType::enumeration(&["plain", "fine"]),
    }
}

pub struct SyntheticSceneNode;

node_ports! {
    struct SyntheticSceneNodePorts {
        /// rendered views, frame_000… (8-bit PNG)
        frames: output "Frames",
        /// the complete annotated mesh (per-vertex object_id, objects.json)
        mesh: output "Mesh",
        /// sparse coloured points
        points: output "Points",
    }
}

impl Node for SyntheticSceneNode {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("synthetic_scene", "1")
            .doc(
                "Procedural room (floor, walls, ceiling, a table, box, cup, ball, chair, bin) with textured surfaces \
                 (plain: planks and wallpaper; fine: a brick wainscot, a notice of glyphs, tiles and a rug) and baked lighting, rendered from an orbit of cameras around the table (or a walk along the walls, from beside the table looking out, or a close orbit over the table top); the annotated ground-truth mesh; \
                 and SfM-like sparse points (surface samples seen by ≥ 2 cameras, with Gaussian noise). Deterministic \
                 from its seed.",
            )
            .ports::<SyntheticSceneNodePorts>()
            .params::<SyntheticSceneParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: SyntheticSceneNodePorts = ctx.ports_as()?;
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
            path: CameraPath::parse(&p.cameras)?,
            surfaces: Surfaces::parse(&p.surfaces)?,
            threads: ctx.threads().max(1),
        };
        let scene = generate(&params)?;
        scene.write(&ports.frames, &ports.mesh, &ports.points)?;
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
