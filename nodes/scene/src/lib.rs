//! Scenes of ObjectSplat: composing trained components into one separable scene,
//! editing it, rendering it and exporting it (scoring it is `objectsplat-evaluate`).
//!
//! - [`scene`]: the Scene artifact (`scene.json` + one Model folder per member),
//!   [`load_scene`], [`save_scene`], [`Scene::merged_model`];
//! - [`edit`]: the RON edit list and [`apply_edits`];
//! - [`render`]: rendering the merged model from a camera, orbit cameras;
//! - [`nodes`]: `compose`, `load_scene`, `edit_scene`, `render`, `export_gltf`, `viewer`
//!   ([`register`]).

pub mod edit;
pub mod nodes;
pub mod render;
pub mod scene;
pub mod sh_rotation;
pub mod surface;

pub use edit::{Edit, EditLog, Target, apply_edits, parse_edits};
pub use nodes::register;
pub use scene::{MergedModel, Scene, SceneEntry, SceneObject, load_scene, save_scene};
