//! The synthetic scene: deterministic from its seed, geometry-complete, with points on
//! the surface and the declared split.

use glam::DVec3;
use objectsplat_core::{Split, SplitPolicy};
use objectsplat_masks::raster::ray_triangle_plane;
use objectsplat_synth::{SyntheticParams, scene};

fn small(seed: u64) -> SyntheticParams {
    SyntheticParams {
        seed,
        views: 8,
        width: 64,
        height: 48,
        points: 300,
        ..Default::default()
    }
}

#[test]
fn same_seed_same_scene_other_seed_other_scene() {
    let a = scene::generate(&small(3)).unwrap();
    let b = scene::generate(&SyntheticParams {
        threads: 1,
        ..small(3)
    })
    .unwrap();
    let c = scene::generate(&small(4)).unwrap();
    assert_eq!(a.images, b.images);
    assert_eq!(a.points, b.points);
    assert_eq!(a.mesh, b.mesh);
    assert_eq!(a.frames, b.frames);
    assert_ne!(a.images, c.images);
    assert_ne!(a.mesh.positions, c.mesh.positions);
}

#[test]
fn objects_are_labelled_and_table_can_be_left_out() {
    let s = scene::generate(&small(7)).unwrap();
    let labels: Vec<&str> = s.labels.values().map(String::as_str).collect();
    for l in [
        "floor", "wall", "ceiling", "table", "box", "cup", "ball", "chair", "bin",
    ] {
        assert!(labels.contains(&l), "missing {l} in {labels:?}");
    }
    assert_eq!(labels.iter().filter(|l| **l == "wall").count(), 4);
    let no_table = scene::generate(&SyntheticParams {
        table: false,
        ..small(7)
    })
    .unwrap();
    assert!(!no_table.labels.values().any(|l| l == "table"));
    // Without a table the small objects stand on the floor.
    let ball = *no_table
        .labels
        .iter()
        .find(|(_, l)| *l == "ball")
        .unwrap()
        .0 as i32;
    let ids = no_table.mesh.object_ids.as_ref().unwrap();
    let lowest = (0..ids.len())
        .filter(|&v| ids[v] == ball)
        .map(|v| no_table.mesh.positions[v][2])
        .fold(f32::MAX, f32::min);
    assert!(lowest.abs() < 1e-3, "ball bottom at {lowest}");
}

#[test]
fn table_top_is_complete_under_the_objects() {
    let s = scene::generate(&small(11)).unwrap();
    let ids = s.mesh.object_ids.as_ref().unwrap();
    let id_of = |label: &str| *s.labels.iter().find(|(_, l)| *l == label).unwrap().0 as i32;
    let table = id_of("table");
    let v = |i: u32| DVec3::from(s.mesh.positions[i as usize].map(f64::from));
    for label in ["box", "cup", "ball"] {
        let id = id_of(label);
        let verts: Vec<DVec3> = (0..ids.len())
            .filter(|&i| ids[i] == id)
            .map(|i| v(i as u32))
            .collect();
        let centre = verts.iter().copied().sum::<DVec3>() / verts.len() as f64;
        let bottom = verts.iter().map(|p| p.z).fold(f64::MAX, f64::min);
        assert!(
            (bottom - 0.75).abs() < 1e-4,
            "{label} rests at z = {bottom}"
        );
        // Straight down from the object's centre, the first table face is the top at 0.75.
        let mut hits = Vec::new();
        for (f, face) in s.mesh.faces.iter().enumerate() {
            if s.mesh.face_object(f) != table {
                continue;
            }
            if let Some((p, l)) =
                ray_triangle_plane(centre, -DVec3::Z, v(face[0]), v(face[1]), v(face[2]))
                && l.iter().all(|&w| w >= -1e-9)
                && p.z < centre.z
            {
                hits.push(p.z);
            }
        }
        let top = hits.iter().copied().fold(f64::MIN, f64::max);
        assert!(
            (top - 0.75).abs() < 1e-4,
            "below the {label}: table faces at {hits:?}"
        );
    }
}

/// Closest distance from `p` to triangle `abc` (Ericson's region tests).
fn point_triangle_distance(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> f64 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (p - a).length();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (p - b).length();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return (p - (a + ab * (d1 / (d1 - d3)))).length();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (p - c).length();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return (p - (a + ac * (d2 / (d2 - d6)))).length();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return (p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))))).length();
    }
    let denom = 1.0 / (va + vb + vc);
    (p - (a + ab * (vb * denom) + ac * (vc * denom))).length()
}

#[test]
fn points_lie_on_the_surface_within_the_noise() {
    let noise = 0.005;
    let s = scene::generate(&SyntheticParams {
        points_noise: noise,
        ..small(5)
    })
    .unwrap();
    assert_eq!(s.points.positions.len(), 300);
    let v = |i: u32| DVec3::from(s.mesh.positions[i as usize].map(f64::from));
    let mut sum_sq = 0.0;
    for p in &s.points.positions {
        let p = DVec3::from(p.map(f64::from));
        let d = s
            .mesh
            .faces
            .iter()
            .map(|f| point_triangle_distance(p, v(f[0]), v(f[1]), v(f[2])))
            .fold(f64::MAX, f64::min);
        // Three-dimensional Gaussian noise: the distance to the surface is at most |offset|.
        assert!(d < 6.0 * noise, "point {p} is {d} m from the surface");
        sum_sq += d * d;
    }
    // The normal component of isotropic noise has variance σ²; allow for curvature.
    let rms = (sum_sq / 300.0).sqrt();
    assert!(rms > 0.5 * noise && rms < 1.5 * noise, "rms distance {rms}");
}

#[test]
fn frames_follow_the_split_and_images_have_the_declared_size() {
    for (policy, train) in [
        (SplitPolicy::Sparse, 2),
        (SplitPolicy::Dense, 14),
        (SplitPolicy::All, 16),
    ] {
        let s = scene::generate(&SyntheticParams {
            views: 16,
            split: policy,
            resolution: 2,
            ..small(1)
        })
        .unwrap();
        assert_eq!(s.frames.len(), 16);
        assert_eq!(
            s.frames.iter().filter(|f| f.split == Split::Train).count(),
            train
        );
        for (f, img) in s.frames.iter().zip(&s.images) {
            assert_eq!(
                (f.camera.width, f.camera.height, img.width, img.height),
                (32, 24, 32, 24)
            );
            assert_eq!(
                f.name,
                format!(
                    "frame_{:03}",
                    s.frames.iter().position(|g| g.name == f.name).unwrap()
                )
            );
        }
    }
}
