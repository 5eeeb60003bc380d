//! The model being trained rendered together with frozen occluders (the
//! trained objects behind which the background is trained): one model whose
//! first vertices and faces are the trained model's, so its gradients and
//! face statistics are a prefix of the composite's. Each occluder keeps its
//! own σ, opacities and colours; both the host and the device steps render it.

use anyhow::{Context, Result};
use objectsplat_raster::Model;

pub(crate) struct Composite {
    frozen: Model<f32>,
    /// Activated opacity of every frozen vertex (kept exactly while the floor moves).
    frozen_opacity: Vec<f64>,
    /// σ of every frozen face.
    frozen_sigma: Vec<f64>,
    /// The frozen logits under `floor`.
    frozen_logits: Vec<f32>,
    floor: Option<f64>,
    merged: Model<f32>,
    /// The trained model's vertex and face counts in `merged`, whose occluder
    /// part is then already in place under the current floor.
    head: Option<(usize, usize)>,
}

impl Composite {
    pub fn new(frozen: &Model<f32>) -> Result<Self> {
        frozen.validate().context("the occluders")?;
        Ok(Composite {
            frozen_opacity: (0..frozen.vertex_count())
                .map(|v| frozen.vertex_opacity(v) as f64)
                .collect(),
            frozen_sigma: if frozen.face_sigma.is_empty() {
                vec![frozen.sigma; frozen.face_count()]
            } else {
                frozen.face_sigma.clone()
            },
            frozen: frozen.clone(),
            frozen_logits: Vec::new(),
            floor: None,
            merged: Model::empty(),
            head: None,
        })
    }

    /// `model` (at σ `sigma`) followed by the occluders, in one model.
    pub fn assemble(&mut self, model: &Model<f32>, sigma: f64) -> &Model<f32> {
        let floor = model.opacity_floor;
        if self.floor != Some(floor) {
            self.head = None;
            self.frozen_logits.clear();
            self.frozen_logits
                .extend(self.frozen_opacity.iter().map(|&o| {
                    objectsplat_raster::model::inverse_sigmoid((o - floor) / (1.0 - floor)) as f32
                }));
            self.floor = Some(floor);
        }
        let m = &mut self.merged;
        let (nv, nf) = (model.vertex_count(), model.face_count());
        m.opacity_floor = floor;
        m.sigma = sigma;
        m.sh_degree = model.sh_degree.max(self.frozen.sh_degree);
        if self.head == Some((nv, nf)) {
            // Every step but a topology edit's, on a background of megabytes:
            // the occluders' part stays where it is, only the model's is new.
            m.vertices[..nv].copy_from_slice(&model.vertices);
            m.sh[..nv].copy_from_slice(&model.sh);
            m.opacity_logits[..nv].copy_from_slice(&model.opacity_logits);
            m.faces[..nf].copy_from_slice(&model.faces);
            m.face_sigma[..nf].fill(sigma);
            return m;
        }
        self.head = Some((nv, nf));
        let nv = nv as u32;
        m.vertices.clear();
        m.vertices.extend_from_slice(&model.vertices);
        m.vertices.extend_from_slice(&self.frozen.vertices);
        m.sh.clear();
        m.sh.extend_from_slice(&model.sh);
        m.sh.extend_from_slice(&self.frozen.sh);
        m.opacity_logits.clear();
        m.opacity_logits.extend_from_slice(&model.opacity_logits);
        m.opacity_logits.extend_from_slice(&self.frozen_logits);
        m.faces.clear();
        m.faces.extend_from_slice(&model.faces);
        m.faces
            .extend(self.frozen.faces.iter().map(|f| f.map(|v| v + nv)));
        m.face_sigma.clear();
        m.face_sigma
            .extend(std::iter::repeat_n(sigma, model.face_count()));
        m.face_sigma.extend_from_slice(&self.frozen_sigma);
        m
    }

    /// The occluders alone.
    pub fn frozen(&self) -> &Model<f32> {
        &self.frozen
    }

    /// The last assembled composite.
    pub fn merged(&self) -> &Model<f32> {
        &self.merged
    }

    /// The SH degree a composite of a model of degree `degree` renders at.
    pub fn sh_degree(&self, degree: u32) -> u32 {
        degree.max(self.frozen.sh_degree)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(vertices: usize, seed: f32) -> Model<f32> {
        let mut m = Model::empty();
        for v in 0..vertices {
            let x = v as f32 + seed;
            m.vertices.push([x, 0.5 * x, seed]);
            m.sh.push([[0.1 * x + seed; 3]; objectsplat_raster::SH_COEFFS]);
            m.opacity_logits.push(seed - x);
        }
        m.faces = (0..vertices as u32 - 2)
            .map(|v| [v, v + 1, v + 2])
            .collect();
        m
    }

    /// What a composite assembled anew from `frozen` makes of `trained`.
    fn fresh(frozen: &Model<f32>, trained: &Model<f32>, sigma: f64) -> Model<f32> {
        Composite::new(frozen)
            .unwrap()
            .assemble(trained, sigma)
            .clone()
    }

    #[test]
    fn a_step_that_keeps_the_counts_rewrites_only_the_trained_part_to_the_same_result() {
        let frozen = model(5, 0.25);
        let mut composite = Composite::new(&frozen).unwrap();
        let mut trained = model(6, 1.0);
        composite.assemble(&trained, 0.5);
        // A step moves every value; a topology edit that keeps the counts
        // changes the faces; a floor change moves the occluders' logits.
        trained = model(6, 2.0);
        assert_eq!(
            composite.assemble(&trained, 0.3),
            &fresh(&frozen, &trained, 0.3)
        );
        trained.faces.reverse();
        assert_eq!(
            composite.assemble(&trained, 0.3),
            &fresh(&frozen, &trained, 0.3)
        );
        trained.set_opacity_floor(0.4).unwrap();
        assert_eq!(
            composite.assemble(&trained, 0.2),
            &fresh(&frozen, &trained, 0.2)
        );
        let grown = model(8, 3.0);
        assert_eq!(
            composite.assemble(&grown, 0.1),
            &fresh(&frozen, &grown, 0.1)
        );
    }
}
