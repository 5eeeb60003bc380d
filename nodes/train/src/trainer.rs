//! The training loop for one component (an object or the background).
//!
//! Each step renders one random training view. Object components keep their
//! own pixels and supervise every OTHER pixel toward the background colour,
//! drawn uniformly at random every iteration when background randomization is
//! on; the background component gives OTHER pixels zero weight; IGNORE pixels
//! are never supervised. The schedule drives σ, the SH degree, the opacity
//! floor, densification, pruning and the connectivity step; the best model on
//! the held-out views is kept and training stops early after `patience`.
//!
//! On a wgpu backend the iterations themselves (render, loss, backward, Adam)
//! run on the device (`device_steps.rs`); the model comes back to the host
//! for evaluation and for the schedule's structural edits.

use crate::adam::Adam;
use crate::connectivity::{ConnectivityOptions, restricted_delaunay};
use crate::densify::{
    DensifyPolicy, VertexEdit, prune_faces, select_faces_to_split, subdivide_faces,
};
use crate::device_steps::DeviceSteps;
use crate::init::{ComponentMasks, InitSettings, init_model};
use crate::schedule::Schedule;
use anyhow::{Context, Result, bail};
use objectsplat_core::component::{IGNORE, OTHER, OWN};
use objectsplat_core::{Camera, ComponentKind, Image, Points, Split};
use objectsplat_raster::loss::{DEFAULT_LAMBDA_DSSIM, Dims, photometric};
use objectsplat_raster::model::SH_COEFFS;
use objectsplat_raster::{
    EvalRecord, Model, OutputGrads, RenderBackend, RenderSettings, StepRecord, TrainingLog,
};
use objectsplat_wgpu::WgpuBackend;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use std::path::Path;
use std::time::Instant;

/// One supervised view of a component.
pub struct View {
    pub name: String,
    pub camera: Camera,
    /// Target colours, H×W×3 (the frame image, or the component's replacement targets).
    pub target: Vec<f32>,
    /// Per-pixel ownership label (OWN / OTHER / IGNORE).
    pub labels: Vec<u8>,
    pub split: Split,
}

/// What a component is trained on.
pub struct ComponentData {
    pub name: String,
    pub kind: ComponentKind,
    pub views: Vec<View>,
}

impl ComponentData {
    /// Reads a Component folder: frames, images, masks and optional replacement targets.
    pub fn read(dir: &Path) -> Result<ComponentData> {
        let masks = ComponentMasks::read(dir)?;
        let mut views = Vec::new();
        for (frame, labels) in masks.frames.frames.iter().zip(&masks.masks) {
            let mut target = masks.frames.load_rgb(frame)?.data;
            let stem = objectsplat_core::frames::frame_stem(&frame.name);
            let replacement = dir.join("targets").join(format!("{stem}.png"));
            if replacement.exists() {
                let img = Image::load(&replacement)?.to_rgb();
                if img.width != frame.width || img.height != frame.height {
                    bail!(
                        "{}: target is {}×{} but the frame is {}×{}",
                        replacement.display(),
                        img.width,
                        img.height,
                        frame.width,
                        frame.height
                    );
                }
                for (p, &l) in labels.iter().enumerate() {
                    if l == OWN {
                        target[3 * p..3 * p + 3].copy_from_slice(&img.data[3 * p..3 * p + 3]);
                    }
                }
            }
            if let Some(i) = target.iter().position(|v| !v.is_finite()) {
                bail!("frame {:?}: target value {i} is not finite", frame.name);
            }
            views.push(View {
                name: frame.name.clone(),
                camera: frame.camera(),
                target,
                labels: labels.clone(),
                split: frame.split,
            });
        }
        Ok(ComponentData {
            name: masks.info.name.clone(),
            kind: masks.info.kind,
            views,
        })
    }
}

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

/// Pixel weights and targets of one view under background colour `b`.
pub fn supervision(view: &View, kind: ComponentKind, b: [f32; 3]) -> (Vec<f32>, Vec<f32>) {
    let (mut target, weights, from_background) = supervision_parts(view, kind);
    for p in (0..weights.len()).filter(|&p| from_background[p]) {
        target[3 * p..3 * p + 3].copy_from_slice(&b);
    }
    (target, weights)
}

