//! Area-weighted random sampling of points on a triangle mesh.

use anyhow::{Result, bail};
use objectsplat_core::Mesh;
use objectsplat_core::geometry::triangle_area;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// How many points to draw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SampleCount {
    /// Exactly this many points.
    Total(usize),
    /// `round(density · total area)` points (density in points per square unit).
    PerArea(f64),
}

/// Points on a mesh and the face each one lies on.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SurfaceSamples {
    pub points: Vec<[f64; 3]>,
    pub faces: Vec<u32>,
}

/// Draws points uniformly over the mesh surface: a face with probability
/// proportional to its area, then a uniform point in it (`√u` barycentric rule).
/// The same mesh, count and seed give the same samples on every platform.
///
/// At most `max_samples` points are drawn: a count beyond it (an area that exploded
/// with a diverged model, a density typed with too many zeros) is an error naming
/// the area, before anything is allocated, never an allocation that aborts the process.
pub fn sample_surface(
    mesh: &Mesh,
    count: SampleCount,
    seed: u64,
    max_samples: usize,
) -> Result<SurfaceSamples> {
    mesh.validate()
        .map_err(|e| anyhow::anyhow!("cannot sample the mesh: {e}"))?;
    let corners = |f: &[u32; 3]| f.map(|v| mesh.positions[v as usize].map(f64::from));
    let mut cumulative = Vec::with_capacity(mesh.faces.len());
    let mut total = 0.0;
    for f in &mesh.faces {
        total += triangle_area(&corners(f));
        cumulative.push(total);
    }
    let wanted = match count {
        SampleCount::Total(n) => n as f64,
        SampleCount::PerArea(density) => {
            if !(density.is_finite() && density > 0.0) {
                bail!("sampling density must be a positive number, got {density}");
            }
            (density * total).round()
        }
    };
    // NaN (an infinite area times a density) is refused with the over-large counts.
    if wanted.is_nan() || wanted > max_samples as f64 {
        let per_area = match count {
            SampleCount::PerArea(d) => format!(" ({d} per square unit)"),
            SampleCount::Total(_) => String::new(),
        };
        bail!(
            "sampling {wanted:.3e} points{per_area} on a surface of area {total:.3e} ({} faces) exceeds max_samples = {max_samples}; \
             a surface this large usually comes from a diverged model (faces blown up), otherwise raise max_samples",
            mesh.faces.len()
        );
    }
    // Finite and within max_samples (a usize), checked just above.
    let n = wanted as usize;
    if n == 0 {
        return Ok(SurfaceSamples::default());
    }
    if total <= 0.0 || !total.is_finite() {
        bail!(
            "cannot sample {n} points on a mesh with surface area {total} ({} faces)",
            mesh.faces.len()
        );
    }
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let mut out = SurfaceSamples {
        points: Vec::with_capacity(n),
        faces: Vec::with_capacity(n),
    };
    for _ in 0..n {
        let target = rng.random::<f64>() * total;
        // Faces of zero area own an empty interval of the CDF and are never chosen.
        let face = cumulative
            .partition_point(|&c| c <= target)
            .min(cumulative.len() - 1);
        let [a, b, c] = corners(&mesh.faces[face]);
        let (u, v): (f64, f64) = (rng.random(), rng.random());
        let s = u.sqrt();
        let (wa, wb, wc) = (1.0 - s, s * (1.0 - v), s * v);
        out.points
            .push(std::array::from_fn(|k| wa * a[k] + wb * b[k] + wc * c[k]));
        out.faces.push(face as u32);
    }
    Ok(out)
}
