//! The self-contained HTML run report: graph with node status and time, metrics table,
//! test-view triplets (ground truth / render / error heatmap), and SVG plots of training
//! curves and run time against error.

pub mod dag;
pub mod data;
pub mod escape;
pub mod images;
pub mod page;
pub mod plot;

pub use data::{
    CurvePoint, GraphEdge, ItemRun, MetricValues, MetricsTable, NodeRun, NodeStatus, ObjectMetrics,
    ReportData, RunSummary, RuntimePoint, TrainingCurve, ViewTriplet,
};
pub use page::{REPORT_FILE, render_report, report_html};
