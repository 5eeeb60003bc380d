//! The forward pass against independent computations: the analytic pixel set
//! of one opaque triangle, and a brute-force per-pixel renderer written from
//! the definitions in docs/trainer.md (edge normals, incenter, φ = max of the signed
//! edge distances) instead of the backend's barycentric closed form.

// Colour channels index several parallel arrays at once.
#![allow(clippy::needless_range_loop)]

mod common;

use common::*;
use objectsplat_core::Camera;
use objectsplat_core::glam::{DVec2, DVec3};
use objectsplat_raster::sh::SH_DC;
use objectsplat_raster::{CpuBackend, Model, RenderBackend, RenderOutput, RenderSettings};

fn render(
    model: &Model<f64>,
    camera: &Camera,
    settings: &RenderSettings,
    bg: &[f64],
) -> RenderOutput<f64> {
    CpuBackend::new(2)
        .forward(model, camera, settings, bg)
        .expect("valid scene")
        .0
}

/// Pixel centres strictly inside the projected triangle, by the sign of the
/// three edge functions of `Camera::project`'s output.
fn analytic_inside(camera: &Camera, corners: [[f64; 3]; 3]) -> Vec<bool> {
    let p = corners.map(|c| {
        let (u, v, _) = camera.project(DVec3::from_array(c)).expect("in front");
        DVec2::new(u, v)
    });
    let edge = |a: DVec2, b: DVec2, q: DVec2| (b - a).perp_dot(q - a);
    let mut inside = Vec::new();
    for j in 0..camera.height {
        for i in 0..camera.width {
            let q = DVec2::new(i as f64 + 0.5, j as f64 + 0.5);
            let e = [
                edge(p[0], p[1], q),
                edge(p[1], p[2], q),
                edge(p[2], p[0], q),
            ];
            assert!(
                e.iter().all(|x| x.abs() > 1e-6),
                "pixel ({i},{j}) sits on an edge; move the triangle"
            );
            inside.push(e.iter().all(|&x| x > 0.0) || e.iter().all(|&x| x < 0.0));
        }
    }
    inside
}

#[test]
fn single_opaque_triangle_covers_exactly_the_analytic_pixel_set() {
    let camera = orbit_camera(37, 29, 30.0, DVec3::new(0.3, -0.2, -3.0));
    let corners = [
        [-0.81, -0.62, 0.1],
        [0.93, -0.31, -0.05],
        [0.07, 0.88, 0.02],
    ];
    let mut rng = Rng(3);
    let mut model = Model::<f64>::empty();
    push_triangle(&mut model, &mut rng, corners, [12.0, 12.5, 13.0]);
    let bg = random_background(&mut rng, &camera);
    // σ → 0: the window is 1 everywhere inside (hard, fully opaque-looking).
    let settings = settings(1e-4, 0);
    let inside = analytic_inside(&camera, corners);
    // One colour at all three corners (degree 0), so every covered pixel shows it.
    let dc = [0.3, -0.4, 0.9];
    let model = {
        let mut m = model;
        for rows in &mut m.sh {
            rows[0] = dc;
        }
        m
    };
    let out = render(&model, &camera, &settings, &bg);
    let count = inside.iter().filter(|&&b| b).count();
    assert!(count > 100, "the triangle covers a real area ({count} px)");
    assert_eq!(out.face_pixel_count[0] as usize, count);
    for (i, &ins) in inside.iter().enumerate() {
        if ins {
            // Opacity ≈ 1 and G^σ ≈ 1 put the α clamp in force: α = 0.999 exactly.
            assert_eq!(
                out.alpha[i], 0.999,
                "pixel {i} inside: alpha {}",
                out.alpha[i]
            );
            for ch in 0..3 {
                let want = 0.999 * (0.5 + SH_DC * dc[ch]) + 0.001 * bg[i * 3 + ch];
                assert!(
                    (out.color[i * 3 + ch] - want).abs() < 1e-12,
                    "pixel {i}: {} vs {want}",
                    out.color[i * 3 + ch]
                );
            }
        } else {
            assert_eq!(out.alpha[i], 0.0, "pixel {i} outside has alpha");
            assert_eq!(
                &out.color[i * 3..i * 3 + 3],
                &bg[i * 3..i * 3 + 3],
                "pixel {i} outside is not the background"
            );
        }
    }
}

/// One face evaluated from the definitions.
struct BruteFace {
    depth: f64,
    index: usize,
    opacity: f64,
    p: [DVec2; 3],
    color: [[f64; 3]; 3],
    z: [f64; 3],
}

