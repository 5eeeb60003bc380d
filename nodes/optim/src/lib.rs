//! Adam over a mesh model's parameter tensors, declared once for both
//! trainers: the host trainer updates the model in place with [`Optim::step`],
//! the device trainer (objectsplat-raster-gpu) keeps the same state on the GPU
//! between host events and reads its settings, rates and moments from here.
//!
//! - [`adam`]: Adam with per-group learning rates and row-resizable state;
//! - [`Optim`]: the three groups of a mesh model — positions (3 per vertex),
//!   SH (48 per vertex, the DC band at its own rate), opacity logits.

pub mod adam;

pub use adam::{Adam, AdamGroup, LogLinearDecay};

use anyhow::{Context, Result, bail};
use objectsplat_raster::model::SH_COEFFS;
use objectsplat_raster::{Model, ModelGrads};

/// Values per vertex of the SH group (16 coefficients × RGB, DC first).
pub const SH_VALUES: usize = 3 * SH_COEFFS;

/// The learning rates of the three tensors at one iteration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LearningRates {
    pub positions: f64,
    /// The SH DC band.
    pub sh_dc: f64,
    /// The SH bands above DC.
    pub sh_rest: f64,
    pub opacity: f64,
}

/// Adam's groups over a mesh model: positions (3 per vertex), SH (48 per
/// vertex, DC first: the DC band at `sh_dc`, the higher bands at `sh_rest`),
/// opacity logits (1 per vertex). One row per vertex in every group.
#[derive(Debug, Clone, PartialEq)]
pub struct Optim {
    pub adam: Adam,
    pub vertices: usize,
    pub sh: usize,
    pub opacity: usize,
}

impl Optim {
    /// Zero moments for `rows` vertices, with the reference betas and ε.
    pub fn new(rates: LearningRates, rows: usize) -> Result<Optim> {
        let mut adam = Adam::new();
        let vertices = adam.add_group("vertices", rates.positions, 3, rows);
        let sh = adam.add_group("sh", rates.sh_dc, SH_VALUES, rows);
        adam.set_column_split(sh, 3, rates.sh_rest)?;
        let opacity = adam.add_group("opacity", rates.opacity, 1, rows);
        Ok(Optim {
            adam,
            vertices,
            sh,
            opacity,
        })
    }

    /// Rows (vertices) of the state.
    pub fn rows(&self) -> usize {
        self.adam.groups[self.vertices].rows()
    }

    /// The groups in the device's tensor order: positions, SH, opacity logits.
    pub fn groups(&self) -> [&AdamGroup; 3] {
        [self.vertices, self.sh, self.opacity].map(|g| &self.adam.groups[g])
    }

    /// Mutable [`Optim::groups`].
    pub fn groups_mut(&mut self) -> [&mut AdamGroup; 3] {
        let order = [self.vertices, self.sh, self.opacity];
        let mut found: [Option<&mut AdamGroup>; 3] = [None, None, None];
        for (g, group) in self.adam.groups.iter_mut().enumerate() {
            if let Some(k) = order.iter().position(|&o| o == g) {
                found[k] = Some(group);
            }
        }
        // Optim::new made the three groups, and nothing removes groups.
        found.map(|g| g.expect("every group of the layout exists"))
    }

    /// The current learning rates.
    pub fn learning_rates(&self) -> LearningRates {
        let g = &self.adam.groups;
        LearningRates {
            positions: g[self.vertices].lr,
            sh_dc: g[self.sh].lr,
            sh_rest: g[self.sh].lr_rest,
            opacity: g[self.opacity].lr,
        }
    }

    /// The state follows a topology edit: the rows of `keep` stay, in order,
    /// then `appended` rows with zero moments.
    pub fn follow_rows(&mut self, keep: &[bool], appended: usize) -> Result<()> {
        self.adam.retain_rows(keep)?;
        self.adam.append_rows(appended);
        Ok(())
    }

    /// The state follows a renumbering of the vertices: row `i` becomes
    /// what row `order[i]` was.
    pub fn follow_order(&mut self, order: &[u32]) -> Result<()> {
        self.adam.permute_rows(order)
    }

    /// One Adam step of every group, in place. SH bands above the model's
    /// degree have no gradient and no moments yet, so they are skipped.
    /// `grads` may cover more vertices than the model (a render of the model
    /// with frozen occluders appended): the model's vertices come first.
    /// `threads` workers share each group's rows (the result does not depend on it).
    pub fn step(
        &mut self,
        model: &mut Model<f32>,
        grads: &ModelGrads<f32>,
        threads: usize,
    ) -> Result<()> {
        let nv = model.vertex_count();
        if grads.vertices.len() < nv || grads.sh.len() < nv || grads.opacity_logits.len() < nv {
            bail!(
                "gradients of {} vertices for a model of {nv}",
                grads.vertices.len()
            );
        }
        self.adam
            .step_columns(
                self.vertices,
                model.vertices.as_flattened_mut(),
                grads.vertices[..nv].as_flattened(),
                3,
                threads,
            )
            .context("vertex positions")?;
        let active = active_sh_values(model.sh_degree);
        self.adam
            .step_columns(
                self.sh,
                model.sh.as_flattened_mut().as_flattened_mut(),
                grads.sh[..nv].as_flattened().as_flattened(),
                active,
                threads,
            )
            .context("SH coefficients")?;
        self.adam
            .step_columns(
                self.opacity,
                &mut model.opacity_logits,
                &grads.opacity_logits[..nv],
                1,
                threads,
            )
            .context("opacity logits")
    }
}

/// SH values per vertex that train at `degree` (the bands above it are off).
pub fn active_sh_values(degree: u32) -> usize {
    3 * objectsplat_raster::sh::coeff_count(degree)
}
