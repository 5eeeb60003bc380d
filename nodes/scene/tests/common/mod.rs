//! Hand-made scenes for the node tests: a few opaque triangles per member.
#![allow(dead_code)]

use glam::DVec3;
use objectsplat_core::{Camera, Frame, Frames, Split};
use objectsplat_raster::sh::SH_DC;
use objectsplat_raster::{Model, SH_COEFFS, save_model};
use objectsplat_runtime::testing::{NodeRun, run_node};
use objectsplat_runtime::{Node, Registry};
use std::path::{Path, PathBuf};

/// Logit of an almost opaque vertex (sigmoid(8) ≈ 0.9997).
pub const OPAQUE: f32 = 8.0;

/// A flat square of two triangles in the plane y = `at.y` (seen by cameras on the
/// −Y side), `size` wide, in one view-independent sRGB colour. σ is tiny so the
/// window is ≈ 1 over the whole triangle: the render shows the flat colour.
pub fn square(at: [f32; 3], size: f32, rgb: [f32; 3]) -> Model<f32> {
    let h = size / 2.0;
    let [x, y, z] = at;
    let mut m = Model::<f32>::empty();
    m.vertices = vec![
        [x - h, y, z - h],
        [x + h, y, z - h],
        [x + h, y, z + h],
        [x - h, y, z + h],
    ];
    m.faces = vec![[0, 1, 2], [0, 2, 3]];
    let mut rows = [[0.0f32; 3]; SH_COEFFS];
    rows[0] = rgb.map(|c| ((c as f64 - 0.5) / SH_DC) as f32);
    m.sh = vec![rows; 4];
    m.opacity_logits = vec![OPAQUE; 4];
    m.sigma = 1e-3;
    m
}

/// Writes a `[Model]` collection: background wall far away, chair (id 3), cup (id 5), lamp (id 4).
pub fn write_models(dir: &Path) {
    save_model(
        &square([0.0, 3.0, 0.0], 6.0, [0.2, 0.3, 0.8]),
        &dir.join("background"),
    )
    .unwrap();
    save_model(
        &square([-0.6, 0.0, 0.0], 0.5, [0.9, 0.1, 0.1]),
        &dir.join("obj_3_chair"),
    )
    .unwrap();
    save_model(
        &square([0.6, 0.0, 0.0], 0.4, [0.1, 0.9, 0.1]),
        &dir.join("obj_5_cup"),
    )
    .unwrap();
    save_model(
        &square([0.0, 0.5, 0.6], 0.3, [0.9, 0.9, 0.1]),
        &dir.join("obj_4_lamp"),
    )
    .unwrap();
}

/// A camera on the −Y axis looking at the origin, Z up.
pub fn front_camera(width: u32, height: u32) -> Camera {
    Camera::look_at(
        width,
        height,
        width as f64,
        width as f64,
        DVec3::new(0.0, -4.0, 0.0),
        DVec3::ZERO,
        DVec3::Z,
    )
}

/// A Frames folder with the given cameras (images are written as grey placeholders
/// unless the caller overwrites them).
pub fn write_frames(dir: &Path, cameras: &[(String, Camera, Split)]) {
    std::fs::create_dir_all(dir.join("images")).unwrap();
    let frames: Vec<Frame> = cameras
        .iter()
        .map(|(name, cam, split)| {
            let image = format!("images/{name}.png");
            objectsplat_core::Image::from_fn(cam.width, cam.height, 3, |_, _, _| 0.5)
                .save_png8(&dir.join(&image))
                .unwrap();
            Frame::new(name, &image, cam, *split)
        })
        .collect();
    Frames::write_json(dir, &frames).unwrap();
}

