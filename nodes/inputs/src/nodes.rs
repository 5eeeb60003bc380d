//! Dataflow nodes: `colmap_scene`, `nerfstudio_scene`, `scannetpp_scene`, `import_masks`
//! (and, from [`crate::sfm_nodes`], `colmap_sfm` and `video_frames`).
//!
//! Shared scene-source params: `split` ("sparse" | "dense" | "all", plus "lists" for
//! sources that carry their own train/test lists), `resolution` (integer downscale
//! factor) and `max_width` (optional width cap in pixels).

use crate::masks_import::{self, MaskFormat, OverlapPolicy};
use crate::scannetpp::{self, GroupOverlap, PoseSource};
use crate::scene::{self, Resolution, SplitChoice, WrittenFrames};
use crate::{colmap, colmap_scene, nerfstudio};
use anyhow::{Context as _, Result, bail};
use objectsplat_core::{Split, SplitPolicy};
use objectsplat_runtime::{
    Context, Node, NodeSpec, Outcome, ParamType, Params, Registry, node_ports,
};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The shared scene-source params; `lists` says where `split: "lists"` takes its lists
/// from (`None`: the source has none, so the option is not offered).
pub(crate) fn with_scene_params(spec: NodeSpec, lists: Option<&str>) -> NodeSpec {
    let mut splits = vec!["sparse", "dense", "all"];
    let mut doc = String::from(
        "sparse: train 1 of 8 frames (sorted by name); dense: train 7 of 8; all: train on every frame",
    );
    if let Some(lists) = lists {
        splits.push("lists");
        doc += &format!(
            "; lists: the source's own train/test lists ({lists}). Frames the source lists as test \
             frames stay test frames under sparse and dense (the rule splits the others)"
        );
    }
    // `split`'s choices and doc depend on the source, so it is declared here by hand.
    spec.param(
        "split",
        ParamType::enumeration(&splits),
        Some("\"sparse\""),
        &doc,
    )
    .params::<ResolutionParams>()
}

objectsplat_runtime::node_params! {
    /// How every scene source scales its images.
    pub struct ResolutionParams {
        /// integer downscale factor of width×height
        resolution: i64 = "1" as ParamType::int_range(1, 64),
        /// cap on the output width in pixels, after `resolution` (aspect kept)
        max_width: Option<i64> = "None" as ParamType::optional(ParamType::int_range(1, 100_000)),
    }
}

/// The split choice; `lists` names where `split: "lists"` reads its lists, or says why
/// there are none.
pub(crate) fn split_param(
    ctx: &Context,
    lists: impl FnOnce() -> Result<String>,
) -> Result<SplitChoice> {
    Ok(match ctx.param::<String>("split")?.as_str() {
        "sparse" => SplitChoice::Rule(SplitPolicy::Sparse),
        "dense" => SplitChoice::Rule(SplitPolicy::Dense),
        "all" => SplitChoice::Rule(SplitPolicy::All),
        "lists" => SplitChoice::Lists(lists()?),
        other => bail!("split {other:?} is not sparse, dense, all or lists"),
    })
}

fn resolution_param(ctx: &Context) -> Result<Resolution> {
    let p: ResolutionParams = ctx.params_as()?;
    Resolution::new(p.resolution, p.max_width)
}

/// Writes the `frames` output into `out`, scaled by the shared resolution params.
pub(crate) fn write_frames_output(
    ctx: &Context,
    out: &Path,
    views: Vec<scene::SourceView>,
    split: &SplitChoice,
) -> Result<WrittenFrames> {
    scene::write_frames(out, views, split, resolution_param(ctx)?, ctx.threads())
}

/// Report lines for the frames a source wrote: how many, how they split, what was undistorted.
pub(crate) fn note_frames(ctx: &mut Context, written: &WrittenFrames) {
    let test = written
        .frames
        .iter()
        .filter(|f| f.split == Split::Test)
        .count();
    ctx.note("frames", written.frames.len());
    ctx.note(
        "split",
        format!("{} train, {test} test", written.frames.len() - test),
    );
    if written.undistorted_frames > 0 {
        let cameras: Vec<String> = written
            .undistorted_cameras
            .iter()
            .map(|(from, to)| {
                format!(
                    "{}×{} → pinhole {}×{} (fx {:.3}, fy {:.3}, cx {:.3}, cy {:.3})",
                    from.width, from.height, to.width, to.height, to.fx, to.fy, to.cx, to.cy
                )
            })
            .collect();
        ctx.note(
            "undistorted",
            format!(
                "{} frames; {}",
                written.undistorted_frames,
                cameras.join("; ")
            ),
        );
    }
}

