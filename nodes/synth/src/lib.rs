//! The procedural demo room for ObjectSplat: a geometry-complete scene with ground truth
//! (the `synthetic_scene` node). It renders with the face-id rasterizer of
//! `objectsplat_masks`, the one ground-truth masks are made with.
//!
//! - [`scene`]: the room, its cameras, renders and sparse points;
//! - [`nodes`]: the node wrapper and [`register`].

pub mod nodes;
pub mod scene;

pub use nodes::register;
pub use scene::{Surfaces, SyntheticParams, SyntheticScene};
