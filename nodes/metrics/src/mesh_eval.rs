//! Scene and per-object mesh F-score: surface sampling, voxel down-sampling, k-d tree matching.

use crate::fscore::{FScore, fscore};
use crate::surface::{SampleCount, sample_surface};
use crate::voxel::voxel_downsample;
use anyhow::{Context, Result, bail};
use objectsplat_core::Mesh;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Indoor-scene protocol defaults: τ = 5 cm, 2 cm voxels, about one sample per cm²,
/// at most [`DEFAULT_MAX_SAMPLES`] samples per surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshEvalParams {
    pub tau: f64,
    pub voxel: f64,
    pub samples: SampleCount,
    pub seed: u64,
    /// Cap on the samples drawn on one surface (see [`sample_surface`]).
    pub max_samples: usize,
}

/// Ten million samples (about 280 MB with their face ids): a 1,000 m² surface at
/// the default density of one sample per cm², ten times the surface of a furnished
/// room. Beyond that a predicted surface has almost surely diverged.
pub const DEFAULT_MAX_SAMPLES: usize = 10_000_000;

impl Default for MeshEvalParams {
    fn default() -> Self {
        MeshEvalParams {
            tau: 0.05,
            voxel: 0.02,
            samples: SampleCount::PerArea(10_000.0),
            seed: 0,
            max_samples: DEFAULT_MAX_SAMPLES,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ObjectFScore {
    pub id: u16,
    /// `None` when the ground-truth mesh has no sample on this object's faces.
    pub fscore: Option<FScore>,
    pub gt_points: usize,
    pub pred_points: usize,
    /// The same comparison at each of the extra thresholds asked for (in their order).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub thresholds: Vec<FScore>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeshFScores {
    pub scene: FScore,
    pub objects: Vec<ObjectFScore>,
}

/// Samples a mesh surface by area and voxel-down-samples the samples.
pub fn mesh_points(mesh: &Mesh, params: &MeshEvalParams) -> Result<Vec<[f64; 3]>> {
    let samples = sample_surface(mesh, params.samples, params.seed, params.max_samples)?;
    voxel_downsample(&samples.points, params.voxel)
}

/// Accepts the ground-truth samples to score against.
pub type GtFilter<'a> = &'a (dyn Fn(&[f64; 3]) -> bool + Sync);

/// Scores a prediction against a ground-truth mesh, for the whole scene and per object.
///
/// `pred_scene` is the whole predicted surface and `pred_objects` one point set per
/// object id (samples of that object's component model), all in ground-truth
/// coordinates; both are voxel-down-sampled here. The ground truth of object `k` is
/// the set of surface samples on faces whose object is `k` (object of a face = the
/// object of its first vertex). Objects listed in `object_ids` but absent from
/// `pred_objects` score 0. `keep_gt`, when given, restricts the ground truth to the
/// samples it accepts (e.g. the surface a capture actually saw). Every object is also
/// scored at each of `object_taus` ([`ObjectFScore::thresholds`]), on the same
/// down-sampled points.
pub fn evaluate_mesh(
    gt: &Mesh,
    pred_scene: &[[f64; 3]],
    pred_objects: &[(u16, Vec<[f64; 3]>)],
    object_ids: &[u16],
    params: &MeshEvalParams,
    keep_gt: Option<GtFilter<'_>>,
    object_taus: &[f64],
) -> Result<MeshFScores> {
    let mut samples = sample_surface(gt, params.samples, params.seed, params.max_samples)
        .context("sampling the ground-truth mesh")?;
    if let Some(keep) = keep_gt {
        let (points, faces) = samples
            .points
            .iter()
            .zip(&samples.faces)
            .filter(|(p, _)| keep(p))
            .map(|(p, f)| (*p, *f))
            .unzip();
        samples.points = points;
        samples.faces = faces;
    }
    if samples.points.is_empty() {
        bail!(
            "the ground-truth mesh gave no surface samples{}; raise the sampling density",
            if keep_gt.is_some() {
                " that the frames see"
            } else {
                ""
            }
        );
    }
    let gt_scene = voxel_downsample(&samples.points, params.voxel)?;
    let pred_scene =
        voxel_downsample(pred_scene, params.voxel).context("down-sampling the predicted scene")?;
    let scene = fscore(&pred_scene, &gt_scene, params.tau)?;

    if !object_ids.is_empty() && gt.object_ids.is_none() {
        bail!("per-object F-score needs a ground-truth mesh annotated with object ids");
    }
    let mut gt_by_object: BTreeMap<i32, Vec<[f64; 3]>> = BTreeMap::new();
    for (p, &face) in samples.points.iter().zip(&samples.faces) {
        gt_by_object
            .entry(gt.face_object(face as usize))
            .or_default()
            .push(*p);
    }
    let mut pred_by_object: BTreeMap<u16, &[[f64; 3]]> = BTreeMap::new();
    for (id, points) in pred_objects {
        if pred_by_object.insert(*id, points).is_some() {
            bail!("predicted points for object {id} are given twice");
        }
    }
    let mut objects = Vec::with_capacity(object_ids.len());
    for &id in object_ids {
        let gt_points = match gt_by_object.get(&i32::from(id)) {
            Some(points) => voxel_downsample(points, params.voxel)?,
            None => Vec::new(),
        };
        // An id the scene has no member for (a label folded into the background,
        // an object that was never trained) has no score of its own: the scene's
        // F-score counts its surface, a 0 here would blame a member that does not exist.
        let pred = match pred_by_object.get(&id) {
            Some(points) => {
                Some(voxel_downsample(points, params.voxel).with_context(|| {
                    format!("down-sampling the predicted points of object {id}")
                })?)
            }
            None => None,
        };
        let (score, thresholds) = match &pred {
            Some(pred) if !gt_points.is_empty() => (
                Some(fscore(pred, &gt_points, params.tau)?),
                object_taus
                    .iter()
                    .map(|&tau| fscore(pred, &gt_points, tau))
                    .collect::<Result<Vec<_>>>()?,
            ),
            _ => (None, Vec::new()),
        };
        objects.push(ObjectFScore {
            id,
            fscore: score,
            gt_points: gt_points.len(),
            pred_points: pred.as_ref().map_or(0, Vec::len),
            thresholds,
        });
    }
    Ok(MeshFScores { scene, objects })
}
