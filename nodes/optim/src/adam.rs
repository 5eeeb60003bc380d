//! Adam with per-group learning rates and row-resizable state.
//!
//! Every parameter group is a row-major table (one row per vertex, `width`
//! values per row). Pruning removes rows by a keep mask and densification
//! appends rows, so the moments of surviving rows must follow their rows.

use anyhow::{Result, bail};
use objectsplat_raster::parallel::{chunk_size, run_iter};
use objectsplat_raster::real::all_finite_on;
use std::sync::atomic::{AtomicBool, Ordering};

/// One parameter group: its learning rate and the first/second moments of its rows.
#[derive(Debug, Clone, PartialEq)]
pub struct AdamGroup {
    pub name: String,
    pub lr: f64,
    /// Columns from `split` on learn at `lr_rest` instead of `lr` (SH bands above DC).
    pub split: usize,
    pub lr_rest: f64,
    /// Values per row (3 for positions, 48 for SH, 1 for opacity logits).
    pub width: usize,
    /// Number of `step` calls applied to this group (bias correction).
    pub steps: u64,
    m: Vec<f32>,
    v: Vec<f32>,
}

impl AdamGroup {
    pub fn rows(&self) -> usize {
        self.m.len() / self.width
    }

    pub fn first_moment(&self) -> &[f32] {
        &self.m
    }

    pub fn second_moment(&self) -> &[f32] {
        &self.v
    }

    /// Replaces the moments (kept elsewhere for a while, e.g. on a GPU) and the step count.
    pub fn set_moments(&mut self, first: Vec<f32>, second: Vec<f32>, steps: u64) -> Result<()> {
        if first.len() != self.m.len() || second.len() != self.v.len() {
            bail!(
                "Adam group {:?}: {} first and {} second moments for a state of {} values",
                self.name,
                first.len(),
                second.len(),
                self.m.len()
            );
        }
        self.m = first;
        self.v = second;
        self.steps = steps;
        Ok(())
    }
}

#[derive(Debug, Clone, PartialEq)]
pub struct Adam {
    pub beta1: f64,
    pub beta2: f64,
    pub eps: f64,
    pub groups: Vec<AdamGroup>,
}

impl Adam {
    /// The reference settings: β = (0.9, 0.999), ε = 1e-15.
    pub fn new() -> Adam {
        Adam {
            beta1: 0.9,
            beta2: 0.999,
            eps: 1e-15,
            groups: Vec::new(),
        }
    }

    /// Adds a group of `rows` rows of `width` values with zero moments; returns its index.
    pub fn add_group(&mut self, name: &str, lr: f64, width: usize, rows: usize) -> usize {
        self.groups.push(AdamGroup {
            name: name.into(),
            lr,
            split: width.max(1),
            lr_rest: lr,
            width: width.max(1),
            steps: 0,
            m: vec![0.0; rows * width.max(1)],
            v: vec![0.0; rows * width.max(1)],
        });
        self.groups.len() - 1
    }

    /// Columns `split..width` of `group` learn at `lr_rest` from now on.
    pub fn set_column_split(&mut self, group: usize, split: usize, lr_rest: f64) -> Result<()> {
        if !lr_rest.is_finite() || lr_rest < 0.0 {
            bail!("learning rate {lr_rest} must be finite and non-negative");
        }
        let g = self.group_mut(group)?;
        g.split = split.min(g.width);
        g.lr_rest = lr_rest;
        Ok(())
    }

    pub fn set_lr(&mut self, group: usize, lr: f64) -> Result<()> {
        if !lr.is_finite() || lr < 0.0 {
            bail!("learning rate {lr} must be finite and non-negative");
        }
        self.group_mut(group)?.lr = lr;
        Ok(())
    }

    fn group_mut(&mut self, group: usize) -> Result<&mut AdamGroup> {
        let n = self.groups.len();
        self.groups
            .get_mut(group)
            .ok_or_else(|| anyhow::anyhow!("Adam has {n} groups, no group {group}"))
    }

