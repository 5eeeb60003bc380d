//! Dataflow nodes: `colmap_scene`, `nerfstudio_scene`, `scannetpp_scene`, `import_masks`.
//!
//! Shared scene-source params: `split` ("sparse" | "dense" | "all"), `resolution`
//! (integer downscale factor) and `max_width` (optional width cap in pixels).

use crate::masks_import::{self, MaskFormat, OverlapPolicy};
use crate::scannetpp::{self, GroupOverlap, PoseSource};
use crate::scene::{self, Resolution};
use crate::{colmap, colmap_scene, nerfstudio};
use anyhow::{Context as _, Result, bail};
use objectsplat_core::SplitPolicy;
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, ParamType, Params, Registry};
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn with_scene_params(spec: NodeSpec) -> NodeSpec {
    spec.param(
        "split",
        ParamType::enumeration(&["sparse", "dense", "all"]),
        Some("\"sparse\""),
        "sparse: train 1 of 8 frames (sorted by name); dense: train 7 of 8; all: train on every frame",
    )
    .param("resolution", ParamType::int_range(1, 64), Some("1"), "integer downscale factor of width×height")
    .param(
        "max_width",
        ParamType::optional(ParamType::int_range(1, 100_000)),
        Some("None"),
        "cap on the output width in pixels, after `resolution` (aspect kept)",
    )
}

fn split_param(ctx: &Context) -> Result<SplitPolicy> {
    Ok(match ctx.param::<String>("split")?.as_str() {
        "sparse" => SplitPolicy::Sparse,
        "dense" => SplitPolicy::Dense,
        "all" => SplitPolicy::All,
        other => bail!("split {other:?} is not sparse, dense or all"),
    })
}

fn resolution_param(ctx: &Context) -> Result<Resolution> {
    Resolution::new(ctx.param("resolution")?, ctx.param("max_width")?)
}

/// `colmap_scene`: a COLMAP sparse model and its images.
pub struct ColmapScene;

impl Node for ColmapScene {
    fn spec(&self) -> NodeSpec {
        with_scene_params(
            NodeSpec::new("colmap_scene", "1")
                .doc("A COLMAP sparse model (text or binary, classic or rigs/frames layout) with PINHOLE or SIMPLE_PINHOLE cameras, and its images.")
                .output("frames", "Frames", "posed images, split and downscaled")
                .output("points", "Points", "the model's 3D points with colours")
                .param("path", ParamType::Path, None, "sparse model folder (or a project folder holding sparse/0)")
                .param(
                    "images",
                    ParamType::optional(ParamType::Path),
                    Some("None"),
                    "image folder; default: the first of <path>/images, <path>/../images, <path>/../../images",
                ),
        )
    }

    /// The default image folder is found beside the model, outside the `path` param.
    fn reads(&self, params: &Params) -> Result<Vec<PathBuf>> {
        if params.get::<Option<String>>("images")?.is_some() {
            return Ok(Vec::new());
        }
        Ok(vec![default_images_dir(Path::new(
            &params.get::<String>("path")?,
        ))?])
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let path = PathBuf::from(ctx.param::<String>("path")?);
        let model = colmap::read_model(&path)?;
        let images = match ctx.param::<Option<String>>("images")? {
            Some(p) => PathBuf::from(p),
            None => default_images_dir(&path)?,
        };
        let views = colmap_scene::views(&model, &images)?;
        ctx.progress(0, 2, "writing frames");
        let frames = scene::write_frames(
            &ctx.output("frames")?,
            views,
            split_param(ctx)?,
            resolution_param(ctx)?,
        )?;
        ctx.progress(1, 2, "writing points");
        scene::write_points(&ctx.output("points")?, &colmap_scene::points(&model))?;
        ctx.progress(2, 2, "done");
        ctx.note("frames", frames.len());
        ctx.note("points", model.points.len());
        ctx.note(
            "layout",
            if model.rigs.is_some() {
                "rigs/frames"
            } else {
                "classic"
            },
        );
        ctx.note("encoding", format!("{:?}", model.encoding).to_lowercase());
        Ok(Outcome::Done)
    }
}

fn default_images_dir(model: &Path) -> Result<PathBuf> {
    let candidates = [
        model.join("images"),
        model.join("../images"),
        model.join("../../images"),
    ];
    candidates.iter().find(|p| p.is_dir()).cloned().with_context(|| {
        format!("{}: no images folder beside the model (looked for images, ../images, ../../images); set `images`", model.display())
    })
}

/// `nerfstudio_scene`: a transforms.json capture.
pub struct NerfstudioScene;

impl Node for NerfstudioScene {
    fn spec(&self) -> NodeSpec {
        with_scene_params(
            NodeSpec::new("nerfstudio_scene", "1")
                .doc("A nerfstudio/instant-ngp transforms.json (OpenGL camera-to-world, converted to OpenCV) with undistorted cameras.")
                .output("frames", "Frames", "posed images, split and downscaled; mask_path becomes valid/<stem>.png")
                .param("path", ParamType::Path, None, "the transforms.json file"),
        )
    }

    /// The images and masks the JSON lists (the `path` param covers the JSON only).
    fn reads(&self, params: &Params) -> Result<Vec<PathBuf>> {
        let path = PathBuf::from(params.get::<String>("path")?);
        let t = nerfstudio::read(&path, &nerfstudio::Roots::default())?;
        Ok(t.frames
            .into_iter()
            .flat_map(|f| std::iter::once(f.image).chain(f.mask))
            .collect())
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let path = PathBuf::from(ctx.param::<String>("path")?);
        let t = nerfstudio::read(&path, &nerfstudio::Roots::default())?;
        let views = t.views(glam::DMat4::IDENTITY)?;
        let frames = scene::write_frames(
            &ctx.output("frames")?,
            views,
            split_param(ctx)?,
            resolution_param(ctx)?,
        )?;
        ctx.note("frames", frames.len());
        if t.skipped_bad > 0 {
            ctx.note("skipped is_bad frames", t.skipped_bad);
        }
        Ok(Outcome::Done)
    }
}

