//! Nodes that pose photos themselves: `colmap_sfm` (structure from motion by COLMAP,
//! optionally aligned to known cameras) and `video_frames` (frames of a video by ffmpeg).

use crate::colmap_sfm::{self, CAMERA_MODELS, Matcher, Options, Reconstruction};
use crate::nodes::{note_frames, split_param, with_scene_params, write_frames_output};
use crate::similarity::{Similarity, extent, rotation_angle_degrees};
use crate::video::{self, Pick};
use crate::{colmap, colmap_scene, scene};
use anyhow::{Context as _, Result, bail};
use glam::DVec3;
use objectsplat_core::frames::frame_stem;
use objectsplat_core::{Camera, Frames};
use objectsplat_runtime::{
    Context, Node, NodeParams, NodeSpec, Outcome, ParamError, ParamType, Params, node_params,
    node_ports,
};
use serde_json::Value;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The file in the `model` output that records which images were registered.
pub const REGISTRATION_JSON: &str = "registration.json";
/// The file in the `model` output that records the alignment to `reference`.
pub const ALIGNMENT_JSON: &str = "alignment.json";
/// The model files, as COLMAP writes them in its binary encoding.
const MODEL_FILES: [&str; 3] = ["cameras.bin", "images.bin", "points3D.bin"];
/// Names listed in a report line before the rest are counted.
const LISTED_NAMES: usize = 20;

node_params! {
    /// The parameters of `colmap_sfm`.
    pub struct ColmapSfmParams {
        /// the folder of photos (PNG or JPEG, searched recursively); or wire the `images`
        /// input; with neither, the images of the `reference` frames are posed afresh
        path: Option<String> = "None" as ParamType::optional(ParamType::Path),
        /// the camera model COLMAP fits; distorted ones are undistorted as colmap_scene does
        camera_model: String = "\"SIMPLE_RADIAL\"" as ParamType::enumeration(&CAMERA_MODELS),
        /// known intrinsics in COLMAP's order for the model (SIMPLE_PINHOLE: f, cx, cy;
        /// PINHOLE: fx, fy, cx, cy; SIMPLE_RADIAL: f, cx, cy, k; …), kept fixed; None: estimated
        camera_params: Option<Vec<f64>> = "None" as ParamType::optional(ParamType::list(ParamType::float())),
        /// true: one camera for every photo (one device, fixed zoom); false: one per photo
        single_camera: bool = "true" as ParamType::Bool,
        /// exhaustive: every pair of photos (up to a few hundred photos); sequential: each
        /// with its neighbours in name order (video frames); neither needs a vocabulary tree
        matcher: String = "\"exhaustive\"" as ParamType::enumeration(&Matcher::NAMES),
        /// COLMAP's GPU SIFT (a CUDA build, or OpenGL with a display) instead of its CPU SIFT
        gpu: bool = "false" as ParamType::Bool,
        /// longest image side, in pixels, features are extracted at (larger photos are scaled down)
        max_image_size: i64 = "3200" as ParamType::int_range(64, 100_000),
        /// DSP-SIFT descriptors: slower, more matches on blurred or heavily compressed photos
        domain_size_pooling: bool = "false" as ParamType::Bool,
        /// SIFT's contrast threshold; below COLMAP's 0.0067 it finds more features on the
        /// low-contrast walls and floors of rooms (docs/benchmarks.md: the synthetic room's
        /// rotation errors drop from 0.56° to 0.20°), and matching takes longer
        peak_threshold: f64 = "0.002" as ParamType::float_range(1e-5, 1.0),
        /// further COLMAP options by their COLMAP names, e.g. {"Mapper.abs_pose_min_num_inliers": 15}
        /// (sections ImageReader, SiftExtraction, SiftMatching, ExhaustiveMatching,
        /// SequentialMatching, Mapper)
        colmap_options: BTreeMap<String, Value> = "{}"
            as ParamType::Ron("a map of COLMAP option names to values, e.g. {\"Mapper.abs_pose_min_num_inliers\": 15}".into()),
        /// the colmap binary: a name looked up on PATH, or a path
        program: String = "\"colmap\"" as ParamType::Str,
        /// seconds each COLMAP step may take before it is killed
        timeout_s: f64 = "86400.0" as ParamType::float_range(1.0, 1.0e7),
    }
}

