//! Rasterizer coverage and depth against a brute-force f64 oracle: for every pixel
//! centre, test every triangle with floating-point edge functions and take the nearest
//! by exact ray–plane depth. Pixels the oracle cannot decide (centre within 0.01 px of
//! an edge, where 1/256-pixel vertex snapping may decide either way, or two depths
//! within the snapping tolerance) are skipped; all others must agree exactly.

use glam::DVec3;
use objectsplat_core::Camera;
use objectsplat_masks::raster::{RasterOptions, pixel_ray, ray_triangle_plane};
use objectsplat_masks::{NO_FACE, rasterize};
use proptest::prelude::*;

fn cam(width: u32, height: u32) -> Camera {
    Camera::look_at(
        width,
        height,
        40.0,
        42.0,
        DVec3::new(0.2, -4.0, 0.5),
        DVec3::ZERO,
        DVec3::Z,
    )
}

/// Inverse depth of the plane of `w` along the ray through pixel position `(px, py)`.
fn plane_inv_depth(camera: &Camera, w: [DVec3; 3], px: f64, py: f64) -> Option<f64> {
    let (origin, dir) = pixel_ray(camera, px, py);
    let (hit, _) = ray_triangle_plane(origin, dir, w[0], w[1], w[2])?;
    Some(1.0 / camera.to_camera(hit).z)
}

/// How far the inverse depth may be off at a pixel: vertices are snapped to 1/256
/// pixel, which tilts the interpolated plane by up to |∇(1/z)| · 1/256 px, a lot
/// for slivers seen at grazing angles.
fn inv_depth_tolerance(camera: &Camera, w: [DVec3; 3], px: f64, py: f64) -> Option<f64> {
    let here = plane_inv_depth(camera, w, px, py)?;
    let gx = plane_inv_depth(camera, w, px + 1.0, py)? - here;
    let gy = plane_inv_depth(camera, w, px, py + 1.0)? - here;
    Some(gx.hypot(gy) * 3.0 / 256.0 + 1e-6 * here)
}

/// (face, inverse depth, tolerance) of the nearest triangle at a pixel centre, or None;
/// Err when undecidable.
fn oracle(
    positions: &[[f32; 3]],
    faces: &[[u32; 3]],
    camera: &Camera,
    x: u32,
    y: u32,
) -> Result<Option<(u32, f64, f64)>, ()> {
    let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
    let mut covering: Vec<(u32, f64, f64)> = Vec::new();
    for (f, face) in faces.iter().enumerate() {
        let w = face.map(|v| DVec3::from(positions[v as usize].map(f64::from)));
        let p = w.map(|v| {
            camera
                .project(v)
                .expect("fixtures are in front of the camera")
        });
        let edge = |a: (f64, f64, f64), b: (f64, f64, f64)| {
            let e = (b.0 - a.0) * (py - a.1) - (b.1 - a.1) * (px - a.0);
            e / ((b.0 - a.0).hypot(b.1 - a.1)) // signed distance in pixels
        };
        let e = [edge(p[1], p[2]), edge(p[2], p[0]), edge(p[0], p[1])];
        if e.iter().any(|d| d.abs() < 0.01) {
            return Err(());
        }
        let inside = e.iter().all(|&d| d > 0.0) || e.iter().all(|&d| d < 0.0);
        if !inside {
            continue;
        }
        let iz = plane_inv_depth(camera, w, px, py).ok_or(())?;
        let tol = inv_depth_tolerance(camera, w, px, py).ok_or(())?;
        covering.push((f as u32, iz, tol));
    }
    // The nearest, unless another covering face lies within the tolerances of it
    // (checked against every one: a face tied with a candidate that a nearer face
    // later displaced may still be tied with that nearer face).
    let best = covering.iter().copied().max_by(|a, b| a.1.total_cmp(&b.1));
    let tie = best.is_some_and(|(bf, b, btol)| {
        covering
            .iter()
            .any(|&(f, iz, tol)| f != bf && (b - iz).abs() <= tol + btol)
    });
    if tie { Err(()) } else { Ok(best) }
}

