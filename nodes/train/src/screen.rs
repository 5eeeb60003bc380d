//! A model's faces as the training cameras see them (projection only, no render).

use objectsplat_core::Camera;
use objectsplat_raster::Model;
use objectsplat_raster::parallel::run_iter_pooled;

/// A projected corner: pixel coordinates and camera depth.
pub(crate) type Projected = (f64, f64, f64);

/// The faces of `model` with all three corners in front of `camera`, projected:
/// (face index, corners). `scratch` holds the projected vertices (reused between calls).
pub(crate) fn projected_faces<'m>(
    model: &'m Model<f32>,
    camera: &Camera,
    scratch: &'m mut Vec<Option<Projected>>,
) -> impl Iterator<Item = (usize, [Projected; 3])> + 'm {
    scratch.clear();
    scratch.extend(
        model
            .vertices
            .iter()
            .map(|v| camera.project(glam::DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64))),
    );
    let projected: &'m [Option<Projected>] = scratch;
    model.faces.iter().enumerate().filter_map(move |(f, face)| {
        let [Some(a), Some(b), Some(c)] = face.map(|v| projected[v as usize]) else {
            return None;
        };
        Some((f, [a, b, c]))
    })
}

/// Per face over a set of cameras: the largest screen extent (centroid-to-corner
/// distance, px) and the largest screen inradius (px), for faces in front of the camera.
pub(crate) struct ScreenSizes {
    pub extent: Vec<f64>,
    pub inradius: Vec<f64>,
}

/// One worker's running maxima over the cameras it took, and its projection scratch.
struct Partial {
    sizes: ScreenSizes,
    scratch: Vec<Option<Projected>>,
}

/// The cameras are shared among `threads` workers; the maxima do not depend
/// on which worker took which camera (both sizes are finite and never −0).
pub(crate) fn screen_sizes(model: &Model<f32>, cameras: &[&Camera], threads: usize) -> ScreenSizes {
    let faces = model.face_count();
    let zero = || ScreenSizes {
        extent: vec![0.0; faces],
        inradius: vec![0.0; faces],
    };
    let mut partials = Vec::new();
    run_iter_pooled(
        threads,
        cameras.iter(),
        &mut partials,
        || Partial {
            sizes: zero(),
            scratch: Vec::new(),
        },
        |partial, camera| {
            let Partial { sizes, scratch } = partial;
            for (f, [a, b, c]) in projected_faces(model, camera, scratch) {
                let (cx, cy) = ((a.0 + b.0 + c.0) / 3.0, (a.1 + b.1 + c.1) / 3.0);
                // Pixel distances: far from overflow, so `hypot`'s care (and cost) is not needed.
                let length = |dx: f64, dy: f64| (dx * dx + dy * dy).sqrt();
                let e = [a, b, c]
                    .iter()
                    .map(|p| length(p.0 - cx, p.1 - cy))
                    .fold(0.0, f64::max);
                sizes.extent[f] = sizes.extent[f].max(e);
                let twice_area = ((b.0 - a.0) * (c.1 - a.1) - (c.0 - a.0) * (b.1 - a.1)).abs();
                let perimeter = length(b.0 - a.0, b.1 - a.1)
                    + length(c.0 - b.0, c.1 - b.1)
                    + length(a.0 - c.0, a.1 - c.1);
                if perimeter > 0.0 {
                    sizes.inradius[f] = sizes.inradius[f].max(twice_area / perimeter);
                }
            }
        },
    );
    let mut sizes = zero();
    for p in partials {
        for (m, v) in sizes.extent.iter_mut().zip(p.sizes.extent) {
            *m = m.max(v);
        }
        for (m, v) in sizes.inradius.iter_mut().zip(p.sizes.inradius) {
            *m = m.max(v);
        }
    }
    sizes
}

/// At most about this many (vertex, view) pairs enter [`pixel_footprint`]'s
/// median: a background of 300k initial vertices in 384 views would otherwise
/// hold ~10⁸ values (GBs) for one number.
const FOOTPRINT_SAMPLES: usize = 1 << 20;

