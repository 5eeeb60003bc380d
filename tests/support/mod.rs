//! Shared by the end-to-end tests: the `objectsplat` binary and its run reports, headless
//! Chromium over the DevTools protocol, a small hand-made scene, a tiny trained room,
//! plugin builds and the local Slurm cluster.
#![allow(dead_code)]

pub mod chromium;
pub mod objectsplat;
pub mod plugin_build;
pub mod slurm;
pub mod small_scene;
pub mod tiny_room;
pub mod viewer_page;
