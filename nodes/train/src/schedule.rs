//! Every scheduled number of the trainer, with the reference defaults (a 30k
//! iteration budget) scaled linearly to the actual budget.
//!
//! Iteration counts (starts, ends, periods) scale with `iterations / 30000`
//! (periods never below 1); thresholds and fractions do not scale. The vertex
//! learning rates do, between two measured points: the reference's
//! 1.5e-3 → 1.5e-5 at 30k iterations, and 4e-3 → 4e-4 at 3k iterations and
//! below (log-interpolated in the budget between them); both are held as steps
//! in pixels at the footprint they were measured at and turned back into world
//! units per component ([`Schedule::for_footprint`]). At short budgets the
//! reference rates leave triangles too little travel to tile the surfaces: on
//! the synthetic room (160×120, dense split) they gave 14.9 dB held-out PSNR
//! at 3000 iterations against 27.5 dB with 4e-3 → 4e-4 (docs/benchmarks.md).
//! The depth loss at measured points (`point_depth_weight`, not in the
//! reference) is on by default at weight 1 for the background: without it the
//! synthetic room's walls came out 20–60 cm inside the room (F-score 0.24 at
//! 5 cm, about 0.65 with it; docs/benchmarks.md).
//! Any field can be overridden by name (`Schedule::new(iterations, overrides)`).

use anyhow::{Context, Result, bail};
use objectsplat_core::ComponentKind;
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};