    /// One Adam update of `params` (the group's rows, flattened) with `grads`.
    ///
    /// `m ← β1·m + (1−β1)·g`, `v ← β2·v + (1−β2)·g²`,
    /// `p ← p − lr·m̂/(√v̂ + ε)` with `m̂ = m/(1−β1^t)`, `v̂ = v/(1−β2^t)`.
    pub fn step(&mut self, group: usize, params: &mut [f32], grads: &[f32]) -> Result<()> {
        let width = self.group_mut(group)?.width;
        self.step_columns(group, params, grads, width, 1)
    }

    /// [`Adam::step`] restricted to the first `active` columns of every row:
    /// the others must have zero gradients and zero moments (an SH band not
    /// yet switched on), which leaves them unchanged, so skipping them is exact.
    /// After the update every changed parameter is checked to be finite.
    /// Blocks of rows are shared among `threads` workers; every value's update
    /// is its own, so the result does not depend on the thread count.
    pub fn step_columns(
        &mut self,
        group: usize,
        params: &mut [f32],
        grads: &[f32],
        active: usize,
        threads: usize,
    ) -> Result<()> {
        let (b1, b2, eps) = (self.beta1, self.beta2, self.eps);
        let g = self.group_mut(group)?;
        if params.len() != g.m.len() || grads.len() != g.m.len() {
            bail!(
                "Adam group {:?}: {} params and {} grads for a state of {} values",
                g.name,
                params.len(),
                grads.len(),
                g.m.len()
            );
        }
        let (w, active) = (g.width, active.min(g.width));
        if !all_finite_on(threads, grads) {
            // The scan found a value that is not finite: the search finds it.
            let i = grads.iter().position(|x| !x.is_finite()).unwrap_or(0);
            bail!(
                "Adam group {:?}: gradient {i} is {} (not finite)",
                g.name,
                grads[i]
            );
        }
        g.steps += 1;
        let t = g.steps as i32;
        // m̂/(√v̂ + ε) = (m/(1−β1^t)) / (√v/√(1−β2^t) + ε), in f32 as on the device.
        let (b1f, b2f) = (b1 as f32, b2 as f32);
        let (c1, c2) = ((1.0 - b1) as f32, (1.0 - b2) as f32);
        let inv_sqrt_bc2 = (1.0 / (1.0 - b2.powi(t)).sqrt()) as f32;
        let bc1 = 1.0 - b1.powi(t);
        let eps = eps as f32;
        let spans = [
            (0, g.split.min(active), (g.lr / bc1) as f32),
            (g.split.min(active), active, (g.lr_rest / bc1) as f32),
        ];
        let spans: Vec<_> = spans.into_iter().filter(|s| s.0 < s.1).collect();
        let update = |p: &mut [f32], gr: &[f32], m: &mut [f32], v: &mut [f32], step: f32| {
            let mut finite = true;
            for i in 0..p.len() {
                let mi = b1f * m[i] + c1 * gr[i];
                let vi = b2f * v[i] + c2 * gr[i] * gr[i];
                m[i] = mi;
                v[i] = vi;
                p[i] -= step * mi / (vi.sqrt() * inv_sqrt_bc2 + eps);
                finite &= p[i].is_finite();
            }
            finite
        };
        // Blocks of whole rows; a block's values are contiguous in all four arrays.
        // At least 16 Ki values a block, in whole rows: a group of SH rows
        // (48 values a row) splits evenly over the threads.
        let block = chunk_size(g.m.len() / w, threads, (16_384 / w).max(1)) * w;
        let jobs = params
            .chunks_mut(block)
            .zip(grads.chunks(block))
            .zip(g.m.chunks_mut(block))
            .zip(g.v.chunks_mut(block));
        let updates_finite = AtomicBool::new(true);
        run_iter(
            threads,
            jobs,
            || (),
            |_, (((p, gr), m), v)| {
                let mut finite = true;
                for &(lo, hi, step) in &spans {
                    if hi - lo == w {
                        finite &= update(p, gr, m, v, step);
                        continue;
                    }
                    for (((p, gr), m), v) in p
                        .chunks_mut(w)
                        .zip(gr.chunks(w))
                        .zip(m.chunks_mut(w))
                        .zip(v.chunks_mut(w))
                    {
                        finite &= update(
                            &mut p[lo..hi],
                            &gr[lo..hi],
                            &mut m[lo..hi],
                            &mut v[lo..hi],
                            step,
                        );
                    }
                }
                if !finite {
                    updates_finite.store(false, Ordering::Relaxed);
                }
            },
        );
        let finite = updates_finite.into_inner();
        if !finite {
            // Found only on the slow path: which value overflowed.
            let i = params.iter().position(|x| !x.is_finite()).unwrap_or(0);
            bail!(
                "Adam group {:?}: value {i} (row {}) is not finite ({}) after a step with \
                 learning rate {} and gradient {}",
                g.name,
                i / w,
                params[i],
                if i % w < g.split { g.lr } else { g.lr_rest },
                grads[i]
            );
        }
        Ok(())
    }

