//! The synthetic room (objects resting on a table) through the real upstream stages —
//! `synthetic_scene`, `gt_masks`, `partition`, `surface_completion` — and a scene
//! standing in for a trained one: each object's model is its ground-truth mesh, the
//! table's is its ground-truth mesh, subdivided to ~1 cm triangles, minus every
//! triangle no frame sees (depth-tested against the whole room), which is what
//! training can reconstruct at best: the tabletop has holes under the objects.
#![allow(dead_code)] // each test file uses a different part

use objectsplat_completion::nodes::{CompleteSurfacesNode, SurfaceCompletionNode};
use objectsplat_core::glam::DVec3;
use objectsplat_core::{Camera, ComponentInfo, Frames, Mesh, ObjectLabels, read_mesh_artifact};
use objectsplat_masks::nodes::{GtMasksNode, PartitionNode};
use objectsplat_masks::{RasterOptions, rasterize};
use objectsplat_raster::Model;
use objectsplat_raster::sh::SH_DC;
use objectsplat_runtime::Outcome;
use objectsplat_runtime::testing::{NodeRun, run_node};
use objectsplat_scene::{Scene, SceneEntry, SceneObject, save_scene};
use objectsplat_synth::nodes::SyntheticSceneNode;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Table height of the synthetic room (its top's upper face), metres.
pub const TABLE_TOP: f64 = 0.75;
/// Objects standing on the table.
pub const RESTING: [&str; 3] = ["box", "cup", "ball"];
/// Objects on the floor that stay in the scene (they must not count as resting).
pub const ON_FLOOR: [&str; 2] = ["chair", "bin"];

pub struct Room {
    pub root: tempfile::TempDir,
    pub frames: PathBuf,
    pub points: PathBuf,
    /// `partition`'s components (no surface completed).
    pub parts: PathBuf,
    /// `surface_completion`'s components (the table completed per frame).
    pub completed: PathBuf,
    pub mesh: Mesh,
    pub labels: ObjectLabels,
    pub cameras: Vec<Camera>,
}

pub fn id_of(labels: &ObjectLabels, label: &str) -> u16 {
    *labels
        .iter()
        .find(|(_, l)| l.as_str() == label)
        .unwrap_or_else(|| panic!("no {label} in the room"))
        .0
}

/// The small room of the tests: 12 views of 128×96.
pub fn build() -> Room {
    build_with("(views: 12, width: 128, height: 96, split: \"all\", points: 2000, supersample: 1)")
}

/// The room with `synthetic_scene` params (RON struct text).
pub fn build_with(scene_params: &str) -> Room {
    let root = tempfile::tempdir().unwrap();
    let out = |name: &str| root.path().join(name);
    let scene = run_node(&SyntheticSceneNode, &[], scene_params, &out("scene"), None).unwrap();
    let (frames, mesh_dir, points) = (
        scene.outputs["frames"].clone(),
        scene.outputs["mesh"].clone(),
        scene.outputs["points"].clone(),
    );
    let masks = run_node(
        &GtMasksNode,
        &[("frames", &frames), ("mesh", &mesh_dir)],
        "()",
        &out("masks"),
        None,
    )
    .unwrap();
    let parts = run_node(
        &PartitionNode,
        &[("frames", &frames), ("masks", &masks.outputs["masks"])],
        "()",
        &out("parts"),
        None,
    )
    .unwrap();
    let completed = run_node(
        &SurfaceCompletionNode,
        &[
            ("components", &parts.outputs["components"]),
            ("frames", &frames),
            ("points", &points),
        ],
        "()",
        &out("completed"),
        None,
    )
    .unwrap();
    assert_eq!(completed.outcome, Outcome::Done, "{:?}", completed.notes);
    let (mesh, labels) = read_mesh_artifact(&mesh_dir).unwrap();
    let cameras = Frames::read(&frames)
        .unwrap()
        .frames
        .iter()
        .map(|f| f.camera())
        .collect();
    Room {
        frames,
        points,
        parts: parts.outputs["components"].clone(),
        completed: completed.outputs["components"].clone(),
        mesh,
        labels,
        cameras,
        root,
    }
}

/// The faces of one object of the ground-truth mesh.
pub fn object_faces(mesh: &Mesh, id: u16) -> Vec<[u32; 3]> {
    (0..mesh.faces.len())
        .filter(|&f| mesh.face_object(f) == i32::from(id))
        .map(|f| mesh.faces[f])
        .collect()
}

/// Triangles as corner positions and corner colours (sRGB in [0, 1]).
pub type Soup = Vec<([DVec3; 3], [[f64; 3]; 3])>;

pub fn soup(mesh: &Mesh, faces: &[[u32; 3]]) -> Soup {
    let colours = mesh.colors.as_ref().expect("the room's mesh is coloured");
    faces
        .iter()
        .map(|f| {
            (
                f.map(|v| DVec3::from_array(mesh.positions[v as usize].map(f64::from))),
                f.map(|v| colours[v as usize].map(|c| f64::from(c) / 255.0)),
            )
        })
        .collect()
}

/// Splits every triangle into four, `levels` times.
pub fn subdivide(mut tris: Soup, levels: usize) -> Soup {
    for _ in 0..levels {
        tris = tris
            .into_iter()
            .flat_map(|(p, c)| {
                let mid = |a: usize, b: usize| {
                    (
                        (p[a] + p[b]) / 2.0,
                        [0, 1, 2].map(|k| (c[a][k] + c[b][k]) / 2.0),
                    )
                };
                let (ab, bc, ca) = (mid(0, 1), mid(1, 2), mid(2, 0));
                [
                    ([p[0], ab.0, ca.0], [c[0], ab.1, ca.1]),
                    ([ab.0, p[1], bc.0], [ab.1, c[1], bc.1]),
                    ([ca.0, bc.0, p[2]], [ca.1, bc.1, c[2]]),
                    ([ab.0, bc.0, ca.0], [ab.1, bc.1, ca.1]),
                ]
            })
            .collect();
    }
    tris
}

/// The triangles whose centroid some camera sees: the pixel it projects to shows a
/// face of `id` at the centroid's depth (within 2 cm).
pub fn observed(room: &Room, tris: Soup, id: u16) -> Soup {
    let rasters: Vec<_> = room
        .cameras
        .iter()
        .map(|c| {
            rasterize(
                &room.mesh.positions,
                &room.mesh.faces,
                c,
                &RasterOptions::default(),
            )
            .unwrap()
        })
        .collect();
    tris.into_iter()
        .filter(|(p, _)| {
            let centroid = (p[0] + p[1] + p[2]) / 3.0;
            room.cameras.iter().zip(&rasters).any(|(camera, raster)| {
                let Some((u, v, z)) = camera.project(centroid) else {
                    return false;
                };
                if u < 0.0 || v < 0.0 || u >= camera.width as f64 || v >= camera.height as f64 {
                    return false;
                }
                let (x, y) = (u as u32, v as u32);
                raster.face_at(x, y).is_some_and(|f| {
                    room.mesh.face_object(f as usize) == i32::from(id)
                        && raster
                            .depth_at(x, y)
                            .is_some_and(|d| (f64::from(d) - z).abs() < 0.02)
                })
            })
        })
        .collect()
}

/// An opaque, view-independent model of a triangle soup (σ as at the end of training).
pub fn model_of(tris: &Soup) -> Model<f32> {
    let mut model = Model::<f32>::empty();
    model.sigma = 1e-4;
    let mut index: HashMap<[u64; 3], u32> = HashMap::new();
    for (p, c) in tris {
        let mut face = [0u32; 3];
        for k in 0..3 {
            let key = p[k].to_array().map(|v| (v as f32).to_bits() as u64);
            face[k] = *index.entry(key).or_insert_with(|| {
                model.vertices.push(p[k].to_array().map(|v| v as f32));
                let mut sh = [[0.0f32; 3]; objectsplat_raster::SH_COEFFS];
                sh[0] = c[k].map(|v| ((v - 0.5) / SH_DC) as f32);
                model.sh.push(sh);
                model.opacity_logits.push(10.0);
                (model.vertices.len() - 1) as u32
            });
        }
        model.faces.push(face);
    }
    model
}

pub fn member(labels: &ObjectLabels, label: &str, model: Model<f32>) -> SceneObject {
    let id = id_of(labels, label);
    let name = ComponentInfo::object(id, label).name;
    SceneObject {
        entry: SceneEntry::object(id, label, &name),
        model,
    }
}

/// The stand-in for a trained scene: the table as seen (see the module docs) and the
/// resting and floor objects' ground-truth meshes.
pub fn trained_scene(room: &Room) -> Scene {
    let table = id_of(&room.labels, "table");
    let seen = observed(
        room,
        subdivide(soup(&room.mesh, &object_faces(&room.mesh, table)), 3),
        table,
    );
    let mut table = model_of(&seen);
    // A trained model carries the flat colours its export draws (here its DC terms).
    table.flat_dc = table.sh.iter().map(|rows| rows[0]).collect();
    trained_scene_with_table(room, table)
}

pub fn trained_scene_with_table(room: &Room, table: Model<f32>) -> Scene {
    let mut objects = vec![member(&room.labels, "table", table)];
    for label in RESTING.iter().chain(&ON_FLOOR) {
        let id = id_of(&room.labels, label);
        objects.push(member(
            &room.labels,
            label,
            model_of(&soup(&room.mesh, &object_faces(&room.mesh, id))),
        ));
    }
    Scene::new(objects).unwrap()
}

pub fn write_scene(scene: &Scene, dir: &Path) -> PathBuf {
    save_scene(scene, dir).unwrap();
    dir.to_path_buf()
}

/// Runs `complete_surfaces` on the scene folder `scene` with `components` and the room's
/// frames (and its points when `with_points`), into `out`.
pub fn complete_surfaces(
    room: &Room,
    scene: &Path,
    components: &Path,
    with_points: bool,
    out: &Path,
) -> NodeRun {
    let mut inputs: Vec<(&str, &Path)> = vec![
        ("scene", scene),
        ("components", components),
        ("frames", &room.frames),
    ];
    if with_points {
        inputs.push(("points", &room.points));
    }
    run_node(&CompleteSurfacesNode, &inputs, "()", out, None).unwrap()
}

/// Builds the room, writes its trained scene to `trained` and completes it into `out`
/// (with the points when `with_points`), asserting the node ran: the room, the trained
/// scene, its folder and the run.
pub fn complete_trained_room(with_points: bool) -> (Room, Scene, PathBuf, NodeRun) {
    let room = build();
    let scene = trained_scene(&room);
    let scene_dir = write_scene(&scene, &room.root.path().join("trained"));
    let out = room.root.path().join("out");
    let run = complete_surfaces(&room, &scene_dir, &room.completed, with_points, &out);
    assert_eq!(run.outcome, Outcome::Done, "{:?}", run.notes);
    (room, scene, scene_dir, run)
}

/// The largest difference between two colours in any one channel.
pub fn colour_distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f64::max)
}