fn brute_faces(model: &Model<f64>, camera: &Camera, s: &RenderSettings) -> Vec<BruteFace> {
    let mut out = Vec::new();
    for (fi, face) in model.faces.iter().enumerate() {
        let x = face.map(|v| DVec3::from_array(model.vertices[v as usize]));
        let c = x.map(|p| camera.to_camera(p));
        if c.iter().any(|p| p.z <= s.z_near) {
            continue;
        }
        let centroid = (c[0] + c[1] + c[2]) / 3.0;
        if centroid.z <= s.min_centroid_depth {
            continue;
        }
        let n = (c[1] - c[0]).cross(c[2] - c[0]);
        if n.length() == 0.0
            || n.dot(centroid).abs() / (n.length() * centroid.length()) < s.min_abs_cos
        {
            continue;
        }
        let opacity = face
            .iter()
            .map(|&v| model.vertex_opacity(v as usize))
            .fold(f64::INFINITY, f64::min);
        if opacity < s.min_opacity {
            continue;
        }
        let p = x.map(|q| {
            let (u, v, _) = camera.project(q).expect("in front");
            DVec2::new(u, v)
        });
        let pc = (p[0] + p[1] + p[2]) / 3.0;
        let extent = p.iter().map(|q| (*q - pc).length()).fold(0.0, f64::max);
        if extent > s.max_screen_extent || extent < s.min_screen_extent {
            continue;
        }
        let area = (p[1] - p[0]).perp_dot(p[2] - p[0]).abs() / 2.0;
        let perimeter = (p[1] - p[0]).length() + (p[2] - p[1]).length() + (p[0] - p[2]).length();
        if 2.0 * area / perimeter < s.min_inradius {
            continue;
        }
        let color =
            face.map(|v| [0, 1, 2].map(|ch| (0.5 + SH_DC * model.sh[v as usize][0][ch]).max(0.0)));
        out.push(BruteFace {
            depth: centroid.z,
            index: fi,
            opacity,
            p,
            color,
            z: [c[0].z, c[1].z, c[2].z],
        });
    }
    out
}

/// φ(q) = max_i (n_i·q + d_i) with outward unit normals; returns (φ(q), φ(incenter)).
fn window_phi(p: &[DVec2; 3], q: DVec2) -> (f64, f64) {
    let a = (p[1] - p[2]).length();
    let b = (p[2] - p[0]).length();
    let c = (p[0] - p[1]).length();
    let incenter = (a * p[0] + b * p[1] + c * p[2]) / (a + b + c);
    let mut phi_q = f64::NEG_INFINITY;
    let mut phi_s = f64::NEG_INFINITY;
    for i in 0..3 {
        let e = p[(i + 1) % 3] - p[i];
        let mut n = DVec2::new(e.y, -e.x).normalize();
        let mut d = -n.dot(p[i]);
        if n.dot(incenter) + d > 0.0 {
            n = -n;
            d = -d;
        }
        phi_q = phi_q.max(n.dot(q) + d);
        phi_s = phi_s.max(n.dot(incenter) + d);
    }
    (phi_q, phi_s)
}

/// Per pixel: (colour, transmittance, expected depth, median depth).
fn brute_force(
    model: &Model<f64>,
    camera: &Camera,
    s: &RenderSettings,
    bg: &[f64],
) -> Vec<([f64; 3], f64, f64, f64)> {
    let mut faces = brute_faces(model, camera, s);
    faces.sort_by(|a, b| a.depth.total_cmp(&b.depth).then(a.index.cmp(&b.index)));
    let mut out = Vec::new();
    for j in 0..camera.height {
        for i in 0..camera.width {
            let q = DVec2::new(i as f64 + 0.5, j as f64 + 0.5);
            let pix = (j * camera.width + i) as usize;
            let (mut t, mut color, mut depth, mut median) = (1.0, [0.0; 3], 0.0, 0.0);
            for f in &faces {
                let (phi, phi_s) = window_phi(&f.p, q);
                if phi >= 0.0 {
                    continue;
                }
                let alpha = (f.opacity * (phi / phi_s).powf(s.sigma)).min(s.alpha_max);
                if alpha < s.alpha_min {
                    continue;
                }
                // Screen-space barycentrics from sub-triangle areas.
                let area = |a: DVec2, b: DVec2, c: DVec2| (b - a).perp_dot(c - a);
                let total = area(f.p[0], f.p[1], f.p[2]);
                let l = [
                    area(q, f.p[1], f.p[2]) / total,
                    area(f.p[0], q, f.p[2]) / total,
                    area(f.p[0], f.p[1], q) / total,
                ];
                let w = alpha * t;
                let z = l[0] * f.z[0] + l[1] * f.z[1] + l[2] * f.z[2];
                for ch in 0..3 {
                    color[ch] +=
                        w * (l[0] * f.color[0][ch] + l[1] * f.color[1][ch] + l[2] * f.color[2][ch]);
                }
                depth += w * z;
                if t > 0.5 {
                    median = z;
                }
                t *= 1.0 - alpha;
                if t < s.transmittance_min {
                    break;
                }
            }
            out.push((
                [0, 1, 2].map(|ch| color[ch] + t * bg[pix * 3 + ch]),
                t,
                depth,
                median,
            ));
        }
    }
    out
}

