//! Edits touch exactly their targets: moving shifts only that object's (world) vertices,
//! rotation and scale act about the centroid, rigid edits leave every model file
//! byte-identical (they change placements), removal leaves the other members' folders
//! byte-identical, the scene records the edits, and bad edits are errors that name the edit.

mod common;

use glam::{DMat3, DVec3};
use objectsplat_raster::sh::SH_DC;
use objectsplat_scene::{Scene, load_scene};

fn world_vertices(scene: &Scene, id: u16) -> Vec<[f32; 3]> {
    let o = &scene.objects[scene.find_id(id).unwrap()];
    o.world_model().unwrap().vertices.clone()
}

#[test]
fn moving_an_object_moves_exactly_its_triangles() {
    // Integers and floats both read as numbers.
    let (_tmp, before_dir, after_dir) =
        common::composed_and_edited("[Move(target: Id(3), by: (0.5, 0, -1))]");
    let before = load_scene(&before_dir).unwrap();
    let after = load_scene(&after_dir).unwrap();
    assert_eq!(before.objects.len(), after.objects.len());
    for (b, a) in before.objects.iter().zip(&after.objects) {
        assert_eq!(b.entry.name, a.entry.name);
        assert_eq!(b.model, a.model, "the model itself is never rewritten");
        let (bw, aw) = (b.world_model().unwrap(), a.world_model().unwrap());
        assert_eq!(bw.faces, aw.faces);
        assert_eq!(bw.sh, aw.sh);
        if b.entry.id == Some(3) {
            for (p, q) in bw.vertices.iter().zip(&aw.vertices) {
                let want = [p[0] + 0.5, p[1], p[2] - 1.0];
                for k in 0..3 {
                    assert!((q[k] - want[k]).abs() < 1e-6, "{q:?} vs {want:?}");
                }
            }
        } else {
            assert_eq!(a.entry, b.entry, "{} must not change", b.entry.name);
            assert_eq!(bw.vertices, aw.vertices, "{} must not move", b.entry.name);
        }
    }
    // In the merged model, exactly the chair's faces changed position.
    let (mb, ma) = (
        before.merged_model().unwrap(),
        after.merged_model().unwrap(),
    );
    for (f, owner) in mb.face_owner.iter().enumerate() {
        let moved = mb.model.faces[f]
            .iter()
            .zip(&ma.model.faces[f])
            .any(|(&i, &j)| mb.model.vertices[i as usize] != ma.model.vertices[j as usize]);
        assert_eq!(
            moved,
            before.objects[*owner].entry.id == Some(3),
            "face {f}"
        );
    }
}

#[test]
fn removing_an_object_leaves_the_others_byte_identical() {
    let (_tmp, before_dir, after_dir) =
        common::composed_and_edited("[Remove(target: Label(\"cup\"))]");
    let before = common::files(&before_dir.join("objects"));
    let after = common::files(&after_dir.join("objects"));
    let kept: Vec<&String> = before
        .keys()
        .filter(|k| !k.starts_with("obj_5_cup"))
        .collect();
    assert_eq!(after.keys().collect::<Vec<_>>(), kept);
    for k in kept {
        assert_eq!(before[k], after[k], "{k} changed");
    }
    let scene = load_scene(&after_dir).unwrap();
    assert!(scene.find_id(5).is_none());
}

#[test]
fn rotation_and_scale_act_about_the_centroid() {
    let (_tmp, before_dir, after_dir) = common::composed_and_edited(
        "[Rotate(target: Name(\"obj_3_chair\"), axis: (0, 0, 1), degrees: 90), Scale(target: Id(5), factor: 2)]",
    );
    let before = load_scene(&before_dir).unwrap();
    let after = load_scene(&after_dir).unwrap();
    let chair = |s: &Scene| world_vertices(s, 3);
    let cup = |s: &Scene| world_vertices(s, 5);
    let to = |v: &[f32; 3]| DVec3::new(v[0] as f64, v[1] as f64, v[2] as f64);
    // The chair square is centred at (−0.6, 0, 0): a quarter turn about +Z maps offset (dx, 0, dz) to (0, dx, dz).
    let c = DVec3::new(-0.6, 0.0, 0.0);
    let r = DMat3::from_rotation_z(std::f64::consts::FRAC_PI_2);
    for (p, q) in chair(&before).iter().zip(&chair(&after)) {
        let want = c + r * (to(p) - c);
        assert!((to(q) - want).length() < 1e-5, "{q:?} vs {want}");
    }
    let c = DVec3::new(0.6, 0.0, 0.0);
    for (p, q) in cup(&before).iter().zip(&cup(&after)) {
        let want = c + (to(p) - c) * 2.0;
        assert!((to(q) - want).length() < 1e-5, "{q:?} vs {want}");
    }
}

#[test]
fn duplicate_gets_the_next_id_and_recolor_sets_the_colour() {
    let (_tmp, _, after_dir) = common::composed_and_edited(
        "[Duplicate(target: Id(4), offset: (1, 0, 0)), Recolor(target: Id(4), rgb: (1, 0, 0.25))]",
    );
    let after = load_scene(&after_dir).unwrap();
    let copy = &after.objects[after
        .find_id(6)
        .expect("the copy takes id 6 (max id 5 + 1)")];
    assert_eq!(copy.entry.name, "obj_6_lamp");
    assert_eq!(copy.entry.label.as_deref(), Some("lamp"));
    assert_eq!(copy.entry.source, "obj_4_lamp");
    let original = &after.objects[after.find_id(4).unwrap()];
    for (p, q) in world_vertices(&after, 4)
        .iter()
        .zip(&world_vertices(&after, 6))
    {
        assert!((q[0] - p[0] - 1.0).abs() < 1e-6 && q[1] == p[1] && q[2] == p[2]);
    }
    // The recolor came after the duplicate, so only the original is red.
    for rows in &original.model.sh {
        let rgb: Vec<f64> = rows[0].iter().map(|&dc| 0.5 + SH_DC * dc as f64).collect();
        assert!(
            (rgb[0] - 1.0).abs() < 1e-6 && rgb[1].abs() < 1e-6 && (rgb[2] - 0.25).abs() < 1e-6,
            "{rgb:?}"
        );
        assert!(rows[1..].iter().flatten().all(|&c| c == 0.0));
    }
    let copy_rgb = 0.5 + SH_DC * copy.model.sh[0][0][1] as f64;
    assert!(
        (copy_rgb - 0.9).abs() < 1e-6,
        "the copy keeps the lamp's yellow"
    );
}

#[test]
fn unknown_targets_and_malformed_edits_name_the_edit() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = common::composed_scene(tmp.path());
    for (out, edits, parts) in [
        (
            "a",
            "[Move(target: Id(3), by: (1, 0, 0)), Remove(target: Id(9))]",
            &["edit 1", "no object has id 9"][..],
        ),
        (
            "b",
            "[Recolor(target: Label(\"sofa\"), rgb: (1, 1, 1))]",
            &["edit 0", "no object has label \"sofa\""],
        ),
        ("c", "[Move(target: Id(3))]", &["edit 0", "by"]),
        (
            "d",
            "[Scale(target: Id(3), factor: 0)]",
            &["edit 0", "factor"],
        ),
        (
            "f",
            "[Duplicate(target: Name(\"background\"), offset: (0, 0, 0))]",
            &["only objects can be duplicated"],
        ),
    ] {
        common::assert_edit_refused(&scene, edits, &tmp.path().join(out), parts);
    }
}
