//! Completion stages of ObjectSplat: OpenCV-compatible inpainting, binary hole
//! filling, flat-support-surface completion and background-inpainting adapters.
//!
//! Everything here serves interactive and qualitative results: following the paper,
//! completed surfaces and inpainted backgrounds are kept out of reported metrics.

pub mod background;
pub mod external;
pub mod fill_holes;
pub mod inpaint;
pub mod nodes;
pub mod plane;
pub mod surface;
pub mod surface_mesh;

pub use inpaint::{InpaintError, Method, Options, Raster, Sample, inpaint};
pub use nodes::register;
