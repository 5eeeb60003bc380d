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

use crate::connectivity::{ConnectivityOptions, restricted_delaunay};
use crate::densify::{DensifyPolicy, prune_faces, select_faces_to_split, subdivide_faces};
use crate::device_steps::DeviceSteps;
use crate::face_stats::FaceWeights;
use crate::host_steps::HostSteps;
use crate::init::{InitSettings, init_model};
use crate::optim::Optim;
use crate::schedule::Schedule;
use anyhow::{Context, Result, bail};
use objectsplat_core::{ComponentKind, Points, Split};
use objectsplat_raster::{
    EvalRecord, Model, RenderBackend, RenderSettings, StepRecord, TrainingLog,
};
use objectsplat_wgpu::WgpuBackend;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::time::Instant;

pub use crate::host_steps::HeldOut;
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

#[derive(Debug, Clone)]
pub struct TrainSettings {
    pub schedule: Schedule,
    pub seed: u64,
    /// Draw the background colour uniformly in [0,1]³ every iteration (else `fixed_background`).
    pub background_randomization: bool,
    pub fixed_background: [f32; 3],
    pub init: InitSettings,
    /// Scales the renderer's depth thresholds for scenes not in metres.
    pub world_scale: f64,
    pub checkpoint: Checkpoint,
    /// Render and score only each view's footprint (exact; off renders whole frames).
    pub crop: bool,
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
}

fn render_settings(model: &Model<f32>, settings: &TrainSettings) -> RenderSettings {
    RenderSettings::for_model(model).with_world_scale(settings.world_scale)
}

/// The held-out views of a component (its training views when none is held out).
fn evaluation_views(data: &ComponentData) -> Vec<usize> {
    let of = |split: Split| -> Vec<usize> {
        (0..data.views.len())
            .filter(|&i| data.views[i].split == split)
            .collect()
    };
    let test = of(Split::Test);
    if test.is_empty() {
        of(Split::Train)
    } else {
        test
    }
}

