//! Structure from motion by COLMAP's command-line tools: feature extraction, matching
//! and incremental mapping of a folder of photos into a sparse model, the largest
//! of the models COLMAP makes chosen and the rest reported.
//!
//! COLMAP runs in a private working folder (its database and models stay there);
//! the caller copies the chosen model where it wants it. Every COLMAP step logs to
//! a file whose tail is quoted when the step fails. The images are checked first:
//! COLMAP skips an image it cannot read with a line in its log and exits successfully,
//! so an unreadable photo would otherwise just be missing from the model.

use crate::colmap::{self, ColmapModel};
use crate::installed::Tool;
use anyhow::{Context as _, Result, bail};
use objectsplat_command::process::{Program, tail};
use std::collections::{BTreeMap, BTreeSet};
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The camera models COLMAP may fit that `colmap_scene` can also undistort.
pub const CAMERA_MODELS: [&str; 9] = [
    "SIMPLE_PINHOLE",
    "PINHOLE",
    "SIMPLE_RADIAL",
    "RADIAL",
    "OPENCV",
    "FULL_OPENCV",
    "OPENCV_FISHEYE",
    "SIMPLE_RADIAL_FISHEYE",
    "RADIAL_FISHEYE",
];

/// The image files COLMAP is given: what both COLMAP and our frame writer decode.
const IMAGE_EXTENSIONS: [&str; 3] = ["png", "jpg", "jpeg"];

/// How image pairs are chosen for matching. Neither needs a vocabulary tree.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Matcher {
    /// Every pair: the most robust, quadratic in the number of images.
    Exhaustive,
    /// Each image with its neighbours in name order: for video frames.
    Sequential,
}

impl Matcher {
    pub const NAMES: [&'static str; 2] = ["exhaustive", "sequential"];

    pub fn parse(name: &str) -> Result<Matcher> {
        Ok(match name {
            "exhaustive" => Matcher::Exhaustive,
            "sequential" => Matcher::Sequential,
            other => bail!("matcher {other:?} is not exhaustive or sequential"),
        })
    }

    fn command(self) -> &'static str {
        match self {
            Matcher::Exhaustive => "exhaustive_matcher",
            Matcher::Sequential => "sequential_matcher",
        }
    }
}

/// The COLMAP option sections `extra` options may name, and the step that takes each.
const SECTIONS: [(&str, Step); 5] = [
    ("ImageReader", Step::Features),
    ("SiftExtraction", Step::Features),
    ("SiftMatching", Step::Matching),
    ("ExhaustiveMatching", Step::Matching),
    ("SequentialMatching", Step::Matching),
];

/// COLMAP options the node sets itself, and the param that sets each.
const SET_BY_PARAMS: [(&str, &str); 14] = [
    ("ImageReader.camera_model", "camera_model"),
    ("ImageReader.single_camera", "single_camera"),
    ("ImageReader.camera_params", "camera_params"),
    ("SiftExtraction.use_gpu", "gpu"),
    ("SiftMatching.use_gpu", "gpu"),
    ("SiftExtraction.max_image_size", "max_image_size"),
    ("SiftExtraction.domain_size_pooling", "domain_size_pooling"),
    ("SiftExtraction.peak_threshold", "peak_threshold"),
    ("SiftExtraction.num_threads", "threads"),
    ("SiftMatching.num_threads", "threads"),
    ("Mapper.num_threads", "threads"),
    ("Mapper.ba_refine_focal_length", "camera_params"),
    ("Mapper.ba_refine_principal_point", "camera_params"),
    ("Mapper.ba_refine_extra_params", "camera_params"),
];

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Step {
    Features,
    Matching,
    Mapping,
}

/// What COLMAP is asked to do.
#[derive(Debug, Clone)]
pub struct Options {
    /// The colmap binary (a name looked up on PATH, or a path).
    pub program: String,
    /// One of [`CAMERA_MODELS`].
    pub camera_model: String,
    /// Known intrinsics in COLMAP's order for the model; they are then kept fixed.
    pub camera_params: Option<Vec<f64>>,
    /// One camera shared by every image (one device), or one per image.
    pub single_camera: bool,
    pub matcher: Matcher,
    /// COLMAP's GPU SIFT (CUDA, or OpenGL with a display) instead of the CPU one.
    pub gpu: bool,
    /// Longest image side features are extracted at (larger images are scaled down).
    pub max_image_size: u32,
    /// DSP-SIFT: descriptors pooled over scales, more robust on blurred or heavily
    /// compressed photos, slower.
    pub domain_size_pooling: bool,
    /// SIFT's contrast threshold: lower finds more features on low-contrast surfaces.
    pub peak_threshold: f64,
    /// Further COLMAP options, `Section.name` → value (see [`check_extra`]).
    pub extra: BTreeMap<String, String>,
    /// Threads for each step.
    pub threads: usize,
    /// Limit on each COLMAP step.
    pub timeout: Duration,
}