node_ports! {
    struct ColmapSfmPorts {
        /// photos made by another node (e.g. `video_frames`), instead of `path`
        images: optional "Images",
        /// known cameras to align to by a similarity (matched by frame name or stem): the
        /// model then has their scale and orientation; alone, also the photos to pose
        reference: optional "Frames",
        /// the registered photos, posed, split and downscaled (as colmap_scene writes them)
        frames: output "Frames",
        /// the model's 3D points with colours
        points: output "Points",
        /// the COLMAP model (cameras.bin, images.bin, points3D.bin; aligned when `reference`
        /// is wired) + registration.json (+ alignment.json): open it in COLMAP's GUI
        model: output "File",
    }
}

/// `colmap_sfm`: photos in, posed frames out.
pub struct ColmapSfm;

impl ColmapSfmParams {
    fn options(&self, threads: usize) -> Result<Options> {
        Ok(Options {
            program: self.program.clone(),
            camera_model: self.camera_model.clone(),
            camera_params: self.camera_params.clone(),
            single_camera: self.single_camera,
            matcher: Matcher::parse(&self.matcher)?,
            gpu: self.gpu,
            max_image_size: u32::try_from(self.max_image_size)
                .context("max_image_size is out of range")?,
            domain_size_pooling: self.domain_size_pooling,
            peak_threshold: self.peak_threshold,
            extra: self
                .colmap_options
                .iter()
                .map(|(k, v)| Ok((k.clone(), option_text(k, v)?)))
                .collect::<Result<_>>()?,
            threads,
            timeout: Duration::from_secs_f64(self.timeout_s),
        })
    }
}

/// A COLMAP option's value as its command line takes it: booleans as 1 or 0.
fn option_text(key: &str, value: &Value) -> Result<String> {
    Ok(match value {
        Value::String(s) => s.clone(),
        Value::Bool(b) => if *b { "1" } else { "0" }.to_string(),
        Value::Number(n) => n.to_string(),
        other => bail!("colmap_options `{key}`: {other} is not a string, number or boolean"),
    })
}

impl Node for ColmapSfm {
    fn spec(&self) -> NodeSpec {
        with_scene_params(
            NodeSpec::new("colmap_sfm", "1")
                .doc("Structure from motion by COLMAP (feature extraction, exhaustive or sequential matching, incremental mapping) on a folder of photos: the registered photos as posed frames and the model's points, written exactly as colmap_scene reads a model, plus the COLMAP model itself. The largest model is kept; unregistered photos and the other models are reported. Without `reference` the scale and orientation are COLMAP's own (arbitrary); with it, a similarity fitted to the reference cameras' centres gives the model their frame. Needs `colmap` installed (Debian: apt-get install colmap); its version is part of the cache key. COLMAP 3.8 is not bit-for-bit reproducible (a few SIFT descriptors differ between runs), so a rerun under another key may move poses slightly.")
                .ports::<ColmapSfmPorts>()
                .params::<ColmapSfmParams>(),
            None,
        )
    }

    fn tool_versions(&self, params: &Params) -> Vec<String> {
        // Planned params always hold `program` (it has a default).
        let program = params
            .get::<String>("program")
            .unwrap_or_else(|_| "colmap".into());
        vec![colmap_sfm::version(&program).unwrap_or_else(|e| format!("{program}: {e}"))]
    }

