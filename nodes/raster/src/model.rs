//! The triangle-splatting model: vertices, faces, per-vertex spherical
//! harmonics and per-vertex opacity logits with the floor activation.

use crate::real::{Real, all_finite_on};
use anyhow::{Result, bail};
use serde_json::{Map, Value};

/// Number of SH coefficients per colour channel at degree 3.
pub const SH_COEFFS: usize = 16;
/// Highest supported SH degree.
pub const MAX_SH_DEGREE: u32 = 3;
/// Logit-space clamp used when inverting the opacity activation, so that an
/// opacity at (or beyond) either end of the activation's range maps to a finite logit.
pub const INVERSE_SIGMOID_EPS: f64 = 1e-6;
/// The window sharpness σ of a finished model: the training schedule's end,
/// where a triangle's window is a step (hard edges), as a mesh export draws it.
pub const FINISHED_SIGMA: f64 = 1e-4;

/// A mesh-splatting model.
///
/// Opacity of vertex `v` is `m + (1 − m)·sigmoid(opacity_logits[v])` with
/// `m = opacity_floor`; a triangle's opacity is the minimum of its corners'.
/// SH coefficients are stored `[vertex][coefficient 0..16][channel r,g,b]`;
/// coefficients above `sh_degree` are kept but not rendered.
#[derive(Debug, Clone, PartialEq)]
pub struct Model<R: Real = f32> {
    pub vertices: Vec<[R; 3]>,
    pub faces: Vec<[u32; 3]>,
    pub sh: Vec<[[R; 3]; SH_COEFFS]>,
    pub opacity_logits: Vec<R>,
    /// Active SH degree, 0..=3.
    pub sh_degree: u32,
    /// The opacity floor `m` in `[0, 1)`.
    pub opacity_floor: f64,
    /// The window sharpness σ the model was last trained with (a schedule value, not learned).
    pub sigma: f64,
    /// Per-face σ overriding the render settings' (empty: every face uses the
    /// settings' σ). Set when models trained to different σ are rendered
    /// together ([`Model::union`]); not saved.
    pub face_sigma: Vec<f64>,
    /// Per vertex, the DC coefficients a flat-coloured copy draws with (a mesh
    /// export, whose viewers show one colour per vertex): `train` bakes the SH
    /// colour averaged over the directions the training views saw the vertex
    /// from, then fits it to those views as the export draws them. Empty: the
    /// DC term. See [`Model::flat_dc`].
    pub flat_dc: Vec<[R; 3]>,
    /// Free-form metadata carried through model.json.
    pub metadata: Map<String, Value>,
}

#[inline]
pub fn sigmoid<R: Real>(x: R) -> R {
    // Written so that neither branch overflows `exp`.
    if x >= R::zero() {
        R::one() / (R::one() + (-x).exp())
    } else {
        let e = x.exp();
        e / (R::one() + e)
    }
}

/// `ln(y / (1 − y))` with `y` clamped into `[ε, 1 − ε]`.
pub fn inverse_sigmoid(y: f64) -> f64 {
    let y = y.clamp(INVERSE_SIGMOID_EPS, 1.0 - INVERSE_SIGMOID_EPS);
    (y / (1.0 - y)).ln()
}

impl<R: Real> Model<R> {
    /// An empty model with degree-0 colours, no floor and σ = 1.
    pub fn empty() -> Self {
        Model {
            vertices: Vec::new(),
            faces: Vec::new(),
            sh: Vec::new(),
            opacity_logits: Vec::new(),
            sh_degree: 0,
            opacity_floor: 0.0,
            sigma: 1.0,
            face_sigma: Vec::new(),
            flat_dc: Vec::new(),
            metadata: Map::new(),
        }
    }

    pub fn vertex_count(&self) -> usize {
        self.vertices.len()
    }

    pub fn face_count(&self) -> usize {
        self.faces.len()
    }

    /// The DC coefficients vertex `v` draws with in a flat-coloured copy: its
    /// baked flat colour where the model has one, its SH DC term otherwise.
    pub fn flat_dc(&self, v: usize) -> [R; 3] {
        self.flat_dc.get(v).copied().unwrap_or(self.sh[v][0])
    }

    /// Activated opacity of vertex `v`.
    #[inline]
    pub fn vertex_opacity(&self, v: usize) -> R {
        let m = R::of(self.opacity_floor);
        m + (R::one() - m) * sigmoid(self.opacity_logits[v])
    }

