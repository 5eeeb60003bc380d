//! Evaluation metrics for ObjectSplat: PSNR, SSIM, LPIPS (AlexNet) and mesh F-score,
//! for the whole scene and per object, written as `metrics.json` + `metrics.csv`.
//!
//! Conventions (each module documents its own in detail):
//! - images are compared in [0, 1] with data range 1;
//! - SSIM uses an 11×11 Gaussian window (σ 1.5); [`SsimMode::Gs3d`] (zero padding,
//!   mean over all pixels) is the default, [`SsimMode::Cropped`] matches scikit-image;
//! - F-score: points sampled on surfaces by area, voxel-down-sampled (one mean point
//!   per occupied voxel, Open3D grid), matched with a k-d tree, strict `d < τ`;
//!   defaults τ = 5 cm, voxel 2 cm.

pub mod evaluate;
pub mod fscore;
pub mod lpips;
pub mod mask;
pub mod mesh_eval;
pub mod normals;
pub mod psnr;
pub mod report;
pub mod ssim;
pub mod surface;
mod validate;
pub mod voxel;

pub use evaluate::{TestImage, assemble_report, evaluate_image};
pub use fscore::{FScore, fscore, nearest_distances};
pub use lpips::{Lpips, LpipsValue};
pub use mask::Mask;
pub use mesh_eval::{
    DEFAULT_MAX_SAMPLES, MeshEvalParams, MeshFScores, ObjectFScore, evaluate_mesh, mesh_points,
};
pub use normals::normal_consistency;
pub use psnr::psnr;
pub use report::MetricsReport;
pub use ssim::{SsimMode, ssim};
pub use surface::{SampleCount, SurfaceSamples, sample_surface};
pub use voxel::voxel_downsample;