    fn check_params(&self, params: &Params) -> Vec<ParamError> {
        let Ok(p) = ColmapSfmParams::try_read(params) else {
            // Ill-typed params are reported by the engine's type check.
            return Vec::new();
        };
        let mut problems = Vec::new();
        if let Some(given) = &p.camera_params {
            let wanted = colmap::CAMERA_MODELS
                .iter()
                .find(|m| m.1 == p.camera_model)
                .map(|m| m.2);
            if let Some(wanted) = wanted
                && wanted != given.len()
            {
                problems.push(ParamError::new(
                    "camera_params",
                    format!(
                        "{} values given, but {} takes {wanted}",
                        given.len(),
                        p.camera_model
                    ),
                ));
            }
        }
        let extra: BTreeMap<String, String> = p
            .colmap_options
            .iter()
            .map(|(k, v)| (k.clone(), option_text(k, v).unwrap_or_default()))
            .collect();
        for (key, value) in &p.colmap_options {
            if let Err(e) = option_text(key, value) {
                problems.push(ParamError::new("colmap_options", e.to_string()).at([key]));
            }
        }
        if let Ok(matcher) = Matcher::parse(&p.matcher) {
            for (key, message) in colmap_sfm::check_extra(&extra, matcher) {
                problems.push(ParamError::new("colmap_options", message).at([key]));
            }
        }
        problems
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: ColmapSfmPorts = ctx.ports_as()?;
        let p: ColmapSfmParams = ctx.params_as()?;
        let options = p.options(ctx.threads())?;
        let split = split_param(ctx, || {
            bail!("structure from motion gives no train/test lists")
        })?;
        let (images_dir, images, ignored) = match (ports.images, &p.path, &ports.reference) {
            (Some(dir), None, _) => {
                let (images, ignored) = colmap_sfm::list_images(&dir)?;
                (dir, images, ignored)
            }
            (None, Some(path), _) => {
                let dir = PathBuf::from(path);
                let (images, ignored) = colmap_sfm::list_images(&dir)?;
                (dir, images, ignored)
            }
            (Some(_), Some(path), _) => bail!(
                "both the `images` input and `path` ({path}) give the photos; keep one of them"
            ),
            // Re-posing a posed capture: its own images, its poses the reference.
            (None, None, Some(reference)) => {
                let frames = Frames::read(reference)?;
                let images: Vec<String> = frames
                    .frames
                    .iter()
                    .map(|f| scene::portable(&f.image))
                    .collect();
                colmap_sfm::check_images(reference, &images)?;
                (reference.clone(), images, Vec::new())
            }
            (None, None, None) => bail!(
                "no photos: set `path` to their folder, wire the `images` input to a node that makes \
                 them, or wire `reference` alone to pose its frames' own images"
            ),
        };
        let version = colmap_sfm::version(&options.program)?;
        let workdir = std::path::absolute(ctx.scratch().join("colmap"))
            .context("no absolute path for the scratch folder")?;
        std::fs::create_dir_all(&workdir)
            .with_context(|| format!("{}: cannot create", workdir.display()))?;
        let recon = {
            let ctx_ref: &Context = ctx;
            colmap_sfm::reconstruct(
                &std::path::absolute(&images_dir)
                    .with_context(|| format!("{}: no absolute path", images_dir.display()))?,
                &images,
                &options,
                &workdir,
                &|| ctx_ref.cancelled(),
                &|step, message| ctx_ref.progress(step, 5, message),
            )?
        };
        ctx.progress(3, 5, "writing the model");
        let alignment = match &ports.reference {
            Some(reference) => Some(align_model(
                &recon,
                reference,
                &options,
                &workdir,
                &ports.model,
                &|| ctx.cancelled(),
            )?),
            None => {
                for file in MODEL_FILES {
                    objectsplat_runtime::store::copy_writable(
                        &recon.model_dir.join(file),
                        &ports.model.join(file),
                    )?;
                }
                None
            }
        };
        write_registration(&ports.model, &images, &recon)?;
        // The frames come from the model as written, through colmap_scene's own path.
        let model = colmap::read_binary(&ports.model)?;
        let views = colmap_scene::views(&model, &images_dir)?;
        ctx.progress(4, 5, "writing frames");
        let written = write_frames_output(ctx, &ports.frames, views, &split)?;
        scene::write_points(&ports.points, &colmap_scene::points(&model))?;
        ctx.progress(5, 5, "done");

        ctx.note("colmap", &version);
        ctx.note(
            "registered",
            format!("{} of {} images", model.images.len(), images.len()),
        );
        if !recon.unregistered.is_empty() {
            ctx.warn(format!(
                "{} of {} images were not registered (not in the largest model): {}",
                recon.unregistered.len(),
                images.len(),
                listed(&recon.unregistered)
            ));
        }
        for (i, other) in recon.other_models.iter().enumerate() {
            ctx.warn(format!(
                "COLMAP also made a separate model of {} images, not kept (model {}): {}",
                other.len(),
                i + 1,
                listed(other)
            ));
        }
        if !ignored.is_empty() {
            ctx.note(
                "files that are not PNG or JPEG images (ignored)",
                listed(&ignored),
            );
        }
        note_frames(ctx, &written);
        ctx.note("points", model.points.len());
        match alignment {
            Some(a) => ctx.note("scale", a.describe()),
            None => ctx.note(
                "scale",
                "arbitrary: COLMAP's own frame and units (wire `reference` to known cameras to align)",
            ),
        }
        Ok(Outcome::Done)
    }
}

