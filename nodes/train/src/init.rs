//! Initialization from sparse points: one small triangle per point, and the
//! choice of which points seed a component.

use anyhow::{Context, Result, bail};
use glam::{DQuat, DVec3};
use kiddo::ImmutableKdTree;
use kiddo::SquaredEuclidean;
use objectsplat_core::Points;
use objectsplat_raster::Model;
use objectsplat_raster::model::{SH_COEFFS, inverse_sigmoid};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::num::NonZero;

/// `Y_0^0`: SH DC coefficient ↔ colour offset from 0.5.
pub const SH_C0: f64 = 0.282_094_791_773_878_14;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InitSettings {
    /// Triangle circumradius = this × RMS distance to the `neighbors` nearest points.
    pub radius_factor: f64,
    pub neighbors: usize,
    pub opacity: f64,
    pub seed: u64,
}

impl Default for InitSettings {
    fn default() -> Self {
        InitSettings {
            radius_factor: 2.23,
            neighbors: 3,
            opacity: 0.28,
            seed: 0,
        }
    }
}

/// RMS distance from each point to its `k` nearest other points (0 for a lone point).
pub fn rms_neighbor_distance(points: &[[f32; 3]], k: usize) -> Vec<f64> {
    if points.len() < 2 || k == 0 {
        return vec![0.0; points.len()];
    }
    let tree: ImmutableKdTree<f32, 3> = ImmutableKdTree::new_from_slice(points);
    let want = (k + 1).min(points.len());
    points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            // want ≥ 2 because points.len() ≥ 2.
            let found = tree.nearest_n::<SquaredEuclidean>(
                p,
                NonZero::new(want).unwrap_or(NonZero::<usize>::MIN),
            );
            let others: Vec<f64> = found
                .iter()
                .filter(|n| n.item as usize != i)
                .take(k)
                .map(|n| n.distance as f64)
                .collect();
            if others.is_empty() {
                0.0
            } else {
                (others.iter().sum::<f64>() / others.len() as f64).sqrt()
            }
        })
        .collect()
}

/// A uniformly random rotation (normalized 4D Gaussian quaternion, Box–Muller).
fn random_rotation(rng: &mut Pcg64Mcg) -> DQuat {
    loop {
        let mut g = [0.0f64; 4];
        for pair in g.chunks_mut(2) {
            let u1: f64 = 1.0 - rng.random::<f64>();
            let u2: f64 = rng.random::<f64>();
            let r = (-2.0 * u1.ln()).sqrt();
            pair[0] = r * (std::f64::consts::TAU * u2).cos();
            pair[1] = r * (std::f64::consts::TAU * u2).sin();
        }
        let q = DQuat::from_xyzw(g[0], g[1], g[2], g[3]);
        if q.length() > 1e-9 {
            return q.normalize();
        }
    }
}

/// One right isosceles triangle per point, inscribed in a circle of radius
/// `radius_factor × RMS 3-NN distance` around it, randomly oriented; SH DC from
/// the point colour, higher bands zero, opacity `opacity` (floor 0).
pub fn init_model(points: &Points, settings: &InitSettings) -> Result<Model<f32>> {
    if points.positions.is_empty() {
        bail!("no points to initialize from");
    }
    points.validate()?;
    if !(settings.opacity > 0.0 && settings.opacity < 1.0) {
        bail!("initial opacity {} must lie in (0, 1)", settings.opacity);
    }
    if !(settings.radius_factor.is_finite() && settings.radius_factor > 0.0) {
        bail!(
            "radius factor {} must be finite and positive",
            settings.radius_factor
        );
    }
    let radii = rms_neighbor_distance(&points.positions, settings.neighbors);
    // A point alone (or duplicated) gets the median radius so its triangle is not degenerate.
    let mut positive: Vec<f64> = radii.iter().copied().filter(|r| *r > 0.0).collect();
    positive.sort_by(f64::total_cmp);
    let fallback = positive.get(positive.len() / 2).copied().unwrap_or(1e-2);
    let theta = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let template = [
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(theta.cos(), theta.sin(), 0.0),
        DVec3::new(0.0, 0.0, -1.0),
    ];
    let mut rng = Pcg64Mcg::seed_from_u64(settings.seed);
    let logit = inverse_sigmoid(settings.opacity) as f32;
    let mut model = Model::<f32>::empty();
    for (i, (p, rgb)) in points.positions.iter().zip(&points.colors).enumerate() {
        let r = settings.radius_factor * if radii[i] > 0.0 { radii[i] } else { fallback };
        let rot = random_rotation(&mut rng);
        let centre = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
        let base = model.vertices.len() as u32;
        for d in template {
            let v = centre + rot * d * r;
            model.vertices.push([v.x as f32, v.y as f32, v.z as f32]);
            let mut sh = [[0.0f32; 3]; SH_COEFFS];
            for c in 0..3 {
                sh[0][c] = ((rgb[c] as f64 / 255.0 - 0.5) / SH_C0) as f32;
            }
            model.sh.push(sh);
            model.opacity_logits.push(logit);
        }
        model.faces.push([base, base + 1, base + 2]);
    }
    model.validate().context("initialized model")?;
    Ok(model)
}
