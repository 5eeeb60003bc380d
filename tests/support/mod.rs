//! Shared by the end-to-end tests: headless Chromium over the DevTools protocol, a small
//! hand-made scene, plugin builds and the local Slurm cluster.
#![allow(dead_code)]

pub mod chromium;
pub mod plugin_build;
pub mod slurm;
pub mod small_scene;