/// Up to [`LISTED_NAMES`] names, then how many more.
fn listed(names: &[String]) -> String {
    let shown = names[..names.len().min(LISTED_NAMES)].join(", ");
    match names.len().checked_sub(LISTED_NAMES) {
        Some(more) if more > 0 => format!("{shown} and {more} more"),
        _ => shown,
    }
}

fn write_registration(model_out: &Path, images: &[String], recon: &Reconstruction) -> Result<()> {
    let registered: Vec<&str> = {
        let mut names: Vec<&str> = recon
            .model
            .images
            .values()
            .map(|i| i.name.as_str())
            .collect();
        names.sort();
        names
    };
    let record = serde_json::json!({
        "images": images.len(),
        "registered": registered,
        "unregistered": recon.unregistered,
        "other_models": recon.other_models,
    });
    let path = model_out.join(REGISTRATION_JSON);
    std::fs::write(&path, serde_json::to_string_pretty(&record)?)
        .with_context(|| format!("{}: cannot write", path.display()))
}

/// How well the model fits the reference cameras after alignment.
#[derive(Debug, Clone)]
pub struct Alignment {
    pub similarity: Similarity,
    /// Model images matched to a reference camera.
    pub matched: usize,
    /// Diagonal of the bounding box of the matched reference cameras' centres.
    pub reference_extent: f64,
    pub max_centre_error: f64,
    pub median_centre_error: f64,
    pub max_rotation_error_degrees: f64,
    pub median_rotation_error_degrees: f64,
}

impl Alignment {
    fn describe(&self) -> String {
        format!(
            "the reference's: aligned by a similarity (scale {:.6}) to {} reference cameras; camera \
             centres within {:.4} (median {:.4}, {:.3} % of their extent {:.4}), rotations within \
             {:.3}° (median {:.3}°)",
            self.similarity.scale,
            self.matched,
            self.max_centre_error,
            self.median_centre_error,
            100.0 * self.max_centre_error / self.reference_extent,
            self.reference_extent,
            self.max_rotation_error_degrees,
            self.median_rotation_error_degrees
        )
    }
}