/// Problems with `extra` options, each naming the option: an unknown section, an
/// option the node's own params set, a matcher section the chosen matcher ignores.
pub fn check_extra(extra: &BTreeMap<String, String>, matcher: Matcher) -> Vec<(String, String)> {
    let mut problems = Vec::new();
    for key in extra.keys() {
        let Some((section, name)) = key.split_once('.') else {
            problems.push((
                key.clone(),
                "expected `Section.option`, e.g. \"Mapper.abs_pose_min_num_inliers\"".into(),
            ));
            continue;
        };
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            problems.push((
                key.clone(),
                "an option name is made of letters, digits and `_`".into(),
            ));
        } else if let Some((_, param)) = SET_BY_PARAMS.iter().find(|(k, _)| k == key) {
            problems.push((key.clone(), format!("set by the `{param}` param; use it")));
        } else if section_step(section).is_none() {
            let known: Vec<&str> = SECTIONS.iter().map(|(s, _)| *s).chain(["Mapper"]).collect();
            problems.push((
                key.clone(),
                format!(
                    "unknown section `{section}`; the sections are {}",
                    known.join(", ")
                ),
            ));
        } else if (section == "ExhaustiveMatching" && matcher != Matcher::Exhaustive)
            || (section == "SequentialMatching" && matcher != Matcher::Sequential)
        {
            problems.push((
                key.clone(),
                format!("`{section}` options do nothing with the {matcher:?} matcher"),
            ));
        }
    }
    problems
}

fn section_step(section: &str) -> Option<Step> {
    if section == "Mapper" {
        return Some(Step::Mapping);
    }
    SECTIONS
        .iter()
        .find(|(s, _)| *s == section)
        .map(|(_, step)| *step)
}

/// The installed COLMAP's version line, e.g. "COLMAP 3.8 (Commit Unknown on Unknown
/// without CUDA)"; an error says how to install it when it is missing.
pub fn version(program: &str) -> Result<String> {
    let colmap = Tool {
        name: "COLMAP",
        package: "colmap",
        note: " (its CPU feature extraction needs no GPU), elsewhere see COLMAP's installation guide",
    };
    let text = colmap.output(program, "-h")?;
    let mut lines = text.lines().map(str::trim).filter(|l| !l.is_empty());
    let Some(first) = lines.next().filter(|l| l.starts_with("COLMAP")) else {
        bail!(
            "{program:?} does not look like COLMAP: `{program} -h` printed {:?}",
            tail(text.as_bytes())
        );
    };
    let name = first.split(" -- ").next().unwrap_or(first);
    Ok(match lines.next().filter(|l| l.starts_with('(')) {
        Some(build) => format!("{name} {build}"),
        None => name.to_string(),
    })
}

/// The images COLMAP will read in `dir`, as `/`-separated names relative to it, sorted;
/// and the files left aside (not PNG or JPEG, or hidden). Every image is decoded once:
/// an unreadable one is an error naming it.
pub fn list_images(dir: &Path) -> Result<(Vec<String>, Vec<String>)> {
    let mut images = Vec::new();
    let mut ignored = Vec::new();
    walk(dir, "", &mut images, &mut ignored)?;
    images.sort();
    ignored.sort();
    if images.is_empty() {
        bail!(
            "{}: no PNG or JPEG images here{}",
            dir.display(),
            if ignored.is_empty() {
                String::new()
            } else {
                format!(" (found only {})", ignored.join(", "))
            }
        );
    }
    check_images(dir, &images)?;
    Ok((images, ignored))
}

/// Decodes every image `names` lists in `dir` once: an unreadable one is an error
/// naming it.
pub fn check_images(dir: &Path, names: &[String]) -> Result<()> {
    for name in names {
        let path = dir.join(name);
        let decoded = image::ImageReader::open(&path)
            .and_then(|r| r.with_guessed_format())
            .map_err(anyhow::Error::from)
            .and_then(|r| r.decode().map_err(anyhow::Error::from));
        if let Err(e) = decoded {
            bail!(
                "{}: cannot be read as an image ({e}); remove it from the folder or replace it",
                path.display()
            );
        }
    }
    Ok(())
}

