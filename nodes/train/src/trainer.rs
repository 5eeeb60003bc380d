//! The training loop for one component (an object or the background).
//!
//! Each step renders one training view, visiting the views in shuffled epochs.
//! Object components keep their own pixels and supervise every OTHER pixel
//! toward the background colour, drawn uniformly at random every iteration
//! when background randomization is on; the background component gives OTHER
//! pixels zero weight; IGNORE pixels are never supervised (`supervision.rs`).
//! The schedule drives σ, the SH degree, the opacity floor, densification,
//! pruning and the connectivity step.
//!
//! What an iteration costs: only the view's footprint is rendered and scored
//! (`host_steps.rs`), Adam updates the model in place, the per-face weights
//! that pruning and densification judge faces by come from the training
//! renders themselves (`face_stats.rs`), and the model is evaluated only where
//! the result can be selected (after the connectivity step, with the `best`
//! checkpoint) and once at the end.
//!
//! On a wgpu backend the iterations themselves (render, loss, backward, Adam,
//! cropped like the host's), the held-out evaluations and the per-face weight
//! statistics run on the device (`device_steps.rs`); the model comes back to
//! the host for the schedule's structural edits and for a new best checkpoint.

use crate::checkpoint::{Progress, TrainerState};
use crate::connectivity::{ConnectivityOptions, restricted_delaunay};
use crate::densify::{DensifyPolicy, prune_faces, select_faces_to_split, subdivide_faces};
use crate::device_steps::DeviceSteps;
use crate::face_stats::FaceWeights;
use crate::flat_color::{FlatColors, Sighting};
use crate::flat_fit::FlatFit;
use crate::free_space::{Seen, sightings};
use crate::host_steps::HostSteps;
use crate::init::{InitSettings, init_model};
use crate::point_depth::PointDepth;
use crate::schedule::Schedule;
use crate::screen::{pixel_footprint, screen_sizes};
use crate::spatial_order::spatial_order;
use crate::steps::{StepInput, StepLoss, StepRunner, Subject, TrainingState};
use crate::surface_filter::{SurfaceFilter, SurfaceScratch};
use anyhow::{Context, Result, bail};
use objectsplat_core::{ComponentKind, Points, Split};
use objectsplat_core::{EvalRecord, StepRecord, TrainingLog, TrainingTimes};
use objectsplat_optim::{LearningRates, Optim};
use objectsplat_raster::{Model, RenderBackend, RenderSettings};
use objectsplat_raster_gpu::WgpuBackend;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};
use std::collections::VecDeque;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

pub use crate::steps::HeldOut;
pub use crate::supervision::{ComponentData, View, supervision};

/// Which model a run returns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Checkpoint {
    /// The best on the held-out views; the run stops early after `patience`.
    #[default]
    Best,
    /// The model at the end of the full budget (no early stop): the paper's fixed-iteration variant.
    Last,
}

/// Which views choose the `best` checkpoint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SelectOn {
    /// One in eight training views, held out of training (with fewer than eight
    /// training views, the training views themselves).
    #[default]
    Validation,
    /// The training views (nothing held out).
    Training,
    /// The test views, which the evaluation then scores too: the paper's protocol.
    Test,
}

impl SelectOn {
    pub fn name(self) -> &'static str {
        match self {
            SelectOn::Validation => "validation",
            SelectOn::Training => "training",
            SelectOn::Test => "test",
        }
    }
}

#[derive(Debug, Clone)]
pub struct TrainSettings {
    pub schedule: Schedule,
    pub seed: u64,
    /// Draw the background colour uniformly in `[0, 1]³` every iteration (else `fixed_background`).
    pub background_randomization: bool,
    pub fixed_background: [f32; 3],
    pub init: InitSettings,
    /// Scales the renderer's depth thresholds for scenes not in metres.
    pub world_scale: f64,
    pub checkpoint: Checkpoint,
    /// Render and score only each view's footprint (exact; off renders whole frames).
    pub crop: bool,
    /// Which views choose the `best` checkpoint.
    pub select_on: SelectOn,
    /// A folder to save the run's state in (every `save_seconds`) and to resume
    /// from: a run killed half-way continues from its last save and ends with
    /// the same model as an uninterrupted one.
    pub resume_dir: Option<std::path::PathBuf>,
    /// Wall seconds between saves of the state (0: at every loss-log point).
    pub save_seconds: f64,
    /// Worker threads of the host-side passes over every face and view (prune
    /// statistics); results do not depend on it.
    pub threads: usize,
    /// The threads the run may use now, set by whoever runs it (a job whose
    /// neighbours finished gets their cores); read every iteration, it sets
    /// `threads` and the host renderer's. None: `threads` throughout.
    pub thread_budget: Option<Arc<AtomicUsize>>,
}

impl TrainSettings {
    /// The defaults around a schedule: seed 0, randomized backgrounds, best checkpoint, cropping.
    pub fn new(schedule: Schedule) -> Self {
        TrainSettings {
            schedule,
            seed: 0,
            background_randomization: true,
            fixed_background: [0.0; 3],
            init: InitSettings::default(),
            world_scale: 1.0,
            checkpoint: Checkpoint::Best,
            crop: true,
            select_on: SelectOn::Validation,
            resume_dir: None,
            save_seconds: 60.0,
            threads: 1,
            thread_budget: None,
        }
    }
}