/// Fits the similarity taking the model's camera centres onto the reference's, has
/// COLMAP apply it (`model_transformer`) into `model_out`, and measures the result.
fn align_model(
    recon: &Reconstruction,
    reference_dir: &Path,
    options: &Options,
    workdir: &Path,
    model_out: &Path,
    cancelled: &dyn Fn() -> bool,
) -> Result<Alignment> {
    let reference = Frames::read(reference_dir)?;
    let pairs = match_reference(&recon.model, &reference)?;
    let source: Vec<DVec3> = pairs.iter().map(|(m, _)| m.center()).collect();
    let target: Vec<DVec3> = pairs.iter().map(|(_, r)| r.center()).collect();
    let similarity = Similarity::fit(&source, &target)
        .context("aligning the model's camera centres to the reference cameras")?;
    let transform = workdir.join("alignment.txt");
    let text: String = similarity
        .matrix_3x4()
        .iter()
        .map(|row| {
            let cells: Vec<String> = row.iter().map(f64::to_string).collect();
            cells.join(" ") + "\n"
        })
        .collect();
    std::fs::write(&transform, text)
        .with_context(|| format!("{}: cannot write", transform.display()))?;
    objectsplat_command::process::Program {
        what: "COLMAP",
        argv: [
            options.program.as_str(),
            "model_transformer",
            "--log_to_stderr",
            "1",
            "--input_path",
            &recon.model_dir.display().to_string(),
            "--output_path",
            &model_out.display().to_string(),
            "--transform_path",
            &transform.display().to_string(),
        ]
        .map(Into::into)
        .to_vec(),
        workdir,
        timeout: options.timeout,
        cancelled,
    }
    .run_logged(&workdir.join("model_transformer.log"))
    .context("COLMAP's model_transformer failed")?;

    // Measured on the model as COLMAP wrote it.
    let aligned = colmap::read_binary(model_out)?;
    let pairs = match_reference(&aligned, &reference)?;
    let mut centre_errors: Vec<f64> = pairs
        .iter()
        .map(|(m, r)| (m.center() - r.center()).length())
        .collect();
    let mut rotation_errors: Vec<f64> = pairs
        .iter()
        .map(|(m, r)| rotation_angle_degrees(m.rotation(), r.rotation()))
        .collect();
    let reference_extent = extent(&target);
    let alignment = Alignment {
        similarity,
        matched: pairs.len(),
        reference_extent,
        max_centre_error: max(&centre_errors),
        median_centre_error: median(&mut centre_errors),
        max_rotation_error_degrees: max(&rotation_errors),
        median_rotation_error_degrees: median(&mut rotation_errors),
    };
    let per_frame: Vec<Value> = pairs
        .iter()
        .map(|(m, r)| {
            serde_json::json!({
                "frame": m.name,
                "centre_error": (m.center() - r.center()).length(),
                "rotation_error_degrees": rotation_angle_degrees(m.rotation(), r.rotation()),
            })
        })
        .collect();
    let s = &alignment.similarity;
    let record = serde_json::json!({
        "scale": s.scale,
        "rotation": s.rotation.transpose().to_cols_array_2d(),
        "translation": s.translation.to_array(),
        "matched": alignment.matched,
        "reference_extent": alignment.reference_extent,
        "max_centre_error": alignment.max_centre_error,
        "median_centre_error": alignment.median_centre_error,
        "max_rotation_error_degrees": alignment.max_rotation_error_degrees,
        "median_rotation_error_degrees": alignment.median_rotation_error_degrees,
        "frames": per_frame,
    });
    let path = model_out.join(ALIGNMENT_JSON);
    std::fs::write(&path, serde_json::to_string_pretty(&record)?)
        .with_context(|| format!("{}: cannot write", path.display()))?;
    Ok(alignment)
}

/// A registered image's camera, by name, for comparing with a reference camera.
struct NamedCamera {
    name: String,
    camera: Camera,
}

impl NamedCamera {
    fn center(&self) -> DVec3 {
        self.camera.center()
    }
    fn rotation(&self) -> glam::DMat3 {
        self.camera.rotation()
    }
}

/// Pairs each model image with the reference frame of the same name, or else of the
/// same stem (`frame_003.png` ↔ `frame_003`); a stem two reference frames share matches
/// neither. Fewer than three pairs is an error.
fn match_reference(
    model: &colmap::ColmapModel,
    reference: &Frames,
) -> Result<Vec<(NamedCamera, Camera)>> {
    let by_name: HashMap<&str, &objectsplat_core::Frame> = reference
        .frames
        .iter()
        .map(|f| (f.name.as_str(), f))
        .collect();
    let mut by_stem: HashMap<&str, Option<&objectsplat_core::Frame>> = HashMap::new();
    for f in &reference.frames {
        by_stem
            .entry(frame_stem(&f.name))
            .and_modify(|e| *e = None)
            .or_insert(Some(f));
    }
    let mut pairs = Vec::new();
    for img in model.images.values() {
        let found = by_name
            .get(img.name.as_str())
            .copied()
            .or_else(|| by_stem.get(frame_stem(&img.name)).copied().flatten());
        if let Some(frame) = found {
            let camera = Camera {
                world_to_camera: img.pose.matrix(),
                ..frame.camera()
            };
            pairs.push((
                NamedCamera {
                    name: img.name.clone(),
                    camera,
                },
                frame.camera(),
            ));
        }
    }
    if pairs.len() < 3 {
        let names: Vec<String> = model.images.values().map(|i| i.name.clone()).collect();
        bail!(
            "{}: only {} of the model's {} images have a reference frame of the same name or stem \
             (the model's: {}); aligning needs at least 3",
            reference.root.display(),
            pairs.len(),
            model.images.len(),
            listed(&names)
        );
    }
    Ok(pairs)
}

