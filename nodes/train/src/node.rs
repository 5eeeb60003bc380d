//! The `train` node: one component (fanned out over `[Component]` in graphs)
//! and the sparse points → a trained Model.

use crate::schedule::Schedule;
use crate::trainer::{Checkpoint, ComponentData, SelectOn, TrainSettings, train_component};
use anyhow::Context as _;
use anyhow::{Result, bail};
use objectsplat_core::TRAINING_TIMES;
use objectsplat_core::artifact::POINTS_PLY;
use objectsplat_core::visibility::Visibility;
use objectsplat_core::{ComponentFolder, ComponentKind, Points};
use objectsplat_raster::{Model, load_model, save_model};
use objectsplat_runtime::{
    Context, Node, NodeSpec, Outcome, ParamError, ParamType, Params, Registry, node_ports,
};
use serde_json::{Map, Number, Value};
use std::collections::BTreeMap;
use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Numbers from the graph as JSON: whole numbers as integers (iteration counts
/// are integers in the schedule), the rest as floats.
fn schedule_overrides(given: &BTreeMap<String, f64>) -> Result<Map<String, Value>> {
    let mut map = Map::new();
    for (name, &v) in given {
        if !v.is_finite() {
            bail!("schedule setting `{name}` = {v} is not finite");
        }
        let number = if v.fract() == 0.0 && v.abs() < 9.0e15 {
            Number::from(v as i64)
        } else {
            Number::from_f64(v).ok_or_else(|| anyhow::anyhow!("schedule setting `{name}` = {v}"))?
        };
        map.insert(name.clone(), Value::Number(number));
    }
    Ok(map)
}

/// The views' memory and, where the system says, the process's peak resident
/// memory so far (shared with the items running beside this one).
fn memory_note(data: &ComponentData) -> String {
    let views = format!(
        "{:.1} MB in {} views",
        data.bytes() as f64 / 1e6,
        data.views.len()
    );
    match peak_resident_bytes() {
        Some(peak) => format!("{views}; process peak {:.2} GB", peak as f64 / 1e9),
        None => views,
    }
}

/// The process's peak resident set (`VmHWM` in /proc/self/status), on Linux.
fn peak_resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

pub fn register(reg: &mut Registry) {
    let node: Arc<dyn Node> = Arc::new(TrainNode);
    // The kind is unique within this crate; a clash means another crate
    // registered `train` first, which the catalogue's tests catch.
    if let Err(e) = reg.add_node(node) {
        panic!("registering train: {e}");
    }
}

objectsplat_runtime::node_params! {
    /// The parameters of `train`.
    pub struct TrainParams {
        /// iteration budget; every schedule number scales with it
        iterations: i64 = "3000" as ParamType::int_range(1, 10_000_000),
        /// seed of initialization, view order, background colours and sampling
        seed: i64 = "0" as ParamType::int_range(0, i64::MAX),
        /// draw the background colour uniformly every iteration (false: black)
        background_randomization: bool = "true" as ParamType::Bool,
        /// render backend: auto = a hardware GPU through wgpu, else the CPU backend; wgpu = a
        /// GPU or lavapipe (slower than the CPU backend on CPUs)
        backend: String = "\"auto\"" as ParamType::enumeration(&["auto", "cpu", "wgpu"]),
        /// best: the best model on the held-out views, stopping early after `patience`; last:
        /// the model at the end of the full budget
        checkpoint: String = "\"best\"" as ParamType::enumeration(&["best", "last"]),
        /// views that choose the best checkpoint: validation = 1 in 8 training views held out
        /// of training (the training views when there are fewer than 8); test = the test views
        /// the evaluation scores too (the paper's protocol)
        select_on: String = "\"validation\"" as ParamType::enumeration(&["validation", "training", "test"]),
        /// which components this node trains; the others are skipped, or passed through from
        /// `occluders` when it holds an item of the same name. supports: the objects
        /// surface_completion completed (tables, desks: what others rest on); non_supports:
        /// every other object
        components: String = "\"all\"" as ParamType::enumeration(&["all", "objects", "background", "supports", "non_supports"]),
        /// seconds between saves of the training state into the cache: a run killed half-way
        /// resumes from the last save and ends with the same model (0: never save)
        state_every_s: f64 = "60.0" as ParamType::float_range(0.0, 1e9),
        /// an object with fewer sparse points than this is seeded with points on the visual
        /// hull of its masks up to this count (small objects get a handful of SfM points, too
        /// few to grow a surface from); 0: never
        min_object_points: i64 = "300" as ParamType::int_range(0, 1_000_000),
        /// scene units per metre, scales the renderer's depth thresholds
        world_scale: f64 = "1.0" as ParamType::float_range(1e-9, 1e9),
        /// overrides of the scaled reference schedule by field name, e.g. {"lr_sh_dc": 0.03,
        /// "patience": 300} (see objectsplat_train::Schedule)
        schedule: BTreeMap<String, f64> = "{}" as ParamType::Ron("map of schedule settings".into()),
    }
}

pub struct TrainNode;

node_ports! {
    struct TrainNodePorts {
        /// the component to train (fan out over [Component])
        component: input "Component",
        /// sparse SfM points of the scene
        points: input "Points",
        /// which points every frame sees (point_visibility's); computed here when not wired
        visibility: optional "Visibility",
        /// trained objects (another train node's models), rendered frozen with the component:
        /// the background is trained behind them, every pixel supervised by the image; an
        /// object among the others, its foreign and completed pixels supervised by what they
        /// draw over its target (so a table learns to stay under the cup resting on it);
        /// items not trained here (`components`) are passed through from it by name
        occluders: optional_items "Model",
        /// the best model on the component's held-out views
        model: output "Model",
    }
}

impl Node for TrainNode {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("train", "25")
            .doc(
                "Mesh-splatting optimization of one component, initialized from the sparse points \
                  that fall inside its mask; objects are trained with background randomization.",
            )
            .ports::<TrainNodePorts>()
            .params::<TrainParams>()
    }

    /// A misspelt or out-of-range `schedule` setting is refused by `check`, at its line.
    fn check_params(&self, params: &Params) -> Vec<ParamError> {
        // The schema checked every other param, so only `schedule` can fail to read.
        let TrainParams {
            schedule: given,
            iterations,
            ..
        } = match params.read_as() {
            Ok(p) => p,
            Err(_) => {
                return vec![ParamError::new(
                    "schedule",
                    "expected a map of schedule setting names to numbers",
                )];
            }
        };
        let known = Schedule::scaled(1);
        let known = serde_json::to_value(&known).unwrap_or_default();
        let mut errors: Vec<ParamError> = given
            .keys()
            .filter(|k| known.get(k.as_str()).is_none() || k.as_str() == "iterations")
            .map(|k| ParamError::new("schedule", format!("unknown schedule setting `{k}`")).at([k]))
            .collect();
        if errors.is_empty()
            && let Err(e) = schedule_overrides(&given)
                .and_then(|overrides| Schedule::new(iterations.max(1) as u64, &overrides))
        {
            errors.push(ParamError::new("schedule", format!("{e:#}")));
        }
        errors
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let p: TrainParams = ctx.params_as()?;
        let ports: TrainNodePorts = ctx.ports_as()?;
        // The one read of the Component folder's description and frames.
        let folder = ComponentFolder::read(&ports.component)?;
        let info = &folder.info;
        let is_object = info.kind == ComponentKind::Object;
        let wanted = match p.components.as_str() {
            "objects" => is_object,
            "supports" => is_object && folder.is_completed_surface(),
            "non_supports" => is_object && !folder.is_completed_surface(),
            "background" => !is_object,
            _ => true,
        };
        let occluders = ports.occluders.unwrap_or_default();
        if !wanted {
            let item = ctx.item().unwrap_or(&info.name).to_string();
            return match occluders.iter().find(|(name, _)| *name == item) {
                Some((_, dir)) => {
                    objectsplat_core::files::share_tree(dir, &ports.model)?;
                    ctx.note("passed through", "from `occluders`");
                    Ok(Outcome::Done)
                }
                None => Ok(Outcome::Skipped(format!(
                    "component {:?} is not among the components this node trains",
                    info.name
                ))),
            };
        }
        let iterations: i64 = p.iterations;
        let seed: i64 = p.seed;
        let randomize: bool = p.background_randomization;
        let backend_name: String = p.backend;
        let world_scale: f64 = p.world_scale;
        let checkpoint = match p.checkpoint.as_str() {
            "last" => Checkpoint::Last,
            _ => Checkpoint::Best,
        };
        let select_on = match p.select_on.as_str() {
            "training" => SelectOn::Training,
            "test" => SelectOn::Test,
            _ => SelectOn::Validation,
        };
        let state_every: f64 = p.state_every_s;
        let overrides: BTreeMap<String, f64> = p.schedule;
        let schedule = Schedule::new(iterations as u64, &schedule_overrides(&overrides)?)?;
        let points_path = ports.points.join(POINTS_PLY);
        let all_points = Points::read_ply(&points_path)?;
        let mut data = ComponentData::from_folder(folder, ctx.threads())?;
        // Nothing to fit: an empty component, or one no training view sees.
        if data.owned_training_pixels() == 0 {
            return Ok(Outcome::Skipped(format!(
                "component {:?} owns no pixel in any training view",
                data.name
            )));
        }
        let min_object_points = p.min_object_points as usize;
        let visibility = ports
            .visibility
            .as_deref()
            .map(Visibility::read)
            .transpose()?;
        let (owned, others) = data.partition_points(&all_points, visibility.as_ref())?;
        let (points, seeded) =
            crate::hull::initial_points(&data, &all_points, owned, min_object_points, seed as u64)?;
        ctx.note(
            "points",
            if seeded > 0 {
                format!(
                    "{} of {} + {seeded} on the visual hull of its masks",
                    points.positions.len() - seeded,
                    all_points.positions.len()
                )
            } else {
                format!(
                    "{} of {}",
                    points.positions.len(),
                    all_points.positions.len()
                )
            },
        );
        data.depth_points = points.positions[..points.positions.len() - seeded].to_vec();
        data.other_points = others;
        if !occluders.is_empty() {
            let models = occluders
                .iter()
                .filter(|(name, _)| name.starts_with("obj_") && **name != data.name)
                .map(|(name, dir)| load_model(dir).with_context(|| format!("occluder {name:?}")))
                .collect::<Result<Vec<_>>>()?;
            let parts: Vec<&Model<f32>> = models.iter().collect();
            ctx.note(
                "occluders",
                format!("{} trained objects, frozen", parts.len()),
            );
            if !parts.is_empty() {
                data.occluders = Some(Model::union(&parts)?);
            }
        }
        // Asked after the reads: a job started beside items passed through gets
        // the workers they freed.
        let (backend, why) = objectsplat_raster_gpu::backend_for(&backend_name, ctx.threads())?;
        ctx.note("backend", why);
        let budget = Arc::new(AtomicUsize::new(ctx.threads()));
        let settings = TrainSettings {
            seed: seed as u64,
            background_randomization: randomize,
            world_scale,
            checkpoint,
            select_on,
            resume_dir: (state_every > 0.0).then(|| ctx.resume().to_path_buf()),
            save_seconds: state_every,
            threads: ctx.threads(),
            thread_budget: Some(budget.clone()),
            ..TrainSettings::new(schedule)
        };
        let report = {
            let ctx_ref = &*ctx;
            train_component(
                backend.as_ref(),
                &data,
                &points,
                &settings,
                |done, total| {
                    budget.store(ctx_ref.threads(), Ordering::Relaxed);
                    if done % 50 == 0 || done == total {
                        ctx_ref.progress(done, total, "training");
                    }
                    !ctx_ref.cancelled()
                },
            )?
        };
        ctx.note("iterations", report.iterations_run);
        ctx.note(
            "steps",
            format!(
                "all {} on the {}",
                report.iterations_run, report.steps_ran_on
            ),
        );
        ctx.note("best_iteration", report.best_iteration);
        ctx.note("best_score", format!("{:.5}", report.best_score));
        ctx.note("held_out_psnr", format!("{:.2} dB", report.log.final_psnr));
        if report.log.stopped_early {
            // A finished model's iterations include its finish, which ran after the stop.
            let stopped_at = report.log.finished_from.unwrap_or(report.iterations_run);
            ctx.note(
                "early_stop",
                format!(
                    "stopped at {stopped_at} of {}, best at {}",
                    report.log.iterations_budget, report.best_iteration
                ),
            );
        }
        ctx.note("faces", report.model.face_count());
        ctx.note("memory", memory_note(&data));
        if !report.notes.is_empty() {
            ctx.note("schedule", report.notes.join("; "));
        }
        save_model(&report.model, &ports.model)?;
        report.log.save(&ports.model)?;
        ctx.measurement(TRAINING_TIMES, &report.times)?;
        Ok(Outcome::Done)
    }
}
