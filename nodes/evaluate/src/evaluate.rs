//! Evaluating a run: renders of the test frames against their photos, and the
//! scene's visible surface against a ground-truth mesh, for the scene and per object.

use anyhow::{Context, Result, bail};
use objectsplat_core::ComponentKind;
use objectsplat_core::artifact::OBJECTS_JSON;
use objectsplat_core::frames::frame_stem;
use objectsplat_core::masks::read_objects;
use objectsplat_core::{Frames, IdMap, Image, Mesh, ObjectLabels, Split};
use objectsplat_metrics::normal_consistency;
use objectsplat_metrics::report::ImageMetrics;
use objectsplat_metrics::surface::sample_surface;
use objectsplat_metrics::{
    Lpips, MeshEvalParams, MetricsReport, SsimMode, TestImage, assemble_report, evaluate_image,
    evaluate_mesh,
};
use objectsplat_raster::{RenderBackend, RenderSettings};
use objectsplat_scene::Scene;
use objectsplat_scene::surface::visible_mesh;
use std::collections::BTreeMap;
use std::path::Path;

/// Ground truth beyond the photos.
pub struct GroundTruth<'a> {
    /// A mesh with (optionally) per-vertex object ids and their labels.
    pub mesh: Option<(&'a Mesh, &'a ObjectLabels)>,
    /// A Masks folder: per-frame object-id maps + objects.json.
    pub masks: Option<&'a Path>,
}

pub struct EvaluateSettings<'a> {
    pub mesh: MeshEvalParams,
    /// More thresholds at which every object's mesh scores are reported.
    pub object_taus: Vec<f64>,
    pub ssim: SsimMode,
    pub lpips: Option<&'a Lpips>,
    pub gt_surface: GtSurface,
    /// Renders the background member to find where it hangs in front of the objects.
    pub backend: &'a dyn RenderBackend<f32>,
}

/// Which ground-truth surface the F-scores compare against.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum GtSurface {
    /// Only what at least one frame of the capture sees (depth-tested): a scan
    /// holds no more, and no method can reconstruct what no camera saw.
    #[default]
    Observed,
    /// The whole mesh (a synthetic room's ceiling and hidden sides included).
    All,
}

impl GtSurface {
    pub fn describe(self) -> &'static str {
        match self {
            GtSurface::Observed => {
                "observed: mesh surface seen (depth-tested) by at least one frame"
            }
            GtSurface::All => "all: the whole mesh",
        }
    }
}

/// Depth maps of the ground-truth mesh in every frame, to tell which surface points a camera sees.
struct ObservedSurface {
    cameras: Vec<objectsplat_core::Camera>,
    depth: Vec<objectsplat_masks::raster::Raster>,
    /// Depth agreement that counts as "this point is the surface seen there": the
    /// larger of `absolute` and `relative`·depth (a pixel spans a range of depths
    /// on a slanted surface).
    absolute: f64,
    relative: f64,
}

impl ObservedSurface {
    fn new(mesh: &Mesh, frames: &Frames, absolute: f64) -> Result<Self> {
        let options = objectsplat_masks::raster::RasterOptions::default();
        let cameras: Vec<_> = frames.frames.iter().map(|f| f.camera()).collect();
        let depth = cameras
            .iter()
            .map(|c| {
                objectsplat_masks::raster::rasterize(&mesh.positions, &mesh.faces, c, &options)
                    .map_err(|e| anyhow::anyhow!("rasterizing the ground-truth mesh: {e}"))
            })
            .collect::<Result<Vec<_>>>()?;
        Ok(ObservedSurface {
            cameras,
            depth,
            absolute,
            relative: 0.02,
        })
    }

    fn sees(&self, p: &[f64; 3]) -> bool {
        let point = glam::DVec3::from_array(*p);
        self.cameras
            .iter()
            .zip(&self.depth)
            .any(|(camera, raster)| {
                let Some((u, v, z)) = camera.project(point) else {
                    return false;
                };
                if !(u >= 0.0 && v >= 0.0 && u < camera.width as f64 && v < camera.height as f64) {
                    return false;
                }
                raster
                    .depth_at(u as u32, v as u32)
                    .is_some_and(|d| (z - d as f64).abs() <= self.absolute.max(self.relative * z))
            })
    }
}

