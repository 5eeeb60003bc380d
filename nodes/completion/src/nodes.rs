//! Node wrappers: `inpaint`, `fill_holes`, `surface_completion`, `complete_surfaces`,
//! `inpaint_background`.

use crate::background::{FillSource, inpaint_background};
use crate::external::ExternalCommand;
use crate::fill_holes::{Connectivity, fill_holes};
use crate::inpaint::{Options, Raster, Sample, inpaint};
use crate::surface::{ScenePoints, SurfaceParams, complete_surfaces};
use crate::surface_mesh::{SurfaceMeshParams, complete_scene_surfaces};
use anyhow::{Context as _, Result, bail};
use objectsplat_core::artifact::{IMAGE_PNG, MASK_PNG};
use objectsplat_core::visibility::Visibility;
use objectsplat_core::{Frames, Points};
use objectsplat_runtime::{
    Context, Node, NodeSpec, Outcome, ParamType, Params, Registry, node_ports,
};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

pub fn register(reg: &mut Registry) {
    let nodes: [Arc<dyn Node>; 5] = [
        Arc::new(InpaintNode),
        Arc::new(FillHolesNode),
        Arc::new(SurfaceCompletionNode),
        Arc::new(CompleteSurfacesNode),
        Arc::new(InpaintBackgroundNode),
    ];
    for node in nodes {
        let kind = node.spec().kind;
        // Kinds are unique within this crate; a clash means another crate registered
        // the same kind first, which the catalogue's tests catch.
        if let Err(e) = reg.add_node(node) {
            panic!("registering {kind}: {e}");
        }
    }
}

/// The scene's points and their visibility, as far as the optional `points` and
/// `visibility` inputs are wired.
struct WiredPoints {
    points: Option<Points>,
    visibility: Option<Visibility>,
}

impl WiredPoints {
    fn read(points: Option<&Path>, visibility: Option<&Path>) -> Result<WiredPoints> {
        Ok(WiredPoints {
            points: points
                .map(|dir| Points::read_ply(&dir.join(objectsplat_core::artifact::POINTS_PLY)))
                .transpose()?,
            visibility: visibility.map(Visibility::read).transpose()?,
        })
    }

    /// The points with their visibility checked against them; `None` without points.
    fn scene_points(&self) -> Result<Option<ScenePoints<'_>>> {
        self.points
            .as_ref()
            .map(|p| ScenePoints::new(p, self.visibility.as_ref()))
            .transpose()
    }
}

fn connectivity(n: i64) -> Result<Connectivity> {
    Connectivity::from_number(n).map_err(anyhow::Error::msg)
}

/// A Mask artifact's `mask.png`: any PNG, non-zero = set.
fn load_mask(dir: &Path) -> Result<(u32, u32, Vec<bool>)> {
    let path = dir.join(MASK_PNG);
    let img =
        image::open(&path).with_context(|| format!("{}: cannot read mask", path.display()))?;
    let (w, h) = (img.width(), img.height());
    Ok((
        w,
        h,
        img.to_luma16()
            .into_raw()
            .into_iter()
            .map(|v| v != 0)
            .collect(),
    ))
}

fn save_mask(dir: &Path, w: u32, h: u32, set: &[bool]) -> Result<()> {
    let data: Vec<u8> = set.iter().map(|&s| if s { 255 } else { 0 }).collect();
    objectsplat_core::image::write_gray8(&dir.join(MASK_PNG), &data, w, h)
}

pub struct InpaintNode;

impl InpaintNode {
    fn fill<T: Sample>(
        raster: Raster<T>,
        mask: &[u8],
        options: &Options,
        path: &Path,
    ) -> Result<Raster<T>> {
        inpaint(&raster, mask, options)
            .with_context(|| format!("{}: inpainting failed", path.display()))
    }
}

objectsplat_runtime::node_params! {
    /// The parameters of `inpaint`.
    pub struct InpaintParams {
        /// OpenCV's INPAINT_NS or INPAINT_TELEA
        method: String = "\"ns\"" as ParamType::enumeration(&["ns", "telea"]),
        /// neighbourhood radius in pixels (rounded half to even, at least 1)
        radius: f64 = "3.0" as ParamType::float_range(0.0, 100.0),
    }
}

node_ports! {
    struct InpaintNodePorts {
        /// the image to fill (image.png, 8- or 16-bit)
        image: input "Image",
        /// mask.png, non-zero = fill
        mask: input "Mask",
        /// the filled image, same bit depth and channels
        image_out: output "Image" as "image",
    }
}

