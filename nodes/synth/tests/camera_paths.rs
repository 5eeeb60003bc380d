//! Each camera path of the synthetic scene frames what it is named for, measured on
//! the ground-truth mesh's own pixels: the orbit and the walk see every small object
//! in most frames, the tabletop orbit shows the small objects over three times larger,
//! and the look-out views see walls and no small object.
//! Every camera stays inside the room.

use objectsplat_masks::raster::{RasterOptions, rasterize};
use objectsplat_synth::scene::{CameraPath, SyntheticScene, layout_bounds};
use objectsplat_synth::{SyntheticParams, scene};
use std::collections::BTreeMap;

fn generate(path: CameraPath) -> SyntheticScene {
    scene::generate(&SyntheticParams {
        seed: 5,
        views: 12,
        width: 96,
        height: 72,
        points: 200,
        path,
        ..Default::default()
    })
    .unwrap()
}

/// Over all frames: the share of pixels showing each label, and in how many frames
/// each label shows at all.
fn coverage(s: &SyntheticScene) -> (BTreeMap<String, f64>, BTreeMap<String, usize>) {
    let ids = s.mesh.object_ids.as_ref().unwrap();
    let mut pixels: BTreeMap<String, f64> = BTreeMap::new();
    let mut frames: BTreeMap<String, usize> = BTreeMap::new();
    let mut total = 0.0;
    for camera in s.cameras() {
        let raster = rasterize(
            &s.mesh.positions,
            &s.mesh.faces,
            &camera,
            &RasterOptions::default(),
        )
        .unwrap();
        let mut seen = std::collections::BTreeSet::new();
        for y in 0..camera.height {
            for x in 0..camera.width {
                total += 1.0;
                let Some(f) = raster.face_at(x, y) else {
                    continue;
                };
                let id = ids[s.mesh.faces[f as usize][0] as usize] as u16;
                let label = s.labels[&id].clone();
                *pixels.entry(label.clone()).or_default() += 1.0;
                seen.insert(label);
            }
        }
        for label in seen {
            *frames.entry(label).or_default() += 1;
        }
    }
    for v in pixels.values_mut() {
        *v /= total;
    }
    (pixels, frames)
}

#[test]
fn every_path_frames_what_it_is_named_for() {
    let paths = [
        CameraPath::Orbit,
        CameraPath::Walk,
        CameraPath::Inside,
        CameraPath::Tabletop,
    ];
    let mut share = BTreeMap::new();
    for path in paths {
        let s = generate(path);
        let (lo, hi) = layout_bounds();
        for camera in s.cameras() {
            let c = camera.center();
            assert!(
                (0..3).all(|k| c[k] > lo[k] && c[k] < hi[k]),
                "{path:?}: camera at {c} is outside the room"
            );
        }
        let (pixels, frames) = coverage(&s);
        let get = |m: &BTreeMap<String, f64>, l: &str| m.get(l).copied().unwrap_or(0.0);
        let small = ["box", "cup", "ball"]
            .iter()
            .map(|l| get(&pixels, l))
            .sum::<f64>();
        eprintln!("{path:?}: {pixels:?}");
        share.insert(format!("{path:?}"), small);
        match path {
            CameraPath::Orbit | CameraPath::Walk | CameraPath::Tabletop => {
                for label in ["box", "cup", "ball", "table"] {
                    assert!(
                        frames.get(label).copied().unwrap_or(0) >= 8,
                        "{path:?}: {label} in {:?} of 12 frames",
                        frames.get(label)
                    );
                }
            }
            CameraPath::Inside => {
                assert!(get(&pixels, "wall") > 0.5, "{path:?}: {pixels:?}");
                assert!(small < 0.01, "{path:?}: small objects {small}");
            }
        }
    }
    let (orbit_small, walk_small, table_small) = (share["Orbit"], share["Walk"], share["Tabletop"]);
    assert!(
        table_small > 3.0 * orbit_small && table_small > 3.0 * walk_small,
        "tabletop {table_small}, orbit {orbit_small}, walk {walk_small}"
    );
}

#[test]
fn an_unknown_path_is_refused_by_name() {
    let err = CameraPath::parse("drone").unwrap_err().to_string();
    assert!(
        err.contains("\"drone\"") && err.contains("tabletop"),
        "{err}"
    );
}