/// Where background geometry hangs in front of an object, in the test views: per
/// object id, the object's true pixels (the ground-truth mesh rasterized) and those
/// at which the background member alone renders an at least half-opaque surface
/// nearer than the object's true surface by more than `tolerance` (or 2 % of its
/// depth): the floaters and sheets a user sees in front of an object.
fn background_in_front(
    scene: &Scene,
    tests: &[&objectsplat_core::Frame],
    gt: &Mesh,
    objects: &[u16],
    tolerance: f64,
    backend: &dyn RenderBackend<f32>,
) -> Result<Option<BTreeMap<u16, (u64, u64)>>> {
    let (Some(gt_ids), Some(background)) = (
        gt.object_ids.as_ref(),
        scene
            .objects
            .iter()
            .find(|o| o.entry.kind == ComponentKind::Background),
    ) else {
        return Ok(None);
    };
    let background = background.world_model()?;
    let settings = RenderSettings::for_model(&background);
    let mut counts: BTreeMap<u16, (u64, u64)> = objects.iter().map(|&id| (id, (0, 0))).collect();
    for frame in tests {
        let camera = frame.camera();
        let truth = objectsplat_masks::raster::rasterize(
            &gt.positions,
            &gt.faces,
            &camera,
            &objectsplat_masks::raster::RasterOptions::default(),
        )
        .map_err(|e| anyhow::anyhow!("rasterizing the ground-truth mesh: {e}"))?;
        let pixels = (camera.width * camera.height) as usize;
        let (rendered, _) = backend
            .forward(&background, &camera, &settings, &vec![0.0; pixels * 3])
            .with_context(|| format!("rendering the background in {}", frame.name))?;
        let region = rendered.region;
        for y in 0..camera.height {
            for x in 0..camera.width {
                let (Some(face), Some(depth)) = (truth.face_at(x, y), truth.depth_at(x, y)) else {
                    continue;
                };
                let id = gt_ids[gt.faces[face as usize][0] as usize];
                let Some(count) = u16::try_from(id).ok().and_then(|id| counts.get_mut(&id)) else {
                    continue;
                };
                count.0 += 1;
                if !region.contains(x, y) {
                    continue;
                }
                let k = ((y - region.y0) * region.width() + (x - region.x0)) as usize;
                let front = rendered.median_depth[k] as f64;
                let depth = depth as f64;
                if front > 0.0 && front < depth - tolerance.max(0.02 * depth) {
                    count.1 += 1;
                }
            }
        }
    }
    Ok(Some(counts))
}

/// What the evaluation covered, for the run report.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EvaluationSummary {
    pub test_images: usize,
    pub images_with_masks: usize,
    pub objects: usize,
}

/// Samples of a scene member's visible surface (raw; `evaluate_mesh` down-samples).
fn surface_points(mesh: &Mesh, params: &MeshEvalParams) -> Result<Vec<[f64; 3]>> {
    if mesh.faces.is_empty() {
        return Ok(Vec::new());
    }
    Ok(sample_surface(mesh, params.samples, params.seed, params.max_samples)?.points)
}

/// The image metrics of `renders` (`<frame stem>.png` per test frame) against the
/// test photos, per object where `masks` holds an id map; and how many had one.
fn score_renders(
    renders: &Path,
    tests: &[&objectsplat_core::Frame],
    frames: &Frames,
    masks: Option<&Path>,
    ids: &[u16],
    settings: &EvaluateSettings,
) -> Result<(Vec<ImageMetrics>, usize)> {
    let mut per_image = Vec::with_capacity(tests.len());
    let mut with_masks = 0;
    for frame in tests {
        let stem = frame_stem(&frame.name);
        let render_path = renders.join(format!("{stem}.png"));
        if !render_path.is_file() {
            bail!(
                "{}: no render for test frame {:?}",
                render_path.display(),
                frame.name
            );
        }
        let rendered = Image::load(&render_path)?.to_rgb();
        let ground_truth = frames.load_rgb(frame)?;
        let id_map = match masks {
            Some(dir) => {
                let path = dir.join(format!("{stem}.png"));
                if path.is_file() {
                    with_masks += 1;
                    Some(IdMap::load(&path)?)
                } else {
                    None
                }
            }
            None => None,
        };
        let test = TestImage {
            name: &frame.name,
            rendered: &rendered,
            ground_truth: &ground_truth,
            valid: None,
            objects: id_map.as_ref(),
        };
        per_image.push(
            evaluate_image(&test, settings.ssim, settings.lpips, ids)
                .with_context(|| format!("render {}", render_path.display()))?,
        );
    }
    Ok((per_image, with_masks))
}

