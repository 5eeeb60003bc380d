//! Scene types shared by every ObjectSplat stage, and their on-disk encodings.
//!
//! Every artifact that crosses a node boundary is a folder in a documented
//! encoding (see `docs/artifacts.md`); this crate reads and writes the ones that
//! describe captures: cameras, frames, images, object masks, meshes and components.

pub mod artifact;
pub mod camera;
pub mod component;
pub mod files;
pub mod frames;
pub mod geometry;
pub mod image;
pub mod label_runs;
pub mod masks;
pub mod mesh_io;
pub mod ply;
pub mod training_log;
pub mod visibility;

pub use camera::Camera;
pub use component::{ComponentFolder, ComponentInfo, ComponentKind};
pub use frames::{Frame, Frames, Split, SplitPolicy};
pub use geometry::{Mesh, Points};
pub use glam;
pub use image::{Image, RgbWindow};
pub use label_runs::LabelRuns;
pub use masks::{IdMap, ObjectLabels};
pub use mesh_io::{read_mesh_artifact, write_mesh_artifact};
pub use ply::Ply;
pub use training_log::{EvalRecord, StepRecord, TRAINING_TIMES, TrainingLog, TrainingTimes};