/// `scannetpp_scene`: one ScanNet++ scene folder.
pub struct ScannetppScene;

impl Node for ScannetppScene {
    fn spec(&self) -> NodeSpec {
        with_scene_params(
            NodeSpec::new("scannetpp_scene", "1")
                .doc("A ScanNet++ scene folder: undistorted DSLR images, COLMAP poses (mesh frame), the annotated mesh.")
                .output("frames", "Frames", "posed undistorted DSLR images")
                .output("mesh", "Mesh", "mesh_aligned_0.05 with per-vertex object ids and labels")
                .output("points", "Points", "COLMAP points (mesh vertices when there are none)")
                .param("path", ParamType::Path, None, "the scene folder (holding dslr/ and scans/)")
                .param(
                    "overlap",
                    ParamType::enumeration(&GroupOverlap::NAMES),
                    Some("\"smallest\""),
                    "a vertex in several annotation groups goes to the smallest group, the first, or the last",
                )
                .param(
                    "background_labels",
                    ParamType::list(ParamType::Str),
                    Some("[\"wall\", \"floor\", \"ceiling\"]"),
                    "annotation labels kept as background (no object id), compared case-insensitively",
                ),
        )
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let path = PathBuf::from(ctx.param::<String>("path")?);
        let overlap = GroupOverlap::parse(&ctx.param::<String>("overlap")?)?;
        let background: Vec<String> = ctx.param("background_labels")?;
        let s = scannetpp::load(&path, overlap, &background)?;
        let frames = scene::write_frames(
            &ctx.output("frames")?,
            s.views,
            split_param(ctx)?,
            resolution_param(ctx)?,
        )?;
        objectsplat_core::write_mesh_artifact(&ctx.output("mesh")?, &s.mesh, &s.labels)?;
        scene::write_points(&ctx.output("points")?, &s.points)?;
        ctx.note("frames", frames.len());
        ctx.note(
            "poses",
            match s.pose_source {
                PoseSource::Colmap => "dslr/colmap (nerfstudio JSON centres checked within 1 mm)",
                PoseSource::NerfstudioJson => {
                    "nerfstudio JSON with the mesh frame change (checked against mesh bounds)"
                }
            },
        );
        ctx.note("objects", s.labels.len());
        ctx.note("vertices in several groups", s.contested_vertices);
        if s.skipped_bad > 0 {
            ctx.note("skipped is_bad frames", s.skipped_bad);
        }
        Ok(Outcome::Done)
    }
}

/// `import_masks`: SAM-family masks as a Masks artifact.
pub struct ImportMasks;

/// Per-object lines in the report beyond this many are summarised.
const REPORTED_OBJECTS: usize = 40;

impl Node for ImportMasks {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("import_masks", "1")
            .doc("Imports DAVIS indexed PNGs, per-object PNG folders, SAM COCO-RLE JSON or Grounded-SAM-2 output as mutually exclusive id maps.")
            .input("frames", "Frames", "the frames the masks belong to (names and sizes)")
            .output("masks", "Masks", "one 16-bit id map per frame + objects.json")
            .param("path", ParamType::Path, None, "the folder holding the masks")
            .param("format", ParamType::enumeration(&MaskFormat::NAMES), None, "how the masks are stored")
            .param(
                "overlap",
                ParamType::enumeration(&OverlapPolicy::NAMES),
                Some("\"lower_id\""),
                "which mask keeps a pixel claimed by several: first in source order, smaller area, or higher score",
            )
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let source = PathBuf::from(ctx.param::<String>("path")?);
        let format = MaskFormat::parse(&ctx.param::<String>("format")?)?;
        let policy = OverlapPolicy::parse(&ctx.param::<String>("overlap")?)?;
        let frames = ctx.input("frames")?.to_path_buf();
        let out = ctx.output("masks")?;
        let summary = {
            let ctx_ref: &Context = ctx;
            masks_import::import(&source, format, policy, &frames, &out, |done, total| {
                ctx_ref.progress(done as u64, total as u64, "importing masks")
            })?
        };
        ctx.note("objects", summary.objects.len());
        ctx.note("overlapping pixels resolved", summary.overlapping_pixels);
        if summary.hidden_masks > 0 {
            ctx.note("masks hidden entirely by overlaps", summary.hidden_masks);
        }
        if summary.void_pixels > 0 {
            ctx.note("void (255) pixels", summary.void_pixels);
        }
        if !summary.frames_without_masks.is_empty() {
            ctx.warn(format!(
                "{} of {} frames have no mask file and are all background (first: {})",
                summary.frames_without_masks.len(),
                summary.frames,
                summary.frames_without_masks[0]
            ));
        }
        for o in summary.objects.iter().take(REPORTED_OBJECTS) {
            ctx.note(&format!("object {}", o.id), o.describe(summary.frames));
        }
        if summary.objects.len() > REPORTED_OBJECTS {
            ctx.note(
                "objects not listed",
                summary.objects.len() - REPORTED_OBJECTS,
            );
        }
        Ok(Outcome::Done)
    }
}

pub fn register(reg: &mut Registry) {
    // The kinds are distinct constants; a clash is a programming error caught by the registry tests.
    for node in [
        Arc::new(ColmapScene) as Arc<dyn Node>,
        Arc::new(NerfstudioScene),
        Arc::new(ScannetppScene),
        Arc::new(ImportMasks),
    ] {
        reg.add_node(node).expect("input node kinds are unique");
    }
}
