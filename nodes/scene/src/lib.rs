//! Scenes of ObjectSplat: composing trained components into one separable scene,
//! editing it and rendering it (exporting it is `objectsplat-export`, scoring it
//! `objectsplat-evaluate`).
//!
//! - [`scene`]: the Scene artifact (`scene.json` + one Model folder per member),
//!   [`load_scene`], [`save_scene`], [`Scene::merged_model`];
//! - [`edit`]: the RON edit list and [`apply_edits`];
//! - [`render`]: rendering the merged model from a camera, orbit cameras;
//! - [`placement`]: an object's pivot and world transform (what a rigid edit changes);
//! - [`nodes`]: `compose`, `load_scene`, `edit_scene`, `render` ([`register`]; the
//!   export nodes are `objectsplat-export`'s).

pub mod edit;
pub mod nodes;
pub mod placement;
pub mod render;
pub mod scene;
pub mod sh_rotation;
pub mod surface;

pub use edit::{Edit, EditLog, Target, apply_edits, parse_edits};
pub use nodes::register;
pub use placement::Placement;
pub use scene::{MergedModel, Scene, SceneEntry, SceneObject, load_scene, save_scene};
