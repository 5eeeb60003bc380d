//! Shared by the browser tests: headless Chromium over the DevTools protocol, and a small
//! hand-made scene.
#![allow(dead_code)]

pub mod chromium;
pub mod small_scene;
