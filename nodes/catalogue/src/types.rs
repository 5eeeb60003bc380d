//! The artifact types every built-in node speaks, with their on-disk encodings
//! (the text `objectsplat nodes` prints and plugin authors read).

use objectsplat_runtime::Registry;

pub const TYPES: &[(&str, &str)] = &[
    (
        "Image",
        "a folder with `image.png` (8-bit sRGB or 16-bit; grey, RGB or RGBA)",
    ),
    (
        "Mask",
        "a folder with `mask.png` (8-bit grey; non-zero = set)",
    ),
    ("Images", "a folder of PNGs named `<frame stem>.png`"),
    (
        "File",
        "a folder of files written by the node (e.g. a .glb or .html), materialized under OUT/<node>/<port>/",
    ),
    (
        "Frames",
        "a folder with `frames.json` — a list of {name, image, width, height, fx, fy, cx, cy, world_to_camera (4×4 row-major, OpenCV axes), split: \"train\"|\"test\"} — and the images it names",
    ),
    (
        "Points",
        "a folder with `points.ply`: binary PLY, vertex x,y,z (float) + red,green,blue (uchar)",
    ),
    (
        "Mesh",
        "a folder with `mesh.ply` (binary PLY; vertex x,y,z, optional red,green,blue and object_id (int, −1 = none); faces vertex_indices) and, when annotated, `objects.json` (id → label)",
    ),
    (
        "Masks",
        "a folder with one 16-bit grey PNG per frame named `<frame stem>.png` (pixel = object id, 0 = no object, 65535 = no surface) and `objects.json` (id → label)",
    ),
    (
        "Component",
        "a folder: `component.json` {name, kind: object|background, object_id, label}, `frames.json` + images, `masks/<stem>.png` (255 own, 0 other, 128 ignore), optional `targets/<stem>.png`",
    ),
    (
        "Model",
        "a folder with `model.ply` (vertices, faces, SH coefficients, opacity logits) and `model.json`; see docs/artifacts.md",
    ),
    (
        "Scene",
        "a folder with `scene.json` (objects: id, label, name) and one Model folder per object under `objects/<name>/`",
    ),
    (
        "Metrics",
        "a folder with `metrics.json` (psnr, ssim, lpips, fscore, precision, recall, tau, objects[...]) and `metrics.csv`",
    ),
];

pub fn register(reg: &mut Registry) {
    for (name, doc) in TYPES {
        reg.add_type(name, doc);
    }
}
