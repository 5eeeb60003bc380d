//! The `report` node: metrics, test views and trained models' training logs (all optional) → an HTML
//! report folder. Inside a graph the node cannot see the run's own node table (nodes
//! downstream or beside it have not finished), so its "Run" section is a marked placeholder
//! that the page fills in when opened, from the `run.js` that `objectsplat run` writes beside
//! the outputs ([`crate::write_run_files`]).
//!
//! `export_gltf` is not wrapped yet: it needs the Model encoding inside a Scene
//! (`objects/<name>/model.ply`), which is not documented yet.

use crate::{MetricsReport, ModelTraining, ReportData, ViewTriplet, render_report};
use anyhow::{Context as _, Result};
use objectsplat_core::Frames;
use objectsplat_core::TrainingLog;
use objectsplat_core::frames::{Split, frame_stem};
use objectsplat_runtime::{Context, Node, NodeSpec, Outcome, ParamType, Registry, node_ports};
use std::path::Path;
use std::sync::Arc;

/// Writes `index.html` from a Metrics artifact and, when wired, test views.
pub struct ReportNode;

/// Up to `max_views` test frames that have a render, spread evenly over the test split.
fn test_views(frames_dir: &Path, renders_dir: &Path, max_views: usize) -> Result<Vec<ViewTriplet>> {
    let frames = Frames::read(frames_dir)?;
    let available: Vec<ViewTriplet> = frames
        .by_split(Split::Test)
        .filter_map(|f| {
            let render = renders_dir.join(format!("{}.png", frame_stem(&f.name)));
            render.is_file().then(|| ViewTriplet {
                name: f.name.clone(),
                ground_truth: frames.image_path(f),
                render,
            })
        })
        .collect();
    if available.len() <= max_views {
        return Ok(available);
    }
    Ok((0..max_views)
        .map(|k| available[k * available.len() / max_views].clone())
        .collect())
}

/// Each model item with its `training.json`, `None` for models trained without one.
fn training_logs(items: &[(String, std::path::PathBuf)]) -> Result<Vec<ModelTraining>> {
    items
        .iter()
        .map(|(name, dir)| {
            let log = TrainingLog::load(dir).with_context(|| format!("models item {name:?}"))?;
            Ok(ModelTraining {
                model: name.clone(),
                log,
            })
        })
        .collect()
}

objectsplat_runtime::node_params! {
    /// The parameters of `report`.
    pub struct ReportParams {
        /// page title
        title: String = "\"ObjectSplat run\"" as ParamType::Str,
        /// test views shown (spread evenly over the test split)
        max_views: i64 = "4" as ParamType::int_range(0, 64),
        /// mean absolute RGB error drawn with the hottest heatmap colour
        error_scale: f64 = "0.25" as ParamType::float_range(1e-6, 1.0),
    }
}

node_ports! {
    struct ReportNodePorts {
        /// the evaluation (metrics.json)
        metrics: optional "Metrics",
        /// the capture; its test-split frames are the ground truth of the views
        frames: optional "Frames",
        /// renders of the test frames, named <frame stem>.png
        renders: optional "Images",
        /// trained models; their training.json gives the training curves
        models: optional_items "Model",
        /// a `viewer` node's folder (index.html, scene.glb, viewer.json): its 3D view is embedded
        viewer: optional "File",
        /// a folder with index.html
        file: output "File",
    }
}

impl Node for ReportNode {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new("report", "8")
            .doc("A self-contained HTML report (index.html): the run's graph with each node's status and time (read from the run.js `objectsplat run` writes beside the outputs), the interactive 3D view of the scene (when a `viewer` folder is wired), metrics table, test-view triplets (ground truth / render / error heatmap), training curves of the models; no external resources.")
            .ports::<ReportNodePorts>()
            .params::<ReportParams>()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let ports: ReportNodePorts = ctx.ports_as()?;
        let p: ReportParams = ctx.params_as()?;
        let title: String = p.title;
        let max_views: i64 = p.max_views;
        let error_scale: f64 = p.error_scale;
        let metrics = match ports.metrics.as_deref() {
            Some(dir) => Some(MetricsReport::read(dir)?),
            None => None,
        };
        let views = match (ports.frames.as_deref(), ports.renders.as_deref()) {
            (Some(frames), Some(renders)) => {
                test_views(frames, renders, max_views.max(0) as usize)?
            }
            _ => Vec::new(),
        };
        let training = match &ports.models {
            Some(models) => training_logs(models)?,
            None => Vec::new(),
        };
        ctx.note("views", views.len());
        if !training.is_empty() {
            let logged = training.iter().filter(|t| t.log.is_some()).count();
            ctx.note("training logs", format!("{logged} of {}", training.len()));
        }
        let viewer = ports.viewer;
        if viewer.is_some() {
            ctx.note("3D view", "embedded");
        }
        let data = ReportData {
            title,
            metrics,
            views,
            training,
            error_scale,
            viewer,
            ..Default::default()
        };
        ctx.progress(0, 1, "writing report");
        render_report(&ports.file, &data)?;
        ctx.progress(1, 1, "report written");
        Ok(Outcome::Done)
    }
}

pub fn register(reg: &mut Registry) {
    // Kinds are unique within this crate and the catalogue registers every artifact type
    // first; a failure here is a wiring bug (a kind clash or a type left unregistered).
    reg.add_node(Arc::new(ReportNode))
        .expect("node kind `report` is registered once, after its port types");
}