/// World units per pixel where `cameras` see the vertices of `model`: the
/// median, over every vertex that projects inside a camera's image, of its
/// depth over that camera's focal length (every k-th vertex when vertices ×
/// views exceed [`FOOTPRINT_SAMPLES`]). `None` when no vertex is in view.
pub(crate) fn pixel_footprint(model: &Model<f32>, cameras: &[&Camera]) -> Option<f64> {
    let pairs = model.vertices.len().saturating_mul(cameras.len());
    let stride = pairs.div_ceil(FOOTPRINT_SAMPLES).max(1);
    let mut footprints = Vec::new();
    for camera in cameras {
        let focal = 0.5 * (camera.fx + camera.fy);
        let (w, h) = (camera.width as f64, camera.height as f64);
        for v in model.vertices.iter().step_by(stride) {
            let p = glam::DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
            if let Some((x, y, depth)) = camera.project(p)
                && (0.0..w).contains(&x)
                && (0.0..h).contains(&y)
            {
                footprints.push(depth / focal);
            }
        }
    }
    if footprints.is_empty() {
        return None;
    }
    let mid = footprints.len() / 2;
    let (_, median, _) = footprints.select_nth_unstable_by(mid, f64::total_cmp);
    Some(*median)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::DVec3;

    /// A 100×100 camera at the origin looking down +z with focal length 50.
    fn camera() -> Camera {
        Camera::look_at(100, 100, 50.0, 50.0, DVec3::ZERO, DVec3::Z, -DVec3::Y)
    }

    fn model(vertices: &[[f32; 3]]) -> Model<f32> {
        Model {
            vertices: vertices.to_vec(),
            ..Model::empty()
        }
    }

    #[test]
    fn footprint_is_the_median_depth_over_the_focal_length() {
        // Depths 1, 2 and 4 on the axis, one point behind the camera and one
        // outside the image (x = 3 at depth 1 projects to pixel 200): neither counts.
        let m = model(&[
            [0.0, 0.0, 1.0],
            [0.0, 0.0, 2.0],
            [0.0, 0.0, 4.0],
            [0.0, 0.0, -3.0],
            [3.0, 0.0, 1.0],
        ]);
        let c = camera();
        assert_eq!(pixel_footprint(&m, &[&c]), Some(2.0 / 50.0));
        // Two views of the same points: the same median.
        assert_eq!(pixel_footprint(&m, &[&c, &c]), Some(2.0 / 50.0));
    }

    #[test]
    fn a_large_model_is_sampled_with_the_same_median() {
        // 600k vertices in 2 views exceed the sample bound, so every 2nd vertex is read;
        // a third of the vertices lie at depth 1, the rest at depth 3: median 3 / 50.
        let vertices: Vec<[f32; 3]> = (0..600_000)
            .map(|i| [0.0, 0.0, if i % 3 == 0 { 1.0 } else { 3.0 }])
            .collect();
        let c = camera();
        assert_eq!(
            pixel_footprint(&model(&vertices), &[&c, &c]),
            Some(3.0 / 50.0)
        );
    }

    #[test]
    fn no_vertex_in_view_has_no_footprint() {
        let m = model(&[[0.0, 0.0, -1.0], [5.0, 0.0, 1.0]]);
        assert_eq!(pixel_footprint(&m, &[&camera()]), None);
        assert_eq!(pixel_footprint(&model(&[]), &[&camera()]), None);
    }

    #[test]
    fn screen_sizes_are_the_largest_over_the_cameras() {
        // A right triangle with 0.2 m legs at depth 1 (legs of 10 px) and a second camera
        // 1 m further back (5 px): extent 10·√5/3 px (centroid to the far acute corner),
        // inradius (a + b − c)/2 = 10 − 5√2 px, both from the nearer camera.
        let mut m = model(&[[0.0, 0.0, 1.0], [0.2, 0.0, 1.0], [0.0, 0.2, 1.0]]);
        m.faces = vec![[0, 1, 2]];
        let near = camera();
        let far = Camera::look_at(
            100,
            100,
            50.0,
            50.0,
            DVec3::new(0.0, 0.0, -1.0),
            DVec3::Z,
            -DVec3::Y,
        );
        // Both orders: the nearer camera wins wherever it comes.
        for (cameras, threads) in [([&far, &near], 1), ([&near, &far], 1), ([&far, &near], 2)] {
            let s = screen_sizes(&m, &cameras, threads);
            assert!((s.extent[0] - 10.0 * 5f64.sqrt() / 3.0).abs() < 1e-5);
            assert!((s.inradius[0] - (10.0 - 5.0 * 2f64.sqrt())).abs() < 1e-5);
        }
    }

    #[test]
    fn screen_sizes_do_not_depend_on_the_thread_count() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
        let vertices: Vec<[f32; 3]> = (0..3000)
            .map(|_| {
                [
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-2.0..2.0),
                    rng.random_range(-1.0..5.0),
                ]
            })
            .collect();
        let mut m = model(&vertices);
        m.faces = (0..2000)
            .map(|_| [0, 1, 2].map(|_| rng.random_range(0..3000u32)))
            .collect();
        let cameras: Vec<Camera> = (0..7)
            .map(|k| {
                let eye = DVec3::new(k as f64 * 0.3 - 1.0, 0.2, -2.0);
                Camera::look_at(
                    100,
                    100,
                    50.0,
                    50.0,
                    eye,
                    DVec3::new(0.0, 0.0, 2.0),
                    -DVec3::Y,
                )
            })
            .collect();
        let views: Vec<&Camera> = cameras.iter().collect();
        let one = screen_sizes(&m, &views, 1);
        assert!(one.extent.iter().any(|&e| e > 0.0));
        for threads in [2, 3, 8] {
            let s = screen_sizes(&m, &views, threads);
            assert_eq!(s.extent, one.extent);
            assert_eq!(s.inradius, one.inradius);
        }
    }
}
