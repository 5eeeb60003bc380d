//! Every artifact type the built-in nodes speak, declared once: its name, the files that
//! define its folder, and its encoding as users read it (`objectsplat nodes` prints it, and
//! the table in docs/artifacts.md is [`markdown_table`] — a test fails when they drift).
//!
//! The file names below are the only place they are spelled; every node, the plugin SDK and
//! the tests name files through these constants.

/// The Image artifact's one file.
pub const IMAGE_PNG: &str = "image.png";
/// The Mask artifact's one file.
pub const MASK_PNG: &str = "mask.png";
/// The camera list of Frames (and of every Component, which carries its frames).
pub const FRAMES_JSON: &str = "frames.json";
/// The Points artifact's one file.
pub const POINTS_PLY: &str = "points.ply";
/// The Visibility artifact's one file.
pub const VISIBILITY_BIN: &str = "visibility.bin";
/// The Mesh artifact's geometry.
pub const MESH_PLY: &str = "mesh.ply";
/// Object id → label, beside Masks and annotated Meshes.
pub const OBJECTS_JSON: &str = "objects.json";
/// What a Component is (name, kind, object id, label).
pub const COMPONENT_JSON: &str = "component.json";
/// A Component's per-frame ownership masks live in this sub-folder.
pub const COMPONENT_MASKS_DIR: &str = "masks";
/// A Component's completed target colours, where completion filled pixels.
pub const COMPONENT_TARGETS_DIR: &str = "targets";
/// Written into a Component by surface completion: it is a completed support surface.
pub const COMPONENT_COMPLETION_JSON: &str = "completion.json";
/// A Model's triangles, SH coefficients and opacities.
pub const MODEL_PLY: &str = "model.ply";
/// A Model's settings and metadata.
pub const MODEL_JSON: &str = "model.json";
/// The curves `train` records beside the model it wrote.
pub const TRAINING_JSON: &str = "training.json";
/// A Scene's member list.
pub const SCENE_JSON: &str = "scene.json";
/// A Scene's per-member Model folders live in this sub-folder.
pub const SCENE_OBJECTS_DIR: &str = "objects";
/// A Scene's per-frame fill images (completion's 2D fills) live in this sub-folder.
pub const SCENE_FILLS_DIR: &str = "fills";
/// The Metrics artifact's JSON.
pub const METRICS_JSON: &str = "metrics.json";
/// The Metrics artifact's table.
pub const METRICS_CSV: &str = "metrics.csv";
/// The binary glTF a scene export writes (a File artifact).
pub const SCENE_GLB: &str = "scene.glb";
/// The page a viewer or report writes (a File artifact).
pub const PAGE_HTML: &str = "index.html";

/// One artifact type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArtifactType {
    /// The type name graphs and node declarations use.
    pub name: &'static str,
    /// The file whose presence makes a folder this type (`None`: any non-empty folder).
    pub defining_file: Option<&'static str>,
    /// The encoding, as `objectsplat nodes` prints it and docs/artifacts.md tabulates it.
    pub doc: &'static str,
}