/// The trained model and what happened.
pub struct TrainReport {
    pub model: Model<f32>,
    pub iterations_run: u64,
    pub best_iteration: u64,
    /// Held-out photometric loss of the returned (finally pruned) model; lower is better.
    pub best_score: f64,
    pub notes: Vec<String>,
    /// Curves and outcome, saved next to the model as `training.json`.
    pub log: TrainingLog,
    /// When the run reached the log's steps and evaluations: not saved with the model,
    /// which must not depend on the clock.
    pub times: TrainingTimes,
    /// Where the iterations ran: "host" or "device".
    pub steps_ran_on: &'static str,
}

fn render_settings(model: &Model<f32>, settings: &TrainSettings) -> RenderSettings {
    RenderSettings::for_model(model).with_world_scale(settings.world_scale)
}

/// Which views a run trains on and which it scores models on.
struct ViewRoles {
    train: Vec<usize>,
    scored: Vec<usize>,
    /// What `scored` is, for the log.
    scored_on: &'static str,
}

/// Splits a component's views: with the `best` checkpoint the scored views are
/// those `select_on` names (validation views leave training); with `last`
/// nothing is selected, every training view trains and the test views (else the
/// training views) only report.
fn view_roles(data: &ComponentData, checkpoint: Checkpoint, select_on: SelectOn) -> ViewRoles {
    let of = |split: Split| -> Vec<usize> {
        (0..data.views.len())
            .filter(|&i| data.views[i].split == split)
            .collect()
    };
    let (train, test) = (of(Split::Train), of(Split::Test));
    let test_or_train = |train: Vec<usize>| {
        if test.is_empty() {
            ViewRoles {
                scored: train.clone(),
                train,
                scored_on: "training",
            }
        } else {
            ViewRoles {
                train,
                scored: test.clone(),
                scored_on: "test",
            }
        }
    };
    match (checkpoint, select_on) {
        (Checkpoint::Last, _) | (Checkpoint::Best, SelectOn::Test) => test_or_train(train),
        (Checkpoint::Best, SelectOn::Validation) if train.len() >= 8 => {
            // Every 8th training view (by position) is held out for validation.
            let held_out = |k: &usize| k % 8 == 7;
            ViewRoles {
                scored: (0..train.len())
                    .filter(held_out)
                    .map(|k| train[k])
                    .collect(),
                train: (0..train.len())
                    .filter(|k| !held_out(k))
                    .map(|k| train[k])
                    .collect(),
                scored_on: "validation",
            }
        }
        (Checkpoint::Best, _) => ViewRoles {
            scored: train.clone(),
            train,
            scored_on: "training",
        },
    }
}

/// The held-out views of a component (its training views when none is held out).
fn evaluation_views(data: &ComponentData) -> Vec<usize> {
    view_roles(data, Checkpoint::Last, SelectOn::Test).scored
}

/// Scores `model` on the held-out views over a black background, so stray
/// coverage of OTHER pixels costs (their target is black too).
pub fn held_out_eval(
    backend: &dyn RenderBackend<f32>,
    model: &Model<f32>,
    data: &ComponentData,
    settings: &TrainSettings,
) -> Result<HeldOut> {
    let supersample = settings.schedule.supersample_for(data.kind);
    HostSteps::new(backend, data, settings.crop, false, supersample)?.evaluate(
        model,
        &evaluation_views(data),
        &render_settings(model, settings),
    )
}

/// The held-out loss alone (see [`held_out_eval`]).
pub fn held_out_score(
    backend: &dyn RenderBackend<f32>,
    model: &Model<f32>,
    data: &ComponentData,
    settings: &TrainSettings,
) -> Result<f64> {
    Ok(held_out_eval(backend, model, data, settings)?.loss)
}

/// The best model so far on the held-out views.
struct Snapshot {
    score: f64,
    iteration: u64,
    model: Model<f32>,
    /// Its per-face weights, when the running statistics were complete then.
    face_weights: Option<Vec<f32>>,
}

/// The end of a run that returns a model from before the end of its budget:
/// from the returned model, the rest of the schedule compressed into the first
/// half of the window and its end values held for the second half.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Finish {
    /// The loop iteration the window starts at.
    pub from: u64,
    /// The loop iteration it ends at.
    pub until: u64,
    /// The schedule iteration the model comes from.
    pub model_from: u64,
}

impl Finish {
    /// The schedule iteration whose σ, floor, SH degree and vertex learning rate
    /// apply at loop iteration `it`.
    fn schedule_iteration(&self, it: u64, iterations: u64) -> u64 {
        let half = ((self.until - self.from) / 2).max(1);
        let t = ((it.saturating_sub(self.from)) as f64 / half as f64).min(1.0);
        self.model_from + ((iterations.saturating_sub(self.model_from)) as f64 * t).round() as u64
    }

    /// Whether the opacity floor is due for its next step at loop iteration `it`.
    fn floor_due(&self, it: u64, floor_every: u64) -> bool {
        (it - self.from).is_multiple_of(floor_every) || it + 1 == self.until
    }
}

/// The training views in shuffled epochs: every view once per epoch.
struct ViewOrder {
    order: Vec<usize>,
    next: usize,
}

impl ViewOrder {
    fn new(views: usize) -> Self {
        ViewOrder {
            order: (0..views).collect(),
            next: views,
        }
    }