/// Every pixel's colour within 1e-9 of the brute force's.
fn assert_colours_match(seed: u64, out: &RenderOutput<f64>, want: &[([f64; 3], f64, f64, f64)]) {
    for (i, (c, _, _, _)) in want.iter().enumerate() {
        for ch in 0..3 {
            assert!(
                (out.color[i * 3 + ch] - c[ch]).abs() < 1e-9,
                "seed {seed} pixel {i} ch {ch}: {} vs {}",
                out.color[i * 3 + ch],
                c[ch]
            );
        }
    }
}

/// A pile of random overlapping triangles in front of a rotated camera.
fn random_scene(seed: u64, count: usize) -> (Model<f64>, Camera, Vec<f64>) {
    random_scene_in(seed, count, [0.9, 0.8, 0.6])
}

/// Random triangles with centres in the box ±`extent` around the point the camera looks at.
fn random_scene_in(seed: u64, count: usize, extent: [f64; 3]) -> (Model<f64>, Camera, Vec<f64>) {
    let mut rng = Rng(seed);
    let camera = orbit_camera(56, 44, 48.0, DVec3::new(0.2, 0.3, -3.2));
    let mut model = Model::<f64>::empty();
    for _ in 0..count {
        let corners = random_corners(&mut rng, extent, (0.3, 0.8));
        let logits = [0, 1, 2].map(|_| rng.uniform(-1.0, 3.0));
        push_triangle(&mut model, &mut rng, corners, logits);
    }
    let bg = random_background(&mut rng, &camera);
    (model, camera, bg)
}

#[test]
fn compositing_matches_a_brute_force_per_pixel_depth_sort() {
    for (seed, sigma) in [(1, 0.8), (2, 0.05), (3, 2.0)] {
        let (model, camera, bg) = random_scene(seed, 40);
        let s = settings(sigma, 0);
        let out = render(&model, &camera, &s, &bg);
        let want = brute_force(&model, &camera, &s, &bg);
        let drawn = out.face_pixel_count.iter().filter(|&&c| c > 0).count();
        assert!(drawn >= 15, "seed {seed}: most faces drawn ({drawn})");
        assert_colours_match(seed, &out, &want);
        for (i, (_, _, d, m)) in want.iter().enumerate() {
            assert!(
                (out.depth[i] - d).abs() < 1e-9,
                "seed {seed} pixel {i} depth {} vs {d}",
                out.depth[i]
            );
            assert!(
                (out.median_depth[i] - m).abs() < 1e-9,
                "seed {seed} pixel {i} median {} vs {m}",
                out.median_depth[i]
            );
        }
    }
}

#[test]
fn rendered_alpha_is_one_minus_the_final_transmittance() {
    for (seed, sigma) in [(4, 0.5), (5, 0.02)] {
        let (model, camera, bg) = random_scene(seed, 60);
        let s = settings(sigma, 0);
        let out = render(&model, &camera, &s, &bg);
        let want = brute_force(&model, &camera, &s, &bg);
        let mut opaque = 0;
        for (i, (_, t, _, _)) in want.iter().enumerate() {
            assert!(
                (out.alpha[i] - (1.0 - t)).abs() < 1e-12,
                "seed {seed} pixel {i}: alpha {} vs 1 − T = {}",
                out.alpha[i],
                1.0 - t
            );
            assert!((0.0..=1.0).contains(&out.alpha[i]));
            if *t < 0.05 {
                opaque += 1;
            }
        }
        assert!(
            opaque > 0 || sigma > 0.1,
            "seed {seed}: the sharp scene has fully covered pixels"
        );
    }
}

/// The renderer rejects most faces from a byte per corner (behind the near
/// plane, or all three beyond one image edge) before it reads their corners;
/// the brute force tests every pixel of every face. Triangles spread far
/// beyond the view — across its edges, across the near plane, behind the
/// camera — must still render the same image.
#[test]
fn faces_across_the_image_edges_and_the_near_plane_render_as_the_brute_force() {
    for (seed, sigma) in [(6, 0.5), (7, 0.05)] {
        let (model, camera, bg) = random_scene_in(seed, 400, [4.0, 3.0, 4.0]);
        let s = settings(sigma, 0);
        let out = render(&model, &camera, &s, &bg);
        let want = brute_force(&model, &camera, &s, &bg);
        let near = model
            .faces
            .iter()
            .filter(|f| {
                let z = f.map(|v| {
                    camera
                        .to_camera(DVec3::from_array(model.vertices[v as usize]))
                        .z
                });
                z.iter().any(|&z| z <= s.z_near) && z.iter().any(|&z| z > s.z_near)
            })
            .count();
        let drawn = out.face_pixel_count.iter().filter(|&&c| c > 0).count();
        assert!(
            near >= 10,
            "seed {seed}: faces across the near plane ({near})"
        );
        assert!(
            drawn >= 20 && drawn <= model.face_count() / 2,
            "seed {seed}: some faces drawn, most outside the view ({drawn} of {})",
            model.face_count()
        );
        assert_colours_match(seed, &out, &want);
        for (i, (_, t, _, _)) in want.iter().enumerate() {
            assert!(
                (out.alpha[i] - (1.0 - t)).abs() < 1e-12,
                "seed {seed} pixel {i} alpha"
            );
        }
    }
}
