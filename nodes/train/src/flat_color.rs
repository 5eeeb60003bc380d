//! The flat colour a mesh export draws each vertex with: its SH colour averaged
//! over the directions the training views saw it from.
//!
//! A viewer without SH shows one colour per vertex. The SH DC term is the colour
//! averaged over the whole sphere of directions, but the training views see a
//! vertex from part of it (a wall from inside the room, an object from above),
//! where the higher bands do not average out: exported with its DC term, the demo's
//! table lost 2 dB on its own pixels. Over the training views, the constant colour
//! with the least squared error is the views' mean, each view weighted by how many
//! pixels the vertex colours there: its faces' projected areas (a face's pixels
//! share its corners' colours, a third each by area), each times the face's
//! largest blending weight in that view (0 where it is hidden).

use anyhow::{Result, bail};
use objectsplat_core::Camera;
use objectsplat_core::glam::DVec3;
use objectsplat_raster::Model;
use objectsplat_raster::sh::{SH_DC, vertex_color, view_direction};

/// A training view as the bake sees it: its camera, and each face's largest
/// blending weight in its render.
pub struct Sighting<'a> {
    pub camera: &'a Camera,
    pub face_weight: &'a [f32],
}

/// The area in pixels² of face `f` projected by `camera`; 0 when a corner is
/// not in front of it.
fn projected_area(model: &Model<f32>, f: usize, camera: &Camera) -> f64 {
    let corners = model.faces[f]
        .map(|v| camera.project(DVec3::from_array(model.vertices[v as usize].map(f64::from))));
    let [Some(a), Some(b), Some(c)] = corners else {
        return 0.0;
    };
    0.5 * ((b.0 - a.0) * (c.1 - a.1) - (c.0 - a.0) * (b.1 - a.1)).abs()
}

/// The running weighted sums of the vertices' SH colours, one sighting at a
/// time (a scene's views × faces of weights need not be held at once).
pub struct FlatColors<'m> {
    model: &'m Model<f32>,
    sum: Vec<[f64; 3]>,
    total: Vec<f64>,
    seen: Vec<f64>,
    sightings: usize,
}

impl<'m> FlatColors<'m> {
    pub fn new(model: &'m Model<f32>) -> Self {
        let nv = model.vertex_count();
        FlatColors {
            model,
            sum: vec![[0.0; 3]; nv],
            total: vec![0.0; nv],
            seen: vec![0.0; nv],
            sightings: 0,
        }
    }

    /// Adds one view: each vertex's SH colour seen from its camera, weighted by
    /// the pixels it colours there (the module's documentation).
    pub fn add(&mut self, sighting: &Sighting<'_>) -> Result<()> {
        let (model, index) = (self.model, self.sightings);
        if sighting.face_weight.len() != model.face_count() {
            bail!(
                "sighting {index} has {} face weights for {} faces",
                sighting.face_weight.len(),
                model.face_count()
            );
        }
        if let Some(f) = sighting.face_weight.iter().position(|w| !w.is_finite()) {
            bail!(
                "sighting {index}: face {f} has weight {}",
                sighting.face_weight[f]
            );
        }
        let center = sighting.camera.center();
        if !center.is_finite() {
            bail!("sighting {index}: camera centre {center} is not finite");
        }
        let center = center.as_vec3().to_array();
        self.sightings += 1;
        self.seen.fill(0.0);
        for (f, face) in model.faces.iter().enumerate() {
            let w = sighting.face_weight[f];
            if w <= 0.0 {
                continue;
            }
            let pixels = f64::from(w) * projected_area(model, f, sighting.camera) / 3.0;
            for &v in face {
                self.seen[v as usize] += pixels;
            }
        }
        for (v, &w) in self.seen.iter().enumerate() {
            if !(w > 0.0) {
                continue;
            }
            let (dir, _) = view_direction(model.vertices[v], center);
            let (rgb, _) = vertex_color(&model.sh[v], dir, model.sh_degree);
            for ch in 0..3 {
                self.sum[v][ch] += w * f64::from(rgb[ch]);
            }
            self.total[v] += w;
        }
        Ok(())
    }