fn walk(
    dir: &Path,
    prefix: &str,
    images: &mut Vec<String>,
    ignored: &mut Vec<String>,
) -> Result<()> {
    for entry in
        std::fs::read_dir(dir).with_context(|| format!("{}: cannot list", dir.display()))?
    {
        let entry = entry.with_context(|| format!("{}: cannot list", dir.display()))?;
        let file_name = entry.file_name();
        let Some(file_name) = file_name.to_str() else {
            ignored.push(format!("{prefix}{}", file_name.to_string_lossy()));
            continue;
        };
        let name = format!("{prefix}{file_name}");
        if file_name.starts_with('.') {
            ignored.push(name);
            continue;
        }
        let path = entry.path();
        // Follows links, as COLMAP does.
        if path.is_dir() {
            walk(&path, &format!("{name}/"), images, ignored)?;
            continue;
        }
        let is_image = Path::new(file_name)
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| IMAGE_EXTENSIONS.contains(&e.to_ascii_lowercase().as_str()));
        if is_image {
            images.push(name);
        } else {
            ignored.push(name);
        }
    }
    Ok(())
}

/// The outcome of a reconstruction.
#[derive(Debug)]
pub struct Reconstruction {
    /// The chosen (largest) model's folder, inside the working folder.
    pub model_dir: PathBuf,
    pub model: ColmapModel,
    /// Images given to COLMAP that the chosen model does not hold.
    pub unregistered: Vec<String>,
    /// The other models COLMAP made: their image names.
    pub other_models: Vec<Vec<String>>,
}

/// Runs extraction, matching and mapping of `images` (names relative to `images_dir`)
/// in `workdir`. `progress(step, message)` is told each step; `cancelled` stops COLMAP.
pub fn reconstruct(
    images_dir: &Path,
    images: &[String],
    options: &Options,
    workdir: &Path,
    cancelled: &dyn Fn() -> bool,
    progress: &dyn Fn(u64, &str),
) -> Result<Reconstruction> {
    let database = workdir.join("database.db");
    let list = workdir.join("images.txt");
    let sparse = workdir.join("sparse");
    std::fs::create_dir_all(&sparse)
        .with_context(|| format!("{}: cannot create", sparse.display()))?;
    std::fs::write(&list, images.join("\n") + "\n")
        .with_context(|| format!("{}: cannot write", list.display()))?;
    let run = |step: &str, args: Vec<OsString>| -> Result<String> {
        let mut argv: Vec<OsString> = vec![options.program.clone().into(), step.into()];
        // glog writes into files under /tmp unless told to use stderr.
        argv.extend(["--log_to_stderr".into(), "1".into()]);
        argv.extend(args);
        let log = workdir.join(format!("{step}.log"));
        Program {
            what: "COLMAP",
            argv,
            workdir,
            timeout: options.timeout,
            cancelled,
        }
        .run_logged(&log)
        .with_context(|| format!("COLMAP's {step} failed"))
    };
    let flag = |b: bool| if b { "1" } else { "0" }.to_string();
    let threads = options.threads.max(1).to_string();

    progress(0, "extracting features");
    let mut args = pairs([
        ("--database_path", database.display().to_string()),
        ("--image_path", images_dir.display().to_string()),
        ("--image_list_path", list.display().to_string()),
        ("--ImageReader.camera_model", options.camera_model.clone()),
        ("--ImageReader.single_camera", flag(options.single_camera)),
        ("--SiftExtraction.use_gpu", flag(options.gpu)),
        ("--SiftExtraction.num_threads", threads.clone()),
        (
            "--SiftExtraction.max_image_size",
            options.max_image_size.to_string(),
        ),
        (
            "--SiftExtraction.domain_size_pooling",
            flag(options.domain_size_pooling),
        ),
        (
            "--SiftExtraction.peak_threshold",
            options.peak_threshold.to_string(),
        ),
    ]);
    if let Some(params) = &options.camera_params {
        let text: Vec<String> = params.iter().map(f64::to_string).collect();
        args.extend(pairs([("--ImageReader.camera_params", text.join(","))]));
    }
    args.extend(extra_args(&options.extra, Step::Features));
    let log = run("feature_extractor", args)?;
    let unread = unread_images(&workdir.join("feature_extractor.log"))?;
    if !unread.is_empty() {
        let hint = if options.single_camera {
            " (with `single_camera: true` every photo must have the same size; set it to false \
             for photos from several cameras)"
        } else {
            ""
        };
        bail!(
            "COLMAP's feature extraction skipped {} image(s): {}{hint}; its log:\n{log}",
            unread.len(),
            unread.join("; ")
        );
    }

    progress(1, "matching features");
    let mut args = pairs([
        ("--database_path", database.display().to_string()),
        ("--SiftMatching.use_gpu", flag(options.gpu)),
        ("--SiftMatching.num_threads", threads.clone()),
    ]);
    args.extend(extra_args(&options.extra, Step::Matching));
    run(options.matcher.command(), args)?;

    progress(2, "mapping");
    let mut args = pairs([
        ("--database_path", database.display().to_string()),
        ("--image_path", images_dir.display().to_string()),
        ("--output_path", sparse.display().to_string()),
        ("--Mapper.num_threads", threads),
    ]);
    if options.camera_params.is_some() {
        for fixed in [
            "--Mapper.ba_refine_focal_length",
            "--Mapper.ba_refine_principal_point",
            "--Mapper.ba_refine_extra_params",
        ] {
            args.extend(pairs([(fixed, "0".to_string())]));
        }
    }
    args.extend(extra_args(&options.extra, Step::Mapping));
    let mapped = run("mapper", args);
    let models = read_models(&sparse)?;
    let Some(largest) =
        (0..models.len()).max_by_key(|&i| (models[i].1.images.len(), usize::MAX - i))
    else {
        let why = match mapped {
            Err(e) => format!("{e:#}"),
            Ok(log) => format!("COLMAP's mapper wrote no model; its log:\n{log}"),
        };
        bail!(
            "structure from motion registered none of the {} images: COLMAP found no pair of them \
             with enough matches to start a model. Photos need to overlap (each part of the scene \
             seen from several places, moving between shots rather than turning on the spot); \
             known intrinsics (`camera_params`), `domain_size_pooling` for blurred or compressed \
             photos, or a lower `max_image_size` for noisy ones can help.\n{why}",
            images.len()
        );
    };
    // Models written by a mapper that then failed are not trusted: its error stands.
    mapped?;
    let mut models = models;
    let (model_dir, model) = models.remove(largest);
    let registered: BTreeSet<&str> = model.images.values().map(|i| i.name.as_str()).collect();
    let unregistered = images
        .iter()
        .filter(|n| !registered.contains(n.as_str()))
        .cloned()
        .collect();
    let other_models = models
        .iter()
        .map(|(_, m)| m.images.values().map(|i| i.name.clone()).collect())
        .collect();
    Ok(Reconstruction {
        model_dir,
        model,
        unregistered,
        other_models,
    })
}

