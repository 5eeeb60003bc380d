//! Completion on vs off on the synthetic room (the demo's room: 24 views of 160×120,
//! every frame used), with the tests' stand-in for a trained scene (tests/room: every
//! object's ground-truth mesh, the table's minus what no frame sees, the room's floor,
//! walls and ceiling as the background):
//!
//! - the table's precision and recall against its complete ground-truth mesh at 5 and 2 cm,
//!   and the recall of its tabletop (the upper face, where the holes are) at 2 cm;
//! - the whole scene's F-score (5 cm) against the whole ground-truth mesh;
//! - PSNR of renders from every frame against the photos;
//! - the time of `complete_surfaces`, and of `surface_completion` (the per-frame stage it
//!   follows) in the same run as the peer to quote it against.
//!
//!   cargo run --release -p objectsplat-completion --example bench_complete_surfaces

#[path = "../tests/room/mod.rs"]
mod room;

use objectsplat_completion::nodes::{CompleteSurfacesNode, SurfaceCompletionNode};
use objectsplat_core::{ComponentInfo, Frames, Mesh};
use objectsplat_metrics::{MeshEvalParams, fscore, mesh_points, psnr};
use objectsplat_raster::CpuBackend;
use objectsplat_runtime::testing::run_node;
use objectsplat_scene::render::{Backdrop, render_view};
use objectsplat_scene::surface::visible_mesh;
use objectsplat_scene::{Scene, SceneEntry, SceneObject, load_scene};
use std::time::Instant;

const RUNS: usize = 5;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let room = room::build_with("(views: 24, width: 160, height: 120, split: \"all\")");
    let mut off = room::trained_scene(&room);
    // The background: floor, walls and ceiling, whole.
    let background: Vec<[u32; 3]> = ["floor", "wall", "ceiling"]
        .iter()
        .flat_map(|label| {
            room.labels
                .iter()
                .filter(move |(_, l)| l.as_str() == *label)
                .flat_map(|(id, _)| room::object_faces(&room.mesh, *id))
                .collect::<Vec<_>>()
        })
        .collect();
    off.objects.push(SceneObject {
        entry: SceneEntry::from_component(&ComponentInfo::background(), "background"),
        model: room::model_of(&room::soup(&room.mesh, &background)),
    });
    let off = Scene::new(off.objects).unwrap();
    let scene_dir = room::write_scene(&off, &room.root.path().join("trained"));

    let mut times = Vec::new();
    let mut on = None;
    for k in 0..RUNS {
        let start = Instant::now();
        let run = run_node(
            &CompleteSurfacesNode,
            &[
                ("scene", &scene_dir),
                ("components", &room.completed),
                ("frames", &room.frames),
                ("points", &room.points),
            ],
            "()",
            &room.root.path().join(format!("on_{k}")),
            None,
        )
        .unwrap();
        times.push(start.elapsed().as_secs_f64());
        if k == 0 {
            for (key, value) in &run.notes {
                println!("note {key}: {value}");
            }
        }
        on = Some(load_scene(&run.outputs["scene"]).unwrap());
    }
    let on = on.unwrap();
    let mut peer = Vec::new();
    for k in 0..RUNS {
        let start = Instant::now();
        run_node(
            &SurfaceCompletionNode,
            &[
                ("components", &room.parts),
                ("frames", &room.frames),
                ("points", &room.points),
            ],
            "()",
            &room.root.path().join(format!("peer_{k}")),
            None,
        )
        .unwrap();
        peer.push(start.elapsed().as_secs_f64());
    }

    let params = MeshEvalParams::default();
    let table = room::id_of(&room.labels, "table");
    let gt_table = mesh_points(
        &Mesh {
            positions: room.mesh.positions.clone(),
            faces: room::object_faces(&room.mesh, table),
            ..Mesh::default()
        },
        &params,
    )
    .unwrap();
    // The tabletop alone (its upper face), where the holes are.
    let top_faces: Vec<[u32; 3]> = room::object_faces(&room.mesh, table)
        .into_iter()
        .filter(|f| {
            f.iter().all(|&v| {
                (f64::from(room.mesh.positions[v as usize][2]) - room::TABLE_TOP).abs() < 1e-4
            })
        })
        .collect();
    let gt_top = mesh_points(
        &Mesh {
            positions: room.mesh.positions.clone(),
            faces: top_faces,
            ..Mesh::default()
        },
        &params,
    )
    .unwrap();
    let gt_scene = mesh_points(
        &Mesh {
            positions: room.mesh.positions.clone(),
            faces: room.mesh.faces.clone(),
            ..Mesh::default()
        },
        &params,
    )
    .unwrap();
    let frames = Frames::read(&room.frames).unwrap();
    println!(
        "| | table P@5cm | table R@5cm | table P@2cm | table R@2cm | tabletop R@2cm | scene F@5cm | PSNR (dB) | table faces |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (name, scene) in [("off", &off), ("on", &on)] {
        let member = &scene.objects[scene.find_id(table).unwrap()].model;
        let pred = mesh_points(&visible_mesh(member), &params).unwrap();
        let at5 = fscore(&pred, &gt_table, 0.05).unwrap();
        let at2 = fscore(&pred, &gt_table, 0.02).unwrap();
        let top = fscore(&pred, &gt_top, 0.02).unwrap();
        let merged = scene.merged_model().unwrap();
        let whole = mesh_points(&visible_mesh(&merged.model), &params).unwrap();
        let f = fscore(&whole, &gt_scene, 0.05).unwrap();
        let mut total = 0.0;
        for frame in &frames.frames {
            let render = render_view(
                &merged.model,
                &frame.camera(),
                &Backdrop::Uniform([0.0; 3]),
                &CpuBackend::new(2),
                1,
            )
            .unwrap();
            total += psnr(&render, &frames.load_rgb(frame).unwrap(), None).unwrap();
        }
        println!(
            "| {name} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.4} | {:.2} | {} |",
            at5.precision,
            at5.recall,
            at2.precision,
            at2.recall,
            top.recall,
            f.fscore,
            total / frames.frames.len() as f64,
            member.faces.len()
        );
    }
    let (ours, theirs) = (median(times), median(peer));
    println!(
        "complete_surfaces: median {ours:.3} s of {RUNS}; surface_completion (same room, same run): median {theirs:.3} s; ratio {:.2}",
        ours / theirs
    );
}