    /// Triangle opacity: the minimum of its corners' opacities.
    pub fn face_opacity(&self, f: usize) -> R {
        let [a, b, c] = self.faces[f];
        self.vertex_opacity(a as usize)
            .min(self.vertex_opacity(b as usize))
            .min(self.vertex_opacity(c as usize))
    }

    /// Changes the opacity floor, re-mapping logits so every vertex keeps its
    /// current opacity. Opacities below the new floor are raised to it (their
    /// logit becomes `logit(ε)`, see [`INVERSE_SIGMOID_EPS`]).
    pub fn set_opacity_floor(&mut self, new_floor: f64) -> Result<()> {
        if !new_floor.is_finite() || !(0.0..1.0).contains(&new_floor) {
            bail!("opacity floor {new_floor} must lie in [0, 1)");
        }
        for v in 0..self.opacity_logits.len() {
            let o = self.vertex_opacity(v).f64();
            let y = (o - new_floor) / (1.0 - new_floor);
            self.opacity_logits[v] = R::of(inverse_sigmoid(y));
        }
        self.opacity_floor = new_floor;
        Ok(())
    }

    /// Checks array lengths, index ranges, finiteness and the scalar settings.
    /// The error names the first offending element.
    pub fn validate(&self) -> Result<()> {
        self.validate_on(1)
    }

    /// [`Model::validate`], its scans of the values on up to `threads`
    /// threads (the render of every training step validates its model).
    pub fn validate_on(&self, threads: usize) -> Result<()> {
        let nv = self.vertices.len();
        if self.sh.len() != nv {
            bail!("model has {nv} vertices but {} SH rows", self.sh.len());
        }
        if self.opacity_logits.len() != nv {
            bail!(
                "model has {nv} vertices but {} opacity logits",
                self.opacity_logits.len()
            );
        }
        if !self.flat_dc.is_empty() && self.flat_dc.len() != nv {
            bail!(
                "model has {nv} vertices but {} flat colours",
                self.flat_dc.len()
            );
        }
        if let Some(v) = self
            .flat_dc
            .iter()
            .position(|rgb| rgb.iter().any(|c| !c.is_finite()))
        {
            bail!("vertex {v} flat colour {:?} is not finite", self.flat_dc[v]);
        }
        if nv > u32::MAX as usize {
            bail!("model has {nv} vertices, more than u32 indices can address");
        }
        if self.sh_degree > MAX_SH_DEGREE {
            bail!(
                "sh_degree {} exceeds the maximum {MAX_SH_DEGREE}",
                self.sh_degree
            );
        }
        if !self.opacity_floor.is_finite() || !(0.0..1.0).contains(&self.opacity_floor) {
            bail!("opacity_floor {} must lie in [0, 1)", self.opacity_floor);
        }
        if !self.sigma.is_finite() || self.sigma <= 0.0 {
            bail!("sigma {} must be finite and positive", self.sigma);
        }
        // Every render validates its model: the branch-free scans below pass
        // a finite model, and only a failing one is searched for the culprit.
        if !all_finite_on(threads, self.vertices.as_flattened()) {
            for (v, p) in self.vertices.iter().enumerate() {
                if p.iter().any(|c| !c.is_finite()) {
                    bail!("vertex {v} position {:?} is not finite", p);
                }
            }
        }
        if !all_finite_on(threads, self.sh.as_flattened().as_flattened()) {
            for (v, rows) in self.sh.iter().enumerate() {
                if let Some(k) = rows
                    .iter()
                    .position(|rgb| rgb.iter().any(|c| !c.is_finite()))
                {
                    bail!("vertex {v} SH coefficient {k} {:?} is not finite", rows[k]);
                }
            }
        }
        if !all_finite_on(threads, &self.opacity_logits) {
            for (v, x) in self.opacity_logits.iter().enumerate() {
                if !x.is_finite() {
                    bail!("vertex {v} opacity logit {x} is not finite");
                }
            }
        }
        if !self.face_sigma.is_empty() {
            if self.face_sigma.len() != self.faces.len() {
                bail!(
                    "model has {} faces but {} per-face σ values",
                    self.faces.len(),
                    self.face_sigma.len()
                );
            }
            let proper = |s: &f64| s.is_finite() && *s > 0.0;
            // Branch-free first (it vectorizes), the search only on a failure.
            if !self.face_sigma.iter().fold(true, |ok, s| ok & proper(s))
                && let Some(f) = self.face_sigma.iter().position(|s| !proper(s))
            {
                bail!(
                    "face {f} σ {} must be finite and positive",
                    self.face_sigma[f]
                );
            }
        }
        let largest_index = self.faces.as_flattened().iter().fold(0, |m, &i| m.max(i));
        if !self.faces.is_empty() && largest_index as usize >= nv {
            for (f, face) in self.faces.iter().enumerate() {
                if let Some(&i) = face.iter().find(|&&i| i as usize >= nv) {
                    bail!(
                        "face {f} {:?} references vertex {i}, but the model has {nv} vertices",
                        face
                    );
                }
            }
        }
        Ok(())
    }