/// The iteration budget the reference numbers are given for.
pub const REFERENCE_ITERATIONS: u64 = 30_000;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Schedule {
    pub iterations: u64,

    /// Vertex learning rate in world units, decaying log-linearly over the
    /// run; 0 (the default) derives it from the `vertex_step_*_px` fields and
    /// the component's pixel footprint (see [`Schedule::for_footprint`]).
    pub lr_vertices_start: f64,
    pub lr_vertices_end: f64,
    /// The vertex learning rate in pixels at the component's surfaces: Adam
    /// moves a vertex about this far on screen per step, whatever the scene's
    /// units, the frames' resolution or the component's distance.
    pub vertex_step_start_px: f64,
    pub vertex_step_end_px: f64,
    pub lr_sh_dc: f64,
    /// The higher SH bands learn at `lr_sh_dc / sh_rest_lr_divisor`.
    pub sh_rest_lr_divisor: f64,
    pub lr_opacity: f64,

    /// Window sharpness σ, linear from start (iteration 0) to end (last iteration).
    pub sigma_start: f64,
    pub sigma_end: f64,

    /// SH degree grows by one every this many iterations, up to `sh_max_degree`.
    pub sh_degree_every: u64,
    pub sh_max_degree: u32,

    /// The opacity floor is 0 before `floor_start`; from then on, every
    /// `floor_every` iterations, `m = floor_base + floor_gain·min(1, (it − floor_start)/floor_ramp)`.
    pub floor_start: u64,
    pub floor_every: u64,
    pub floor_base: f64,
    pub floor_gain: f64,
    pub floor_ramp: u64,
    /// After the connectivity step the floor pauses for this many iterations.
    pub floor_pause_after_connectivity: u64,

    /// Pruning every `prune_every` iterations from `prune_start` until the connectivity step.
    pub prune_start: u64,
    pub prune_every: u64,
    /// Threshold `prune_threshold + prune_threshold_step·⌊(it − prune_threshold_rise_start)/prune_every⌋`
    /// (the increment counts only once the rise has started).
    pub prune_threshold: f64,
    pub prune_threshold_step: f64,
    pub prune_threshold_rise_start: u64,
    /// Faces whose screen extent (px) exceeds this in any view are pruned.
    pub prune_max_screen_extent: f64,

    /// Densification at `densify_start`, `+densify_every`, … up to `densify_until` (inclusive).
    pub densify_start: u64,
    pub densify_every: u64,
    pub densify_until: u64,
    /// Fraction of faces added (faces split = ⌊(1 + growth)·T⌋ − T).
    pub densify_growth: f64,
    /// Faces with a 3D area below this are never sampled.
    pub densify_min_area: f64,
    /// The largest-area faces always split at each densification.
    pub densify_always_largest: usize,
    /// Faces whose screen inradius (in rendered samples: pixels × supersample)
    /// stays below this in every training view are never split: their children
    /// would fall under the renderer's 1-sample inradius cull, draw nothing and
    /// be pruned again.
    pub densify_min_inradius: f64,
    /// Densification stops adding once the model has this many vertices.
    pub max_vertices: usize,

    /// Iteration at whose start the restricted Delaunay connectivity step runs.
    pub connectivity_at: u64,

    /// One epoch after the connectivity step, faces whose max blending weight over
    /// the training views is ≤ this are removed: most faces of the restricted
    /// Delaunay mesh lie inside surfaces and never show. 0 turns the cleanup off.
    pub connectivity_cleanup_threshold: f64,

    /// From the connectivity step on, every this many iterations a background
    /// component's normals are filtered and its vertices moved to fit them (see
    /// `crate::surface_filter`); 0 turns this off.
    pub surface_every: u64,
    /// The same for object components. Off by default: on the demo it raised
    /// the table's and chair's normal consistency (0.70 → 0.87, 0.71 → 0.84)
    /// but cost every object 0.7–3.3 dB on its pixels (the ball 23.2 → 19.9).
    pub object_surface_every: u64,
    /// The last iteration that starts with a pass: the photometric loss has
    /// the schedule's end, and a finish, to itself.
    pub surface_until: u64,
    /// Faces whose normals make |cos| at or below this are across a crease and
    /// do not smooth each other.
    pub surface_crease_cos: f64,
    /// Rounds of normal filtering and of the vertex update per pass.
    pub surface_normal_rounds: u64,
    pub surface_vertex_rounds: u64,

    /// After training, faces whose max blending weight over the training views is ≤ this are removed.
    pub final_prune_threshold: f64,
    /// After the final prune and the bake, passes over the training views that
    /// fit the flat colours to them as the export draws them (see
    /// `crate::flat_fit`); 0 keeps the bake.
    pub flat_fit_epochs: u64,
    /// Adam's learning rate of the flat colours' DC coefficients in that fit.
    pub flat_fit_lr: f64,
    /// A depth-supervised component (the background, by default) also loses, at
    /// every prune during training, the faces its training views saw measured
    /// points through at least this many times and more often than they saw
    /// points on them (see `crate::free_space`); 0 turns this off.
    pub free_space_min_sightings: u64,
    /// 1: the free-space rule also counts the other components' points on the
    /// pixels they own (an object's point proves the ray to it empty of the
    /// background); 0: only the component's own points.
    pub free_space_other_components: u64,

    /// Weight of the depth loss at a background component's measured points
    /// (see `crate::point_depth`); 0 turns it off.
    pub point_depth_weight: f64,
    /// The same for object components. Off by default: an object is seen from
    /// all around and its silhouettes fix its shape (F 0.92–1.0 at 5 cm without
    /// it), while the handful of points a small object owns only roughened it
    /// (demo: the ball 16.6 → 12.3 dB on its pixels with weight 1).
    pub object_point_depth_weight: f64,
    /// The depth loss applies from this iteration on.
    pub point_depth_start: u64,
    /// Weight of the planarity prior on a background component's rendered depth
    /// (see `crate::depth_smoothness`). 0 turns it off.
    pub depth_smoothness_weight: f64,
    /// The same for object components. Off by default: it flattens their faces
    /// (demo, weight 0.3: normal consistency 0.63–0.71 → 0.70–0.85) at a cost in
    /// appearance (−0.3 dB for the scene, the ball −3.3 dB on its pixels).
    pub object_depth_smoothness_weight: f64,
    /// The planarity prior applies from this iteration on (by default the
    /// connectivity step's: from the start it slowed the early growth of
    /// coverage, −2.7 dB at 1000 iterations on the dense bench), and never
    /// while the cleanup after the connectivity step is pending.
    pub depth_smoothness_start: u64,
    /// Weight of the prior that faces sharing an edge agree on their normal
    /// (see `crate::normal_agreement`), for a background component, from the
    /// connectivity step on; 0 turns it off.
    pub normal_agreement_weight: f64,
    /// The same for object components.
    pub object_normal_agreement_weight: f64,

    /// A run that returns a model from before the end of its budget (an early
    /// stop, or a best checkpoint before the last iteration) first finishes it:
    /// the rest of the schedule — σ, opacity floor, SH degree, vertex learning
    /// rate — compressed into the first half of this many more iterations, then
    /// the schedule's end values for the second half, so the model returned is
    /// opaque and hard-edged like every exported one.
    pub finish_iterations: u64,

    /// Samples per pixel side for a background component's renders: 1, 2 or
    /// 4 (`s × s` samples box-filtered, see `objectsplat_raster::supersample`).
    /// At one sample the true box and cup of the team's room score 19.3 and
    /// 21.7 dB on their pixels against its frames (a camera integrates over
    /// the pixel). A background trained at fewer samples than its occluders
    /// loses their thinnest faces to the renderer's 1-sample cull and grows
    /// geometry in their place (demo: 15.6 % of the chair's pixels).
    pub supersample: u32,
    /// The same for object components.
    pub object_supersample: u32,

    /// Held-out evaluation (best checkpoint) every this many iterations.
    pub eval_every: u64,
    /// Early stop when the held-out score has not improved for this many iterations
    /// (counted only after the connectivity step).
    pub patience: u64,
}