objectsplat_runtime::node_params! {
    /// The parameters of `colmap_scene`.
    pub struct ColmapSceneParams {
        /// sparse model folder (or a project folder holding sparse/0)
        path: String = required as ParamType::Path,
        /// image folder; default: the first of <path>/images, <path>/../images,
        /// <path>/../../images
        images: Option<String> = "None" as ParamType::optional(ParamType::Path),
    }
}

/// `colmap_scene`: a COLMAP sparse model and its images.
pub struct ColmapScene;

node_ports! {
    struct ColmapScenePorts {
        /// posed images, split and downscaled
        frames: output "Frames",
        /// the model's 3D points with colours
        points: output "Points",
    }
}

impl Node for ColmapScene {
    fn spec(&self) -> NodeSpec {
        with_scene_params(
            NodeSpec::new("colmap_scene", "1")
                .doc("A COLMAP sparse model (text or binary, classic or rigs/frames layout) and its images. Distorted cameras (SIMPLE_RADIAL, RADIAL, OPENCV, FULL_OPENCV, OPENCV_FISHEYE, SIMPLE_RADIAL_FISHEYE, RADIAL_FISHEYE) are undistorted to the pinhole camera COLMAP's image_undistorter would choose, images resampled bilinearly.")
                .ports::<ColmapScenePorts>()
                .params::<ColmapSceneParams>(),
            None,
        )
    }