fn max(values: &[f64]) -> f64 {
    values.iter().copied().fold(0.0, f64::max)
}

/// The median (the mean of the middle two for an even count); sorts `values`.
fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    let n = values.len();
    if n == 0 {
        return 0.0;
    }
    if n % 2 == 1 {
        values[n / 2]
    } else {
        (values[n / 2 - 1] + values[n / 2]) / 2.0
    }
}

node_params! {
    /// The parameters of `video_frames`.
    pub struct VideoFramesParams {
        /// the video file (anything ffmpeg decodes: MP4, MOV, MKV, …)
        path: String = required as ParamType::Path,
        /// how many frames to keep
        frames: i64 = "100" as ParamType::int_range(1, 100_000),
        /// even: spread evenly over the video; sharpest: the sharpest frame of each of as
        /// many equal stretches (less motion blur)
        pick: String = "\"sharpest\"" as ParamType::enumeration(&Pick::NAMES),
        /// the ffmpeg binary: a name looked up on PATH, or a path
        program: String = "\"ffmpeg\"" as ParamType::Str,
        /// seconds each ffmpeg pass may take before it is killed
        timeout_s: f64 = "3600.0" as ParamType::float_range(1.0, 1.0e7),
    }
}

node_ports! {
    struct VideoFramesPorts {
        /// frame_<index>.png (8-bit RGB; index counts the video's frames from 0)
        images: output "Images",
    }
}

/// `video_frames`: photos for `colmap_sfm` from a video.
pub struct VideoFrames;

impl Node for VideoFrames {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("video_frames", "1")
            .doc("Frames of a video by ffmpeg, as photos for colmap_sfm: N spread evenly over it, or the sharpest (highest Laplacian variance) of each of N equal stretches. Needs `ffmpeg` installed (Debian: apt-get install ffmpeg); its version is part of the cache key.")
            .ports::<VideoFramesPorts>()
            .params::<VideoFramesParams>()
    }

    fn tool_versions(&self, params: &Params) -> Vec<String> {
        let program = params
            .get::<String>("program")
            .unwrap_or_else(|_| "ffmpeg".into());
        vec![video::version(&program).unwrap_or_else(|e| format!("{program}: {e}"))]
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: VideoFramesPorts = ctx.ports_as()?;
        let p: VideoFramesParams = ctx.params_as()?;
        let version = video::version(&p.program)?;
        let pick = Pick::parse(&p.pick)?;
        let count = usize::try_from(p.frames).context("frames is out of range")?;
        let workdir = std::path::absolute(ctx.scratch())
            .context("no absolute path for the scratch folder")?;
        ctx.progress(0, 1, "decoding the video");
        let extracted = {
            let ctx_ref: &Context = ctx;
            video::extract(
                &p.program,
                Path::new(&p.path),
                count,
                pick,
                &ports.images,
                &workdir,
                Duration::from_secs_f64(p.timeout_s),
                &|| ctx_ref.cancelled(),
            )?
        };
        ctx.progress(1, 1, "done");
        ctx.note("ffmpeg", version);
        ctx.note(
            "frames",
            format!(
                "{} of {} ({})",
                extracted.chosen.len(),
                extracted.total,
                p.pick
            ),
        );
        Ok(Outcome::Done)
    }
}