/// The budget at and below which the short-budget vertex learning rates apply.
pub const SHORT_BUDGET: u64 = 3_000;

/// The vertex learning rates in world units where they were measured: the
/// reference's at 30k iterations, and the short budget's on the synthetic
/// room's background at 160×120 (module docs).
const REFERENCE_LR_START: f64 = 1.5e-3;
const REFERENCE_LR_END: f64 = 1.5e-5;
const SHORT_LR_START: f64 = 4e-3;
const SHORT_LR_END: f64 = 4e-4;
/// [`SHORT_LR_START`] in pixels: that background's pixel footprint is
/// 24.1 mm ([`crate::screen::pixel_footprint`]). The same step in pixels is what
/// the room's objects at 320×240 measured best at (their footprint 6–9 mm:
/// 1e-3 m, where 4e-3 m gave 2.4–4.4 dB less on the table, chair and bin and
/// 3.1 dB less on the ball; docs/benchmarks.md).
const SHORT_VERTEX_STEP_PX: f64 = 0.166;

/// `(short, reference)` log-interpolated in the budget between
/// [`SHORT_BUDGET`] and [`REFERENCE_ITERATIONS`] (clamped outside).
fn by_budget(iterations: u64, short: f64, reference: f64) -> f64 {
    let (lo, hi) = (
        (SHORT_BUDGET as f64).ln(),
        (REFERENCE_ITERATIONS as f64).ln(),
    );
    let t = (((iterations.max(1)) as f64).ln() - lo) / (hi - lo);
    if t <= 0.0 {
        short
    } else if t >= 1.0 {
        reference
    } else {
        (short.ln() * (1.0 - t) + reference.ln() * t).exp()
    }
}

/// A reference iteration count scaled to the budget.
fn scale_at(reference: u64, iterations: u64) -> u64 {
    ((reference as f64) * iterations as f64 / REFERENCE_ITERATIONS as f64).round() as u64
}

/// A reference period scaled to the budget, never below 1.
fn scale_every(reference: u64, iterations: u64) -> u64 {
    scale_at(reference, iterations).max(1)
}

