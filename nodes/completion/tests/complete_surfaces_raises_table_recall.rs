//! `complete_surfaces` on the synthetic room (tests/room): the table's recall against
//! its complete ground-truth mesh rises at τ = 5 cm and 2 cm, its precision falls by
//! no more than 0.02, every added vertex lies on the tabletop inside its outline, the
//! objects on the floor are not taken for resting ones, and the new colours come from
//! the frames (close to the tabletop's own).

mod room;

use objectsplat_completion::surface_mesh::METADATA_KEY;
use objectsplat_core::Mesh;
use objectsplat_core::glam::DVec3;
use objectsplat_metrics::{MeshEvalParams, fscore, mesh_points};
use objectsplat_raster::sh::SH_DC;
use objectsplat_runtime::Outcome;
use objectsplat_scene::load_scene;
use objectsplat_scene::surface::visible_mesh;
use room::{RESTING, TABLE_TOP, id_of, object_faces};

fn table_scores(pred: &objectsplat_raster::Model<f32>, gt: &[[f64; 3]], tau: f64) -> (f64, f64) {
    let points = mesh_points(&visible_mesh(pred), &MeshEvalParams::default()).unwrap();
    let s = fscore(&points, gt, tau).unwrap();
    (s.recall, s.precision)
}

#[test]
fn completion_raises_table_recall_and_keeps_its_precision() {
    let (room, scene, scene_dir, run) = room::complete_trained_room(true);
    let completed = load_scene(&run.outputs["scene"]).unwrap();

    let table_id = id_of(&room.labels, "table");
    let find = |s: &objectsplat_scene::Scene| s.objects[s.find_id(table_id).unwrap()].model.clone();
    let (before, after) = (find(&scene), find(&completed));
    let note = run
        .notes
        .iter()
        .find(|(k, _)| k.starts_with("surface obj_") && k.ends_with("_table"))
        .map(|(_, v)| v.clone())
        .unwrap_or_default();
    for label in RESTING {
        assert!(note.contains(label), "{label} not resting: {note}");
    }
    for label in room::ON_FLOOR {
        assert!(!note.contains(label), "{label} taken for resting: {note}");
    }
    // Every other member is unchanged.
    for (a, b) in scene.objects.iter().zip(&completed.objects) {
        if a.entry.id != Some(table_id) {
            assert_eq!(a, b);
        }
    }

    // The patch: on the tabletop plane, inside its rectangle (in the table's own frame).
    let meta = &after.metadata[METADATA_KEY];
    let first = meta["first_vertex"].as_u64().unwrap() as usize;
    assert_eq!(first, before.vertices.len());
    assert_eq!(
        after.faces.len(),
        before.faces.len() + meta["faces"].as_u64().unwrap() as usize
    );
    assert!(after.vertices.len() > first);
    // The trained table carries flat colours for its export; so does its patch.
    assert_eq!(before.flat_dc.len(), before.vertices.len());
    assert_eq!(after.flat_dc.len(), after.vertices.len());
    let top = top_rectangle(&room.mesh, table_id);
    for v in &after.vertices[first..] {
        let p = DVec3::from_array(v.map(f64::from));
        assert!(
            (p.z - TABLE_TOP).abs() < 0.01,
            "vertex {p} is off the tabletop"
        );
        assert!(top.contains(p), "vertex {p} lies outside the tabletop");
    }
    // Colours: the tabletop's (wood), not the objects' that hid it.
    let table_colour = mean_colour(&before, 0..before.vertices.len(), |p| {
        (p.z - TABLE_TOP).abs() < 1e-3
    });
    let patch_colour = mean_colour(&after, first..after.vertices.len(), |_| true);
    let distance = room::colour_distance(table_colour, patch_colour);
    assert!(
        distance < 0.12,
        "patch colour {patch_colour:?} is far from the tabletop's {table_colour:?}"
    );

    // Recall against the complete table rises; precision falls by at most 0.02.
    let gt_table = Mesh {
        positions: room.mesh.positions.clone(),
        faces: object_faces(&room.mesh, table_id),
        colors: None,
        object_ids: None,
    };
    let gt = mesh_points(&gt_table, &MeshEvalParams::default()).unwrap();
    for tau in [0.05, 0.02] {
        let (recall_off, precision_off) = table_scores(&before, &gt, tau);
        let (recall_on, precision_on) = table_scores(&after, &gt, tau);
        eprintln!(
            "τ = {tau}: recall {recall_off:.4} → {recall_on:.4}, precision {precision_off:.4} → {precision_on:.4}"
        );
        assert!(recall_on > recall_off, "τ = {tau}: recall did not rise");
        assert!(
            precision_on >= precision_off - 0.02,
            "τ = {tau}: precision fell from {precision_off} to {precision_on}"
        );
    }
    // The points input is optional: without it the same plane and patch come out.
    let out = room.root.path().join("out_no_points");
    let without_points = room::complete_surfaces(&room, &scene_dir, &room.completed, false, &out);
    assert_eq!(without_points.outcome, Outcome::Done);
}

/// The tabletop's rectangle: the table's vertices at the top height, in the frame of
/// the top's edges (the table is turned about z).
struct Rectangle {
    centre: DVec3,
    axes: [DVec3; 2],
    half: [f64; 2],
}

impl Rectangle {
    fn contains(&self, p: DVec3) -> bool {
        (0..2).all(|k| ((p - self.centre).dot(self.axes[k])).abs() <= self.half[k] + 1e-3)
    }
}

fn top_rectangle(mesh: &Mesh, table: u16) -> Rectangle {
    let top: Vec<DVec3> = object_faces(mesh, table)
        .iter()
        .flatten()
        .map(|&v| DVec3::from_array(mesh.positions[v as usize].map(f64::from)))
        .filter(|p| (p.z - TABLE_TOP).abs() < 1e-4)
        .collect();
    let centre = top.iter().sum::<DVec3>() / top.len() as f64;
    // The corner farthest from the centre, and the two nearest to it span the edges.
    let far = *top
        .iter()
        .max_by(|a, b| (**a - centre).length().total_cmp(&(**b - centre).length()))
        .unwrap();
    let corners: Vec<DVec3> = top
        .iter()
        .filter(|p| ((**p - centre).length() - (far - centre).length()).abs() < 1e-3)
        .copied()
        .collect();
    let mut edges: Vec<DVec3> = corners
        .iter()
        .map(|c| *c - far)
        .filter(|e| e.length() > 1e-3)
        .collect();
    edges.sort_by(|a, b| a.length().total_cmp(&b.length()));
    // Corners repeat (faces of the top and its rim do not share vertices): the second
    // edge is the shortest one across the first.
    let a = edges[0];
    let b = *edges
        .iter()
        .find(|e| e.normalize().dot(a.normalize()).abs() < 0.5)
        .unwrap();
    Rectangle {
        centre,
        axes: [a.normalize(), b.normalize()],
        half: [a.length() / 2.0, b.length() / 2.0],
    }
}

fn mean_colour(
    model: &objectsplat_raster::Model<f32>,
    range: std::ops::Range<usize>,
    keep: impl Fn(DVec3) -> bool,
) -> [f64; 3] {
    let mut sum = [0.0; 3];
    let mut n = 0.0;
    for v in range {
        if !keep(DVec3::from_array(model.vertices[v].map(f64::from))) {
            continue;
        }
        for (c, s) in sum.iter_mut().enumerate() {
            *s += 0.5 + SH_DC * f64::from(model.sh[v][0][c]);
        }
        n += 1.0;
    }
    sum.map(|s| s / n)
}