impl Node for InpaintNode {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("inpaint", "1")
            .doc("Single-image inpainting with OpenCV's semantics (cv::inpaint, 4.10+): fast-marching order, NS isophote-weighted or Telea averages. 8- and 16-bit PNGs, 1-4 channels; pixels outside the mask are unchanged.")
            .ports::<InpaintNodePorts>()
            .params::<InpaintParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: InpaintNodePorts = ctx.ports_as()?;
        let p: InpaintParams = ctx.params_as()?;
        let options = Options {
            method: p.method.parse().map_err(anyhow::Error::msg)?,
            radius: p.radius,
            threads: ctx.threads(),
        };
        let image_path = ports.image.join(IMAGE_PNG);
        let (mw, mh, set) = load_mask(&ports.mask)?;
        let img = image::open(&image_path)
            .with_context(|| format!("{}: cannot read image", image_path.display()))?;
        let (w, h) = (img.width(), img.height());
        if (mw, mh) != (w, h) {
            bail!("mask is {mw}×{mh} but {} is {w}×{h}", image_path.display());
        }
        let mask: Vec<u8> = set.iter().map(|&s| u8::from(s)).collect();
        let filled = set.iter().filter(|&&s| s).count();
        let out = ports.image_out.join(IMAGE_PNG);
        let (wu, hu) = (w as usize, h as usize);
        use image::DynamicImage as D;
        use image::ExtendedColorType as E;
        let (bytes, color): (Vec<u8>, E) = match img {
            D::ImageLuma8(_) | D::ImageLumaA8(_) | D::ImageRgb8(_) | D::ImageRgba8(_) => {
                let (ch, color) = match img.color().channel_count() {
                    1 => (1, E::L8),
                    2 => (2, E::La8),
                    3 => (3, E::Rgb8),
                    _ => (4, E::Rgba8),
                };
                let raw = img.into_bytes();
                (
                    Self::fill(Raster::new(wu, hu, ch, raw)?, &mask, &options, &image_path)?.data,
                    color,
                )
            }
            D::ImageLuma16(_) | D::ImageLumaA16(_) | D::ImageRgb16(_) | D::ImageRgba16(_) => {
                let ch = img.color().channel_count() as usize;
                let color = [E::L16, E::La16, E::Rgb16, E::Rgba16][ch - 1];
                let samples: Vec<u16> = match img {
                    D::ImageLuma16(b) => b.into_raw(),
                    D::ImageLumaA16(b) => b.into_raw(),
                    D::ImageRgb16(b) => b.into_raw(),
                    D::ImageRgba16(b) => b.into_raw(),
                    _ => unreachable!("matched 16-bit variants above"),
                };
                let filled = Self::fill(
                    Raster::new(wu, hu, ch, samples)?,
                    &mask,
                    &options,
                    &image_path,
                )?;
                (
                    filled.data.iter().flat_map(|v| v.to_ne_bytes()).collect(),
                    color,
                )
            }
            other => bail!(
                "{}: unsupported colour type {:?} (8- or 16-bit PNG expected)",
                image_path.display(),
                other.color()
            ),
        };
        image::save_buffer_with_format(&out, &bytes, w, h, color, image::ImageFormat::Png)
            .with_context(|| format!("{}: cannot write", out.display()))?;
        ctx.note("pixels_filled", filled);
        Ok(Outcome::Done)
    }
}

objectsplat_runtime::node_params! {
    /// The parameters of `fill_holes`.
    pub struct FillHolesParams {
        /// 4 or 8: connectivity of the background flood (SciPy's structure; 4 is SciPy's
        /// default)
        connectivity: i64 = "4" as ParamType::int_range(4, 8),
    }
}

pub struct FillHolesNode;

node_ports! {
    struct FillHolesNodePorts {
        /// mask.png, non-zero = set
        mask: input "Mask",
        /// the filled mask (mask.png, 0/255)
        mask_out: output "Mask" as "mask",
    }
}

impl Node for FillHolesNode {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("fill_holes", "1")
            .doc("Binary hole filling with scipy.ndimage.binary_fill_holes semantics.")
            .ports::<FillHolesNodePorts>()
            .params::<FillHolesParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: FillHolesNodePorts = ctx.ports_as()?;
        let connectivity = connectivity(ctx.params_as::<FillHolesParams>()?.connectivity)?;
        let (w, h, set) = load_mask(&ports.mask)?;
        let filled = fill_holes(&set, w as usize, h as usize, connectivity);
        let added = filled.iter().zip(&set).filter(|(f, s)| **f && !**s).count();
        save_mask(&ports.mask_out, w, h, &filled)?;
        ctx.note("pixels_filled", added);
        Ok(Outcome::Done)
    }
}

