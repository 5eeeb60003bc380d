//! The ObjectSplat plugin SDK: write node kinds as ordinary Rust functions, export
//! them from a `cdylib` with [`export_plugin!`], and read/write artifacts in their
//! documented encodings with [`artifacts`]. docs/plugins.md is the guide.
//!
//! ```ignore
//! use objectsplat_plugin_sdk::prelude::*;
//!
//! fn invert(req: &mut Request) -> Result<Outcome> {
//!     let mut img = read_image(req.input("image")?)?;
//!     img.data.iter_mut().for_each(|v| *v = 1.0 - *v);
//!     write_image(&req.output("image")?, &img, 8)?;
//!     Ok(Outcome::Done)
//! }
//!
//! export_plugin!(Plugin::new("invert", "1").node(
//!     NodeDecl::new("invert_image", invert).input("image", "Image", "").output("image", "Image", "")
//! ));
//! ```

pub mod abi;
pub mod artifacts;
pub mod declare;
pub mod export;
pub use objectsplat_plugin_abi::protocol;
pub mod request;
pub mod testing;

pub use anyhow;
pub use declare::{NodeDecl, NodeFn, Outcome, Plugin};
pub use objectsplat_core as core;
pub use request::Request;

/// Everything a plugin usually needs.
pub mod prelude {
    pub use crate::artifacts::*;
    pub use crate::core::{Frame, Frames, IdMap, Image, ObjectLabels};
    pub use crate::export_plugin;
    pub use crate::{NodeDecl, Outcome, Plugin, Request};
    pub use anyhow::{Context as _, Result, anyhow, bail};
}