/// Every file under `dir` with its bytes, by relative path.
pub fn files(dir: &Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    let mut out = std::collections::BTreeMap::new();
    fn walk(root: &Path, d: &Path, out: &mut std::collections::BTreeMap<String, Vec<u8>>) {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(root, &p, out);
            } else {
                let rel = p.strip_prefix(root).unwrap().to_string_lossy().into_owned();
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    walk(dir, dir, &mut out);
    out
}

/// The pixel whose centre is nearest the projection of `p`.
pub fn pixel_of(camera: &Camera, p: [f64; 3]) -> (u32, u32) {
    let (u, v, _) = camera.project(DVec3::from_array(p)).unwrap();
    (u.floor() as u32, v.floor() as u32)
}

/// Writes `tmp/frames`, a Frames folder whose views all share `camera`; returns its path.
pub fn write_frames_from(tmp: &Path, camera: Camera, views: &[(&str, Split)]) -> PathBuf {
    let dir = tmp.join("frames");
    let cameras: Vec<(String, Camera, Split)> = views
        .iter()
        .map(|&(name, split)| (name.to_string(), camera, split))
        .collect();
    write_frames(&dir, &cameras);
    dir
}

/// Runs `node` outside a graph, expecting success.
pub fn run(node: &dyn Node, inputs: &[(&str, &Path)], params: &str, out: &Path) -> NodeRun {
    run_node(node, inputs, params, out, None).unwrap()
}

/// Runs `node` outside a graph, expecting failure; returns the error with its causes.
pub fn run_error(node: &dyn Node, inputs: &[(&str, &Path)], params: &str, out: &Path) -> String {
    match run_node(node, inputs, params, out, None) {
        Ok(_) => panic!("{params} should have been refused"),
        Err(e) => format!("{e:#}"),
    }
}

/// Runs `render` with its defaults (the test views), returning the images folder.
pub fn rendered(scene: &Path, frames: &Path, out: &Path) -> PathBuf {
    let run = run(
        &objectsplat_scene::nodes::Render,
        &[("scene", scene), ("frames", frames)],
        "()",
        out,
    );
    run.outputs["images"].clone()
}

/// The parsed JSON file at `path`.
pub fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// A registry with the artifact types the scene nodes use and the scene nodes.
pub fn registry() -> Registry {
    let mut reg = Registry::new();
    for t in [
        "Model", "Scene", "Images", "Frames", "Mesh", "Masks", "Metrics", "File",
    ] {
        reg.add_type(t, "test type");
    }
    objectsplat_scene::register(&mut reg);
    reg
}

/// Runs `compose` on the test collection, returning the scene folder.
pub fn composed_scene(tmp: &Path) -> PathBuf {
    let models = tmp.join("models");
    write_models(&models);
    let run = run(
        &objectsplat_scene::nodes::Compose,
        &[("models", &models)],
        "()",
        &tmp.join("compose"),
    );
    run.outputs["scene"].clone()
}

/// Runs `edit_scene` with `edits` (RON list) on `scene`, returning the result or the error text.
pub fn edited(scene: &Path, edits: &str, out: &Path) -> Result<PathBuf, String> {
    run_node(
        &objectsplat_scene::nodes::EditScene,
        &[("scene", scene)],
        &format!("(edits: {edits})"),
        out,
        None,
    )
    .map(|run| run.outputs["scene"].clone())
    .map_err(|e| format!("{e:#}"))
}

/// Composes the test collection in a fresh folder and applies `edits` to it (into `e`),
/// returning the folder and the scene folders before and after.
pub fn composed_and_edited(edits: &str) -> (tempfile::TempDir, PathBuf, PathBuf) {
    let tmp = tempfile::tempdir().unwrap();
    let before = composed_scene(tmp.path());
    let after = edited(&before, edits, &tmp.path().join("e")).unwrap();
    (tmp, before, after)
}

/// Asserts `edits` on `scene` are refused with an error containing every one of `parts`.
pub fn assert_edit_refused(scene: &Path, edits: &str, out: &Path, parts: &[&str]) {
    let err = edited(scene, edits, out).unwrap_err();
    for part in parts {
        assert!(err.contains(part), "{err}");
    }
}

/// The visible surfaces of `scene`'s members as one ground-truth mesh, each vertex
/// carrying its member's object id (`background_id` for members without one).
pub fn surfaces_as_ground_truth(
    scene: &objectsplat_scene::Scene,
    background_id: i32,
) -> objectsplat_core::Mesh {
    let mut gt = objectsplat_core::Mesh {
        positions: vec![],
        faces: vec![],
        colors: None,
        object_ids: Some(vec![]),
    };
    for o in &scene.objects {
        let m = objectsplat_scene::surface::visible_mesh(&o.model);
        let base = gt.positions.len() as u32;
        gt.positions.extend(&m.positions);
        gt.faces.extend(m.faces.iter().map(|f| f.map(|v| v + base)));
        let id = o.entry.id.map_or(background_id, i32::from);
        gt.object_ids
            .as_mut()
            .expect("built with ids above")
            .extend(std::iter::repeat_n(id, m.positions.len()));
    }
    gt
}
