//! A model's visible surface as a plain mesh, for mesh metrics and export.

use objectsplat_core::Mesh;
use objectsplat_raster::sh::SH_DC;
use objectsplat_raster::{Model, RenderSettings};

/// The faces the renderer can ever draw: those whose opacity (the corners' minimum)
/// reaches the renderer's default culling threshold. Fainter faces never show in a
/// render, so they are not part of the reconstructed surface.
pub fn visible_faces(model: &Model<f32>) -> Vec<[u32; 3]> {
    let threshold = RenderSettings::default().min_opacity;
    (0..model.face_count())
        .filter(|&f| f64::from(model.face_opacity(f)) >= threshold)
        .map(|f| model.faces[f])
        .collect()
}

/// The display colour of each vertex (sRGB in [0, 1]): the SH DC term, as `model.ply` shows it.
pub fn display_colors(model: &Model<f32>) -> Vec<[f32; 3]> {
    model
        .sh
        .iter()
        .map(|rows| rows[0].map(|dc| (0.5 + SH_DC * f64::from(dc)).clamp(0.0, 1.0) as f32))
        .collect()
}

/// The visible faces over all vertices (unused vertices are harmless to sampling).
pub fn visible_mesh(model: &Model<f32>) -> Mesh {
    Mesh {
        positions: model.vertices.clone(),
        faces: visible_faces(model),
        colors: None,
        object_ids: None,
    }
}
