//! `surfaces: "fine"` covers the room's shell with detail a few pixels wide and finer
//! (bricks, tiles, a rug, a notice of glyphs) and changes nothing else: the same
//! mesh, cameras and objects. Measured on the ground-truth mesh's own pixels: the
//! shell's pixel-to-pixel contrast rises, the objects' pixels away from any edge keep
//! their colours exactly.

use objectsplat_masks::raster::{RasterOptions, rasterize};
use objectsplat_synth::scene::{Surfaces, SyntheticScene};
use objectsplat_synth::{SyntheticParams, scene};

fn generate(surfaces: Surfaces) -> SyntheticScene {
    scene::generate(&SyntheticParams {
        seed: 3,
        views: 8,
        width: 160,
        height: 120,
        points: 200,
        surfaces,
        ..Default::default()
    })
    .unwrap()
}

const SHELL: [&str; 3] = ["floor", "wall", "ceiling"];

/// Per frame, the label under each pixel (None: nothing) from the mesh.
fn labels(s: &SyntheticScene) -> Vec<Vec<Option<String>>> {
    let ids = s.mesh.object_ids.as_ref().unwrap();
    s.cameras()
        .iter()
        .map(|camera| {
            let raster = rasterize(
                &s.mesh.positions,
                &s.mesh.faces,
                camera,
                &RasterOptions::default(),
            )
            .unwrap();
            (0..camera.height)
                .flat_map(|y| (0..camera.width).map(move |x| (x, y)))
                .map(|(x, y)| {
                    raster.face_at(x, y).map(|f| {
                        let id = ids[s.mesh.faces[f as usize][0] as usize] as u16;
                        s.labels[&id].clone()
                    })
                })
                .collect()
        })
        .collect()
}

/// Mean absolute difference between horizontal neighbours whose labels are both
/// the shell's, over all frames and channels.
fn shell_contrast(s: &SyntheticScene, labels: &[Vec<Option<String>>]) -> f64 {
    let (mut sum, mut n) = (0.0, 0.0);
    for (image, labels) in s.images.iter().zip(labels) {
        let w = image.width as usize;
        for i in 0..labels.len() {
            let shell = |k: usize| labels[k].as_deref().is_some_and(|l| SHELL.contains(&l));
            if i % w + 1 == w || !shell(i) || !shell(i + 1) {
                continue;
            }
            for ch in 0..3 {
                sum += (image.rgb[i * 3 + ch] as f64 - image.rgb[(i + 1) * 3 + ch] as f64).abs();
                n += 1.0;
            }
        }
    }
    sum / n
}

#[test]
fn fine_surfaces_add_shell_detail_and_leave_the_objects_alone() {
    let (plain, fine) = (generate(Surfaces::Plain), generate(Surfaces::Fine));
    assert_eq!(plain.mesh.positions, fine.mesh.positions);
    assert_eq!(plain.mesh.faces, fine.mesh.faces);
    assert_eq!(plain.mesh.object_ids, fine.mesh.object_ids);
    assert_eq!(plain.frames, fine.frames);
    let labels = labels(&plain);

    let (before, after) = (
        shell_contrast(&plain, &labels),
        shell_contrast(&fine, &labels),
    );
    assert!(
        after > 1.3 * before,
        "shell contrast {before:.2} → {after:.2} levels per pixel"
    );

    // An object pixel whose 5×5 neighbourhood shows only that object (at pixel
    // centres; the frames take 2×2 samples) has the same colour in both rooms: the
    // objects' materials and the lighting are shared.
    let mut compared = 0;
    for ((a, b), labels) in plain.images.iter().zip(&fine.images).zip(&labels) {
        let (w, h) = (a.width as usize, a.height as usize);
        for y in 2..h - 2 {
            for x in 2..w - 2 {
                let label = &labels[y * w + x];
                let Some(l) = label.as_deref() else { continue };
                let inside = (0..25).all(|k| &labels[(y + k / 5 - 2) * w + x + k % 5 - 2] == label);
                if SHELL.contains(&l) || !inside {
                    continue;
                }
                let i = (y * w + x) * 3;
                assert_eq!(a.rgb[i..i + 3], b.rgb[i..i + 3], "{l} at ({x}, {y})");
                compared += 1;
            }
        }
    }
    assert!(compared > 1000, "only {compared} object pixels compared");
}

#[test]
fn an_unknown_surface_is_refused_by_name() {
    let err = Surfaces::parse("marble").unwrap_err().to_string();
    assert!(err.contains("marble") && err.contains("fine"), "{err}");
}
