//! A model's visible surface as a plain mesh, for mesh metrics and export.

use objectsplat_core::Mesh;
use objectsplat_raster::Model;
pub use objectsplat_raster::exported::{exported_model, visible_faces};

/// The visible faces over all vertices (unused vertices are harmless to sampling).
pub fn visible_mesh(model: &Model<f32>) -> Mesh {
    Mesh {
        positions: model.vertices.clone(),
        faces: visible_faces(model),
        colors: None,
        object_ids: None,
    }
}
