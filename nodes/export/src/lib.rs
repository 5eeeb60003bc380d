//! Scene export: the `.glb`, per-component PLYs and the interactive viewer page, and the
//! nodes that write them (`export_gltf`, `viewer`: [`register`]).
//!
//! - [`glb`]: one `.glb` for the whole scene, a node per object, linear vertex colours,
//!   an unlit material (checked against the Khronos validator in the tests);
//! - [`ply`]: one binary PLY per component;
//! - [`escape`]: HTML escaping for the pages written here and by the report;
//! - [`viewer`]: the interactive 3D page (WebGL2) that picks, edits and exports edits;

pub mod color;
pub mod escape;
pub mod glb;
pub mod nodes;
pub mod object;
pub mod ply;
pub mod viewer;

pub use glb::{ExportedComponent, build_glb, write_glb};
pub use nodes::register;
pub use object::{ExportObject, ShColors, SrgbColors};
pub use objectsplat_scene::Placement;