    /// The default image folder is found beside the model, outside the `path` param.
    fn reads(&self, params: &Params) -> Result<Vec<PathBuf>> {
        let p: ColmapSceneParams = params.read_as()?;
        if p.images.is_some() {
            return Ok(Vec::new());
        }
        Ok(vec![default_images_dir(Path::new(&p.path))?])
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: ColmapScenePorts = ctx.ports_as()?;
        let p: ColmapSceneParams = ctx.params_as()?;
        let path = PathBuf::from(p.path);
        let model = colmap::read_model(&path)?;
        let images = match p.images {
            Some(p) => PathBuf::from(p),
            None => default_images_dir(&path)?,
        };
        let views = colmap_scene::views(&model, &images)?;
        ctx.progress(0, 2, "writing frames");
        let split = split_param(ctx, || bail!("a COLMAP model has no train/test lists"))?;
        let written = write_frames_output(ctx, &ports.frames, views, &split)?;
        ctx.progress(1, 2, "writing points");
        scene::write_points(&ports.points, &colmap_scene::points(&model))?;
        ctx.progress(2, 2, "done");
        note_frames(ctx, &written);
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

/// The transforms JSON the params name, its paths resolved against `images` / `masks`
/// and its masks dropped unless `use_masks`.
fn read_transforms(p: &NerfstudioSceneParams) -> Result<nerfstudio::Transforms> {
    let roots = nerfstudio::Roots {
        images: p.images.as_ref().map(PathBuf::from),
        masks: p.masks.as_ref().map(PathBuf::from),
    };
    let mut t = nerfstudio::read(Path::new(&p.path), &roots)?;
    if !p.use_masks {
        for f in &mut t.frames {
            f.mask = None;
        }
    }
    Ok(t)
}

objectsplat_runtime::node_params! {
    /// The parameters of `nerfstudio_scene`.
    pub struct NerfstudioSceneParams {
        /// the transforms.json file
        path: String = required as ParamType::Path,
        /// the folder the file_paths are relative to; default: the JSON's folder (ScanNet++:
        /// dslr/resized_images for transforms.json, dslr/resized_undistorted_images for
        /// transforms_undistorted.json)
        images: Option<String> = "None" as ParamType::optional(ParamType::Path),
        /// the folder the mask_paths are relative to; default: the JSON's folder (ScanNet++:
        /// dslr/resized_anon_masks, dslr/resized_undistorted_masks)
        masks: Option<String> = "None" as ParamType::optional(ParamType::Path),
        /// load mask_path validity masks (also skipped when the JSON says has_mask: false)
        use_masks: bool = "true" as ParamType::Bool,
        /// json: poses as stored; scannetpp_mesh: a ScanNet++ JSON moved into the scene's mesh
        /// frame (JSON world = M · mesh world, M = [[0,1,0],[1,0,0],[0,0,−1]]), so the frames
        /// line up with scannetpp_scene's mesh and poses
        world: String = "\"json\"" as ParamType::enumeration(&["json", "scannetpp_mesh"]),
    }
}

node_ports! {
    struct NerfstudioScenePorts {
        /// posed images, split and downscaled; mask_path becomes valid/<stem>.png
        frames: output "Frames",
    }
}

impl Node for NerfstudioScene {
    fn spec(&self) -> NodeSpec {
        with_scene_params(
            NodeSpec::new("nerfstudio_scene", "2")
                .doc("A nerfstudio/instant-ngp transforms.json (OpenGL camera-to-world, converted to OpenCV). Distorted cameras (camera_model OPENCV with k1, k2, k3, p1, p2; OPENCV_FISHEYE with k1..k4) are undistorted to the pinhole camera COLMAP's image_undistorter would choose. ScanNet++ test_frames are test frames.")
                .ports::<NerfstudioScenePorts>()
                .params::<NerfstudioSceneParams>(),
            Some("the JSON's test_frames, or its train_filenames / test_filenames"),
        )
    }

    /// The images and masks the JSON lists (the `path` param covers the JSON only).
    /// The images and masks the JSON lists, where `images` / `masks` say they are.
    fn reads(&self, params: &Params) -> Result<Vec<PathBuf>> {
        let p: NerfstudioSceneParams = params.read_as()?;
        let t = read_transforms(&p)?;
        Ok(t.frames
            .into_iter()
            .flat_map(|f| std::iter::once(f.image).chain(f.mask))
            .collect())
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: NerfstudioScenePorts = ctx.ports_as()?;
        let p: NerfstudioSceneParams = ctx.params_as()?;
        let t = read_transforms(&p)?;
        let path = PathBuf::from(&p.path);
        t.check_files()?;
        let world = match p.world.as_str() {
            "json" => glam::DMat4::IDENTITY,
            "scannetpp_mesh" => scannetpp::mesh_change(),
            other => bail!("world {other:?} is not json or scannetpp_mesh"),
        };
        let views = t.views(world)?;
        let split = split_param(ctx, || {
            let source = t.lists.with_context(|| {
                format!(
                    "{}: split \"lists\" needs the JSON's own split (test_frames, or train_filenames / \
                     test_filenames), and it gives none",
                    path.display()
                )
            })?;
            Ok(format!("{} ({source})", path.display()))
        })?;
        let written = write_frames_output(ctx, &ports.frames, views, &split)?;
        note_frames(ctx, &written);
        if t.skipped_bad > 0 {
            ctx.note("skipped is_bad frames", t.skipped_bad);
        }
        Ok(Outcome::Done)
    }
}

objectsplat_runtime::node_params! {
    /// The parameters of `scannetpp_scene`.
    pub struct ScannetppSceneParams {
        /// the scene folder (holding dslr/ and scans/)
        path: String = required as ParamType::Path,
        /// a vertex in several annotation groups goes to the smallest group, the first, or the
        /// last
        overlap: String = "\"smallest\"" as ParamType::enumeration(&GroupOverlap::NAMES),
        /// annotation labels kept as background (no object id), compared case-insensitively
        background_labels: Vec<String> = "[\"wall\", \"floor\", \"ceiling\"]" as ParamType::list(ParamType::Str),
    }
}

/// `scannetpp_scene`: one ScanNet++ scene folder.
pub struct ScannetppScene;

node_ports! {
    struct ScannetppScenePorts {
        /// posed undistorted DSLR images; the JSON's test_frames are test frames
        frames: output "Frames",
        /// mesh_aligned_0.05 with per-vertex object ids (the annotation's objectIds; ids above 65534 are an error) and labels
        mesh: output "Mesh",
        /// COLMAP points (mesh vertices when there are none)
        points: output "Points",
    }
}

impl Node for ScannetppScene {
    fn spec(&self) -> NodeSpec {
        with_scene_params(
            NodeSpec::new("scannetpp_scene", "2")
                .doc("A ScanNet++ scene folder: DSLR images (the toolkit's undistorted ones, else the fisheye ones undistorted here), COLMAP poses (mesh frame), the annotated mesh with the annotation's own objectIds.")
                .ports::<ScannetppScenePorts>()
                .params::<ScannetppSceneParams>(),
            Some("dslr/train_test_lists.json"),
        )
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: ScannetppScenePorts = ctx.ports_as()?;
        let p: ScannetppSceneParams = ctx.params_as()?;
        let path = PathBuf::from(p.path);
        let overlap = GroupOverlap::parse(&p.overlap)?;
        let background: Vec<String> = p.background_labels;
        let mut s = scannetpp::load(&path, overlap, &background)?;
        let mut unmatched_list_entries = 0;
        let split = split_param(ctx, || {
            let (file, lists) = scannetpp::read_train_test_lists(&path)?;
            for v in &mut s.views {
                v.listed = lists.get(&v.name).copied();
            }
            let loaded: std::collections::HashSet<&str> =
                s.views.iter().map(|v| v.name.as_str()).collect();
            unmatched_list_entries = lists
                .keys()
                .filter(|n| !loaded.contains(n.as_str()))
                .count();
            Ok(file.display().to_string())
        })?;
        let written =
            write_frames_output(ctx, &ports.frames, std::mem::take(&mut s.views), &split)?;
        objectsplat_core::write_mesh_artifact(&ports.mesh, &s.mesh, &s.labels)?;
        scene::write_points(&ports.points, &s.points)?;
        note_frames(ctx, &written);
        ctx.note(
            "images",
            if s.distorted {
                format!("{} (fisheye, undistorted here)", s.images)
            } else {
                s.images.clone()
            },
        );
        if unmatched_list_entries > 0 {
            ctx.note(
                "list entries without a loaded frame (is_bad or missing)",
                unmatched_list_entries,
            );
        }
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
        if let (Some(lo), Some(hi)) = (s.labels.keys().next(), s.labels.keys().last()) {
            ctx.note(
                "object ids (the annotation's objectIds)",
                format!("{lo}..={hi}"),
            );
        }
        if s.nonpositive_object_ids > 0 {
            ctx.note(
                "groups with objectId ≤ 0 (kept as background)",
                s.nonpositive_object_ids,
            );
        }
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

objectsplat_runtime::node_params! {
    /// The parameters of `import_masks`.
    pub struct ImportMasksParams {
        /// the folder holding the masks (or wire the `source` input instead)
        path: Option<String> = "None" as ParamType::optional(ParamType::Path),
        /// how the masks are stored
        format: String = required as ParamType::enumeration(&MaskFormat::NAMES),
        /// which mask keeps a pixel claimed by several: first in source order, smaller area, or
        /// higher score
        overlap: String = "\"lower_id\"" as ParamType::enumeration(&OverlapPolicy::NAMES),
    }
}

node_ports! {
    struct ImportMasksPorts {
        /// the frames the masks belong to (names and sizes)
        frames: input "Frames",
        /// the mask files made by another node (e.g. a `command` mask source), instead of `path`
        source: optional "File",
        /// one 16-bit id map per frame + objects.json
        masks: output "Masks",
    }
}

impl Node for ImportMasks {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("import_masks", "1")
            .doc("Imports DAVIS indexed PNGs, per-object PNG folders, SAM COCO-RLE JSON or Grounded-SAM-2 output as mutually exclusive id maps.")
            .ports::<ImportMasksPorts>()
            .params::<ImportMasksParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: ImportMasksPorts = ctx.ports_as()?;
        let p: ImportMasksParams = ctx.params_as()?;
        let source = match (ports.source.as_deref(), p.path) {
            (Some(dir), None) => dir.to_path_buf(),
            (None, Some(path)) => PathBuf::from(path),
            (Some(_), Some(path)) => bail!(
                "both the `source` input and `path` ({path}) give the masks; keep one of them"
            ),
            (None, None) => bail!(
                "no masks: set `path` to the folder holding them, or wire the `source` input to a node that writes them"
            ),
        };
        let format = MaskFormat::parse(&p.format)?;
        let policy = OverlapPolicy::parse(&p.overlap)?;
        let frames = ports.frames;
        let out = ports.masks;
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
        Arc::new(crate::sfm_nodes::ColmapSfm),
        Arc::new(crate::sfm_nodes::VideoFrames),
        Arc::new(crate::stereo_points::StereoPoints),
    ] {
        reg.add_node(node).expect("input node kinds are unique");
    }
}