/// The parts of [`supervision`] that do not depend on the background colour:
/// targets, weights, and which pixels take the background colour as target.
pub(crate) fn supervision_parts(
    view: &View,
    kind: ComponentKind,
) -> (Vec<f32>, Vec<f32>, Vec<bool>) {
    let mut from_background = vec![false; view.labels.len()];
    let weights = view
        .labels
        .iter()
        .enumerate()
        .map(|(p, &l)| match (l, kind) {
            (OWN, _) => 1.0,
            (OTHER, ComponentKind::Object) => {
                from_background[p] = true;
                1.0
            }
            (IGNORE, _) | (OTHER, ComponentKind::Background) => 0.0,
            // Any other grey value is an unowned pixel: treated as not supervised.
            _ => 0.0,
        })
        .collect();
    (view.target.clone(), weights, from_background)
}

/// Adam over the model's parameter groups.
pub(crate) struct Optim {
    pub adam: Adam,
    pub vertices: usize,
    pub sh_dc: usize,
    pub sh_rest: usize,
    pub opacity: usize,
}

impl Optim {
    fn new(schedule: &Schedule, rows: usize) -> Optim {
        let mut adam = Adam::new();
        let vertices = adam.add_group("vertices", schedule.lr_vertices_start, 3, rows);
        let sh_dc = adam.add_group("sh_dc", schedule.lr_sh_dc, 3, rows);
        let sh_rest = adam.add_group(
            "sh_rest",
            schedule.lr_sh_dc / schedule.sh_rest_lr_divisor,
            3 * (SH_COEFFS - 1),
            rows,
        );
        let opacity = adam.add_group("opacity", schedule.lr_opacity, 1, rows);
        Optim {
            adam,
            vertices,
            sh_dc,
            sh_rest,
            opacity,
        }
    }

    fn apply_edit(&mut self, edit: &VertexEdit) -> Result<()> {
        self.adam.retain_rows(&edit.keep)?;
        self.adam.append_rows(edit.appended);
        Ok(())
    }

    fn step(
        &mut self,
        model: &mut Model<f32>,
        grads: &objectsplat_raster::ModelGrads<f32>,
    ) -> Result<()> {
        let mut pos: Vec<f32> = model.vertices.iter().flatten().copied().collect();
        let g: Vec<f32> = grads.vertices.iter().flatten().copied().collect();
        self.adam.step(self.vertices, &mut pos, &g)?;
        for (v, p) in model.vertices.iter_mut().zip(pos.chunks_exact(3)) {
            v.copy_from_slice(p);
        }
        let mut dc: Vec<f32> = model.sh.iter().flat_map(|s| s[0]).collect();
        let gdc: Vec<f32> = grads.sh.iter().flat_map(|s| s[0]).collect();
        self.adam.step(self.sh_dc, &mut dc, &gdc)?;
        let mut rest: Vec<f32> = model
            .sh
            .iter()
            .flat_map(|s| s[1..].iter().flatten().copied())
            .collect();
        let grest: Vec<f32> = grads
            .sh
            .iter()
            .flat_map(|s| s[1..].iter().flatten().copied())
            .collect();
        self.adam.step(self.sh_rest, &mut rest, &grest)?;
        for (v, s) in model.sh.iter_mut().enumerate() {
            s[0].copy_from_slice(&dc[3 * v..3 * v + 3]);
            for k in 1..SH_COEFFS {
                let o = v * 3 * (SH_COEFFS - 1) + 3 * (k - 1);
                s[k].copy_from_slice(&rest[o..o + 3]);
            }
        }
        self.adam.step(
            self.opacity,
            &mut model.opacity_logits,
            &grads.opacity_logits,
        )
    }
}

fn render_settings(model: &Model<f32>, settings: &TrainSettings) -> RenderSettings {
    RenderSettings::for_model(model).with_world_scale(settings.world_scale)
}

/// A model's quality on a component's held-out views.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeldOut {
    /// Mean weighted photometric loss (`0.8·L1 + 0.2·D-SSIM`); selects the checkpoint.
    pub loss: f64,
    /// PSNR (dB) over every supervised pixel of those views (one pooled MSE).
    pub psnr: f64,
}

