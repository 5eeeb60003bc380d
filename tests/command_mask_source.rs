//! The shipped example of the generic `command` stage
//! (nodes/command/examples/mask_source: a standard-library Python script writing DAVIS
//! PNGs, wired into `import_masks`) runs through `objectsplat run` on a tiny COLMAP scene
//! made here: the imported masks are the rectangles painted into the images; the run
//! reports show what ran — a cached rerun runs nothing, an edited script reruns the command
//! alone (same masks: import_masks is served from the cache), new options rerun both; a
//! failing script fails its node with the script's stderr, and a typo in a placeholder is
//! caught by `objectsplat check` at its file:line:column.

use image::{Rgb, RgbImage};
use objectsplat_core::artifact::OBJECTS_JSON;
use std::path::{Path, PathBuf};

mod support;
use support::objectsplat::{assert_ok, failure, objectsplat, read_json, run_graph_ron, statuses};

const W: u32 = 24;
const H: u32 = 16;
const RED: [u8; 3] = [220, 40, 40];
const GREEN: [u8; 3] = [40, 200, 60];

/// Per image: (x0, y0, x1, y1) of the red and the green rectangle (end exclusive).
const RECTS: [[(u32, u32, u32, u32); 2]; 3] = [
    [(2, 2, 8, 7), (12, 6, 20, 14)],
    [(0, 0, 5, 16), (15, 1, 24, 4)],
    [(9, 3, 14, 9), (1, 10, 6, 15)],
];

fn example(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("nodes/command/examples/mask_source")
        .join(file)
}

fn expected_id(image: usize, x: u32, y: u32) -> u16 {
    let inside = |(x0, y0, x1, y1): (u32, u32, u32, u32)| x >= x0 && x < x1 && y >= y0 && y < y1;
    // The script keys red first, so red wins where the rectangles overlap (they do not here).
    if inside(RECTS[image][0]) {
        1
    } else if inside(RECTS[image][1]) {
        2
    } else {
        0
    }
}

/// The example graph's scene: a COLMAP text model with three PINHOLE views and their images.
fn build_scene(dir: &Path) {
    let sparse = dir.join("scene/sparse");
    let images = dir.join("scene/images");
    std::fs::create_dir_all(&sparse).unwrap();
    std::fs::create_dir_all(&images).unwrap();
    std::fs::write(
        sparse.join("cameras.txt"),
        format!("1 PINHOLE {W} {H} 20 20 12 8\n"),
    )
    .unwrap();
    let mut lines = String::new();
    for i in 0..RECTS.len() {
        lines += &format!("{} 1 0 0 0 0 0 {} 1 view{i}.png\n\n", i + 1, i as f64 * 0.1);
        let img = RgbImage::from_fn(W, H, |x, y| match expected_id(i, x, y) {
            1 => Rgb(RED),
            2 => Rgb(GREEN),
            // A background with some texture, far from both keys.
            _ => Rgb([120 + (x % 5) as u8 * 4, 128, 140 - (y % 3) as u8 * 5]),
        });
        img.save(images.join(format!("view{i}.png"))).unwrap();
    }
    std::fs::write(sparse.join("images.txt"), lines).unwrap();
    std::fs::write(sparse.join("points3D.txt"), "").unwrap();
}

/// Runs the graph; returns each node's status from the --json report.
fn run(dir: &Path, sets: &[&str]) -> Vec<(String, String)> {
    let mut args = run_graph_ron(&["-j", "1"]);
    for s in sets {
        args.extend(["--set", s]);
    }
    assert_ok(&objectsplat(dir, &args), "the run");
    statuses(&read_json(&dir.join("report.json")))
}

fn ran(statuses: &[(String, String)]) -> Vec<&str> {
    statuses
        .iter()
        .filter(|(_, s)| s == "ran")
        .map(|(id, _)| id.as_str())
        .collect()
}

fn assert_masks(dir: &Path, keys: usize) {
    let masks = dir.join("out/masks/masks");
    for i in 0..RECTS.len() {
        let map = objectsplat_core::IdMap::load(&masks.join(format!("view{i}.png"))).unwrap();
        assert_eq!((map.width, map.height), (W, H));
        for y in 0..H {
            for x in 0..W {
                let want = match expected_id(i, x, y) {
                    2 if keys < 2 => 0,
                    id => id,
                };
                assert_eq!(map.get(x, y), want, "view{i} ({x}, {y})");
            }
        }
    }
    let objects = read_json(&masks.join(OBJECTS_JSON));
    assert_eq!(objects.as_object().unwrap().len(), keys);
}

#[test]
fn a_python_mask_source_feeds_import_masks() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    build_scene(d);
    std::fs::copy(example("graph.ron"), d.join("graph.ron")).unwrap();
    std::fs::copy(
        example("colour_key_masks.py"),
        d.join("colour_key_masks.py"),
    )
    .unwrap();

    let first = run(d, &[]);
    assert_eq!(ran(&first), ["scene", "sam", "masks"]);
    assert_masks(d, 2);

    assert_eq!(ran(&run(d, &[])), Vec::<&str>::new(), "a rerun is cached");

    // The script is part of the command's key; its output is unchanged, so import_masks
    // is served from the cache (early cutoff).
    let script = d.join("colour_key_masks.py");
    let mut text = std::fs::read_to_string(&script).unwrap();
    text += "\n# an edit that changes nothing\n";
    std::fs::write(&script, text).unwrap();
    assert_eq!(ran(&run(d, &[])), ["sam"]);

    // Options are params: one colour only → new masks.
    let one_key = r#"sam.options={"colours": [[220, 40, 40]], "tolerance": 30}"#;
    assert_eq!(ran(&run(d, &[one_key])), ["sam", "masks"]);
    assert_masks(d, 1);

    // A failing script fails its node, quoting its stderr.
    let no_colours = r#"sam.options={"colours": []}"#;
    let stderr = failure(&objectsplat(d, &run_graph_ron(&["--set", no_colours])));
    assert!(
        stderr.contains("sam")
            && stderr.contains("colours\" must be a non-empty list of [r, g, b]"),
        "{stderr}"
    );
}

#[test]
fn a_placeholder_typo_is_caught_by_check() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let graph = std::fs::read_to_string(example("graph.ron"))
        .unwrap()
        .replace("{in:frames}", "{in:frame}");
    std::fs::write(d.join("graph.ron"), &graph).unwrap();
    std::fs::write(d.join("colour_key_masks.py"), "").unwrap();
    let out = objectsplat(d, &["check", "graph.ron"]);
    let stderr = failure(&out);
    let line = graph.lines().position(|l| l.contains("argv:")).unwrap() + 1;
    assert!(
        stderr.contains(&format!("graph.ron:{line}:"))
            && stderr.contains(
                "param `argv`: {in:frame} names the input port `frame`, which is not declared; the inputs are frames"
            ),
        "{stderr}"
    );
}