    /// Converts the scalar type (e.g. an `f32` model to `f64` for gradient checks).
    pub fn cast<S: Real>(&self) -> Model<S> {
        let c = |x: R| S::of(x.f64());
        Model {
            vertices: self.vertices.iter().map(|p| p.map(c)).collect(),
            faces: self.faces.clone(),
            sh: self
                .sh
                .iter()
                .map(|rows| rows.map(|rgb| rgb.map(c)))
                .collect(),
            opacity_logits: self.opacity_logits.iter().map(|&x| c(x)).collect(),
            sh_degree: self.sh_degree,
            opacity_floor: self.opacity_floor,
            sigma: self.sigma,
            face_sigma: self.face_sigma.clone(),
            flat_dc: self.flat_dc.iter().map(|rgb| rgb.map(c)).collect(),
            metadata: self.metadata.clone(),
        }
    }

    /// The union of several models' triangles as one model that renders every
    /// part as it was trained: each part keeps its own σ (per face), its
    /// opacities (logits re-mapped to the smallest part floor, which every part's
    /// opacities are at least) and its colours (bands above a part's SH degree
    /// are zeroed, the union renders at the largest degree). σ of the union is
    /// the largest part σ. Flat colours are kept where a part has them (the
    /// others' DC terms fill in).
    pub fn union(parts: &[&Model<R>]) -> Result<Model<R>> {
        let mut merged = Model::<R>::empty();
        let floor = parts
            .iter()
            .map(|m| m.opacity_floor)
            .fold(f64::INFINITY, f64::min);
        merged.opacity_floor = if floor.is_finite() { floor } else { 0.0 };
        merged.sh_degree = parts.iter().map(|m| m.sh_degree).max().unwrap_or(0);
        merged.sigma = parts.iter().map(|m| m.sigma).fold(f64::NAN, f64::max);
        if !merged.sigma.is_finite() {
            merged.sigma = 1.0;
        }
        let baked = parts.iter().any(|m| !m.flat_dc.is_empty());
        for (index, part) in parts.iter().enumerate() {
            let mut m = (*part).clone();
            // Re-mapping clamps extreme logits, so parts already on the floor keep theirs.
            if m.opacity_floor != merged.opacity_floor {
                m.set_opacity_floor(merged.opacity_floor)
                    .map_err(|e| anyhow::anyhow!("part {index}: {e}"))?;
            }
            let active = crate::sh::coeff_count(m.sh_degree);
            let base = merged.vertices.len();
            if base + m.vertices.len() > u32::MAX as usize {
                bail!("the union has more vertices than u32 indices can address");
            }
            merged.vertices.extend_from_slice(&m.vertices);
            merged.sh.extend(m.sh.iter().map(|rows| {
                let mut rows = *rows;
                for row in rows.iter_mut().skip(active) {
                    *row = [R::zero(); 3];
                }
                rows
            }));
            merged.opacity_logits.extend_from_slice(&m.opacity_logits);
            if baked {
                merged
                    .flat_dc
                    .extend((0..m.vertex_count()).map(|v| m.flat_dc(v)));
            }
            // `base` fits in u32: checked above.
            let offset = base as u32;
            merged
                .faces
                .extend(m.faces.iter().map(|f| f.map(|v| v + offset)));
            if m.face_sigma.is_empty() {
                merged
                    .face_sigma
                    .extend(std::iter::repeat_n(m.sigma, m.faces.len()));
            } else {
                merged.face_sigma.extend_from_slice(&m.face_sigma);
            }
        }
        if merged.face_sigma.iter().all(|&s| s == merged.sigma) {
            merged.face_sigma.clear();
        }
        Ok(merged)
    }
}

