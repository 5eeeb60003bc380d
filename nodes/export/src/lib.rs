//! Scene export and the run report.
//!
//! - [`glb`]: one `.glb` for the whole scene, a node per object, linear vertex colours,
//!   an unlit material (checked against the Khronos validator in the tests);
//! - [`placement`]: an object's pivot and world transform (the `.glb` node's TRS);
//! - [`ply`]: one binary PLY per component;
//! - [`report`]: a self-contained HTML report of a run;
//! - [`viewer`]: the interactive 3D page (WebGL2) that picks, edits and exports edits;
//! - [`nodes`]: the `report` dataflow node ([`register`]).

pub mod color;
pub mod glb;
pub mod nodes;
pub mod object;
pub mod placement;
pub mod ply;
pub mod report;
pub mod viewer;

pub use glb::{ExportedComponent, build_glb, write_glb};
pub use nodes::register;
pub use object::{ExportObject, SrgbColors};
pub use placement::Placement;
pub use report::{ReportData, render_report};
