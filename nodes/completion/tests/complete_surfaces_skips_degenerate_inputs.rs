//! `complete_surfaces` skips, with a reason and the scene passed on untouched, every
//! support surface it cannot complete soundly (tests/room): no support surface
//! upstream, a surface seen in one view, a surface nothing rests on, objects covering
//! (almost) the whole top, and a "table" that is not planar.

mod room;

use objectsplat_core::component::OTHER;
use objectsplat_core::glam::{DVec2, DVec3};
use objectsplat_runtime::Outcome;
use objectsplat_runtime::testing::NodeRun;
use objectsplat_scene::Scene;
use room::{Room, Soup, TABLE_TOP, id_of, object_faces, soup, subdivide};
use std::path::Path;

fn run(room: &Room, scene: &Scene, components: &Path, name: &str) -> NodeRun {
    run_with(room, scene, components, name, true)
}

fn run_with(room: &Room, scene: &Scene, components: &Path, name: &str, points: bool) -> NodeRun {
    let dir = room::write_scene(scene, &room.root.path().join(format!("{name}_in")));
    let out = room.root.path().join(format!("{name}_out"));
    let run = room::complete_surfaces(room, &dir, components, points, &out);
    // Skipped: the output is the input scene itself, so nothing was added anywhere.
    if matches!(run.outcome, Outcome::Skipped(_)) {
        assert_eq!(
            run.outputs["scene"], dir,
            "{name}: a skip must forward the scene"
        );
    }
    run
}

fn skipped_because(run: &NodeRun, words: &str) {
    match &run.outcome {
        Outcome::Skipped(reason) => assert!(
            reason.contains(words),
            "skip reason {reason:?} does not say {words:?}"
        ),
        other => panic!(
            "expected a skip saying {words:?}, got {other:?} ({:?})",
            run.notes
        ),
    }
}

#[test]
fn no_support_surface_upstream() {
    let room = room::build();
    // partition's components: surface_completion never marked a surface.
    let out = run(&room, &room::trained_scene(&room), &room.parts, "none");
    skipped_because(&out, "no support surface");
}

#[test]
fn a_surface_seen_in_one_view() {
    let room = room::build();
    let components = room.root.path().join("one_view");
    copy_tree(&room.completed, &components);
    let table = objectsplat_core::ComponentInfo::object(id_of(&room.labels, "table"), "table").name;
    let masks = components.join(&table).join("masks");
    let mut files: Vec<_> = std::fs::read_dir(&masks)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    for path in &files[1..] {
        let mask = image::open(path).unwrap().to_luma8();
        let blank = image::GrayImage::from_pixel(mask.width(), mask.height(), image::Luma([OTHER]));
        std::fs::remove_file(path).unwrap();
        blank.save(path).unwrap();
    }
    let out = run(&room, &room::trained_scene(&room), &components, "one_view");
    skipped_because(&out, "seen in 1 view");
}

#[test]
fn a_surface_nothing_rests_on() {
    let room = room::build();
    let mut scene = room::trained_scene(&room);
    let table = id_of(&room.labels, "table");
    scene.objects.retain(|o| o.entry.id == Some(table));
    let out = run(&room, &scene, &room.completed, "alone");
    skipped_because(&out, "no object rests on the surface");
}

/// The upper face of the tabletop, as triangles.
fn top_face(room: &Room) -> Soup {
    let table = id_of(&room.labels, "table");
    soup(&room.mesh, &object_faces(&room.mesh, table))
        .into_iter()
        .filter(|(p, _)| p.iter().all(|c| (c.z - TABLE_TOP).abs() < 1e-4))
        .collect()
}

/// The mean of the triangles' corners.
fn centroid(tris: &Soup) -> DVec3 {
    tris.iter().map(|(p, _)| p[0] + p[1] + p[2]).sum::<DVec3>() / (3 * tris.len()) as f64
}

fn inside(tris: &Soup, p: DVec3) -> bool {
    let q = DVec2::new(p.x, p.y);
    tris.iter().any(|(t, _)| {
        let t = t.map(|c| DVec2::new(c.x, c.y));
        let s = |a: DVec2, b: DVec2| (b - a).perp_dot(q - a);
        let (d0, d1, d2) = (s(t[0], t[1]), s(t[1], t[2]), s(t[2], t[0]));
        (d0 >= 0.0 && d1 >= 0.0 && d2 >= 0.0) || (d0 <= 0.0 && d1 <= 0.0 && d2 <= 0.0)
    })
}

#[test]
fn objects_covering_the_whole_top() {
    let room = room::build();
    let top = top_face(&room);
    let centre = centroid(&top);
    // A tray over 90% of the top (each way), lying on it.
    let tray: Soup = top
        .iter()
        .map(|(p, c)| {
            (
                p.map(|v| {
                    centre
                        + (v - centre) * DVec3::new(0.9, 0.9, 0.0)
                        + DVec3::Z * (TABLE_TOP - centre.z + 0.002)
                }),
                *c,
            )
        })
        .collect();
    // The table as training would see it: the slab's top and upper rim around the tray.
    let table = id_of(&room.labels, "table");
    let slab: Soup = subdivide(soup(&room.mesh, &object_faces(&room.mesh, table)), 3)
        .into_iter()
        .filter(|(p, _)| {
            let c = (p[0] + p[1] + p[2]) / 3.0;
            c.z > TABLE_TOP - 0.03 && !(c.z > TABLE_TOP - 1e-4 && inside(&tray, c))
        })
        .collect();
    let mut scene = Scene::new(vec![
        room::member(&room.labels, "table", room::model_of(&slab)),
        room::member(&room.labels, "box", room::model_of(&tray)),
    ])
    .unwrap();
    scene.edits.clear();
    let out = run(&room, &scene, &room.completed, "covered");
    skipped_because(&out, "objects cover");
}

#[test]
fn a_table_that_is_not_planar() {
    let room = room::build();
    // The tabletop bent into a bowl: 35 cm higher at the corners than at the centre.
    let top = top_face(&room);
    let centre = centroid(&top);
    let bowl: Soup = subdivide(top, 2)
        .into_iter()
        .map(|(p, c)| {
            (
                p.map(|v| {
                    let r2 = (v - centre).truncate().length_squared();
                    DVec3::new(v.x, v.y, TABLE_TOP + 0.7 * r2)
                }),
                c,
            )
        })
        .collect();
    let scene = room::trained_scene_with_table(&room, room::model_of(&bowl));
    // Without points the trained faces decide (the room's points would say the real,
    // flat table is planar).
    let out = run_with(&room, &scene, &room.completed, "bowl", false);
    skipped_because(&out, "not planar");
    skipped_because(&out, "of its visible area");
}

fn copy_tree(src: &Path, dst: &Path) {
    std::fs::create_dir_all(dst).unwrap();
    for entry in std::fs::read_dir(src).unwrap() {
        let entry = entry.unwrap();
        let to = dst.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_tree(&entry.path(), &to);
        } else {
            std::fs::copy(entry.path(), &to).unwrap();
        }
    }
}