fn pairs<const N: usize>(items: [(&str, String); N]) -> Vec<OsString> {
    items
        .into_iter()
        .flat_map(|(k, v)| [OsString::from(k), OsString::from(v)])
        .collect()
}

fn extra_args(extra: &BTreeMap<String, String>, step: Step) -> Vec<OsString> {
    extra
        .iter()
        .filter(|(key, _)| {
            key.split_once('.')
                .and_then(|(section, _)| section_step(section))
                == Some(step)
        })
        .flat_map(|(k, v)| [OsString::from(format!("--{k}")), OsString::from(v)])
        .collect()
}

/// The images COLMAP's feature extractor skipped, with its reasons (unreadable, another
/// size than the single camera's): it logs `Name: <file>` for each image and an
/// `ERROR:` line below a skipped one.
fn unread_images(log: &Path) -> Result<Vec<String>> {
    let text = std::fs::read_to_string(log)
        .with_context(|| format!("{}: cannot read COLMAP's log", log.display()))?;
    let mut current = None;
    let mut unread = Vec::new();
    for line in text.lines().map(str::trim) {
        if let Some(name) = line.strip_prefix("Name:") {
            current = Some(name.trim().to_string());
        } else if let Some(error) = line.strip_prefix("ERROR:") {
            let name = current.as_deref().unwrap_or("(an image)");
            unread.push(format!("{name}: {}", error.trim()));
        }
    }
    Ok(unread)
}

/// The models in COLMAP's output folder (`0`, `1`, … in its order).
fn read_models(sparse: &Path) -> Result<Vec<(PathBuf, ColmapModel)>> {
    let mut numbered = Vec::new();
    for entry in
        std::fs::read_dir(sparse).with_context(|| format!("{}: cannot list", sparse.display()))?
    {
        let entry = entry.with_context(|| format!("{}: cannot list", sparse.display()))?;
        if let Some(n) = entry
            .file_name()
            .to_str()
            .and_then(|s| s.parse::<usize>().ok())
        {
            numbered.push((n, entry.path()));
        }
    }
    numbered.sort();
    numbered
        .into_iter()
        .map(|(_, dir)| Ok((dir.clone(), colmap::read_binary(&dir)?)))
        .collect()
}