impl Schedule {
    /// The reference schedule scaled to `iterations`.
    pub fn scaled(iterations: u64) -> Schedule {
        let at = |r| scale_at(r, iterations);
        let every = |r| scale_every(r, iterations);
        Schedule {
            iterations,
            lr_vertices_start: 0.0,
            lr_vertices_end: 0.0,
            vertex_step_start_px: by_budget(
                iterations,
                SHORT_VERTEX_STEP_PX,
                SHORT_VERTEX_STEP_PX * REFERENCE_LR_START / SHORT_LR_START,
            ),
            vertex_step_end_px: by_budget(
                iterations,
                SHORT_VERTEX_STEP_PX * SHORT_LR_END / SHORT_LR_START,
                SHORT_VERTEX_STEP_PX * REFERENCE_LR_END / SHORT_LR_START,
            ),
            lr_sh_dc: 1.6e-3,
            sh_rest_lr_divisor: 20.0,
            lr_opacity: 0.03,
            sigma_start: 1.0,
            sigma_end: objectsplat_raster::FINISHED_SIGMA,
            sh_degree_every: every(1000),
            sh_max_degree: 3,
            floor_start: at(5000),
            floor_every: every(500),
            floor_base: 0.1,
            floor_gain: 0.8999,
            floor_ramp: every(19_000),
            floor_pause_after_connectivity: at(1000),
            prune_start: at(4000),
            prune_every: every(500),
            prune_threshold: 0.235,
            prune_threshold_step: 0.01,
            prune_threshold_rise_start: at(5000),
            prune_max_screen_extent: 1400.0,
            densify_start: at(1000),
            densify_every: every(500),
            densify_until: at(9500),
            densify_growth: 0.23,
            densify_min_area: 7.5e-5,
            densify_always_largest: 100,
            densify_min_inradius: 2.0,
            max_vertices: 4_000_000,
            // The reference runs it at the start of iteration densify_until + 1000 + 1 (11001).
            connectivity_at: at(11_000) + 1,
            connectivity_cleanup_threshold: 0.02,
            surface_every: every(100),
            object_surface_every: 0,
            surface_until: at(27_000),
            surface_crease_cos: 0.5,
            surface_normal_rounds: 2,
            surface_vertex_rounds: 5,
            final_prune_threshold: 0.5,
            flat_fit_epochs: 2,
            flat_fit_lr: 5e-3,
            free_space_min_sightings: 2,
            free_space_other_components: 1,
            point_depth_weight: 1.0,
            object_point_depth_weight: 0.0,
            point_depth_start: 0,
            depth_smoothness_weight: 3.0,
            object_depth_smoothness_weight: 0.0,
            depth_smoothness_start: at(11_000) + 1,
            normal_agreement_weight: 0.0,
            object_normal_agreement_weight: 0.0,
            finish_iterations: every(3000),
            supersample: 2,
            object_supersample: 2,
            eval_every: every(500),
            patience: every(3000),
        }
    }

    /// The scaled schedule with named fields replaced (unknown names are an error).
    pub fn new(iterations: u64, overrides: &Map<String, Value>) -> Result<Schedule> {
        let base = Schedule::scaled(iterations);
        let mut value = serde_json::to_value(&base).context("serialising the schedule")?;
        let Value::Object(fields) = &mut value else {
            bail!("the schedule did not serialise to an object");
        };
        for (k, v) in overrides {
            if k == "iterations" {
                bail!("schedule override `iterations`: set it through the iteration budget");
            }
            if !fields.contains_key(k) {
                bail!("unknown schedule setting `{k}`");
            }
            fields.insert(k.clone(), v.clone());
        }
        let s: Schedule = serde_json::from_value(value).context("schedule overrides")?;
        s.validate()?;
        Ok(s)
    }