objectsplat_runtime::node_params! {
    /// The parameters of `surface_completion`.
    pub struct SurfaceCompletionParams {
        /// labels (or label words) that name support surfaces
        labels: Vec<String> = "[\"table\", \"desk\", \"counter\"]" as ParamType::list(ParamType::Str),
        /// plane-fit tolerance relative to the surface points' extent (used when points are
        /// wired)
        planarity_tolerance: f64 = "0.02" as ParamType::float_range(0.0, 1.0),
        /// NS inpainting radius in pixels
        radius: f64 = "5.0" as ParamType::float_range(0.0, 100.0),
        /// 4 or 8: background connectivity of the hole filling
        connectivity: i64 = "4" as ParamType::int_range(4, 8),
    }
}

pub struct SurfaceCompletionNode;

node_ports! {
    struct SurfaceCompletionNodePorts {
        /// the partition's components
        components: items "Component",
        /// the capture
        frames: input "Frames",
        /// scene points for the planarity test (optional)
        points: optional "Points",
        /// which points every frame sees (point_visibility's): a point counts only where it is
        /// seen, not through the surface it is behind (optional)
        visibility: optional "Visibility",
        /// all components; completed surfaces gain pixels, targets/ and completion.json
        components_out: output "[Component]" as "components",
    }
}

impl Node for SurfaceCompletionNode {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("surface_completion", "2")
            .doc("Completes flat support surfaces (tables, desks, counters): hole-fills each surface mask per frame, adopts filled pixels owned by other objects, and inpaints their colours with NS as training targets. Qualitative use: the paper keeps it out of reported metrics.")
            .ports::<SurfaceCompletionNodePorts>()
            .params::<SurfaceCompletionParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: SurfaceCompletionNodePorts = ctx.ports_as()?;
        let p: SurfaceCompletionParams = ctx.params_as()?;
        let params = SurfaceParams {
            labels: p.labels,
            planarity_tolerance: p.planarity_tolerance,
            radius: p.radius,
            connectivity: connectivity(p.connectivity)?,
        };
        // Validates the capture even though the components carry their own frames.
        Frames::read(&ports.frames)?;
        let wired = WiredPoints::read(ports.points.as_deref(), ports.visibility.as_deref())?;
        let scene_points = wired.scene_points()?;
        let items = ports.components;
        ctx.progress(0, 1, "completing support surfaces");
        let report = complete_surfaces(&items, scene_points, &params, &ports.components_out)?;
        for s in &report.surfaces {
            ctx.note(
                &format!("surface {}", s.component),
                format!(
                    "{} ({} frames, {} pixels added)",
                    s.reason, s.frames_completed, s.pixels_added
                ),
            );
        }
        ctx.note(
            "use",
            "qualitative only: completion is excluded from reported metrics",
        );
        ctx.progress(1, 1, "done");
        match report.skipped {
            Some(reason) => {
                ctx.forward("components", "components")?;
                Ok(Outcome::Skipped(reason))
            }
            None => Ok(Outcome::Done),
        }
    }
}

pub struct CompleteSurfacesNode;

node_ports! {
    struct CompleteSurfacesNodePorts {
        /// the composed scene (members in the frame they were trained in)
        scene: input "Scene",
        /// surface_completion's components: completion.json marks a support surface, targets/ hold its inpainted colours
        components: items "Component",
        /// the capture
        frames: input "Frames",
        /// scene points; those on a surface's pixels join its plane fit
        points: optional "Points",
        /// which points every frame sees (point_visibility's): only those seen count (optional)
        visibility: optional "Visibility",
        /// the scene with completed surfaces (model.json metadata surface_completion_3d records each patch)
        scene_out: output "Scene" as "scene",
    }
}

