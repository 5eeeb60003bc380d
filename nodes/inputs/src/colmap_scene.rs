//! A COLMAP sparse model plus its image folder as posed views and SfM points.

use crate::colmap::ColmapModel;
use crate::scene::SourceView;
use crate::undistort;
use anyhow::{Context, Result};
use objectsplat_core::{Camera, Points};
use std::path::Path;

/// One view per registered image; distorted cameras carry their distortion, which
/// `scene::write_frames` removes (see `ColmapCamera::lens` for the models).
pub fn views(model: &ColmapModel, images_dir: &Path) -> Result<Vec<SourceView>> {
    let mut out = Vec::with_capacity(model.images.len());
    // Cameras whose distortion was checked to be invertible (an error names the camera).
    let mut checked = std::collections::HashSet::new();
    for img in model.images.values() {
        // `ColmapModel::check` guarantees every image's camera exists; stay defensive anyway.
        let cam = model.cameras.get(&img.camera_id).with_context(|| {
            format!(
                "{}: image {:?} has no camera {}",
                model.dir.display(),
                img.name,
                img.camera_id
            )
        })?;
        let (lens, distortion) = cam
            .lens()
            .map_err(|e| anyhow::anyhow!("{}: {e}", model.dir.display()))?;
        let distortion = distortion.filter(|d| !d.is_identity());
        if let Some(d) = &distortion
            && checked.insert(cam.id)
        {
            undistort::undistorted_camera(&lens, d).with_context(|| {
                format!("{}: camera {} ({})", model.dir.display(), cam.id, cam.model)
            })?;
        }
        let camera = Camera {
            width: lens.width,
            height: lens.height,
            fx: lens.fx,
            fy: lens.fy,
            cx: lens.cx,
            cy: lens.cy,
            world_to_camera: img.pose.matrix(),
        };
        out.push(SourceView {
            name: img.name.clone(),
            image: images_dir.join(crate::scene::portable(&img.name)),
            camera,
            valid_mask: None,
            distortion,
            listed: None,
        });
    }
    Ok(out)
}

/// The model's 3D points with their colours (f64 → f32).
pub fn points(model: &ColmapModel) -> Points {
    let positions = model
        .points
        .values()
        .map(|p| p.xyz.map(|v| v as f32))
        .collect();
    let colors = model.points.values().map(|p| p.rgb).collect();
    Points { positions, colors }
}
