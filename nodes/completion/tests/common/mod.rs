//! A small hand-made partitioned scene: two 32×24 frames seen from above, a table
//! with a cup standing on it (frame 0: the cup lies inside the table's silhouette;
//! frame 1: it overhangs the table's edge), a chair beside the table, a background
//! pixel showing through a gap in the tabletop, and the background around them.
#![allow(dead_code)] // each test file uses a different part

use objectsplat_core::component::{self, OTHER, OWN};
use objectsplat_core::{Camera, ComponentInfo, Frame, Frames, Split};
use objectsplat_runtime::Node;
use objectsplat_runtime::testing::{NodeRun, run_node};
use std::path::{Path, PathBuf};

pub const W: u32 = 32;
pub const H: u32 = 24;
pub const TABLE_RGB: [u8; 3] = [150, 100, 60];
pub const CUP_RGB: [u8; 3] = [20, 200, 20];
pub const CHAIR_RGB: [u8; 3] = [200, 30, 30];
pub const BACKGROUND_RGB: [u8; 3] = [90, 90, 90];
/// The tabletop gap where the background shows through (frame 0).
pub const GAP: (u32, u32) = (22, 16);

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub enum Owner {
    Table,
    Cup,
    Chair,
    Background,
}

pub fn owner(frame: usize, x: u32, y: u32) -> Owner {
    let cup = if frame == 0 {
        (12..17).contains(&x) && (11..15).contains(&y)
    } else {
        (12..17).contains(&x) && (5..10).contains(&y)
    };
    if cup {
        Owner::Cup
    } else if frame == 0 && (x, y) == GAP {
        Owner::Background
    } else if (4..28).contains(&x) && (8..20).contains(&y) {
        Owner::Table
    } else if x < 10 && y < 6 {
        Owner::Chair
    } else {
        Owner::Background
    }
}

pub fn colour(o: Owner) -> [u8; 3] {
    match o {
        Owner::Table => TABLE_RGB,
        Owner::Cup => CUP_RGB,
        Owner::Chair => CHAIR_RGB,
        Owner::Background => BACKGROUND_RGB,
    }
}

pub fn camera() -> Camera {
    use objectsplat_core::glam::DVec3;
    Camera::look_at(
        W,
        H,
        30.0,
        30.0,
        DVec3::new(0.0, 0.0, 5.0),
        DVec3::ZERO,
        DVec3::Y,
    )
}

pub struct Scene {
    pub root: tempfile::TempDir,
    pub frames: PathBuf,
    pub components: PathBuf,
}

fn frame_rgb(f: usize) -> Vec<u8> {
    (0..H)
        .flat_map(|y| (0..W).flat_map(move |x| colour(owner(f, x, y))))
        .collect()
}

fn write_rgb(path: &Path, data: &[u8]) {
    objectsplat_core::image::write_rgb8(path, data, W, H).unwrap();
}

/// Builds the scene; the table component carries `table_label`.
pub fn build(table_label: &str) -> Scene {
    let root = tempfile::tempdir().unwrap();
    let frames_dir = root.path().join("frames");
    std::fs::create_dir_all(frames_dir.join("images")).unwrap();
    let frames: Vec<Frame> = (0..2)
        .map(|f| {
            Frame::new(
                format!("f{f}"),
                format!("images/f{f}.png"),
                &camera(),
                Split::Train,
            )
        })
        .collect();
    for f in 0..2 {
        write_rgb(&frames_dir.join(format!("images/f{f}.png")), &frame_rgb(f));
    }
    Frames::write_json(&frames_dir, &frames).unwrap();

    let components = root.path().join("components");
    let parts = [
        (ComponentInfo::object(1, table_label), Owner::Table),
        (ComponentInfo::object(2, "cup"), Owner::Cup),
        (ComponentInfo::object(3, "chair"), Owner::Chair),
        (ComponentInfo::background(), Owner::Background),
    ];
    for (info, who) in parts {
        let dir = components.join(&info.name);
        std::fs::create_dir_all(dir.join("images")).unwrap();
        info.write(&dir).unwrap();
        for (f, frame) in frames.iter().enumerate() {
            write_rgb(&dir.join(format!("images/f{f}.png")), &frame_rgb(f));
            let mask: Vec<u8> = (0..H)
                .flat_map(|y| (0..W).map(move |x| if owner(f, x, y) == who { OWN } else { OTHER }))
                .collect();
            component::write_mask(&dir, frame, &mask).unwrap();
        }
        Frames::write_json(&dir, &frames).unwrap();
    }
    Scene {
        root,
        frames: frames_dir,
        components,
    }
}

/// The component folders as (name, folder), sorted like the runtime lists them.
pub fn items(dir: &Path) -> Vec<(String, PathBuf)> {
    let mut items: Vec<(String, PathBuf)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap())
        .map(|e| (e.file_name().to_string_lossy().into_owned(), e.path()))
        .collect();
    items.sort();
    items
}

pub fn read_gray(path: &Path) -> Vec<u8> {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_luma8()
        .into_raw()
}

pub fn read_rgb(path: &Path) -> Vec<u8> {
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgb8()
        .into_raw()
}

/// A path under tests/fixtures.
pub fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(rel)
}

/// The JSON file at `path`, deserialised.
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> T {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Runs `node` outside a graph, expecting success.
pub fn run(node: &dyn Node, inputs: &[(&str, &Path)], params: &str, out: &Path) -> NodeRun {
    run_node(node, inputs, params, out, None).unwrap()
}

/// Runs `node` outside a graph, expecting failure; returns the error with its causes.
pub fn run_error(node: &dyn Node, inputs: &[(&str, &Path)], params: &str, out: &Path) -> String {
    let Err(e) = run_node(node, inputs, params, out, None) else {
        panic!("{params} should have been refused");
    };
    format!("{e:#}")
}