impl<R: Real> Default for Model<R> {
    fn default() -> Self {
        Self::empty()
    }
}

/// Gradients of a scalar loss with respect to the model's parameters and the
/// background image, laid out like the model.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelGrads<R: Real = f32> {
    pub vertices: Vec<[R; 3]>,
    pub sh: Vec<[[R; 3]; SH_COEFFS]>,
    pub opacity_logits: Vec<R>,
    /// dL/d(background), H×W×3 interleaved.
    pub background: Vec<R>,
}

impl<R: Real> ModelGrads<R> {
    pub fn zeros(vertex_count: usize, pixel_count: usize) -> Self {
        ModelGrads {
            vertices: vec![[R::zero(); 3]; vertex_count],
            sh: vec![[[R::zero(); 3]; SH_COEFFS]; vertex_count],
            opacity_logits: vec![R::zero(); vertex_count],
            background: vec![R::zero(); pixel_count * 3],
        }
    }

    /// True when every gradient is finite.
    pub fn all_finite(&self) -> bool {
        self.vertices.iter().flatten().all(|x| x.is_finite())
            && self.sh.iter().flatten().flatten().all(|x| x.is_finite())
            && self.opacity_logits.iter().all(|x| x.is_finite())
            && self.background.iter().all(|x| x.is_finite())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Re-mapping logits for a new floor keeps every opacity above the floor unchanged.
    #[test]
    fn changing_the_floor_preserves_opacities() {
        let mut m = Model::<f64>::empty();
        m.vertices = vec![[0.0; 3]; 5];
        m.sh = vec![[[0.0; 3]; SH_COEFFS]; 5];
        m.opacity_logits = vec![-3.0, -0.5, 0.0, 2.0, 6.0];
        m.opacity_floor = 0.1;
        let before: Vec<f64> = (0..5).map(|v| m.vertex_opacity(v)).collect();
        m.set_opacity_floor(0.3).unwrap();
        for v in 0..5 {
            let after = m.vertex_opacity(v);
            if before[v] > 0.3 {
                assert!(
                    (after - before[v]).abs() < 1e-12,
                    "vertex {v}: {} → {after}",
                    before[v]
                );
            } else {
                assert!(
                    (after - 0.3).abs() < 1e-6,
                    "vertex {v} below the floor rises to it: {after}"
                );
            }
        }
        assert!(m.set_opacity_floor(1.0).is_err());
        assert!(m.set_opacity_floor(f64::NAN).is_err());
    }

    /// A union keeps each baked part's flat colours and fills the others' from
    /// their DC terms; a union of unbaked parts has none.
    #[test]
    fn a_union_keeps_flat_colours_where_parts_have_them() {
        let part = |dc: f64, flat: Option<f64>| {
            let mut m = Model::<f64>::empty();
            m.vertices = vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
            m.faces = vec![[0, 1, 2]];
            m.sh = vec![[[dc; 3]; SH_COEFFS]; 3];
            m.opacity_logits = vec![0.0; 3];
            m.flat_dc = flat.map_or(Vec::new(), |f| vec![[f; 3]; 3]);
            m
        };
        let (baked, plain) = (part(0.1, Some(0.7)), part(0.2, None));
        let merged = Model::union(&[&plain, &baked]).unwrap();
        merged.validate().unwrap();
        let want: Vec<[f64; 3]> = [[0.2; 3]; 3].into_iter().chain([[0.7; 3]; 3]).collect();
        assert_eq!(merged.flat_dc, want);
        assert!(Model::union(&[&plain, &plain]).unwrap().flat_dc.is_empty());
    }

    /// The activation is m + (1 − m)·sigmoid(x) and the triangle opacity is the corners' min.
    #[test]
    fn opacity_activation_and_triangle_min() {
        let mut m = Model::<f64>::empty();
        m.vertices = vec![[0.0; 3]; 3];
        m.sh = vec![[[0.0; 3]; SH_COEFFS]; 3];
        m.opacity_logits = vec![1.0, -2.0, 0.5];
        m.faces = vec![[0, 1, 2]];
        m.opacity_floor = 0.25;
        let want = 0.25 + 0.75 / (1.0 + 2f64.exp());
        assert!((m.face_opacity(0) - want).abs() < 1e-15);
        assert!((sigmoid(-800.0f64) - 0.0).abs() < 1e-300 && sigmoid(800.0f64) == 1.0);
    }
}
