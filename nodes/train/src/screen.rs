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
