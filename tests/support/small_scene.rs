//! A small hand-made scene (no training): a grey floor as the background and three
//! opaque, single-coloured boxes as objects, saved as a Scene folder.

use objectsplat_raster::sh::SH_DC;
use objectsplat_raster::{Model, SH_COEFFS};
use objectsplat_scene::{Scene, SceneEntry, SceneObject, save_scene};
use std::path::Path;

/// Logit of an almost opaque vertex (sigmoid(8) ≈ 0.9997).
const OPAQUE: f32 = 8.0;

/// An object: (id, label, lower corner, upper corner, sRGB colour).
pub type BoxSpec = (u16, &'static str, [f32; 3], [f32; 3], [f32; 3]);

/// The objects.
pub const BOXES: [BoxSpec; 3] = [
    (
        3,
        "chair",
        [-0.9, -0.3, 0.0],
        [-0.4, 0.2, 0.6],
        [0.8, 0.2, 0.2],
    ),
    (
        5,
        "cup",
        [0.3, -0.5, 0.0],
        [0.55, -0.25, 0.3],
        [0.2, 0.7, 0.3],
    ),
    (
        7,
        "desk lamp",
        [0.2, 0.4, 0.0],
        [0.5, 0.7, 0.9],
        [0.25, 0.35, 0.9],
    ),
];

fn coloured(vertices: Vec<[f32; 3]>, faces: Vec<[u32; 3]>, rgb: [f32; 3]) -> Model<f32> {
    let mut m = Model::<f32>::empty();
    let mut rows = [[0.0f32; 3]; SH_COEFFS];
    rows[0] = rgb.map(|c| ((c as f64 - 0.5) / SH_DC) as f32);
    m.sh = vec![rows; vertices.len()];
    m.opacity_logits = vec![OPAQUE; vertices.len()];
    m.vertices = vertices;
    m.faces = faces;
    m.sigma = 1e-3;
    m
}

/// The six sides of a box, two triangles each (corner k has bits x, y, z).
const CUBOID_SIDES: [[[u32; 3]; 2]; 6] = [
    [[0, 2, 1], [1, 2, 3]],
    [[4, 5, 6], [5, 7, 6]],
    [[0, 1, 4], [1, 5, 4]],
    [[2, 6, 3], [3, 6, 7]],
    [[0, 4, 2], [2, 4, 6]],
    [[1, 3, 5], [3, 7, 5]],
];

/// An axis-aligned box as 8 corners and 12 triangles.
pub fn cuboid(lo: [f32; 3], hi: [f32; 3], rgb: [f32; 3]) -> Model<f32> {
    let vertices = (0..8u32)
        .map(|k| {
            [
                if k & 1 == 0 { lo[0] } else { hi[0] },
                if k & 2 == 0 { lo[1] } else { hi[1] },
                if k & 4 == 0 { lo[2] } else { hi[2] },
            ]
        })
        .collect();
    let faces = CUBOID_SIDES.iter().flatten().copied().collect();
    coloured(vertices, faces, rgb)
}

/// A 4 m × 4 m floor at z = 0 in 0.25 m squares: small triangles, so the splatting
/// renderer's per-tile depth order (by triangle centroid) puts the boxes in front of it.
fn floor() -> Model<f32> {
    const CELLS: u32 = 16;
    let mut vertices = Vec::new();
    for j in 0..=CELLS {
        for i in 0..=CELLS {
            vertices.push([-2.0 + 0.25 * i as f32, -2.0 + 0.25 * j as f32, 0.0]);
        }
    }
    let mut faces = Vec::new();
    for j in 0..CELLS {
        for i in 0..CELLS {
            let a = j * (CELLS + 1) + i;
            let (b, c, d) = (a + 1, a + CELLS + 2, a + CELLS + 1);
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
    }
    coloured(vertices, faces, [0.55, 0.55, 0.5])
}

/// The floor (background) and the three boxes.
pub fn scene() -> Scene {
    let floor = floor();
    let mut members = vec![SceneObject {
        entry: SceneEntry::from_component(
            &objectsplat_core::ComponentInfo::background(),
            "background",
        ),
        model: floor,
    }];
    for (id, label, lo, hi, rgb) in BOXES {
        let entry = SceneEntry::object(
            id,
            label,
            &objectsplat_core::component::object_item_name(id, label),
        );
        members.push(SceneObject {
            entry,
            model: cuboid(lo, hi, rgb),
        });
    }
    Scene::new(members).unwrap()
}

/// Writes [`scene`] as a Scene folder at `dir`.
pub fn write(dir: &Path) {
    save_scene(&scene(), dir).unwrap();
}