    /// Per vertex, the DC coefficients whose colour is the weighted mean; a
    /// vertex no sighting saw keeps its DC term.
    pub fn finish(self) -> Vec<[f32; 3]> {
        (0..self.model.vertex_count())
            .map(|v| {
                if self.total[v] > 0.0 {
                    self.sum[v].map(|s| ((s / self.total[v] - 0.5) / SH_DC) as f32)
                } else {
                    self.model.sh[v][0]
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use objectsplat_raster::SH_COEFFS;

    /// [`FlatColors`] over `sightings` at once.
    fn flat_dc(model: &Model<f32>, sightings: &[Sighting<'_>]) -> Result<Vec<[f32; 3]>> {
        let mut colors = FlatColors::new(model);
        for sighting in sightings {
            colors.add(sighting)?;
        }
        Ok(colors.finish())
    }

    /// One triangle around the origin with degree-3 colours: odd bands only
    /// (1 and 3) on vertex 0, every band on the others.
    fn triangle() -> Model<f32> {
        let mut m = Model::<f32>::empty();
        m.vertices = vec![[0.0; 3], [0.1, 0.0, 0.0], [0.0, 0.1, 0.0]];
        m.faces = vec![[0, 1, 2]];
        m.opacity_logits = vec![0.0; 3];
        m.sh_degree = 3;
        let mut odd = [[0.0f32; 3]; SH_COEFFS];
        odd[0] = [0.2, -0.1, 0.3];
        for (k, row) in odd.iter_mut().enumerate().skip(1) {
            let band = if k < 4 {
                1
            } else if k < 9 {
                2
            } else {
                3
            };
            if band != 2 {
                *row = [0.05 * k as f32, -0.03, 0.02];
            }
        }
        let every: [[f32; 3]; SH_COEFFS] =
            std::array::from_fn(|k| [0.1 - 0.01 * k as f32, 0.02 * k as f32, 0.05]);
        m.sh = vec![odd, every, every];
        m
    }

    /// A 64×64 camera at `eye` looking at the triangle's corner at the origin.
    fn camera_at(eye: [f64; 3]) -> Camera {
        Camera::look_at(
            64,
            64,
            80.0,
            80.0,
            DVec3::from_array(eye),
            DVec3::ZERO,
            DVec3::Y,
        )
    }

    /// The squared error of the constant colour `dc` against the vertex's SH
    /// colour over the sightings, each weighted by its (one) face's weight times
    /// its projected area.
    fn error(m: &Model<f32>, v: usize, sightings: &[Sighting<'_>], dc: [f64; 3]) -> f64 {
        sightings
            .iter()
            .map(|s| {
                let w = f64::from(s.face_weight[0]) * projected_area(m, 0, s.camera);
                let center = s.camera.center().as_vec3().to_array();
                let (dir, _) = view_direction(m.vertices[v], center);
                let (rgb, _) = vertex_color(&m.sh[v], dir, m.sh_degree);
                (0..3)
                    .map(|ch| {
                        let flat = 0.5 + SH_DC * dc[ch];
                        (flat - f64::from(rgb[ch])).powi(2) * w
                    })
                    .sum::<f64>()
            })
            .sum()
    }

    #[test]
    fn opposite_views_cancel_the_odd_bands() {
        // Odd bands are odd functions of the direction: seen from ±d with equal
        // weight, their mean is zero and the flat colour is the DC term's. The
        // triangle's mirror image through vertex 0 makes the pixels it colours
        // the same from both cameras.
        let mut m = triangle();
        for v in [1, 2] {
            m.vertices.push(m.vertices[v].map(|c| -c));
            m.sh.push(m.sh[v]);
            m.opacity_logits.push(0.0);
        }
        m.faces.push([0, 3, 4]);
        let w = [1.0f32, 1.0];
        let (front, back) = (camera_at([0.3, -0.4, 1.2]), camera_at([-0.3, 0.4, -1.2]));
        let sightings = [
            Sighting {
                camera: &front,
                face_weight: &w,
            },
            Sighting {
                camera: &back,
                face_weight: &w,
            },
        ];
        let flat = flat_dc(&m, &sightings).unwrap();
        for ch in 0..3 {
            assert!(
                (flat[0][ch] - m.sh[0][0][ch]).abs() < 1e-6,
                "{:?} vs {:?}",
                flat[0],
                m.sh[0][0]
            );
        }
    }

    #[test]
    fn the_flat_colour_has_the_least_weighted_error_over_the_views() {
        let m = triangle();
        let (strong, faint) = ([0.9f32], [0.3f32]);
        let cameras = [
            camera_at([0.5, 0.2, 1.0]),
            camera_at([-0.2, 0.6, 0.8]),
            // Nearly edge-on: few pixels.
            camera_at([1.0, -0.7, 0.15]),
        ];
        let sightings = [
            Sighting {
                camera: &cameras[0],
                face_weight: &strong,
            },
            Sighting {
                camera: &cameras[1],
                face_weight: &faint,
            },
            Sighting {
                camera: &cameras[2],
                face_weight: &strong,
            },
        ];
        let flat = flat_dc(&m, &sightings).unwrap();
        for v in 0..3 {
            let best = flat[v].map(f64::from);
            let e = error(&m, v, &sightings, best);
            // Every move of any channel by 1e-3 (either way) costs error.
            for ch in 0..3 {
                for step in [-1e-3, 1e-3] {
                    let mut moved = best;
                    moved[ch] += step;
                    assert!(
                        error(&m, v, &sightings, moved) > e,
                        "vertex {v}: moving channel {ch} by {step} lowers the error"
                    );
                }
            }
            // And the DC term itself is worse: the views cover part of the sphere.
            assert!(error(&m, v, &sightings, m.sh[v][0].map(f64::from)) > e);
        }
    }

    #[test]
    fn unseen_vertices_keep_their_dc_term_and_bad_sightings_are_refused() {
        let m = triangle();
        let camera = camera_at([0.0, 0.3, 1.0]);
        let sighting = |face_weight| Sighting {
            camera: &camera,
            face_weight,
        };
        let flat = flat_dc(&m, &[sighting(&[0.0])]).unwrap();
        assert_eq!(flat, m.sh.iter().map(|rows| rows[0]).collect::<Vec<_>>());
        // Seen from below it has pixels; behind a camera looking away, none.
        let below = camera_at([0.0, 0.3, -1.0]);
        let away = Camera::look_at(
            64,
            64,
            80.0,
            80.0,
            DVec3::new(0.0, 0.3, -1.0),
            DVec3::new(0.0, 0.3, -2.0),
            DVec3::Y,
        );
        assert!(projected_area(&m, 0, &below) > 0.0);
        assert_eq!(projected_area(&m, 0, &away), 0.0);
        assert!(flat_dc(&m, &[sighting(&[1.0, 1.0])]).is_err());
        assert!(flat_dc(&m, &[sighting(&[f32::NAN])]).is_err());
    }
}