    /// The next view slot, and whether it starts a new epoch.
    fn next(&mut self, rng: &mut Pcg64Mcg) -> (usize, bool) {
        let new_epoch = self.next == self.order.len();
        if new_epoch {
            self.order.shuffle(rng);
            self.next = 0;
        }
        self.next += 1;
        (self.order[self.next - 1], new_epoch)
    }
}

/// What a [`StepHook`] is shown after each training iteration.
pub struct Step<'a> {
    /// Iterations done, this one included (1-based).
    pub iteration: u64,
    pub total: u64,
    /// The index into `ComponentData::views` of the view this iteration rendered.
    pub view: Option<usize>,
    /// The photometric loss of that view, when known at once (the host's
    /// steps; a device reports its losses in batches).
    pub loss: Option<f64>,
    /// The model after this iteration's update. On a device it is copied back
    /// only for a hook that asks ([`StepHook::wants_model`]), which is slow.
    pub model: Option<&'a Model<f32>>,
}

/// Watches a training run step by step — for probes and studies that would
/// otherwise copy the training loop — and may interrupt it.
pub trait StepHook {
    /// Whether [`Step::model`] should be filled on a device too.
    fn wants_model(&self) -> bool {
        false
    }
    /// Called after every iteration; false interrupts the run (an error).
    fn after_step(&mut self, step: &Step) -> bool;
}

/// A progress callback `(done, total) -> keep going` as a hook.
struct ProgressHook<F>(F);

impl<F: FnMut(u64, u64) -> bool> StepHook for ProgressHook<F> {
    fn after_step(&mut self, step: &Step) -> bool {
        (self.0)(step.iteration, step.total)
    }
}

/// The loss log: one record per `every` iterations, the mean loss of its
/// window. A device's losses arrive after the log point they belong to, so
/// points wait for their windows.
struct LossLog {
    records: Vec<StepRecord>,
    /// (iteration, wall seconds) of each record.
    times: Vec<(u64, f64)>,
    /// Points whose window has not fully arrived: (iteration, wall seconds, faces).
    waiting: VecDeque<(u64, f64, usize)>,
    arrived: VecDeque<StepLoss>,
    window_sum: f64,
    window_len: u64,
    /// The iteration of the last loss summed into a window.
    last_taken: Option<u64>,
}

impl LossLog {
    fn new(records: Vec<StepRecord>, times: Vec<(u64, f64)>) -> Self {
        LossLog {
            records,
            times,
            waiting: VecDeque::new(),
            arrived: VecDeque::new(),
            window_sum: 0.0,
            window_len: 0,
            last_taken: None,
        }
    }

    fn point(&mut self, iteration: u64, wall_seconds: f64, faces: usize) {
        self.waiting.push_back((iteration, wall_seconds, faces));
        self.resolve();
    }

    fn arrive(&mut self, losses: Vec<StepLoss>) {
        self.arrived.extend(losses);
        self.resolve();
    }

    fn resolve(&mut self) {
        while let Some(&(iteration, wall_seconds, faces)) = self.waiting.front() {
            while let Some(l) = self.arrived.front().filter(|l| l.iteration <= iteration) {
                self.window_sum += l.loss;
                self.window_len += 1;
                self.last_taken = Some(l.iteration);
                self.arrived.pop_front();
            }
            let complete = self.window_len > 0
                && self
                    .arrived
                    .front()
                    .map_or(self.last_arrived_was(iteration), |next| {
                        next.iteration > iteration
                    });
            if !complete {
                return;
            }
            self.records.push(StepRecord {
                iteration,
                loss: self.window_sum / self.window_len as f64,
                faces,
            });
            self.times.push((iteration, wall_seconds));
            self.waiting.pop_front();
            self.window_sum = 0.0;
            self.window_len = 0;
        }
    }

    /// With nothing left in `arrived`: whether the window of `iteration` is
    /// complete, i.e. its last loss was the last one taken.
    fn last_arrived_was(&self, iteration: u64) -> bool {
        self.last_taken == Some(iteration)
    }
}

/// Trains one component from its sparse points. `progress(done, total)` returns
/// false to interrupt the run (an error).
pub fn train_component(
    backend: &dyn RenderBackend<f32>,
    data: &ComponentData,
    points: &Points,
    settings: &TrainSettings,
    progress: impl FnMut(u64, u64) -> bool,
) -> Result<TrainReport> {
    train_component_with_hook(backend, data, points, settings, &mut ProgressHook(progress))
}

