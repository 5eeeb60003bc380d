//! Evaluating a run: renders of the test frames against their photos, and the
//! scene's visible surface against a ground-truth mesh, for the scene and per object.

use crate::scene::Scene;
use crate::surface::visible_mesh;
use anyhow::{Context, Result, bail};
use objectsplat_core::frames::frame_stem;
use objectsplat_core::masks::{OBJECTS_JSON, read_objects};
use objectsplat_core::{Frames, IdMap, Image, Mesh, ObjectLabels, Split};
use objectsplat_metrics::surface::sample_surface;
use objectsplat_metrics::{
    Lpips, MeshEvalParams, MetricsReport, SsimMode, TestImage, assemble_report, evaluate_image,
    evaluate_mesh,
};
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
    pub ssim: SsimMode,
    pub lpips: Option<&'a Lpips>,
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

/// Runs the whole evaluation. Renders are `<renders>/<frame stem>.png` for every
/// test frame; a missing render is an error naming it.
pub fn evaluate_scene(
    renders: &Path,
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

    let mut per_image = Vec::with_capacity(tests.len());
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
        let id_map = match truth.masks {
            Some(dir) => {
                let path = dir.join(format!("{stem}.png"));
                if path.is_file() {
                    summary.images_with_masks += 1;
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
            evaluate_image(&test, settings.ssim, settings.lpips, &ids)
                .with_context(|| format!("render {}", render_path.display()))?,
        );
    }

    let mesh_scores = match truth.mesh {
        Some((gt, _)) => {
            let merged = scene.merged_model()?;
            let pred_scene = surface_points(&visible_mesh(&merged.model), &settings.mesh)
                .context("sampling the scene's surface")?;
            let mut pred_objects = Vec::new();
            for o in &scene.objects {
                if let Some(id) = o.entry.id {
                    let points = surface_points(&visible_mesh(&o.model), &settings.mesh)
                        .with_context(|| format!("sampling the surface of {:?}", o.entry.name))?;
                    pred_objects.push((id, points));
                }
            }
            // Per-object scores need ids on the ground-truth faces.
            let object_ids: Vec<u16> = if gt.object_ids.is_some() {
                ids.clone()
            } else {
                Vec::new()
            };
            Some(evaluate_mesh(
                gt,
                &pred_scene,
                &pred_objects,
                &object_ids,
                &settings.mesh,
            )?)
        }
        None => None,
    };
    let report = assemble_report(
        per_image,
        mesh_scores.as_ref(),
        truth.mesh.map(|_| settings.mesh.voxel),
        &labels,
        settings.ssim,
        settings.lpips.is_some(),
    );
    Ok((report, summary))
}