    pub fn validate(&self) -> Result<()> {
        let positive = [
            ("vertex_step_start_px", self.vertex_step_start_px),
            ("vertex_step_end_px", self.vertex_step_end_px),
            ("sh_rest_lr_divisor", self.sh_rest_lr_divisor),
            ("sigma_start", self.sigma_start),
            ("sigma_end", self.sigma_end),
        ];
        for (name, v) in positive {
            if !v.is_finite() || v <= 0.0 {
                bail!("schedule {name} = {v} must be finite and positive");
            }
        }
        let non_negative = [
            ("lr_vertices_start", self.lr_vertices_start),
            ("lr_vertices_end", self.lr_vertices_end),
            ("lr_sh_dc", self.lr_sh_dc),
            ("lr_opacity", self.lr_opacity),
            ("floor_base", self.floor_base),
            ("floor_gain", self.floor_gain),
            ("prune_threshold", self.prune_threshold),
            ("prune_threshold_step", self.prune_threshold_step),
            ("prune_max_screen_extent", self.prune_max_screen_extent),
            ("densify_growth", self.densify_growth),
            ("densify_min_area", self.densify_min_area),
            ("final_prune_threshold", self.final_prune_threshold),
            ("flat_fit_lr", self.flat_fit_lr),
            ("point_depth_weight", self.point_depth_weight),
            ("object_point_depth_weight", self.object_point_depth_weight),
            ("depth_smoothness_weight", self.depth_smoothness_weight),
            (
                "object_depth_smoothness_weight",
                self.object_depth_smoothness_weight,
            ),
            ("normal_agreement_weight", self.normal_agreement_weight),
            (
                "object_normal_agreement_weight",
                self.object_normal_agreement_weight,
            ),
            ("densify_min_inradius", self.densify_min_inradius),
            (
                "connectivity_cleanup_threshold",
                self.connectivity_cleanup_threshold,
            ),
        ];
        for (name, v) in non_negative {
            if !v.is_finite() || v < 0.0 {
                bail!("schedule {name} = {v} must be finite and non-negative");
            }
        }
        if self.floor_base + self.floor_gain >= 1.0 {
            bail!(
                "schedule floor_base + floor_gain = {} must stay below 1",
                self.floor_base + self.floor_gain
            );
        }
        for (name, v) in [
            ("sh_degree_every", self.sh_degree_every),
            ("floor_every", self.floor_every),
            ("floor_ramp", self.floor_ramp),
            ("prune_every", self.prune_every),
            ("densify_every", self.densify_every),
            ("eval_every", self.eval_every),
            ("finish_iterations", self.finish_iterations),
        ] {
            if v == 0 {
                bail!("schedule {name} must be at least 1");
            }
        }
        if self.free_space_other_components > 1 {
            bail!(
                "schedule free_space_other_components = {} must be 0 or 1",
                self.free_space_other_components
            );
        }
        if self.sh_max_degree > 3 {
            bail!("schedule sh_max_degree {} exceeds 3", self.sh_max_degree);
        }
        if !(self.surface_crease_cos.is_finite() && (0.0..1.0).contains(&self.surface_crease_cos)) {
            bail!(
                "schedule surface_crease_cos = {} must be in [0, 1)",
                self.surface_crease_cos
            );
        }
        for (name, v) in [
            ("supersample", self.supersample),
            ("object_supersample", self.object_supersample),
        ] {
            objectsplat_raster::supersample::validate(v)
                .with_context(|| format!("schedule {name}"))?;
        }
        Ok(())
    }

    /// The schedule with its vertex learning rates in world units for a
    /// component whose surfaces the training views see at `metres_per_px`
    /// (world units per pixel: depth over focal length); rates set in world
    /// units are kept.
    pub fn for_footprint(&self, metres_per_px: f64) -> Result<Schedule> {
        if !(metres_per_px.is_finite() && metres_per_px > 0.0) {
            bail!("pixel footprint {metres_per_px} must be finite and positive");
        }
        let mut s = self.clone();
        if s.lr_vertices_start == 0.0 {
            s.lr_vertices_start = s.vertex_step_start_px * metres_per_px;
        }
        if s.lr_vertices_end == 0.0 {
            s.lr_vertices_end = s.vertex_step_end_px * metres_per_px;
        }
        Ok(s)
    }

    /// Whether iteration `it` of a `kind` component starts with a surface
    /// filter pass (after the connectivity step).
    pub fn surface_at(&self, kind: ComponentKind, it: u64) -> bool {
        let every = match kind {
            ComponentKind::Background => self.surface_every,
            ComponentKind::Object => self.object_surface_every,
        };
        every > 0
            && it > self.connectivity_at
            && it <= self.surface_until
            && (it - self.connectivity_at).is_multiple_of(every)
    }

    /// The learning rates at iteration `it` (only the vertices' decay), of a
    /// schedule whose vertex rates are in world units ([`Schedule::for_footprint`]).
    pub fn learning_rates(&self, it: u64) -> objectsplat_optim::LearningRates {
        objectsplat_optim::LearningRates {
            positions: self.lr_vertices(it),
            sh_dc: self.lr_sh_dc,
            sh_rest: self.lr_sh_dc / self.sh_rest_lr_divisor,
            opacity: self.lr_opacity,
        }
    }