/// [`train_component`] with a [`StepHook`] shown every iteration.
pub fn train_component_with_hook(
    backend: &dyn RenderBackend<f32>,
    data: &ComponentData,
    points: &Points,
    settings: &TrainSettings,
    hook: &mut dyn StepHook,
) -> Result<TrainReport> {
    settings.schedule.validate()?;
    if !(settings.world_scale.is_finite() && settings.world_scale > 0.0) {
        bail!(
            "world_scale {} must be finite and positive",
            settings.world_scale
        );
    }
    let ViewRoles {
        train,
        scored: held_out,
        scored_on,
    } = view_roles(data, settings.checkpoint, settings.select_on);
    if train.is_empty() {
        bail!("component {:?} has no training views", data.name);
    }
    let model = init_model(
        points,
        &InitSettings {
            seed: settings.seed,
            ..settings.init
        },
    )
    .with_context(|| format!("initializing component {:?}", data.name))?;
    let train_cameras: Vec<&objectsplat_core::Camera> =
        train.iter().map(|&i| &data.views[i].camera).collect();
    // The initial surface's distance from the cameras sets how far a vertex
    // step moves on screen; the rates are fixed for the run from it.
    let footprint = pixel_footprint(&model, &train_cameras).with_context(|| {
        format!(
            "component {:?}: no initial point projects into a training view",
            data.name
        )
    })?;
    let resolved = settings.schedule.for_footprint(footprint)?;
    let s = &resolved;
    let optim = Optim::new(
        LearningRates {
            positions: s.lr_vertices_start,
            ..s.learning_rates(0)
        },
        model.vertex_count(),
    )?;
    let mut state = TrainingState {
        stats: FaceWeights::new(model.face_count()),
        model,
        optim,
    };
    let depth_weight = s.point_depth_weight_for(data.kind);
    let depth_supervised = depth_weight > 0.0 && !data.depth_points.is_empty();
    let smoothness_weight = s.depth_smoothness_weight_for(data.kind);
    let normal_agreement_weight = s.normal_agreement_weight_for(data.kind);
    let mut notes = vec![format!(
        "vertex learning rate {:.2e} → {:.2e} ({:.1} mm per pixel at the initial surface)",
        s.lr_vertices_start,
        s.lr_vertices_end,
        footprint / settings.world_scale * 1e3
    )];
    if depth_supervised {
        notes.push(format!(
            "depth loss at {} measured points, weight {depth_weight}",
            data.depth_points.len()
        ));
    }
    if smoothness_weight > 0.0 {
        notes.push(format!(
            "planarity prior on the rendered depth, weight {smoothness_weight}"
        ));
    }
    if normal_agreement_weight > 0.0 {
        notes.push(format!(
            "normal agreement of faces sharing an edge, weight {normal_agreement_weight}"
        ));
    }
    if (s.connectivity_at + 1..=s.surface_until).any(|it| s.surface_at(data.kind, it)) {
        notes.push(format!(
            "surface filter after the connectivity step until iteration {} (crease at |cos| {})",
            s.surface_until, s.surface_crease_cos
        ));
    }
    // The returned model is reported on the held-out test views, whichever views chose it.
    let report_views = evaluation_views(data);
    let supersample = s.supersample_for(data.kind);
    notes.push(match supersample {
        1 => "one sample per pixel".to_string(),
        n => format!("{n}×{n} samples per pixel"),
    });
    // On a wgpu backend the iterations run on the device; everything else
    // (schedule, edits, checkpoints) stays here.
    let mut runner: Box<dyn StepRunner> = match backend
        .as_any()
        .and_then(|b| b.downcast_ref::<WgpuBackend>())
    {
        Some(gpu) => {
            if normal_agreement_weight > 0.0 {
                bail!(
                    "the normal-agreement prior (normal_agreement_weight, \
                     object_normal_agreement_weight) runs on the host only: set it to 0 or \
                     train with the cpu backend"
                );
            }
            let mut scored = held_out.clone();
            scored.extend(report_views.iter().filter(|v| !held_out.contains(v)));
            Box::new(DeviceSteps::new(
                gpu,
                data,
                &train,
                &scored,
                settings.crop,
                depth_supervised,
                supersample,
                settings.world_scale,
            )?)
        }
        None => Box::new(HostSteps::new(
            backend,
            data,
            settings.crop,
            depth_supervised,
            supersample,
        )?),
    };
    let mut rng = Pcg64Mcg::seed_from_u64(settings.seed ^ 0x9e37_79b9_7f4a_7c15);
    let mut order = ViewOrder::new(train.len());
    // What a saved state must belong to for this run to continue from it.
    let identity = format!(
        "{}|{:?}|{}|{}|{:?}|{:?}|{}|{}",
        data.name,
        data.kind,
        settings.seed,
        serde_json::to_string(s)?,
        settings.checkpoint,
        settings.select_on,
        settings.background_randomization,
        data.views.len()
    );
    // The free-space rule, over the measured points each training view sees.
    let free_space = depth_supervised && s.free_space_min_sightings > 0;
    let in_front_of_others = if free_space && s.free_space_other_components == 1 {
        PointDepth::on_other_components(&data.other_points, data)
    } else {
        PointDepth::default()
    };
    let floating = |model: &Model<f32>, points: &PointDepth| -> Option<Vec<bool>> {
        if !free_space {
            return None;
        }
        let views: Vec<_> = train
            .iter()
            .map(|&v| Seen {
                camera: &data.views[v].camera,
                own: points.of_view(v),
                others: in_front_of_others.of_view(v),
            })
            .collect();
        let min = u32::try_from(s.free_space_min_sightings).unwrap_or(u32::MAX);
        Some(
            sightings(model, &views, settings.world_scale, settings.threads)
                .iter()
                .map(|s| s.floats(min))
                .collect(),
        )
    };
    let mut best: Option<Snapshot> = None;
    let started = Instant::now();
    // Evaluations before the connectivity step could never be returned (it resets the best).
    let eval_from = if s.connectivity_at < s.iterations {
        s.connectivity_at
    } else {
        0
    };
    // About 200 loss points per run, whatever the budget.
    let log_every = (s.iterations / 200).max(1);
    let mut log = LossLog::new(Vec::new(), Vec::new());
    let mut evals = Vec::new();
    let mut eval_times = Vec::new();
    let mut stopped_early = false;
    let mut finish: Option<Finish> = None;
    let mut cleanup_pending = false;
    let mut it = 0;
    let mut resumed = false;
    let mut elapsed_before = 0.0;
    if let Some(dir) = &settings.resume_dir
        && let Some(saved) = TrainerState::load(dir, &identity, &state.optim.adam)
            .with_context(|| format!("reading the saved training state in {}", dir.display()))?
    {
        let p = saved.progress;
        state.model = saved.model;
        state.optim.adam = saved.adam;
        state.stats = saved.stats;
        rng = p.rng;
        order = ViewOrder {
            order: p.order,
            next: p.order_next,
        };
        best = match (p.best, saved.best) {
            (Some((score, iteration, _)), Some((model, face_weights))) => Some(Snapshot {
                score,
                iteration,
                model,
                face_weights,
            }),
            _ => None,
        };
        log = LossLog::new(p.steps, p.times.steps);
        (evals, eval_times, notes) = (p.evals, p.times.evals, p.notes);
        cleanup_pending = p.cleanup_pending;
        (finish, stopped_early) = (p.finish, p.stopped_early);
        elapsed_before = p.times.seconds;
        runner.set_rendered(p.rendered);
        it = p.iteration;
        notes.push(format!("resumed at iteration {it} from a saved state"));
        resumed = true;
    }
    let clock = |started: &Instant| elapsed_before + started.elapsed().as_secs_f64();
    let surface_filter = SurfaceFilter {
        crease_cos: s.surface_crease_cos,
        normal_rounds: s.surface_normal_rounds as usize,
        vertex_rounds: s.surface_vertex_rounds as usize,
    };
    let mut surface_scratch = SurfaceScratch::default();
    let (mut surface_passes, mut surface_largest_move, mut surface_limited) = (0u64, 0.0f64, 0);
    let mut last_save = Instant::now();
    let mut threads = settings.threads;
    while it < finish.map_or(s.iterations, |f| f.until) {
        if let Some(budget) = &settings.thread_budget {
            let now = budget.load(Ordering::Relaxed).max(1);
            if now != threads {
                threads = now;
                runner.set_threads(now);
            }
        }
        // Where the schedule stands: the loop's iteration, or within a finish
        // the compressed rest of the schedule, whose structural edits are over.
        let at = finish.map_or(it, |f| f.schedule_iteration(it, s.iterations));
        let connect = finish.is_none() && it == s.connectivity_at && state.model.face_count() > 0;
        let floor = match finish {
            None => s.floor_update(it),
            Some(f) => f
                .floor_due(it, s.floor_every)
                .then(|| s.floor_at(at))
                .filter(|&m| m > state.model.opacity_floor),
        };
        let prune = s.prune_at(it).filter(|_| finish.is_none());
        let densify =
            finish.is_none() && s.densify_at(it) && state.model.vertex_count() < s.max_vertices;
        let surface = finish.is_none() && s.surface_at(data.kind, it);
        if connect || floor.is_some() || prune.is_some() || densify || surface {
            runner.sync(&mut state)?;
            runner.edited();
        }
        let TrainingState {
            model,
            optim,
            stats,
        } = &mut state;
        if connect {
            let faces = restricted_delaunay(
                &model.vertices,
                &model.faces,
                ConnectivityOptions {
                    include_hull_faces: true,
                    seed: settings.seed,
                },
            )?;
            if faces.is_empty() {
                // Too few vertices (a very short run, a tiny component): an empty
                // model helps no one, so the triangle soup trains on.
                notes.push(format!(
                    "connectivity step at {it} skipped: the restricted Delaunay mesh of {} vertices has no faces",
                    model.vertex_count()
                ));
            } else {
                model.faces = faces;
                let order = spatial_order(model)?;
                optim.follow_order(&order)?;
                stats.reset(model.face_count());
                cleanup_pending = true;
                notes.push(format!(
                    "connectivity step at {it}: {} faces",
                    model.face_count()
                ));
                // Scores before the connected mesh are not comparable: start over.
                best = None;
            }
        }
        if surface {
            let moved = surface_filter.apply(
                &mut model.vertices,
                &model.faces,
                threads,
                &mut surface_scratch,
            );
            surface_passes += 1;
            surface_largest_move = surface_largest_move.max(moved.largest_move);
            surface_limited += moved.limited;
        }
        if let Some(m) = floor {
            model.set_opacity_floor(m)?;
        }
        model.sigma = s.sigma(at);
        model.sh_degree = s.sh_degree(at);
        if prune.is_some() || densify {
            let render = render_settings(model, settings);
            // The running maxima cover the last one to two epochs. When prunes come
            // more often than an epoch they would keep faces a fresh render no longer
            // shows (300 iterations on 42 views at 320×240: 1.2 M faces at the
            // connectivity step instead of 27 k), so then the views are rendered.
            let stats_recent = prune.is_none() || s.prune_every as usize >= train.len();
            let mut max_weight = if stats.complete() && stats_recent {
                stats.max_weight()
            } else {
                runner.face_max_weight(Subject::Other(model), &train, &render)?
            };
            let mut sizes = screen_sizes(model, &train_cameras, threads);
            if let Some(threshold) = prune {
                let floats = floating(model, runner.seen_points());
                let keep: Vec<bool> = (0..model.face_count())
                    .map(|f| {
                        model.face_opacity(f) as f64 > threshold
                            && max_weight[f] as f64 > threshold
                            && sizes.extent[f] <= s.prune_max_screen_extent
                            && !floats.as_ref().is_some_and(|fl| fl[f])
                    })
                    .collect();
                // Never prune the model away entirely; the held-out score decides what survives.
                if keep.iter().any(|&k| k) {
                    let edit = prune_faces(model, &keep)?;
                    optim.follow_rows(&edit.keep, edit.appended)?;
                    stats.follow(&edit);
                    sizes.inradius = edit
                        .face_origin
                        .iter()
                        .map(|&f| sizes.inradius[f as usize])
                        .collect();
                    max_weight = edit
                        .face_origin
                        .iter()
                        .map(|&f| max_weight[f as usize])
                        .collect();
                }
            }
            if densify {
                let policy = DensifyPolicy {
                    count: s.densify_count(model.face_count()),
                    min_area: s.densify_min_area * settings.world_scale * settings.world_scale,
                    always_largest: s.densify_always_largest,
                };
                let splittable: Vec<bool> = sizes
                    .inradius
                    .iter()
                    // The guard is in rendered samples, where the renderer culls.
                    .map(|&r| r * supersample as f64 >= s.densify_min_inradius)
                    .collect();
                let chosen =
                    select_faces_to_split(model, &max_weight, Some(&splittable), policy, &mut rng)?;
                let edit = subdivide_faces(model, &chosen)?;
                optim.follow_rows(&edit.keep, edit.appended)?;
                stats.follow(&edit);
            }
        }
        optim.adam.set_lr(optim.vertices, s.lr_vertices(at))?;

        let (slot, new_epoch) = order.next(&mut rng);
        if new_epoch && it > 0 {
            state.stats.end_epoch();
            runner.end_epoch();
            // The first complete statistics of the connected mesh: drop what never shows.
            if cleanup_pending && state.stats.complete() && s.connectivity_cleanup_threshold > 0.0 {
                cleanup_pending = false;
                runner.sync(&mut state)?;
                let TrainingState {
                    model,
                    optim,
                    stats,
                } = &mut state;
                let keep: Vec<bool> = stats
                    .max_weight()
                    .iter()
                    .map(|&w| w as f64 > s.connectivity_cleanup_threshold)
                    .collect();
                let removed = keep.iter().filter(|k| !**k).count();
                if removed > 0 && removed < keep.len() {
                    let edit = prune_faces(model, &keep)?;
                    optim.follow_rows(&edit.keep, edit.appended)?;
                    stats.follow(&edit);
                    runner.edited();
                    notes.push(format!(
                        "cleanup at {it}: {removed} faces never above weight {} removed, {} remain",
                        s.connectivity_cleanup_threshold,
                        model.face_count()
                    ));
                }
            }
        }
        let background = if settings.background_randomization {
            [
                rng.random::<f32>(),
                rng.random::<f32>(),
                rng.random::<f32>(),
            ]
        } else {
            settings.fixed_background
        };
        let view = train[slot];
        let input = StepInput {
            view,
            background,
            render: render_settings(&state.model, settings),
            point_depth_weight: if at >= s.point_depth_start {
                depth_weight
            } else {
                0.0
            },
            // Not while the cleanup after the connectivity step is pending: the
            // prior would decide which faces never show (at 320×240 the cleanup
            // then took upper walls with it; −2.5 dB).
            smoothness_weight: if at >= s.depth_smoothness_start
                && !(cleanup_pending && s.connectivity_cleanup_threshold > 0.0)
            {
                smoothness_weight
            } else {
                0.0
            },
            // Before the connectivity step the faces share no edges.
            normal_agreement_weight: if at >= s.connectivity_at {
                normal_agreement_weight
            } else {
                0.0
            },
        };
        runner.step(&mut state, it + 1, &input)?;
        it += 1;
        let arrived = runner.losses(false)?;
        let step_loss = arrived.last().filter(|l| l.iteration == it).map(|l| l.loss);
        log.arrive(arrived);
        if it % log_every == 0 || it == s.iterations || finish.is_some_and(|f| it == f.until) {
            log.point(it, clock(&started), state.model.face_count());
        }
        if hook.wants_model() {
            runner.sync(&mut state)?;
        }
        let shown = Step {
            iteration: it,
            total: finish.map_or(s.iterations, |f| f.until.max(s.iterations)),
            view: Some(view),
            loss: step_loss,
            model: (hook.wants_model() || runner.model_is_current()).then_some(&state.model),
        };
        if !hook.after_step(&shown) {
            bail!(
                "training of {:?} was interrupted at iteration {it}",
                data.name
            );
        }

        let selectable = finish.is_none()
            && settings.checkpoint == Checkpoint::Best
            && it > eval_from
            && it % s.eval_every == 0;
        if selectable || (finish.is_none() && it == s.iterations) {
            let render = render_settings(&state.model, settings);
            let score = runner.evaluate(Subject::Training(&state), &held_out, &render)?;
            eval_times.push((it, clock(&started)));
            evals.push(EvalRecord {
                iteration: it,
                loss: score.loss,
                psnr: score.psnr,
                faces: state.model.face_count(),
            });
            if best.as_ref().is_none_or(|b| score.loss < b.score) {
                runner.sync(&mut state)?;
                best = Some(Snapshot {
                    score: score.loss,
                    iteration: it,
                    model: state.model.clone(),
                    face_weights: state.stats.complete().then(|| state.stats.max_weight()),
                });
            }
            if let Some(Snapshot {
                iteration: best_it, ..
            }) = &best
                && settings.checkpoint == Checkpoint::Best
                && it > s.connectivity_at
                && it - best_it >= s.patience
                && it < s.iterations
            {
                notes.push(format!(
                    "early stop at {it}: no held-out improvement since {best_it}"
                ));
                stopped_early = true;
            }
            // The model to return is from before the schedule's end: finish it.
            let returned_early = best
                .as_ref()
                .is_some_and(|b| b.iteration < s.iterations && b.iteration < it);
            if settings.checkpoint == Checkpoint::Best
                && (stopped_early || it == s.iterations)
                && returned_early
                && let Some(b) = best.take()
            {
                runner.sync(&mut state)?;
                let f = Finish {
                    from: it,
                    until: it + s.finish_iterations,
                    model_from: b.iteration,
                };
                notes.push(format!(
                    "finished the model of iteration {}: the rest of the schedule over iterations {}–{}, its end values to {}",
                    b.iteration,
                    f.from + 1,
                    f.from + (f.until - f.from) / 2,
                    f.until
                ));
                // At the budget's end the last state is finished too (σ and floor at
                // their end values): it stays a candidate, held where the best was.
                let last = (it == s.iterations).then(|| Snapshot {
                    score: score.loss,
                    iteration: it,
                    model: state.model.clone(),
                    face_weights: state.stats.complete().then(|| state.stats.max_weight()),
                });
                state = TrainingState {
                    stats: FaceWeights::new(b.model.face_count()),
                    optim: Optim::new(s.learning_rates(b.iteration), b.model.vertex_count())?,
                    model: b.model,
                };
                runner.edited();
                cleanup_pending = false;
                finish = Some(f);
                best = last;
            }
        }
        // Save at loss-log points, where no loss is pending anywhere.
        if let Some(dir) = &settings.resume_dir
            && it % log_every == 0
            && it < finish.map_or(s.iterations, |f| f.until)
            && last_save.elapsed().as_secs_f64() >= settings.save_seconds
        {
            runner.sync(&mut state)?;
            log.arrive(runner.losses(true)?);
            TrainerState {
                progress: Progress {
                    identity: identity.clone(),
                    iteration: it,
                    rng: rng.clone(),
                    order: order.order.clone(),
                    order_next: order.next,
                    stats_epochs: state.stats.epochs(),
                    best: best
                        .as_ref()
                        .map(|b| (b.score, b.iteration, b.face_weights.is_some())),
                    steps: log.records.clone(),
                    evals: evals.clone(),
                    times: TrainingTimes {
                        iterations: it,
                        seconds: clock(&started),
                        steps: log.times.clone(),
                        evals: eval_times.clone(),
                    },
                    notes: notes.clone(),
                    cleanup_pending,
                    finish,
                    stopped_early,
                    adam: state
                        .optim
                        .adam
                        .groups
                        .iter()
                        .map(|g| (g.lr, g.lr_rest, g.split, g.steps))
                        .collect(),
                    rendered: runner.rendered(),
                },
                model: state.model.clone(),
                adam: state.optim.adam.clone(),
                stats: state.stats.clone(),
                best: best
                    .as_ref()
                    .map(|b| (b.model.clone(), b.face_weights.clone())),
            }
            .save(dir)
            .with_context(|| format!("saving the training state in {}", dir.display()))?;
            last_save = Instant::now();
        }
    }
    if surface_passes > 0 {
        let since = if resumed { " since the resume" } else { "" };
        notes.push(format!(
            "surface filter: {surface_passes} passes{since}, the largest vertex move {surface_largest_move:.3e} (world units), {surface_limited} moves limited to half the vertex's shortest edge"
        ));
    }
    runner.sync(&mut state)?;
    log.arrive(runner.losses(true)?);
    let current_weights = state.stats.complete().then(|| state.stats.max_weight());
    // A finish that started at the budget's end competes with the last state, which the
    // schedule finished itself: the returned model is the finished one the held-out
    // views prefer. At 320×240 a background whose best came 50 iterations before the
    // end lost 1.3 dB to its finish (docs/benchmarks.md, "Flat colours for a mesh export").
    let finish = match (finish, &best) {
        (Some(f), Some(last)) => {
            let render = render_settings(&state.model, settings);
            let finished = runner.evaluate(Subject::Training(&state), &held_out, &render)?;
            if last.score <= finished.loss {
                notes.push(format!(
                    "kept the last state (iteration {}, held-out loss {:.5}) over the finished model of iteration {} ({:.5})",
                    last.iteration, last.score, f.model_from, finished.loss
                ));
                None
            } else {
                notes.push(format!(
                    "the finished model of iteration {} (held-out loss {:.5}) beat the last state ({:.5})",
                    f.model_from, finished.loss, last.score
                ));
                best = None;
                Some(f)
            }
        }
        (finish, _) => finish,
    };
    let (best_iteration, mut model, weights) = match (finish, best, settings.checkpoint) {
        (Some(f), _, _) => (f.model_from, state.model, current_weights),
        (None, Some(b), Checkpoint::Best) => (b.iteration, b.model, b.face_weights),
        (None, Some(b), Checkpoint::Last) => (b.iteration, state.model, current_weights),
        (None, None, _) => (it, state.model, current_weights),
    };
    // What the schedule's end leaves, exactly: the σ and floor every export draws with.
    model.sigma = s.sigma_end;
    if model.opacity_floor < s.floor_end() {
        notes.push(format!(
            "opacity floor raised from {:.4} to its end value {:.4} (the schedule ended below it)",
            model.opacity_floor,
            s.floor_end()
        ));
        model.set_opacity_floor(s.floor_end())?;
    }
    // Final prune: faces that never reach a blending weight above the threshold in any training view.
    let max_weight = match weights {
        Some(w) => w,
        None => runner.face_max_weight(
            Subject::Other(&model),
            &train,
            &render_settings(&model, settings),
        )?,
    };
    // Free space is left to the prunes during training: a face removed here leaves a
    // hole nothing refills, and on structure from motion's points these removals cost
    // 0.8 dB (docs/benchmarks.md, "Structure from motion").
    let keep: Vec<bool> = max_weight
        .iter()
        .map(|&w| w as f64 > s.final_prune_threshold)
        .collect();
    let removed = keep.iter().filter(|k| !**k).count();
    if removed == keep.len() {
        // Short runs end before opacities saturate; an empty model helps no one.
        notes.push(format!(
            "final prune skipped: no face reaches a blending weight above {}",
            s.final_prune_threshold
        ));
    } else {
        prune_faces(&mut model, &keep)?;
        notes.push(format!(
            "final prune removed {removed} faces, {} remain",
            model.face_count()
        ));
    }
    let render = render_settings(&model, settings);
    // The flat colours a mesh export draws (flat_color.rs), over the views that trained it.
    let mut flat = FlatColors::new(&model);
    for &view in &train {
        let face_weight = runner.face_max_weight(Subject::Other(&model), &[view], &render)?;
        flat.add(&Sighting {
            camera: &data.views[view].camera,
            face_weight: &face_weight,
        })?;
    }
    model.flat_dc = flat.finish();
    let fit = FlatFit {
        epochs: s.flat_fit_epochs,
        lr: s.flat_fit_lr,
        seed: settings.seed,
        randomize_background: settings.background_randomization,
        fixed_background: settings.fixed_background,
    };
    if let Some(r) = fit.apply(runner.as_mut(), &mut model, &train, settings.world_scale)? {
        notes.push(format!(
            "flat colours fitted as exported over {} steps: training loss {:.5} → {:.5} (first and last pass)",
            r.steps, r.first_pass_loss, r.last_pass_loss
        ));
    }
    let final_score = runner.evaluate(Subject::Other(&model), &report_views, &render)?;
    notes.extend(runner.summary());
    let times = TrainingTimes {
        iterations: it,
        seconds: clock(&started),
        steps: log.times,
        evals: eval_times,
    };
    let log = TrainingLog {
        component: data.name.clone(),
        kind: match data.kind {
            ComponentKind::Object => "object",
            ComponentKind::Background => "background",
        }
        .into(),
        backend: backend.name().into(),
        seed: settings.seed,
        background_randomization: settings.background_randomization,
        iterations_budget: s.iterations,
        iterations_run: it,
        best_iteration,
        checkpoint: match settings.checkpoint {
            Checkpoint::Best => "best",
            Checkpoint::Last => "last",
        }
        .into(),
        stopped_early,
        finished_from: finish.map(|f| f.from),
        final_psnr: final_score.psnr,
        final_faces: model.face_count(),
        rendered_fraction: runner.rendered_fraction(),
        scored_on: Some(scored_on.to_string()),
        steps: log.records,
        evals,
        notes: notes.clone(),
    };
    Ok(TrainReport {
        model,
        iterations_run: it,
        best_iteration,
        best_score: final_score.loss,
        notes,
        log,
        times,
        steps_ran_on: runner.place(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use objectsplat_core::{Camera, ComponentKind};

    /// Views named by index, split as given.
    fn data(splits: &[Split]) -> ComponentData {
        let camera = Camera::look_at(
            4,
            4,
            4.0,
            4.0,
            glam::DVec3::new(0.0, 0.0, -1.0),
            glam::DVec3::ZERO,
            glam::DVec3::Y,
        );
        ComponentData {
            name: "c".into(),
            kind: ComponentKind::Object,
            views: splits
                .iter()
                .enumerate()
                .map(|(k, &split)| {
                    View::from_planes(&format!("v{k}"), camera, &[0.0; 48], &[0; 16], split)
                        .unwrap()
                })
                .collect(),
            occluders: None,
            depth_points: Vec::new(),
            other_points: Vec::new(),
        }
    }

    #[test]
    fn validation_holds_out_every_eighth_training_view() {
        // 17 training views with a test view at index 3.
        let mut splits = vec![Split::Train; 18];
        splits[3] = Split::Test;
        let roles = view_roles(&data(&splits), Checkpoint::Best, SelectOn::Validation);
        let train: Vec<usize> = (0..18).filter(|&i| i != 3).collect();
        // Positions 7 and 15 among the training views: views 8 and 16.
        assert_eq!(roles.scored, vec![8, 16]);
        assert_eq!(roles.scored_on, "validation");
        let kept: Vec<usize> = train.into_iter().filter(|v| ![8, 16].contains(v)).collect();
        assert_eq!(roles.train, kept);
        // `last` trains on every training view and reports on the test views.
        let last = view_roles(&data(&splits), Checkpoint::Last, SelectOn::Validation);
        assert_eq!(last.scored, vec![3]);
        assert_eq!(last.train.len(), 17);
    }
}