/// The types, in the order users meet them.
pub const TYPES: &[ArtifactType] = &[
    ArtifactType {
        name: "Image",
        defining_file: Some(IMAGE_PNG),
        doc: "`image.png` — 8-bit sRGB or 16-bit; grey, grey+alpha, RGB or RGBA",
    },
    ArtifactType {
        name: "Mask",
        defining_file: Some(MASK_PNG),
        doc: "`mask.png` — 8-bit grey; non-zero = set",
    },
    ArtifactType {
        name: "Images",
        defining_file: None,
        doc: "one PNG per frame, `<frame stem>.png`",
    },
    ArtifactType {
        name: "File",
        defining_file: None,
        doc: "whatever files the node writes (a `.glb`, an `index.html`, a PNG at a chosen \
              relative path)",
    },
    ArtifactType {
        name: "Frames",
        defining_file: Some(FRAMES_JSON),
        doc: "`frames.json` + the images it names. `frames.json` is a list of `{name, image, \
              width, height, fx, fy, cx, cy, world_to_camera, split}`; `image` is relative to \
              the folder; `split` is `\"train\"` or `\"test\"`. Optional `valid/<stem>.png` \
              (8-bit, 255 = use the pixel, 0 = ignore it): a source's own validity mask \
              (nerfstudio `mask_path`), and the pixels an undistorted image does not cover. \
              Frames are always pinhole: distorted sources are undistorted when loaded \
              (docs/artifacts.md, \"Capture sources\")",
    },
    ArtifactType {
        name: "Points",
        defining_file: Some(POINTS_PLY),
        doc: "`points.ply` — binary little-endian PLY, vertex `x,y,z` (float) + \
              `red,green,blue` (uchar)",
    },
    ArtifactType {
        name: "Visibility",
        defining_file: Some(VISIBILITY_BIN),
        doc: "`visibility.bin` — per frame, the scene points it sees (in front, inside the \
              image, not hidden behind nearer points): little-endian binary, magic \
              `OSVIS01\\0`, u64 point count, f64 neighbour spacing, u32 frames, then per \
              frame a u32-length name, a u32 count and (u32 point, u32 pixel, f32 depth) \
              entries",
    },
    ArtifactType {
        name: "Mesh",
        defining_file: Some(MESH_PLY),
        doc: "`mesh.ply` — binary PLY, vertex `x,y,z`, optional `red,green,blue`, optional \
              `object_id` (int, −1 = none); faces `vertex_indices` (uchar count, int indices) \
              — plus `objects.json` (id → label) when annotated. A face belongs to the object \
              of its first vertex (the ScanNet++ toolkit rule)",
    },
    ArtifactType {
        name: "Masks",
        defining_file: Some(OBJECTS_JSON),
        doc: "one 16-bit grey PNG per frame, `<frame stem>.png`: pixel = object id, 0 = no \
              object, 65535 = no surface (a hole in the scan; partition gives it to the \
              background) — plus `objects.json` (id → label)",
    },
    ArtifactType {
        name: "Component",
        defining_file: Some(COMPONENT_JSON),
        doc: "`component.json` `{name, kind, object_id, label}` (`kind` is `\"object\"` or `\"background\"`); \
              `frames.json` + images (the frames it appears in); `masks/<stem>.png` 8-bit: \
              255 = owned by this component, 0 = owned by another (an object supervises it \
              toward the random background colour, the background gives it zero weight), 128 = \
              never supervised; optional `targets/<stem>.png` replacing the frame's colours \
              where completion filled pixels",
    },
    ArtifactType {
        name: "Model",
        defining_file: Some(MODEL_PLY),
        doc: "`model.ply` (vertices, faces, per-vertex SH coefficients, opacity logits and, from `train`, flat colours) + \
              `model.json` (SH degree, opacity floor, σ, metadata); `train` adds \
              `training.json` (loss and size over the steps; no clock reading: its times are in the run \
              record, docs/engine.md#measurements). Encoding: nodes/raster/README.md",
    },
    ArtifactType {
        name: "Scene",
        defining_file: Some(SCENE_JSON),
        doc: "`scene.json` (members with name, kind, id, \
              label, source, optional `placement`; optional `edits`) + `objects/<name>/` (one \
              Model folder per member, in the member's model frame) + optional \
              `fills/<frame stem>.png`; a support surface `complete_surfaces` closed records \
              its patch (first vertex and face, plane, resting objects) in its `model.json` \
              metadata `surface_completion_3d`. Encoding: nodes/scene/README.md; placements: \
              docs/artifacts.md, \"Scene placements\"",
    },
    ArtifactType {
        name: "Metrics",
        defining_file: Some(METRICS_JSON),
        doc: "`metrics.json` — top level: scene averages `psnr`, `ssim`, `lpips` (null when \
              skipped), `fscore`, `precision`, `recall`, `tau`, `normal_consistency` (area-weighted \
              |cos| between the faces and the true surface nearest them), and with `evaluate`'s \
              `exported` input `exported_psnr`, `exported_ssim` (the test views rendered as the \
              `.glb` holds the scene: opaque, hard-edged, flat colours; null otherwise), \
              `background_in_front` (with the mesh: the share of the objects' true pixels in the \
              test views where the background member renders an at least half-opaque surface \
              nearer than the object by more than `tau`); `objects`: the same per object \
              with `id`, `label`, and `thresholds` (one `{tau, fscore, precision, recall}` per \
              extra threshold of `evaluate`'s `object_taus`, default 5 and 2 cm; absent in \
              older reports); per-image entries — and `metrics.csv` (extra thresholds as \
              `object_tau` rows)",
    },
];

/// The declared type called `name`.
pub fn find(name: &str) -> Option<&'static ArtifactType> {
    TYPES.iter().find(|t| t.name == name)
}

/// The table of types as docs/artifacts.md shows it.
pub fn markdown_table() -> String {
    let mut table = String::from("| type | folder contents |\n|---|---|\n");
    for t in TYPES {
        table.push_str(&format!("| `{}` | {} |\n", t.name, t.doc));
    }
    table
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_defining_file_is_named_in_its_doc() {
        for t in TYPES {
            if let Some(file) = t.defining_file {
                assert!(t.doc.contains(&format!("`{file}`")), "{}", t.name);
            }
        }
    }

    #[test]
    fn names_are_unique() {
        for (i, t) in TYPES.iter().enumerate() {
            assert!(
                TYPES[i + 1..].iter().all(|u| u.name != t.name),
                "{}",
                t.name
            );
        }
    }
}
