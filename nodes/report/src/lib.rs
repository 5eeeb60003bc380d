//! The self-contained HTML run report and its `report` node: graph with node status and time
//! (from the run's `run.js`, see [`run_summary`]; it also draws how long each trained item
//! took, from the times its run measured), metrics table, test-view triplets (ground truth /
//! render / error heatmap), SVG plots of the training curves against iterations and of run
//! time against error, and the scene's interactive view when a `viewer` folder is wired.

pub mod dag;
pub mod data;
pub mod images;
pub mod node;
pub mod page;
pub mod plot;
pub mod run_summary;
pub mod training;

pub use data::{
    GraphEdge, ItemRun, ModelTraining, NodeRun, NodeStatus, ReportData, RunSummary, RuntimePoint,
    ViewTriplet,
};
pub use node::register;
pub use objectsplat_core::{EvalRecord, StepRecord, TrainingLog};
pub use objectsplat_metrics::report::{MetricsReport, ObjectMetrics, ScopeMetrics};
pub use page::{REPORT_FILE, render_report, report_html};
pub use run_summary::{
    RUN_DATA_FILE, RUN_SCRIPT_FILE, RUN_SUMMARY_BEGIN, RUN_SUMMARY_END, inject_run_summary,
    read_run_summary, run_loader, run_section, write_run_files, write_with_run_summary,
};
