//! What a report shows, as plain serde structs that mirror the run's own files:
//! the `--json` run report (nodes, and what their items measured), `metrics.json`
//! (scene + per-object metrics), the graph's edges, test views as image paths, and the
//! trained models' `training.json`.

use objectsplat_core::TrainingLog;
use objectsplat_metrics::report::MetricsReport;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct ReportData {
    pub title: String,
    #[serde(default)]
    pub run: RunSummary,
    /// `metrics.json` as written by `evaluate`; absent when the run did not evaluate.
    #[serde(default)]
    pub metrics: Option<MetricsReport>,
    #[serde(default)]
    pub views: Vec<ViewTriplet>,
    /// Mean absolute RGB error (values in [0, 1]) shown as the hottest heatmap colour; 0 means the default.
    #[serde(default)]
    pub error_scale: f64,
    /// One entry per trained model (the `models` collection), in collection order.
    #[serde(default)]
    pub training: Vec<ModelTraining>,
    #[serde(default)]
    pub runtime_vs_error: Vec<RuntimePoint>,
    /// A folder written by [`objectsplat_export::viewer::write_viewer`] (a `viewer` node's output):
    /// its interactive 3D view is embedded in the page.
    #[serde(default)]
    pub viewer: Option<PathBuf>,
}

/// The nodes of the `--json` run report plus the graph's edges (for the drawing). The
/// report's other fields (notes, outputs, warnings) are not shown and are ignored.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RunSummary {
    pub nodes: Vec<NodeRun>,
    #[serde(default)]
    pub edges: Vec<GraphEdge>,
    /// The graph file the run came from.
    #[serde(default)]
    pub graph: Option<String>,
    /// Wall time of the whole run (nodes overlap, so this is not the sum of node times).
    #[serde(default)]
    pub seconds: Option<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NodeStatus {
    Ran,
    Cached,
    Skipped,
    Failed,
}

impl NodeStatus {
    pub fn as_str(self) -> &'static str {
        match self {
            NodeStatus::Ran => "ran",
            NodeStatus::Cached => "cached",
            NodeStatus::Skipped => "skipped",
            NodeStatus::Failed => "failed",
        }
    }
}

/// One node of the run report (`{"id","kind","status","seconds","reason","items"}`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NodeRun {
    pub id: String,
    pub kind: String,
    pub status: NodeStatus,
    /// Its own run time; for a cached node, that of the run that produced its outputs.
    pub seconds: f64,
    /// Time it waited for a worker (not part of `seconds`).
    #[serde(default)]
    pub queued_seconds: f64,
    #[serde(default)]
    pub reason: Option<String>,
    #[serde(default)]
    pub items: Vec<ItemRun>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ItemRun {
    pub name: String,
    pub status: NodeStatus,
    pub seconds: f64,
    /// What the item's run measured about itself (for a cached item, the producing run's):
    /// a `train` item's [`objectsplat_core::TrainingTimes`], under
    /// [`objectsplat_core::TRAINING_TIMES`].
    #[serde(default, skip_serializing_if = "serde_json::Map::is_empty")]
    pub measurements: serde_json::Map<String, serde_json::Value>,
}

/// A data dependency: `from`'s output feeds `to`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct GraphEdge {
    pub from: String,
    pub to: String,
}

/// A test view: ground truth and render as PNG/JPEG files of equal size.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ViewTriplet {
    pub name: String,
    pub ground_truth: PathBuf,
    pub render: PathBuf,
}

/// A trained model of the `models` collection and its `training.json`, `None` when the
/// model has no training log (built by hand or by another tool).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelTraining {
    /// The collection item's name (`background`, `obj_<id>_<label>`).
    pub model: String,
    pub log: Option<TrainingLog>,
}

/// One measured configuration: how long it ran and how good it is.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RuntimePoint {
    /// Points of one series are joined by a line in order of run time.
    pub series: String,
    pub label: String,
    pub seconds: f64,
    pub psnr: f64,
}
