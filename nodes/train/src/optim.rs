//! Adam over the model's parameter groups, updating the model in place.

use crate::adam::Adam;
use crate::densify::VertexEdit;
use crate::schedule::Schedule;
use anyhow::{Context, Result, bail};
use objectsplat_raster::model::SH_COEFFS;
use objectsplat_raster::{Model, ModelGrads};

/// Values per vertex of the SH group (16 coefficients × RGB, DC first).
pub const SH_VALUES: usize = 3 * SH_COEFFS;

/// Adam's groups: positions (3 per vertex), SH (48 per vertex, the DC band at
/// `lr_sh_dc`, the higher bands at `lr_sh_dc / sh_rest_lr_divisor`), opacity logits.
pub struct Optim {
    pub adam: Adam,
    pub vertices: usize,
    pub sh: usize,
    pub opacity: usize,
}

impl Optim {
    pub fn new(schedule: &Schedule, rows: usize) -> Result<Optim> {
        let mut adam = Adam::new();
        let vertices = adam.add_group("vertices", schedule.lr_vertices_start, 3, rows);
        let sh = adam.add_group("sh", schedule.lr_sh_dc, SH_VALUES, rows);
        adam.set_column_split(sh, 3, schedule.lr_sh_dc / schedule.sh_rest_lr_divisor)?;
        let opacity = adam.add_group("opacity", schedule.lr_opacity, 1, rows);
        Ok(Optim {
            adam,
            vertices,
            sh,
            opacity,
        })
    }

    /// The optimizer state follows a topology edit's vertex table.
    pub fn apply_edit(&mut self, edit: &VertexEdit) -> Result<()> {
        self.adam.retain_rows(&edit.keep)?;
        self.adam.append_rows(edit.appended);
        Ok(())
    }

    /// One Adam step of every group, in place. SH bands above the model's
    /// degree have no gradient and no moments yet, so they are skipped.
    /// `grads` may cover more vertices than the model (a render of the model
    /// with frozen occluders appended): the model's vertices come first.
    pub fn step(&mut self, model: &mut Model<f32>, grads: &ModelGrads<f32>) -> Result<()> {
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
            )
            .context("vertex positions")?;
        let active = 3 * objectsplat_raster::sh::coeff_count(model.sh_degree);
        self.adam
            .step_columns(
                self.sh,
                model.sh.as_flattened_mut().as_flattened_mut(),
                grads.sh[..nv].as_flattened().as_flattened(),
                active,
            )
            .context("SH coefficients")?;
        self.adam
            .step_columns(
                self.opacity,
                &mut model.opacity_logits,
                &grads.opacity_logits[..nv],
                1,
            )
            .context("opacity logits")
    }
}
