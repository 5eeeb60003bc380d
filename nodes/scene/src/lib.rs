//! Scenes of ObjectSplat: composing trained components into one separable scene,
//! editing it, rendering it, evaluating it and exporting it.
//!
//! - [`scene`]: the Scene artifact (`scene.json` + one Model folder per member),
//!   [`load_scene`], [`save_scene`], [`Scene::merged_model`];
//! - [`edit`]: the RON edit list and [`apply_edits`];
//! - [`render`]: rendering the merged model from a camera, orbit cameras;
//! - [`evaluate`]: image metrics and mesh F-score of a run;
//! - [`nodes`]: `compose`, `edit_scene`, `render`, `evaluate`, `export_gltf` ([`register`]).

pub mod edit;
pub mod evaluate;
pub mod nodes;
pub mod render;
pub mod scene;
pub mod sh_rotation;
pub mod surface;

pub use edit::{Edit, EditLog, Target, apply_edits, parse_edits};
pub use nodes::register;
pub use scene::{MergedModel, Scene, SceneEntry, SceneObject, load_scene, save_scene};
