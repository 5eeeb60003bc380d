//! Normal consistency: whether a predicted mesh is a surface or a field of shingles.
//!
//! The area-weighted mean, over the predicted surface, of |cos| between a face's normal
//! and the normal of the true surface nearest to it. Faces lying along the true surface
//! score 1 whatever their winding; a table top of shingles tilted 45° scores 0.71, one of
//! faces standing on edge 0. Both surfaces are sampled by area (one sample per voxel² of
//! the evaluation), each sample carrying its face's normal; a predicted sample takes the
//! normal of its nearest true sample.

use crate::fscore::nearest_neighbours;
use crate::mesh_eval::{GtFilter, MeshEvalParams};
use crate::surface::{SampleCount, sample_surface};
use anyhow::{Result, bail};
use objectsplat_core::Mesh;
use objectsplat_core::geometry::triangle_cross;

/// Unit normals of `mesh`'s faces; `None` for a face with no area.
fn face_normals(mesh: &Mesh) -> Vec<Option<[f64; 3]>> {
    mesh.faces
        .iter()
        .map(|f| {
            let n = triangle_cross(&f.map(|v| mesh.positions[v as usize].map(f64::from)));
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            (len > 0.0 && len.is_finite()).then(|| n.map(|x| x / len))
        })
        .collect()
}

/// Points on a surface and, for each, its face's unit normal.
type Oriented = (Vec<[f64; 3]>, Vec<[f64; 3]>);

/// Samples of `mesh` with their face's unit normal (samples on faces without one left out).
fn oriented_samples(mesh: &Mesh, params: &MeshEvalParams, seed: u64) -> Result<Oriented> {
    if mesh.faces.is_empty() {
        return Ok((Vec::new(), Vec::new()));
    }
    let density = 1.0 / (params.voxel * params.voxel);
    let samples = sample_surface(
        mesh,
        SampleCount::PerArea(density),
        seed,
        params.max_samples,
    )?;
    let normals = face_normals(mesh);
    let (mut points, mut directions) = (Vec::new(), Vec::new());
    for (p, &f) in samples.points.iter().zip(&samples.faces) {
        if let Some(n) = normals[f as usize] {
            points.push(*p);
            directions.push(n);
        }
    }
    Ok((points, directions))
}

/// The normal consistency of `pred` against `truth` (see the module doc); `None` when
/// either surface has no sample. `keep` limits the true surface (to what the cameras saw,
/// as the F-score does).
pub fn normal_consistency(
    pred: &Mesh,
    truth: &Mesh,
    params: &MeshEvalParams,
    keep: Option<GtFilter<'_>>,
) -> Result<Option<f64>> {
    if !(params.voxel.is_finite() && params.voxel > 0.0) {
        bail!(
            "normal consistency: the sample spacing (voxel) must be a positive number, got {}",
            params.voxel
        );
    }
    let (mut true_points, mut true_normals) = oriented_samples(truth, params, params.seed)?;
    if let Some(keep) = keep {
        let kept: Vec<usize> = (0..true_points.len())
            .filter(|&i| keep(&true_points[i]))
            .collect();
        true_points = kept.iter().map(|&i| true_points[i]).collect();
        true_normals = kept.iter().map(|&i| true_normals[i]).collect();
    }
    let (pred_points, pred_normals) = oriented_samples(pred, params, params.seed + 1)?;
    if true_points.is_empty() || pred_points.is_empty() {
        return Ok(None);
    }
    let nearest = nearest_neighbours(&pred_points, &true_points)?;
    let sum: f64 = nearest
        .iter()
        .zip(&pred_normals)
        .map(|(&(i, _), n)| {
            let m = true_normals[i];
            (n[0] * m[0] + n[1] * m[1] + n[2] * m[2]).abs()
        })
        .sum();
    Ok(Some(sum / pred_points.len() as f64))
}
