//! Surface completion on the synthetic room: the table's completed masks cover the
//! footprint of the objects standing on it; with no table the node is skipped.
//!
//! The expected footprint is computed here independently: in each frame, the pixels of
//! the objects resting on the table that lie in an enclosed hole of the table's mask
//! (a 4-connected flood fill of the non-table pixels from the image border).

use std::collections::VecDeque;
use std::path::Path;

mod support;
use support::objectsplat::{assert_ok, objectsplat, read_json, report_node};

const GRAPH: &str = r#"(
  nodes: {
    "scene":     (kind: "synthetic_scene", params: (seed: 7, views: 24, table: TABLE)),
    "masks":     (kind: "gt_masks", inputs: (frames: "scene.frames", mesh: "scene.mesh")),
    "parts":     (kind: "partition", inputs: (frames: "scene.frames", masks: "masks.masks")),
    "completed": (kind: "surface_completion",
                  inputs: (components: "parts.components", frames: "scene.frames", points: "scene.points")),
  },
  targets: ["masks", "parts", "completed"],
)"#;

/// Runs the graph (with or without the table); returns the `completed` node's report.
fn run_completion(dir: &Path, table: bool) -> serde_json::Value {
    std::fs::write(
        dir.join("g.ron"),
        GRAPH.replace("TABLE", if table { "true" } else { "false" }),
    )
    .unwrap();
    let out = objectsplat(dir, &["run", "g.ron", "--out", "out", "--json", "r.json"]);
    assert_ok(&out, "the run");
    report_node(&read_json(&dir.join("r.json")), "completed").clone()
}

fn gray(path: &Path) -> (u32, u32, Vec<u16>) {
    let img = image::open(path).unwrap();
    let (w, h) = (img.width(), img.height());
    (w, h, img.into_luma16().into_raw())
}

/// Pixels not reachable from the border through non-`set` pixels (4-connected).
fn enclosed(w: usize, h: usize, set: &[bool]) -> Vec<bool> {
    let mut outside = vec![false; w * h];
    let mut queue = VecDeque::new();
    for y in 0..h {
        for x in 0..w {
            if (x == 0 || y == 0 || x == w - 1 || y == h - 1) && !set[y * w + x] {
                outside[y * w + x] = true;
                queue.push_back((x, y));
            }
        }
    }
    while let Some((x, y)) = queue.pop_front() {
        let mut visit = |nx: usize, ny: usize| {
            let i = ny * w + nx;
            if !set[i] && !outside[i] {
                outside[i] = true;
                queue.push_back((nx, ny));
            }
        };
        if x > 0 {
            visit(x - 1, y);
        }
        if x + 1 < w {
            visit(x + 1, y);
        }
        if y > 0 {
            visit(x, y - 1);
        }
        if y + 1 < h {
            visit(x, y + 1);
        }
    }
    (0..w * h).map(|i| !set[i] && !outside[i]).collect()
}

#[test]
fn the_completed_table_covers_what_rests_on_it() {
    let dir = tempfile::tempdir().unwrap();
    let completed = run_completion(dir.path(), true);
    assert_eq!(completed["status"], "ran", "{completed}");
    let out = dir.path().join("out");
    let labels: std::collections::BTreeMap<String, String> = serde_json::from_str(
        &std::fs::read_to_string(out.join("masks/masks/objects.json")).unwrap(),
    )
    .unwrap();
    let id_of = |label: &str| {
        labels
            .iter()
            .find(|(_, l)| *l == label)
            .map(|(k, _)| k.parse::<u16>().unwrap())
            .unwrap()
    };
    let table = id_of("table");
    let resting: Vec<u16> = ["box", "cup", "ball"].iter().map(|l| id_of(l)).collect();
    let table_dir = format!("obj_{table}_table");
    let mut footprint_pixels = 0;
    for entry in std::fs::read_dir(out.join("masks/masks")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "png") {
            continue;
        }
        let stem = path.file_name().unwrap().to_owned();
        let (w, h, ids) = gray(&path);
        let before_path = out
            .join("parts/components")
            .join(&table_dir)
            .join("masks")
            .join(&stem);
        if !before_path.exists() {
            continue; // the table is not in this frame
        }
        let (_, _, before) = gray(&before_path);
        let (_, _, after) = gray(
            &out.join("completed/components")
                .join(&table_dir)
                .join("masks")
                .join(&stem),
        );
        // 8-bit masks read as 16-bit: 255 → 65535.
        let own = |v: u16| v == 65535;
        let table_set: Vec<bool> = before.iter().map(|&v| own(v)).collect();
        let holes = enclosed(w as usize, h as usize, &table_set);
        for i in 0..ids.len() {
            let on_table_object = resting.contains(&ids[i]);
            if holes[i] && on_table_object {
                footprint_pixels += 1;
                assert!(
                    own(after[i]),
                    "{stem:?}: pixel {i} of a resting object inside the table is not completed"
                );
            }
            if !holes[i] {
                assert_eq!(
                    before[i], after[i],
                    "{stem:?}: pixel {i} outside the table's holes changed"
                );
            }
        }
    }
    assert!(
        footprint_pixels > 100,
        "the objects on the table cover only {footprint_pixels} enclosed pixels"
    );
}

#[test]
fn without_a_table_the_node_is_skipped_with_a_reason() {
    let dir = tempfile::tempdir().unwrap();
    let completed = run_completion(dir.path(), false);
    assert_eq!(completed["status"], "skipped", "{completed}");
    assert!(
        completed["reason"]
            .as_str()
            .unwrap()
            .contains("support surface")
            || completed["reason"].as_str().unwrap().contains("table"),
        "{completed}"
    );
}
