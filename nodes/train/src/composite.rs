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
        })
    }

    /// `model` (at σ `sigma`) followed by the occluders, in one model.
    pub fn assemble(&mut self, model: &Model<f32>, sigma: f64) -> &Model<f32> {
        let floor = model.opacity_floor;
        if self.floor != Some(floor) {
            self.frozen_logits.clear();
            self.frozen_logits
                .extend(self.frozen_opacity.iter().map(|&o| {
                    objectsplat_raster::model::inverse_sigmoid((o - floor) / (1.0 - floor)) as f32
                }));
            self.floor = Some(floor);
        }
        let m = &mut self.merged;
        let nv = model.vertex_count() as u32;
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
        m.opacity_floor = floor;
        m.sigma = sigma;
        m.sh_degree = model.sh_degree.max(self.frozen.sh_degree);
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
