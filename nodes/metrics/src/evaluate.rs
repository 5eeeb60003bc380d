//! Per-image evaluation and assembly of the Metrics report.

use crate::lpips::Lpips;
use crate::mask::Mask;
use crate::mesh_eval::MeshFScores;
use crate::psnr::psnr;
use crate::report::{
    ImageMetrics, MetricsReport, ObjectImageMetrics, ObjectMetrics, ScopeMetrics, ThresholdMetrics,
};
use crate::ssim::{SsimMode, WINDOW_RADIUS, ssim};
use anyhow::{Context, Result, bail};
use objectsplat_core::{IdMap, Image, ObjectLabels};

/// One test view: the rendering, its ground truth and optional masks.
#[derive(Debug, Clone, Copy)]
pub struct TestImage<'a> {
    pub name: &'a str,
    pub rendered: &'a Image,
    pub ground_truth: &'a Image,
    /// Pixels that count for the scene metrics (e.g. valid ground truth); all when `None`.
    pub valid: Option<&'a Mask>,
    /// Ground-truth object ids, for the per-object masked metrics.
    pub objects: Option<&'a IdMap>,
}

/// PSNR and SSIM (masked by `valid`), LPIPS when a network is given (on the whole
/// image), and per object the PSNR/SSIM masked by that object's valid pixels.
/// Both images are compared in RGB (alpha dropped, grey replicated).
pub fn evaluate_image(
    t: &TestImage,
    mode: SsimMode,
    lpips: Option<&Lpips>,
    object_ids: &[u16],
) -> Result<ImageMetrics> {
    let eval = || -> Result<ImageMetrics> {
        let (a, b) = (t.rendered.to_rgb(), t.ground_truth.to_rgb());
        let psnr_all = psnr(&a, &b, t.valid)?;
        let ssim_all = ssim(&a, &b, mode, t.valid)?;
        let lpips_value = match lpips {
            Some(net) => Some(net.distance(&a, &b)?.total),
            None => None,
        };
        let mut objects = Vec::new();
        if let Some(map) = t.objects {
            if (map.width, map.height) != (a.width, a.height) {
                bail!(
                    "object-id map is {}×{} but the image is {}×{}",
                    map.width,
                    map.height,
                    a.width,
                    a.height
                );
            }
            for &id in object_ids {
                let mut mask = Mask::from_id_map(map, id);
                if let Some(v) = t.valid {
                    mask = mask.intersect(v)?;
                }
                if mask.count() == 0 {
                    continue;
                }
                let has_ssim_support = mask.eroded(WINDOW_RADIUS as u32).count() > 0;
                let object_ssim = if has_ssim_support {
                    Some(ssim(&a, &b, mode, Some(&mask))?)
                } else {
                    None
                };
                objects.push(ObjectImageMetrics {
                    id,
                    psnr: Some(psnr(&a, &b, Some(&mask))?),
                    ssim: object_ssim,
                });
            }
        }
        Ok(ImageMetrics {
            name: t.name.to_string(),
            psnr: Some(psnr_all),
            ssim: Some(ssim_all),
            lpips: lpips_value,
            objects,
        })
    };
    eval().with_context(|| format!("evaluating test image {:?}", t.name))
}

fn mean(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (sum, n) = values.fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (n > 0).then(|| sum / n as f64)
}

/// Averages the per-image results and joins the mesh F-scores into one report.
/// `lpips_given` says whether LPIPS weights were supplied (else LPIPS is reported as skipped).
pub fn assemble_report(
    images: Vec<ImageMetrics>,
    mesh: Option<&MeshFScores>,
    voxel: Option<f64>,
    labels: &ObjectLabels,
    mode: SsimMode,
    lpips_given: bool,
) -> MetricsReport {
    let mut scene = ScopeMetrics {
        psnr: mean(images.iter().filter_map(|i| i.psnr)),
        ssim: mean(images.iter().filter_map(|i| i.ssim)),
        lpips: if lpips_given {
            mean(images.iter().filter_map(|i| i.lpips))
        } else {
            None
        },
        ..Default::default()
    };
    if let Some(m) = mesh {
        fill_fscore(&mut scene, Some(&m.scene));
    }
    let objects = labels
        .iter()
        .map(|(&id, label)| {
            let per_image: Vec<&ObjectImageMetrics> = images
                .iter()
                .flat_map(|i| i.objects.iter())
                .filter(|o| o.id == id)
                .collect();
            let mut metrics = ScopeMetrics {
                psnr: mean(per_image.iter().filter_map(|o| o.psnr)),
                ssim: mean(per_image.iter().filter_map(|o| o.ssim)),
                ..Default::default()
            };
            let mut thresholds = Vec::new();
            if let Some(m) = mesh {
                let object = m.objects.iter().find(|o| o.id == id);
                fill_fscore(&mut metrics, object.and_then(|o| o.fscore.as_ref()));
                metrics.tau = Some(m.scene.tau);
                thresholds = object
                    .map(|o| {
                        o.thresholds
                            .iter()
                            .map(|s| ThresholdMetrics {
                                tau: s.tau,
                                fscore: Some(s.fscore),
                                precision: Some(s.precision),
                                recall: Some(s.recall),
                            })
                            .collect()
                    })
                    .unwrap_or_default();
            }
            ObjectMetrics {
                id,
                label: label.clone(),
                metrics,
                images: per_image.len(),
                thresholds,
            }
        })
        .collect();
    let lpips_status = if lpips_given {
        "computed (AlexNet, v0.1)".to_string()
    } else {
        "skipped: no LPIPS weights file was given".to_string()
    };
    MetricsReport {
        scene,
        voxel: mesh.and(voxel),
        ssim_convention: mode.describe().to_string(),
        lpips_status,
        gt_surface: None,
        objects,
        images,
    }
}

fn fill_fscore(m: &mut ScopeMetrics, score: Option<&crate::fscore::FScore>) {
    if let Some(s) = score {
        m.fscore = Some(s.fscore);
        m.precision = Some(s.precision);
        m.recall = Some(s.recall);
        m.accuracy = s.accuracy;
        m.completeness = s.completeness;
        m.tau = Some(s.tau);
    }
}
