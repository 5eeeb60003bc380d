//! The mesh-splatting trainer's building blocks (see docs/trainer.md):
//!
//! - [`adam`] and [`Optim`] (from objectsplat-optim, shared with the device
//!   trainer): Adam with per-group learning rates and row-resizable state;
//! - [`schedule`]: every scheduled number, scaled to the iteration budget;
//! - [`densify`]: midpoint-subdivision densification and pruning;
//! - [`delaunay`] + [`connectivity`]: the restricted Delaunay connectivity step;
//! - [`init`]: triangles from sparse points, and a component's point selection;
//! - [`point_depth`] and [`depth_smoothness`]: depth at the measured points and the
//!   background's planar prior, the two geometric losses;
//! - [`free_space`]: faces the training views saw measured points through;
//! - [`surface_filter`]: normal filtering that keeps the connected mesh a surface;
//! - [`spatial_order`]: the connected mesh renumbered along a space-filling curve;
//! - [`flat_color`] and `flat_fit`: the flat colours a mesh export draws, baked from
//!   the SH colours and then fitted to the training views as exported.

// Negated comparisons are deliberate: NaN must fail every acceptance test.
// Numerical loops index several parallel arrays with one index.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]

pub mod checkpoint;
mod composite;
pub mod connectivity;
pub mod delaunay;
pub mod densify;
pub mod depth_smoothness;
mod device_steps;
pub mod face_stats;
pub mod flat_color;
mod flat_fit;
pub mod free_space;
mod host_steps;
pub mod hull;
pub mod init;
pub mod neighbours;
pub mod normal_agreement;
pub mod point_depth;
pub mod schedule;
mod screen;
pub mod spatial_order;
mod steps;

pub use objectsplat_optim::{Adam, LogLinearDecay, Optim, adam};
pub use schedule::Schedule;
pub mod node;
pub mod supervision;
pub mod surface_filter;
pub mod trainer;
mod vec3;

pub use node::register;