/// Scores `model` on the held-out views over a black background, so stray
/// coverage of OTHER pixels costs (their target is black too).
pub fn held_out_eval(
    backend: &dyn RenderBackend<f32>,
    model: &Model<f32>,
    data: &ComponentData,
    settings: &TrainSettings,
) -> Result<HeldOut> {
    HostSteps::new(backend, data, settings.crop).evaluate(
        model,
        data,
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

/// Per face, the largest screen extent in pixels (centroid-to-corner
/// distance, faces in front of the camera) over `cameras`: projection only.
fn max_screen_extent(model: &Model<f32>, cameras: &[&objectsplat_core::Camera]) -> Vec<f64> {
    let mut extent = vec![0.0f64; model.face_count()];
    let mut projected = Vec::with_capacity(model.vertex_count());
    for camera in cameras {
        projected.clear();
        projected.extend(
            model
                .vertices
                .iter()
                .map(|v| camera.project(glam::DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64))),
        );
        for (f, face) in model.faces.iter().enumerate() {
            let [Some(a), Some(b), Some(c)] = face.map(|v| projected[v as usize]) else {
                continue;
            };
            let (cx, cy) = ((a.0 + b.0 + c.0) / 3.0, (a.1 + b.1 + c.1) / 3.0);
            let e = [a, b, c]
                .iter()
                .map(|p| (p.0 - cx).hypot(p.1 - cy))
                .fold(0.0, f64::max);
            extent[f] = extent[f].max(e);
        }
    }
    extent
}

/// The best model so far on the held-out views.
struct Snapshot {
    score: f64,
    iteration: u64,
    model: Model<f32>,
    /// Its per-face weights, when the running statistics were complete then.
    face_weights: Option<Vec<f32>>,
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

/// Trains one component from its sparse points. `progress(done, total)` returns
/// false to interrupt the run (an error).
pub fn train_component(
    backend: &dyn RenderBackend<f32>,
    data: &ComponentData,
    points: &Points,
    settings: &TrainSettings,
    mut progress: impl FnMut(u64, u64) -> bool,
) -> Result<TrainReport> {
    let s = &settings.schedule;
    s.validate()?;
    if !(settings.world_scale.is_finite() && settings.world_scale > 0.0) {
        bail!(
            "world_scale {} must be finite and positive",
            settings.world_scale
        );
    }
    let train: Vec<usize> = (0..data.views.len())
        .filter(|&i| data.views[i].split == Split::Train)
        .collect();
    if train.is_empty() {
        bail!("component {:?} has no training views", data.name);
    }
    let held_out = evaluation_views(data);
    let mut model = init_model(
        points,
        &InitSettings {
            seed: settings.seed,
            ..settings.init
        },
    )
    .with_context(|| format!("initializing component {:?}", data.name))?;
    let mut optim = Optim::new(s, model.vertex_count())?;
    // On a wgpu backend the iterations run on the device; everything else stays here.
    let mut device = match backend
        .as_any()
        .and_then(|b| b.downcast_ref::<WgpuBackend>())
    {
        Some(gpu) => Some(DeviceSteps::new(
            gpu,
            data,
            &train,
            &held_out,
            &optim,
            settings.crop,
        )?),
        None => None,
    };
    let mut host = HostSteps::new(backend, data, settings.crop);
    let mut rng = Pcg64Mcg::seed_from_u64(settings.seed ^ 0x9e37_79b9_7f4a_7c15);
    let mut order = ViewOrder::new(train.len());
    let mut stats = FaceWeights::new(model.face_count());
    let train_cameras: Vec<&objectsplat_core::Camera> =
        train.iter().map(|&i| &data.views[i].camera).collect();
    let mut best: Option<Snapshot> = None;
    let mut notes = Vec::new();
    let started = Instant::now();
    // Evaluations before the connectivity step could never be returned (it resets the best).
    let eval_from = if s.connectivity_at < s.iterations {
        s.connectivity_at
    } else {
        0
    };
    // About 200 loss points per run, whatever the budget.
    let log_every = (s.iterations / 200).max(1);
    let (mut steps, mut evals) = (Vec::new(), Vec::new());
    let mut window_loss = 0.0;
    let mut stopped_early = false;
    let mut it = 0;
    while it < s.iterations {
        let edits_model = (it == s.connectivity_at && model.face_count() > 0)
            || s.floor_update(it).is_some()
            || s.prune_at(it).is_some()
            || (s.densify_at(it) && model.vertex_count() < s.max_vertices);
        if let Some(device) = device.as_mut().filter(|_| edits_model) {
            device.pull(&mut model, &mut optim, data)?;
            if let Some((current, previous)) = device.face_weights()? {
                stats.set_arrays(current, previous);
            }
            device.host_edited();
        }
        if it == s.connectivity_at && model.face_count() > 0 {
            model.faces = restricted_delaunay(
                &model.vertices,
                &model.faces,
                ConnectivityOptions {
                    include_hull_faces: true,
                    seed: settings.seed,
                },
            )?;
            stats.reset(model.face_count());
            notes.push(format!(
                "connectivity step at {it}: {} faces",
                model.face_count()
            ));
            // Scores before the connected mesh are not comparable: start over.
            best = None;
        }
        if let Some(m) = s.floor_update(it) {
            model.set_opacity_floor(m)?;
        }
        model.sigma = s.sigma(it);
        model.sh_degree = s.sh_degree(it);
        let prune = s.prune_at(it);
        let densify = s.densify_at(it) && model.vertex_count() < s.max_vertices;
        if prune.is_some() || densify {
            let render = render_settings(&model, settings);
            let mut max_weight = if stats.complete() {
                stats.max_weight()
            } else {
                host.face_max_weight(&model, data, &train, &render)?
            };
            if let Some(threshold) = prune {
                let extent = max_screen_extent(&model, &train_cameras);
                let keep: Vec<bool> = (0..model.face_count())
                    .map(|f| {
                        model.face_opacity(f) as f64 > threshold
                            && max_weight[f] as f64 > threshold
                            && extent[f] <= s.prune_max_screen_extent
                    })
                    .collect();
                // Never prune the model away entirely; the held-out score decides what survives.
                if keep.iter().any(|&k| k) {
                    let edit = prune_faces(&mut model, &keep)?;
                    optim.apply_edit(&edit)?;
                    stats.follow(&edit);
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
                let chosen = select_faces_to_split(&model, &max_weight, policy, &mut rng)?;
                let edit = subdivide_faces(&mut model, &chosen)?;
                optim.apply_edit(&edit)?;
                stats.follow(&edit);
            }
        }
        optim.adam.set_lr(optim.vertices, s.lr_vertices(it))?;

        let (slot, new_epoch) = order.next(&mut rng);
        if new_epoch && it > 0 {
            stats.end_epoch();
            if let Some(device) = device.as_mut() {
                device.end_epoch();
            }
        }
        let b = if settings.background_randomization {
            [
                rng.random::<f32>(),
                rng.random::<f32>(),
                rng.random::<f32>(),
            ]
        } else {
            settings.fixed_background
        };
        let render = render_settings(&model, settings);
        match device.as_mut() {
            Some(device) => {
                if edits_model {
                    let (current, previous) = stats.arrays();
                    device.set_face_weights(current.to_vec(), previous.to_vec())?;
                }
                device.step(&model, &optim, it + 1, slot, b, render)?
            }
            None => {
                let view = train[slot];
                let loss = host
                    .step(&mut model, &mut optim, data, view, b, &render, &mut stats)
                    .with_context(|| {
                        format!(
                            "training of {:?} diverged at iteration {} (view {:?}; parameters \
                             overflowed, lower the learning rates)",
                            data.name,
                            it + 1,
                            data.views[view].name
                        )
                    })?;
                window_loss += loss;
            }
        }
        it += 1;
        if it % log_every == 0 || it == s.iterations {
            if let Some(device) = device.as_mut() {
                window_loss += device.losses(data)?.iter().map(|&l| l as f64).sum::<f64>();
            }
            let window = (it - 1) % log_every + 1;
            steps.push(StepRecord {
                iteration: it,
                wall_seconds: started.elapsed().as_secs_f64(),
                loss: window_loss / window as f64,
                faces: model.face_count(),
            });
            window_loss = 0.0;
        }
        if !progress(it, s.iterations) {
            bail!(
                "training of {:?} was interrupted at iteration {it}",
                data.name
            );
        }

        let selectable =
            settings.checkpoint == Checkpoint::Best && it > eval_from && it % s.eval_every == 0;
        if selectable || it == s.iterations {
            let render = render_settings(&model, settings);
            let score = match device.as_mut() {
                Some(device) => device.evaluate(&model, &optim, data, &held_out, render)?,
                None => host.evaluate(&model, data, &held_out, &render)?,
            };
            evals.push(EvalRecord {
                iteration: it,
                wall_seconds: started.elapsed().as_secs_f64(),
                loss: score.loss,
                psnr: score.psnr,
                faces: model.face_count(),
            });
            if best.as_ref().is_none_or(|b| score.loss < b.score) {
                if let Some(device) = device.as_mut() {
                    device.pull(&mut model, &mut optim, data)?;
                    if let Some((current, previous)) = device.face_weights()? {
                        stats.set_arrays(current, previous);
                    }
                }
                best = Some(Snapshot {
                    score: score.loss,
                    iteration: it,
                    model: model.clone(),
                    face_weights: stats.complete().then(|| stats.max_weight()),
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
                break;
            }
        }
    }
    if let Some(device) = device.as_mut() {
        device.pull(&mut model, &mut optim, data)?;
        if let Some((current, previous)) = device.face_weights()? {
            stats.set_arrays(current, previous);
        }
    }
    let current_weights = stats.complete().then(|| stats.max_weight());
    let (best_iteration, mut model, weights) = match (best, settings.checkpoint) {
        (Some(b), Checkpoint::Best) => (b.iteration, b.model, b.face_weights),
        (Some(b), Checkpoint::Last) => (b.iteration, model, current_weights),
        (None, _) => (it, model, current_weights),
    };
    // Final prune: faces that never reach a blending weight above the threshold in any training view.
    let max_weight = match weights {
        Some(w) => w,
        None => host.face_max_weight(&model, data, &train, &render_settings(&model, settings))?,
    };
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
    let final_score = match device.as_mut() {
        Some(device) => {
            let score = device.evaluate_model(&model, data, &held_out, render)?;
            notes.push(device.summary());
            score
        }
        None => host.evaluate(&model, data, &held_out, &render)?,
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
        wall_seconds: started.elapsed().as_secs_f64(),
        final_psnr: final_score.psnr,
        final_faces: model.face_count(),
        rendered_fraction: match &device {
            Some(device) => device.rendered_fraction(),
            None => host.rendered_fraction(),
        },
        steps,
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
    })
}