fn check_against_oracle(positions: &[[f32; 3]], faces: &[[u32; 3]], camera: &Camera) -> usize {
    let r = rasterize(
        positions,
        faces,
        camera,
        &RasterOptions {
            near: 0.01,
            threads: 2,
        },
    )
    .unwrap();
    let mut decided = 0;
    for y in 0..camera.height {
        for x in 0..camera.width {
            let Ok(expected) = oracle(positions, faces, camera, x, y) else {
                continue;
            };
            decided += 1;
            let got = r.face[(y * camera.width + x) as usize];
            match expected {
                None => assert_eq!(got, NO_FACE, "pixel ({x}, {y}) should be empty"),
                Some((f, iz, tol)) => {
                    assert_eq!(got, f, "pixel ({x}, {y})");
                    let iz_raster = r.inv_depth[(y * camera.width + x) as usize] as f64;
                    // f32 storage adds a relative 1e-7.
                    assert!(
                        (iz_raster - iz).abs() <= tol + 1e-6 * iz,
                        "pixel ({x}, {y}): 1/z {iz_raster} vs {iz} ± {tol}"
                    );
                }
            }
        }
    }
    decided
}

fn triangles_strategy() -> impl Strategy<Value = Vec<[[f32; 3]; 3]>> {
    let coord = -1.5f32..1.5;
    let vertex = (coord.clone(), -1.0f32..1.0, coord);
    prop::collection::vec([vertex.clone(), vertex.clone(), vertex], 1..12).prop_map(|tris| {
        tris.into_iter()
            .map(|t| t.map(|(x, y, z)| [x, y, z]))
            .collect()
    })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]
    #[test]
    fn random_overlapping_triangles_match_brute_force(tris in triangles_strategy()) {
        let positions: Vec<[f32; 3]> = tris.iter().flatten().copied().collect();
        let faces: Vec<[u32; 3]> = (0..tris.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        let camera = cam(48, 36);
        let decided = check_against_oracle(&positions, &faces, &camera);
        prop_assert!(decided > 48 * 36 * 9 / 10);
    }
}

/// A plane of pixel-aligned vertices split into triangles whose edges pass exactly
/// through pixel centres: the top-left rule must give every centre to exactly one.
#[test]
fn shared_edges_through_pixel_centres_are_covered_exactly_once() {
    // Identity pose, principal point 0, f = 1: a vertex at z = 1 projects to (x, y).
    let camera = Camera::from_view(32, 32, 1.0, 1.0, 0.0, 0.0, glam::DMat4::IDENTITY);
    let grid = 6;
    let at = |i: u32, j: u32| [(i as f32) * 6.0 + 0.5, (j as f32) * 6.0 + 0.5, 1.0];
    let mut positions = Vec::new();
    for j in 0..grid {
        for i in 0..grid {
            positions.push(at(i, j));
        }
    }
    let mut faces = Vec::new();
    for j in 0..grid - 1 {
        for i in 0..grid - 1 {
            let a = j * grid + i;
            let (b, c, d) = (a + 1, a + grid + 1, a + grid);
            // Alternate diagonals so both orientations of shared edges occur.
            if (i + j) % 2 == 0 {
                faces.push([a, b, c]);
                faces.push([a, c, d]);
            } else {
                faces.push([a, b, d]);
                faces.push([b, c, d]);
            }
        }
    }
    let options = RasterOptions {
        near: 0.01,
        threads: 1,
    };
    let mut coverage = vec![0u32; 32 * 32];
    for f in &faces {
        let r = rasterize(&positions, std::slice::from_ref(f), &camera, &options).unwrap();
        for (c, &id) in coverage.iter_mut().zip(&r.face) {
            *c += u32::from(id != NO_FACE);
        }
    }
    let extent = (grid - 1) * 6;
    for y in 0..32u32 {
        for x in 0..32u32 {
            let c = coverage[(y * 32 + x) as usize];
            // Centres strictly inside the grid's square are covered once; the square's own
            // boundary follows the same rule (left/top edges in, right/bottom out).
            let expected = u32::from(x < extent && y < extent);
            assert_eq!(c, expected, "pixel ({x}, {y})");
        }
    }
}

#[test]
fn thread_count_does_not_change_the_result() {
    let scene = objectsplat_synth::scene::generate(&objectsplat_synth::SyntheticParams {
        views: 2,
        points: 10,
        width: 64,
        height: 48,
        ..Default::default()
    })
    .unwrap();
    let camera = scene.frames[0].camera().scaled(200, 150);
    let one = rasterize(
        &scene.mesh.positions,
        &scene.mesh.faces,
        &camera,
        &RasterOptions {
            near: 0.01,
            threads: 1,
        },
    );
    let three = rasterize(
        &scene.mesh.positions,
        &scene.mesh.faces,
        &camera,
        &RasterOptions {
            near: 0.01,
            threads: 3,
        },
    );
    assert_eq!(one.unwrap(), three.unwrap());
}
