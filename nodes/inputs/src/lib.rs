//! Scene sources and mask import: COLMAP, nerfstudio and ScanNet++ captures become
//! Frames/Points/Mesh artifacts; SAM-family masks become Masks artifacts. Photos and
//! videos without poses are posed by COLMAP's structure from motion.

pub mod binio;
pub mod colmap;
pub mod colmap_scene;
pub mod colmap_sfm;
pub mod installed;
pub mod label_png;
pub mod masks_import;
pub mod nerfstudio;
pub mod nodes;
pub mod npy;
pub mod rle;
pub mod scannetpp;
pub mod scene;
pub mod sfm_nodes;
pub mod similarity;
pub mod stereo;
pub mod stereo_points;
pub mod undistort;
pub mod video;

pub use nodes::register;
