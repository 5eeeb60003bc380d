//! Small scenes shared by the export tests.
#![allow(dead_code)]

use objectsplat_export::{ExportObject, SrgbColors};

/// Asserts `text` contains every one of `parts`, showing `text` when it does not.
pub fn assert_mentions(text: &str, parts: &[&str]) {
    for part in parts {
        assert!(text.contains(part), "{text}");
    }
}

/// An axis-aligned box [lo, hi] as 8 vertices and 12 triangles, one sRGB colour per corner.
pub fn cuboid(
    id: u16,
    label: &str,
    lo: [f32; 3],
    hi: [f32; 3],
    colors: [[u8; 3]; 8],
) -> ExportObject {
    let mut positions = Vec::new();
    for k in 0..8u32 {
        positions.push([
            if k & 1 == 0 { lo[0] } else { hi[0] },
            if k & 2 == 0 { lo[1] } else { hi[1] },
            if k & 4 == 0 { lo[2] } else { hi[2] },
        ]);
    }
    #[rustfmt::skip]
    let faces = vec![
        [0, 2, 1], [1, 2, 3], // z = lo
        [4, 5, 6], [5, 7, 6], // z = hi
        [0, 1, 4], [1, 5, 4], // y = lo
        [2, 6, 3], [3, 6, 7], // y = hi
        [0, 4, 2], [2, 4, 6], // x = lo
        [1, 3, 5], [3, 7, 5], // x = hi
    ];
    ExportObject::object(id, label, positions, faces, SrgbColors::U8(colors.to_vec()))
}

#[rustfmt::skip]
pub const CORNER_COLOURS: [[u8; 3]; 8] = [
    [0, 0, 0], [255, 255, 255], [128, 64, 10], [10, 128, 64],
    [64, 10, 128], [200, 30, 30], [30, 200, 30], [30, 30, 200],
];

/// A floor quad (background) with float sRGB colours.
pub fn floor() -> ExportObject {
    ExportObject::background(
        vec![
            [-2.0, -2.0, 0.0],
            [2.0, -2.0, 0.0],
            [2.0, 2.0, 0.0],
            [-2.0, 2.0, 0.0],
        ],
        vec![[0, 1, 2], [0, 2, 3]],
        SrgbColors::F32(vec![
            [0.5, 0.5, 0.5],
            [0.25, 0.5, 0.75],
            [1.0, 0.0, 0.0],
            [0.0, 0.04, 0.04045],
        ]),
    )
}

/// Two objects (one with a degenerate face and an unused far vertex) plus the floor.
pub fn scene() -> Vec<ExportObject> {
    let chair = cuboid(3, "chair", [0.0, 0.0, 0.0], [0.5, 0.5, 0.9], CORNER_COLOURS);
    let mut lamp = cuboid(
        7,
        "desk lamp",
        [1.0, -1.0, 0.7],
        [1.2, -0.8, 1.3],
        CORNER_COLOURS,
    );
    // A vertex no face uses (far away, must not widen the bounds) and two degenerate faces.
    lamp.positions.push([100.0, 100.0, 100.0]);
    if let SrgbColors::U8(c) = &mut lamp.colors_srgb {
        c.push([1, 2, 3]);
    }
    lamp.faces.push([0, 0, 1]);
    lamp.faces.push([0, 1, 1]);
    vec![chair, lamp, floor()]
}