impl Node for CompleteSurfacesNode {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("complete_surfaces", "1")
            .doc("Closes the holes resting objects leave in trained support surfaces (those surface_completion completed): fits the surface's plane to its trained faces, finds the part of its outline under resting objects' footprints that its faces do not cover, triangulates it (constrained Delaunay, spade), colours it from the NS-inpainted per-frame completions and appends it to the surface's model as opaque triangles. Degenerate surfaces are skipped with a reason.")
            .ports::<CompleteSurfacesNodePorts>()
            .params::<SurfaceMeshParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: CompleteSurfacesNodePorts = ctx.ports_as()?;
        let params: SurfaceMeshParams = ctx.params_as()?;
        // Validates the capture; the components carry their own frames.
        Frames::read(&ports.frames)?;
        let wired = WiredPoints::read(ports.points.as_deref(), ports.visibility.as_deref())?;
        let scene_points = wired.scene_points()?;
        let mut scene = objectsplat_scene::load_scene(&ports.scene)?;
        let items = ports.components;
        ctx.progress(0, 1, "completing support surfaces in 3D");
        let report = complete_scene_surfaces(&mut scene, &items, scene_points, &params)?;
        for s in &report.surfaces {
            ctx.note(&format!("surface {}", s.component), &s.reason);
            if s.completed {
                ctx.note(
                    &format!("surface {} colour", s.component),
                    format!(
                        "{} vertices from {} frames ({} with no frame: surface mean)",
                        s.vertices_added, s.colour_frames, s.uncoloured_vertices
                    ),
                );
            }
        }
        ctx.progress(1, 1, "done");
        match report.skipped {
            Some(reason) => {
                ctx.forward("scene", "scene")?;
                Ok(Outcome::Skipped(reason))
            }
            None => {
                objectsplat_scene::save_scene(&scene, &ports.scene_out)?;
                Ok(Outcome::Done)
            }
        }
    }
}

objectsplat_runtime::node_params! {
    /// The parameters of `inpaint_background`.
    pub struct InpaintBackgroundParams {
        /// where fills come from
        method: String = "\"ns\"" as ParamType::enumeration(&["ns", "telea", "command", "folder"]),
        /// radius for ns/telea
        radius: f64 = "5.0" as ParamType::float_range(0.0, 100.0),
        /// argv for method command; arguments exactly {input} / {output} become the folders;
        /// the program file and every absolute argument naming a file or folder are part of the
        /// cache key (files the program finds by itself are not: name them in the argv)
        command: Vec<String> = "[]" as ParamType::list(ParamType::Str),
        /// seconds before the command is killed
        timeout_s: f64 = "600.0" as ParamType::float_range(0.001, 1.0e6),
        /// folder of <frame stem>.png fills for method folder
        path: Option<String> = "None" as ParamType::optional(ParamType::Path),
    }
}

pub struct InpaintBackgroundNode;

node_ports! {
    struct InpaintBackgroundNodePorts {
        /// the partition's components (the background's masks say what to fill)
        components: items "Component",
        /// the capture
        frames: input "Frames",
        /// <frame stem>.png per background frame
        fills: output "Images",
    }
}

impl Node for InpaintBackgroundNode {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("inpaint_background", "1")
            .doc("Fills the background where objects stood, per frame, for interactive/qualitative use only (never fed to metrics or training). Methods: built-in ns/telea, an external command (argv, no shell; protocol in the crate docs), or a folder of precomputed fills.")
            .ports::<InpaintBackgroundNodePorts>()
            .params::<InpaintBackgroundParams>()
    }

    /// For method `command`: the program and the files its arguments name.
    fn reads(&self, params: &Params) -> Result<Vec<PathBuf>> {
        let p = params.read_as::<InpaintBackgroundParams>()?;
        if p.method != "command" {
            return Ok(Vec::new());
        }
        Ok(ExternalCommand::reads(&p.command))
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: InpaintBackgroundNodePorts = ctx.ports_as()?;
        let p: InpaintBackgroundParams = ctx.params_as()?;
        let source = match p.method.as_str() {
            "ns" | "telea" => FillSource::Builtin {
                method: p.method.parse().map_err(anyhow::Error::msg)?,
                radius: p.radius,
            },
            "command" => FillSource::Command(ExternalCommand {
                argv: p.command,
                timeout: Duration::from_secs_f64(p.timeout_s),
            }),
            "folder" => {
                let Some(path) = p.path else {
                    bail!("method \"folder\" needs the param `path`")
                };
                FillSource::Folder(PathBuf::from(path))
            }
            other => bail!("unknown method {other:?}"),
        };
        let frames = Frames::read(&ports.frames)?;
        let items = ports.components;
        let scratch = ctx.scratch().to_path_buf();
        let report = inpaint_background(&items, &frames, &source, &ports.fills, &scratch)?;
        ctx.note("use", "qualitative only: never fed to metrics or training");
        ctx.note(
            "frames_filled",
            format!("{} of {}", report.frames_with_holes, report.frames),
        );
        ctx.note("pixels_filled", report.pixels_filled);
        match report.skipped {
            Some(reason) => Ok(Outcome::Skipped(reason)),
            None => Ok(Outcome::Done),
        }
    }
}