    pub fn lr_vertices(&self, it: u64) -> f64 {
        crate::adam::LogLinearDecay {
            start: self.lr_vertices_start,
            end: self.lr_vertices_end,
            total: self.iterations,
        }
        .at(it)
    }

    /// The depth loss's weight for a component of `kind`.
    pub fn point_depth_weight_for(&self, kind: ComponentKind) -> f64 {
        match kind {
            ComponentKind::Background => self.point_depth_weight,
            ComponentKind::Object => self.object_point_depth_weight,
        }
    }

    /// Samples per pixel side for a component of `kind`.
    pub fn supersample_for(&self, kind: ComponentKind) -> u32 {
        match kind {
            ComponentKind::Background => self.supersample,
            ComponentKind::Object => self.object_supersample,
        }
    }

    /// The planarity prior's weight for a component of `kind`.
    pub fn depth_smoothness_weight_for(&self, kind: ComponentKind) -> f64 {
        match kind {
            ComponentKind::Background => self.depth_smoothness_weight,
            ComponentKind::Object => self.object_depth_smoothness_weight,
        }
    }

    /// The normal-agreement prior's weight for a component of `kind`.
    pub fn normal_agreement_weight_for(&self, kind: ComponentKind) -> f64 {
        match kind {
            ComponentKind::Background => self.normal_agreement_weight,
            ComponentKind::Object => self.object_normal_agreement_weight,
        }
    }

    pub fn sigma(&self, it: u64) -> f64 {
        let t = if self.iterations == 0 {
            1.0
        } else {
            (it as f64 / self.iterations as f64).min(1.0)
        };
        self.sigma_start + (self.sigma_end - self.sigma_start) * t
    }

    pub fn sh_degree(&self, it: u64) -> u32 {
        ((it / self.sh_degree_every).min(self.sh_max_degree as u64)) as u32
    }

    /// The new floor to apply at the start of iteration `it`, if it changes then.
    pub fn floor_update(&self, it: u64) -> Option<f64> {
        if it < self.floor_start || !(it - self.floor_start).is_multiple_of(self.floor_every) {
            return None;
        }
        let paused_from = self.connectivity_at;
        let paused_until = self.connectivity_at + self.floor_pause_after_connectivity;
        if (paused_from..paused_until).contains(&it) {
            return None;
        }
        Some(self.floor_at(it))
    }

    /// The floor's scheduled value at iteration `it` (0 before `floor_start`; no pause).
    pub fn floor_at(&self, it: u64) -> f64 {
        if it < self.floor_start {
            return 0.0;
        }
        let ramp = ((it - self.floor_start) as f64 / self.floor_ramp as f64).min(1.0);
        self.floor_base + self.floor_gain * ramp
    }

    /// The floor of a finished model: the ramp's end.
    pub fn floor_end(&self) -> f64 {
        self.floor_base + self.floor_gain
    }

    /// The pruning threshold at iteration `it`, when pruning happens then.
    pub fn prune_at(&self, it: u64) -> Option<f64> {
        if it < self.prune_start
            || it >= self.connectivity_at
            || !(it - self.prune_start).is_multiple_of(self.prune_every)
        {
            return None;
        }
        Some(self.prune_threshold_at(it))
    }

    pub fn prune_threshold_at(&self, it: u64) -> f64 {
        let steps = it.saturating_sub(self.prune_threshold_rise_start) / self.prune_every;
        self.prune_threshold + self.prune_threshold_step * steps as f64
    }

    /// Whether densification happens at the start of iteration `it`.
    pub fn densify_at(&self, it: u64) -> bool {
        it >= self.densify_start
            && it <= self.densify_until
            && it < self.connectivity_at
            && (it - self.densify_start).is_multiple_of(self.densify_every)
    }

    /// Number of faces to split for a model of `faces` faces.
    pub fn densify_count(&self, faces: usize) -> usize {
        (((1.0 + self.densify_growth) * faces as f64).floor() as usize).saturating_sub(faces)
    }
}
