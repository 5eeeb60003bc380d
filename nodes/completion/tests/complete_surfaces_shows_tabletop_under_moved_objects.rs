//! Editing a completed scene (tests/room): after the box is removed or moved away,
//! a camera looking straight down at where it stood sees tabletop — the completed
//! patch, coloured like the table — where the uncompleted scene shows the backdrop
//! through the hole the box left.

mod room;

use objectsplat_core::Camera;
use objectsplat_core::glam::DVec3;
use objectsplat_raster::CpuBackend;
use objectsplat_scene::edit::Num;
use objectsplat_scene::render::{Backdrop, render_view};
use objectsplat_scene::{Edit, Scene, Target, apply_edits, load_scene};
use room::{TABLE_TOP, id_of, object_faces};

const BACKDROP: [f32; 3] = [1.0, 0.0, 1.0];
// Close enough that the ~1 cm triangles are several pixels across (the renderer culls
// triangles whose inradius is under a pixel).
const SIZE: u32 = 128;

/// Pixels of a top-down view that look at the inner 60% of the box's base.
fn footprint_pixels(base: &[DVec3], camera: &Camera) -> Vec<usize> {
    let centre = base.iter().sum::<DVec3>() / base.len() as f64;
    let mut pixels: Vec<usize> = base
        .iter()
        .flat_map(|&corner| {
            (0..=10).map(move |k| centre + (corner - centre) * 0.6 * (k as f64 / 10.0))
        })
        .filter_map(|p| {
            let (u, v, _) = camera.project(p)?;
            Some(v as usize * SIZE as usize + u as usize)
        })
        .collect();
    pixels.sort_unstable();
    pixels.dedup();
    pixels
}

/// Of the given pixels: the fraction showing the backdrop, and the mean colour of the others.
fn look(scene: &Scene, camera: &Camera, pixels: &[usize]) -> (f64, [f64; 3]) {
    let merged = scene.merged_model().unwrap();
    let image = render_view(
        &merged.model,
        camera,
        &Backdrop::Uniform(BACKDROP),
        &CpuBackend::new(2),
        1,
    )
    .unwrap();
    let mut backdrop = 0;
    let mut sum = [0.0; 3];
    for &p in pixels {
        let rgb = [0, 1, 2].map(|c| f64::from(image.data[p * 3 + c]));
        let off = (0..3)
            .map(|c| (rgb[c] - f64::from(BACKDROP[c])).abs())
            .fold(0.0, f64::max);
        if off < 0.25 {
            backdrop += 1;
        } else {
            for c in 0..3 {
                sum[c] += rgb[c];
            }
        }
    }
    let shown = (pixels.len() - backdrop).max(1) as f64;
    (
        backdrop as f64 / pixels.len() as f64,
        sum.map(|s| s / shown),
    )
}

#[test]
fn a_removed_or_moved_box_uncovers_completed_tabletop() {
    let (room, off, _, run) = room::complete_trained_room(false);
    let on = load_scene(&run.outputs["scene"]).unwrap();

    let box_id = id_of(&room.labels, "box");
    let base: Vec<DVec3> = object_faces(&room.mesh, box_id)
        .iter()
        .flatten()
        .map(|&v| DVec3::from_array(room.mesh.positions[v as usize].map(f64::from)))
        .filter(|p| (p.z - TABLE_TOP).abs() < 1e-4)
        .collect();
    let centre = base.iter().sum::<DVec3>() / base.len() as f64;
    let camera = Camera::look_at(
        SIZE,
        SIZE,
        128.0,
        128.0,
        centre + DVec3::new(0.0, 0.01, 0.35),
        centre,
        DVec3::Y,
    );
    let pixels = footprint_pixels(&base, &camera);
    assert!(pixels.len() > 50, "{} pixels", pixels.len());
    // The tabletop's colour around the box, as the uncompleted scene renders it.
    let table = &off.objects[off.find_id(id_of(&room.labels, "table")).unwrap()];
    let scaled =
        |k: f64| -> Vec<DVec3> { base.iter().map(|&c| centre + (c - centre) * k).collect() };
    // A ring of tabletop around the box, clear of its sides.
    let inner = footprint_pixels(&scaled(1.4), &camera);
    let ring: Vec<usize> = footprint_pixels(&scaled(1.8), &camera)
        .into_iter()
        .filter(|p| !inner.contains(p))
        .collect();
    let mut table_only = off.clone();
    table_only.objects.retain(|o| o.entry.id == table.entry.id);
    let (_, table_colour) = look(&table_only, &camera, &ring);

    let edits = [
        Edit::Remove {
            target: Target::Label("box".into()),
        },
        Edit::Move {
            target: Target::Label("box".into()),
            by: [Num(0.4), Num(0.0), Num(0.0)],
        },
    ];
    for edit in edits {
        let mut edited_off = off.clone();
        apply_edits(&mut edited_off, std::slice::from_ref(&edit)).unwrap();
        let mut edited_on = on.clone();
        apply_edits(&mut edited_on, std::slice::from_ref(&edit)).unwrap();
        let (hole_off, _) = look(&edited_off, &camera, &pixels);
        let (hole_on, colour_on) = look(&edited_on, &camera, &pixels);
        eprintln!(
            "{edit}: backdrop {:.0}% without completion, {:.0}% with; colour {colour_on:?} vs table {table_colour:?}",
            hole_off * 100.0,
            hole_on * 100.0
        );
        assert!(
            hole_off > 0.8,
            "{edit}: the hole under the box is not open without completion ({hole_off})"
        );
        assert!(
            hole_on < 0.05,
            "{edit}: {:.0}% of the box's place shows the backdrop",
            hole_on * 100.0
        );
        let distance = room::colour_distance(colour_on, table_colour);
        assert!(
            distance < 0.15,
            "{edit}: tabletop colour {colour_on:?} far from {table_colour:?}"
        );
    }
}
