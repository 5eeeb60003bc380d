//! Point-cloud precision, recall and F-score at a distance threshold.

use anyhow::{Result, bail};
use kiddo::SquaredEuclidean;
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Accuracy and completeness are `None` when the prediction is empty (no distance exists).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FScore {
    /// Fraction of predicted points closer than τ to the ground truth.
    pub precision: f64,
    /// Fraction of ground-truth points closer than τ to the prediction.
    pub recall: f64,
    /// `2PR / (P + R)`, 0 when both are 0.
    pub fscore: f64,
    /// Mean distance from predicted points to the ground truth.
    pub accuracy: Option<f64>,
    /// Mean distance from ground-truth points to the prediction.
    pub completeness: Option<f64>,
    pub tau: f64,
}

type Tree = ImmutableKdTree<f64, u64, 3, 32>;

/// Distance from each query point to its nearest neighbour in `reference` (k-d tree).
pub fn nearest_distances(queries: &[[f64; 3]], reference: &[[f64; 3]]) -> Result<Vec<f64>> {
    Ok(nearest_neighbours(queries, reference)?
        .into_iter()
        .map(|(_, d)| d)
        .collect())
}

/// For each query point, the index of its nearest neighbour in `reference` and the
/// distance to it (k-d tree).
pub fn nearest_neighbours(
    queries: &[[f64; 3]],
    reference: &[[f64; 3]],
) -> Result<Vec<(usize, f64)>> {
    check_points("reference", reference)?;
    check_points("query", queries)?;
    if reference.is_empty() {
        bail!("nearest distances: the reference point set is empty");
    }
    let tree: Tree = ImmutableKdTree::new_from_slice(reference);
    // Queries run in Morton (Z-curve) order: neighbouring queries then walk the same
    // tree nodes, which keeps them in cache.
    let order = morton_order(queries);
    let sorted: Vec<(usize, f64)> = order
        .par_iter()
        .map(|&i| {
            let hit = tree.nearest_one::<SquaredEuclidean>(&queries[i]);
            (hit.item as usize, hit.distance.sqrt())
        })
        .collect();
    let mut out = vec![(0, 0.0); queries.len()];
    for (&i, hit) in order.iter().zip(sorted) {
        out[i] = hit;
    }
    Ok(out)
}

/// Indices of `points` sorted along a 3-D Morton curve over their bounding box.
fn morton_order(points: &[[f64; 3]]) -> Vec<usize> {
    let (lo, hi) = objectsplat_core::geometry::bounding_box(points.iter().copied());
    // 21 bits per axis fill a u64 code.
    let cells = ((1u64 << 21) - 1) as f64;
    let scale: [f64; 3] = std::array::from_fn(|k| {
        if hi[k] > lo[k] {
            cells / (hi[k] - lo[k])
        } else {
            0.0
        }
    });
    let mut keyed: Vec<(u64, usize)> = points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let code = objectsplat_core::geometry::morton_code(std::array::from_fn(|k| {
                ((p[k] - lo[k]) * scale[k]) as u64
            }));
            (code, i)
        })
        .collect();
    keyed.par_sort_unstable();
    keyed.into_iter().map(|(_, i)| i).collect()
}

/// Precision/recall/F at threshold `tau` (strict `d < τ`, as the indoor-scene and
/// Tanks-and-Temples protocols). An empty prediction scores 0 (nothing of the
/// ground truth is reconstructed); an empty ground truth is an error.
pub fn fscore(pred: &[[f64; 3]], gt: &[[f64; 3]], tau: f64) -> Result<FScore> {
    if !(tau.is_finite() && tau > 0.0) {
        bail!("F-score threshold must be a positive number, got {tau}");
    }
    if gt.is_empty() {
        bail!("F-score: the ground-truth point set is empty");
    }
    check_points("predicted", pred)?;
    if pred.is_empty() {
        return Ok(FScore {
            precision: 0.0,
            recall: 0.0,
            fscore: 0.0,
            accuracy: None,
            completeness: None,
            tau,
        });
    }
    let to_gt = nearest_distances(pred, gt)?;
    let to_pred = nearest_distances(gt, pred)?;
    let within = |d: &[f64]| d.iter().filter(|&&v| v < tau).count() as f64 / d.len() as f64;
    let mean = |d: &[f64]| d.iter().sum::<f64>() / d.len() as f64;
    let (precision, recall) = (within(&to_gt), within(&to_pred));
    let fscore = if precision + recall > 0.0 {
        2.0 * precision * recall / (precision + recall)
    } else {
        0.0
    };
    Ok(FScore {
        precision,
        recall,
        fscore,
        accuracy: Some(mean(&to_gt)),
        completeness: Some(mean(&to_pred)),
        tau,
    })
}

fn check_points(name: &str, points: &[[f64; 3]]) -> Result<()> {
    if let Some(i) = points.iter().position(|p| p.iter().any(|v| !v.is_finite())) {
        bail!("{name} point {i} has a non-finite coordinate");
    }
    Ok(())
}
