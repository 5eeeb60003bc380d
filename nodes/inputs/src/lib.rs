//! Scene sources and mask import: COLMAP, nerfstudio and ScanNet++ captures become
//! Frames/Points/Mesh artifacts; SAM-family masks become Masks artifacts.

pub mod binio;
pub mod colmap;
pub mod colmap_scene;
pub mod label_png;
pub mod masks_import;
pub mod nerfstudio;
pub mod nodes;
pub mod npy;
pub mod rle;
pub mod scannetpp;
pub mod scene;
pub mod undistort;

pub use nodes::register;
