//! A model's faces as the training cameras see them (projection only, no render).

use objectsplat_core::Camera;
use objectsplat_raster::Model;

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

pub(crate) fn screen_sizes(model: &Model<f32>, cameras: &[&Camera]) -> ScreenSizes {
    let mut sizes = ScreenSizes {
        extent: vec![0.0; model.face_count()],
        inradius: vec![0.0; model.face_count()],
    };
    let mut scratch = Vec::with_capacity(model.vertex_count());
    for camera in cameras {
        for (f, [a, b, c]) in projected_faces(model, camera, &mut scratch) {
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
}