    /// Keeps the rows whose mask entry is true, in order, in every group.
    pub fn retain_rows(&mut self, keep: &[bool]) -> Result<()> {
        for g in &mut self.groups {
            if keep.len() != g.rows() {
                bail!(
                    "Adam group {:?} has {} rows but the keep mask has {}",
                    g.name,
                    g.rows(),
                    keep.len()
                );
            }
        }
        for g in &mut self.groups {
            let w = g.width;
            // In place: surviving rows move down, in order.
            let mut next = 0;
            for (row, _) in keep.iter().enumerate().filter(|(_, k)| **k) {
                g.m.copy_within(row * w..(row + 1) * w, next * w);
                g.v.copy_within(row * w..(row + 1) * w, next * w);
                next += 1;
            }
            g.m.truncate(next * w);
            g.v.truncate(next * w);
        }
        Ok(())
    }

    /// Renumbers the rows of every group: row `i` becomes what row
    /// `order[i]` was (`order` a permutation of the rows).
    pub fn permute_rows(&mut self, order: &[u32]) -> Result<()> {
        let mut seen = vec![false; order.len()];
        for &r in order {
            match seen.get_mut(r as usize) {
                Some(s) if !*s => *s = true,
                _ => bail!(
                    "a row order of {} names row {r} twice or beyond its length",
                    order.len()
                ),
            }
        }
        for g in &mut self.groups {
            if order.len() != g.rows() {
                bail!(
                    "Adam group {:?} has {} rows but the row order has {}",
                    g.name,
                    g.rows(),
                    order.len()
                );
            }
        }
        for g in &mut self.groups {
            let w = g.width;
            let gather = |values: &[f32]| -> Vec<f32> {
                order
                    .iter()
                    .flat_map(|&r| &values[r as usize * w..(r as usize + 1) * w])
                    .copied()
                    .collect()
            };
            g.m = gather(&g.m);
            g.v = gather(&g.v);
        }
        Ok(())
    }

    /// Every group to `rows` rows (moments of new rows zero), e.g. before
    /// restoring saved moments of a model of that size.
    pub fn resize_rows(&mut self, rows: usize) {
        for g in &mut self.groups {
            g.m.resize(rows * g.width, 0.0);
            g.v.resize(rows * g.width, 0.0);
        }
    }

    /// Appends `rows` rows with zero moments to every group.
    pub fn append_rows(&mut self, rows: usize) {
        for g in &mut self.groups {
            let n = g.m.len() + rows * g.width;
            g.m.resize(n, 0.0);
            g.v.resize(n, 0.0);
        }
    }
}

impl Default for Adam {
    fn default() -> Self {
        Adam::new()
    }
}

/// Log-linear decay from `start` at iteration 0 to `end` at `total`
/// (`exp(lerp(ln start, ln end, t))`), constant at `end` afterwards.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LogLinearDecay {
    pub start: f64,
    pub end: f64,
    pub total: u64,
}

impl LogLinearDecay {
    pub fn validate(&self) -> Result<()> {
        if !(self.start.is_finite() && self.end.is_finite() && self.start > 0.0 && self.end > 0.0) {
            bail!(
                "learning-rate decay {} → {} needs finite positive ends",
                self.start,
                self.end
            );
        }
        Ok(())
    }

    pub fn at(&self, iteration: u64) -> f64 {
        let t = if self.total == 0 {
            1.0
        } else {
            (iteration as f64 / self.total as f64).clamp(0.0, 1.0)
        };
        (self.start.ln() * (1.0 - t) + self.end.ln() * t).exp()
    }
}
