//! Object masks and the partition into components: the stages between a capture and
//! per-component training.
//!
//! - [`raster`]: the multi-threaded z-buffer rasterizer of face ids (the synthetic scene
//!   renders with it too);
//! - [`gpu_raster`]: the same face ids on wgpu (bit-identical), sharing its triangle setup;
//! - [`gt_masks`](mod@gt_masks): per-frame object-id masks from an annotated mesh (`gt_masks` node);
//! - [`partition`]: every pixel to exactly one component (`partition` node);
//! - [`nodes`]: the node wrappers and [`register`].

pub mod gpu_raster;
pub mod gt_masks;
pub mod nodes;
pub mod partition;
pub mod raster;

pub use gt_masks::{GtMaskParams, GtMasks, gt_masks};
pub use nodes::register;
pub use partition::{Partition, PartitionParams, plan_partition};
pub use raster::{NO_FACE, Raster, RasterOptions, rasterize};
