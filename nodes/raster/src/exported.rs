//! A model as a mesh export holds it: the faces that can ever show, opaque and
//! hard-edged, one colour per vertex. Shared by what renders the export (the
//! `render` node's `appearance: "exported"`) and what fits its colours (the trainer).

use crate::model::{FINISHED_SIGMA, Model, inverse_sigmoid};
use crate::{RenderSettings, SH_COEFFS};

/// The opacity floor of an exported model: as close to 1 as the activation allows,
/// so every face is opaque to within 1e-12.
const OPAQUE_FLOOR: f64 = 1.0 - 1e-6;

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

/// `model` as a mesh export holds it, for rendering: the visible faces only, every
/// one opaque with hard edges (σ [`FINISHED_SIGMA`]), one colour per vertex (its
/// flat colour, [`Model::flat_dc`]). A render of it is what a user who opens the
/// `.glb` sees from that camera.
pub fn exported_model(model: &Model<f32>) -> Model<f32> {
    let opaque = inverse_sigmoid(1.0) as f32;
    Model {
        vertices: model.vertices.clone(),
        faces: visible_faces(model),
        sh: (0..model.vertex_count())
            .map(|v| {
                let mut rows = [[0.0; 3]; SH_COEFFS];
                rows[0] = model.flat_dc(v);
                rows
            })
            .collect(),
        opacity_logits: vec![opaque; model.vertex_count()],
        sh_degree: 0,
        opacity_floor: OPAQUE_FLOOR,
        sigma: FINISHED_SIGMA,
        face_sigma: Vec::new(),
        flat_dc: Vec::new(),
        metadata: model.metadata.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_exported_model_is_opaque_hard_edged_and_keeps_only_visible_faces() {
        let mut model = Model::<f32>::empty();
        model.vertices = vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]];
        model.faces = vec![[0, 1, 2], [1, 3, 2]];
        model.sh = vec![[[0.0; 3]; SH_COEFFS]; 4];
        // Vertex 3 is too faint to draw (opacity sigmoid(−10) ≈ 4.5e-5): face 1 never shows.
        model.opacity_logits = vec![0.0, 0.0, 0.0, -10.0];
        model.sh_degree = 3;
        model.sigma = 0.4;
        model.face_sigma = vec![0.4, 0.5];
        let exported = exported_model(&model);
        exported.validate().unwrap();
        assert_eq!(exported.faces, vec![[0, 1, 2]]);
        assert_eq!((exported.sh_degree, exported.sigma), (0, FINISHED_SIGMA));
        assert!(exported.face_sigma.is_empty());
        for v in 0..4 {
            assert!(1.0 - exported.vertex_opacity(v) as f64 <= 1e-6);
        }
    }
}
