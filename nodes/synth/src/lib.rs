//! Ground truth and the demo scene for ObjectSplat.
//!
//! - [`raster`]: the multi-threaded z-buffer rasterizer everything here is built on;
//! - [`gpu_raster`]: the same face ids on wgpu (bit-identical), sharing its triangle setup;
//! - [`gt_masks`](mod@gt_masks): per-frame object-id masks from an annotated mesh (`gt_masks` node);
//! - [`partition`]: every pixel to exactly one component (`partition` node);
//! - [`scene`]: the procedural, geometry-complete demo room (`synthetic_scene` node);
//! - [`nodes`]: the three node wrappers and [`register`].

pub mod gpu_raster;
pub mod gt_masks;
pub mod nodes;
pub mod partition;
pub mod raster;
pub mod scene;

pub use gt_masks::{GtMaskParams, GtMasks, gt_masks};
pub use nodes::register;
pub use partition::{Partition, PartitionParams, plan_partition};
pub use raster::{NO_FACE, Raster, RasterOptions, rasterize};
pub use scene::{SyntheticParams, SyntheticScene};