/// The held-out views of a component (its training views when none is held out).
fn evaluation_views(data: &ComponentData) -> Vec<&View> {
    let test: Vec<&View> = data
        .views
        .iter()
        .filter(|v| v.split == Split::Test)
        .collect();
    if test.is_empty() {
        data.views
            .iter()
            .filter(|v| v.split == Split::Train)
            .collect()
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
    let views = evaluation_views(data);
    let (mut loss, mut squared_error, mut weight) = (0.0, 0.0, 0.0);
    for view in &views {
        let pixels = view.labels.len();
        let bg = vec![0.0f32; 3 * pixels];
        let (out, _) =
            backend.forward(model, &view.camera, &render_settings(model, settings), &bg)?;
        let (target, weights) = supervision(view, data.kind, [0.0; 3]);
        let dims = Dims::rgb(view.camera.width, view.camera.height);
        loss += photometric(
            dims,
            &out.color,
            &target,
            Some(&weights),
            DEFAULT_LAMBDA_DSSIM,
        )?
        .value as f64;
        for (p, &w) in weights.iter().enumerate() {
            for c in 3 * p..3 * p + 3 {
                let d = (out.color[c] - target[c]) as f64;
                squared_error += w as f64 * d * d;
            }
            weight += 3.0 * w as f64;
        }
    }
    let mse = squared_error / weight.max(1.0);
    Ok(HeldOut {
        loss: loss / views.len().max(1) as f64,
        // A perfect fit is capped at 100 dB rather than reported as infinity.
        psnr: if mse > 1e-10 {
            -10.0 * mse.log10()
        } else {
            100.0
        },
    })
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

/// Per face, over all training views: the largest blending weight (what
/// pruning, densification and the final prune judge faces by) and the largest
/// screen extent in pixels (centroid-to-corner distance, faces in front of the camera).
struct FaceStats {
    max_weight: Vec<f32>,
    max_screen_extent: Vec<f64>,
}

fn face_stats(
    backend: &dyn RenderBackend<f32>,
    model: &Model<f32>,
    views: &[&View],
    settings: &TrainSettings,
) -> Result<FaceStats> {
    let mut stats = FaceStats {
        max_weight: vec![0.0; model.face_count()],
        max_screen_extent: vec![0.0; model.face_count()],
    };
    for view in views {
        let bg = vec![0.0f32; 3 * view.labels.len()];
        let (out, _) =
            backend.forward(model, &view.camera, &render_settings(model, settings), &bg)?;
        for (m, &w) in stats.max_weight.iter_mut().zip(&out.face_max_weight) {
            *m = m.max(w);
        }
        let projected: Vec<Option<(f64, f64, f64)>> = model
            .vertices
            .iter()
            .map(|v| {
                view.camera
                    .project(glam::DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64))
            })
            .collect();
        for (f, face) in model.faces.iter().enumerate() {
            let corners = face.map(|v| projected[v as usize]);
            let [Some(a), Some(b), Some(c)] = corners else {
                continue;
            };
            let (cx, cy) = ((a.0 + b.0 + c.0) / 3.0, (a.1 + b.1 + c.1) / 3.0);
            let extent = [a, b, c]
                .iter()
                .map(|p| (p.0 - cx).hypot(p.1 - cy))
                .fold(0.0, f64::max);
            stats.max_screen_extent[f] = stats.max_screen_extent[f].max(extent);
        }
    }
    Ok(stats)
}

/// The first parameter that is not finite, named for the error message.
fn first_non_finite(model: &Model<f32>) -> Option<String> {
    if let Some(v) = model
        .vertices
        .iter()
        .position(|p| !p.iter().all(|x| x.is_finite()))
    {
        return Some(format!("vertex {v} position {:?}", model.vertices[v]));
    }
    if let Some(v) = model
        .sh
        .iter()
        .position(|s| !s.iter().flatten().all(|x| x.is_finite()))
    {
        return Some(format!("vertex {v} SH coefficients"));
    }
    model
        .opacity_logits
        .iter()
        .position(|x| !x.is_finite())
        .map(|v| format!("vertex {v} opacity logit {}", model.opacity_logits[v]))
}

/// One iteration on the host: render, loss, backward, Adam. Returns the loss.
#[allow(clippy::too_many_arguments)]
fn host_step(
    backend: &dyn RenderBackend<f32>,
    model: &mut Model<f32>,
    optim: &mut Optim,
    data: &ComponentData,
    view: &View,
    b: [f32; 3],
    render: &RenderSettings,
    it: u64,
) -> Result<f32> {
    let pixels = view.labels.len();
    let bg: Vec<f32> = (0..3 * pixels).map(|i| b[i % 3]).collect();
    let (out, saved) = backend.forward(model, &view.camera, render, &bg)?;
    if !out.all_finite() {
        bail!(
            "training of {:?} diverged at iteration {}: the render of view {:?} is not \
             finite (parameters overflowed; lower the learning rates)",
            data.name,
            it + 1,
            view.name
        );
    }
    let (target, weights) = supervision(view, data.kind, b);
    let dims = Dims::rgb(view.camera.width, view.camera.height);
    let loss = photometric(
        dims,
        &out.color,
        &target,
        Some(&weights),
        DEFAULT_LAMBDA_DSSIM,
    )?;
    if !loss.value.is_finite() || loss.grad.iter().any(|g| !g.is_finite()) {
        bail!(
            "training of {:?} diverged at iteration {}: the loss on view {:?} is not \
             finite (parameters overflowed; lower the learning rates)",
            data.name,
            it + 1,
            view.name
        );
    }
    let grads = backend.backward(model, &saved, &OutputGrads::color_only(&loss.grad))?;
    optim.step(model, &grads)?;
    // Cheap next to a render, so checked in every build, not only debug ones.
    if let Some(what) = first_non_finite(model) {
        bail!(
            "training of {:?} diverged at iteration {}: {what} is not finite \
             (view {:?}, loss {})",
            data.name,
            it + 1,
            view.name,
            loss.value
        );
    }
    Ok(loss.value)
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
    let mut model = init_model(
        points,
        &InitSettings {
            seed: settings.seed,
            ..settings.init
        },
    )
    .with_context(|| format!("initializing component {:?}", data.name))?;
    let mut optim = Optim::new(s, model.vertex_count());
    // On a wgpu backend the iterations run on the device; everything else stays here.
    let mut device = match backend
        .as_any()
        .and_then(|b| b.downcast_ref::<WgpuBackend>())
    {
        Some(gpu) => Some(DeviceSteps::new(gpu, data, &train, &optim)?),
        None => None,
    };
    let mut rng = Pcg64Mcg::seed_from_u64(settings.seed ^ 0x9e37_79b9_7f4a_7c15);
    let train_views: Vec<&View> = train.iter().map(|&i| &data.views[i]).collect();
    let mut best: Option<(f64, u64, Model<f32>)> = None;
    let mut notes = Vec::new();
    let started = Instant::now();
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
        if let Some(threshold) = s.prune_at(it) {
            let stats = face_stats(backend, &model, &train_views, settings)?;
            let keep: Vec<bool> = (0..model.face_count())
                .map(|f| {
                    model.face_opacity(f) as f64 > threshold
                        && stats.max_weight[f] as f64 > threshold
                        && stats.max_screen_extent[f] <= s.prune_max_screen_extent
                })
                .collect();
            // Never prune the model away entirely; the held-out score decides what survives.
            if keep.iter().any(|&k| k) {
                let edit = prune_faces(&mut model, &keep)?;
                optim.apply_edit(&edit)?;
            }
        }
        if s.densify_at(it) && model.vertex_count() < s.max_vertices {
            let policy = DensifyPolicy {
                count: s.densify_count(model.face_count()),
                min_area: s.densify_min_area * settings.world_scale * settings.world_scale,
                always_largest: s.densify_always_largest,
            };
            let stats = face_stats(backend, &model, &train_views, settings)?;
            let chosen = select_faces_to_split(&model, &stats.max_weight, policy, &mut rng)?;
            let edit = subdivide_faces(&mut model, &chosen)?;
            optim.apply_edit(&edit)?;
        }
        optim.adam.set_lr(optim.vertices, s.lr_vertices(it))?;

        let slot = rng.random_range(0..train.len());
        let view = &data.views[train[slot]];
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
            Some(device) => device.step(&model, &optim, it + 1, slot, b, render)?,
            None => {
                let loss = host_step(backend, &mut model, &mut optim, data, view, b, &render, it)?;
                window_loss += loss as f64;
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

        if it % s.eval_every == 0 || it == s.iterations {
            if let Some(device) = device.as_mut() {
                device.pull(&mut model, &mut optim, data)?;
            }
            let score = held_out_eval(backend, &model, data, settings)?;
            evals.push(EvalRecord {
                iteration: it,
                wall_seconds: started.elapsed().as_secs_f64(),
                loss: score.loss,
                psnr: score.psnr,
                faces: model.face_count(),
            });
            if best.as_ref().is_none_or(|(b, _, _)| score.loss < *b) {
                best = Some((score.loss, it, model.clone()));
            }
            if let Some((_, best_it, _)) = &best
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
        notes.push(device.summary());
    }
    let (best_iteration, mut model) = match (best, settings.checkpoint) {
        (Some((_, best_it, best_model)), Checkpoint::Best) => (best_it, best_model),
        (Some((_, best_it, _)), Checkpoint::Last) => (best_it, model),
        (None, _) => (it, model),
    };
    // Final prune: faces that never reach a blending weight above the threshold in any training view.
    let max_weight = face_stats(backend, &model, &train_views, settings)?.max_weight;
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
    let final_score = held_out_eval(backend, &model, data, settings)?;
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