/// Runs the whole evaluation. Renders are `<renders>/<frame stem>.png` for every
/// test frame, and so are the renders as exported when given (`exported`); a
/// missing render is an error naming it.
pub fn evaluate_scene(
    renders: &Path,
    exported: Option<&Path>,
    frames: &Frames,
    scene: &Scene,
    truth: &GroundTruth,
    settings: &EvaluateSettings,
) -> Result<(MetricsReport, EvaluationSummary)> {
    let tests: Vec<_> = frames.by_split(Split::Test).collect();
    if tests.is_empty() {
        bail!(
            "{}: no frame has split \"test\"; nothing to evaluate",
            frames.root.display()
        );
    }
    let mut labels = ObjectLabels::new();
    if let Some((_, mesh_labels)) = truth.mesh {
        labels.extend(mesh_labels.iter().map(|(k, v)| (*k, v.clone())));
    }
    if let Some(dir) = truth.masks
        && dir.join(OBJECTS_JSON).exists()
    {
        labels.extend(read_objects(dir)?);
    }
    let ids: Vec<u16> = labels.keys().copied().collect();
    let mut summary = EvaluationSummary {
        test_images: tests.len(),
        objects: ids.len(),
        ..Default::default()
    };

    let (per_image, with_masks) =
        score_renders(renders, &tests, frames, truth.masks, &ids, settings)?;
    summary.images_with_masks = with_masks;
    let exported = match exported {
        Some(dir) => {
            let (images, _) = score_renders(dir, &tests, frames, truth.masks, &ids, settings)
                .context("the renders as exported")?;
            let scored = assemble_report(images, None, None, &labels, settings.ssim, false);
            Some(scored)
        }
        None => None,
    };

    // Background in front of the objects, measured against the true surfaces.
    let in_front = match truth.mesh {
        Some((gt, _)) => {
            let objects: Vec<u16> = scene.objects.iter().filter_map(|o| o.entry.id).collect();
            background_in_front(
                scene,
                &tests,
                gt,
                &objects,
                settings.mesh.tau,
                settings.backend,
            )?
        }
        None => None,
    };
    // Mesh scores, and the normal consistency of the scene and of each object.
    let (mesh_scores, normals) = match truth.mesh {
        Some((gt, _)) => {
            let observed = match settings.gt_surface {
                GtSurface::Observed => Some(ObservedSurface::new(gt, frames, settings.mesh.voxel)?),
                GtSurface::All => None,
            };
            let keep = observed.as_ref().map(|o| move |p: &[f64; 3]| o.sees(p));
            let keep_normals = keep
                .as_ref()
                .map(|k| k as &(dyn Fn(&[f64; 3]) -> bool + Sync));
            let merged = scene.merged_model()?;
            let scene_mesh = visible_mesh(&merged.model);
            let pred_scene = surface_points(&scene_mesh, &settings.mesh)
                .context("sampling the scene's surface")?;
            let scene_normals = normal_consistency(&scene_mesh, gt, &settings.mesh, keep_normals)
                .context("the scene's normal consistency")?;
            let mut pred_objects = Vec::new();
            let mut object_normals = Vec::new();
            for o in &scene.objects {
                if let Some(id) = o.entry.id {
                    let mesh = visible_mesh(o.world_model()?.as_ref());
                    let points = surface_points(&mesh, &settings.mesh)
                        .with_context(|| format!("sampling the surface of {:?}", o.entry.name))?;
                    pred_objects.push((id, points));
                    let nc = normal_consistency(&mesh, gt, &settings.mesh, keep_normals)
                        .with_context(|| format!("the normal consistency of {:?}", o.entry.name))?;
                    object_normals.push((id, nc));
                }
            }
            // Per-object scores need ids on the ground-truth faces.
            let object_ids: Vec<u16> = if gt.object_ids.is_some() {
                ids.clone()
            } else {
                Vec::new()
            };
            let scores = evaluate_mesh(
                gt,
                &pred_scene,
                &pred_objects,
                &object_ids,
                &settings.mesh,
                keep_normals,
                &settings.object_taus,
            )?;
            (Some(scores), Some((scene_normals, object_normals)))
        }
        None => (None, None),
    };
    let mut report = assemble_report(
        per_image,
        mesh_scores.as_ref(),
        truth.mesh.map(|_| settings.mesh.voxel),
        &labels,
        settings.ssim,
        settings.lpips.is_some(),
    );
    if let Some(counts) = in_front {
        let share = |(total, front): (u64, u64)| (total > 0).then(|| front as f64 / total as f64);
        let pooled = counts
            .values()
            .fold((0, 0), |(t, f), &(total, front)| (t + total, f + front));
        report.scene.background_in_front = share(pooled);
        for o in &mut report.objects {
            o.metrics.background_in_front = counts.get(&o.id).copied().and_then(share);
        }
    }
    if let Some(x) = exported {
        report.scene.exported_psnr = x.scene.psnr;
        report.scene.exported_ssim = x.scene.ssim;
        for (o, xo) in report.objects.iter_mut().zip(&x.objects) {
            // Both reports list the same labels in the same order.
            debug_assert_eq!(o.id, xo.id);
            o.metrics.exported_psnr = xo.metrics.psnr;
            o.metrics.exported_ssim = xo.metrics.ssim;
        }
    }
    report.gt_surface = truth
        .mesh
        .map(|_| settings.gt_surface.describe().to_string());
    if let Some((scene_normals, object_normals)) = normals {
        report.scene.normal_consistency = scene_normals;
        for o in &mut report.objects {
            o.metrics.normal_consistency = object_normals
                .iter()
                .find(|(id, _)| *id == o.id)
                .and_then(|(_, nc)| *nc);
        }
    }
    Ok((report, summary))
}
