//! Triangles crossing the near plane (here: a floor reaching behind the camera) are
//! clipped, not exploded: coverage and depth match analytic ray–plane intersection.

use glam::DVec3;
use objectsplat_core::Camera;
use objectsplat_masks::raster::{RasterOptions, pixel_ray};
use objectsplat_masks::{NO_FACE, rasterize};

#[test]
fn floor_reaching_behind_the_camera_matches_ray_plane_intersection() {
    let (eye, target) = (DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.0, 5.0, 0.6));
    let camera = Camera::look_at(80, 60, 50.0, 50.0, eye, target, DVec3::Z);
    // Two huge triangles of the plane z = 0, extending far behind and beside the camera.
    let s = 1000.0f32;
    let positions = vec![[-s, -s, 0.0], [s, -s, 0.0], [s, s, 0.0], [-s, s, 0.0]];
    let faces = vec![[0, 1, 2], [0, 2, 3]];
    let near = 0.05;
    let r = rasterize(
        &positions,
        &faces,
        &camera,
        &RasterOptions { near, threads: 2 },
    )
    .unwrap();
    let mut covered = 0;
    for y in 0..camera.height {
        for x in 0..camera.width {
            let (origin, dir) = pixel_ray(&camera, x as f64 + 0.5, y as f64 + 0.5);
            let got = r.face[(y * camera.width + x) as usize];
            // The ray meets z = 0 at t = −origin.z / dir.z when going down.
            if dir.z >= -1e-3 {
                // Near the horizon the hit is beyond the 1 km square or undefined: skip.
                if dir.z > 1e-3 {
                    assert_eq!(got, NO_FACE, "pixel ({x}, {y}) looks above the horizon");
                }
                continue;
            }
            let hit = origin + dir * (-origin.z / dir.z);
            if hit.x.abs() > 999.0 || hit.y.abs() > 999.0 {
                continue;
            }
            assert_ne!(got, NO_FACE, "pixel ({x}, {y}) sees the floor");
            let depth = camera.to_camera(hit).z;
            let d = r.depth_at(x, y).unwrap() as f64;
            assert!(
                (d - depth).abs() < 1e-3 * depth,
                "pixel ({x}, {y}): depth {d} vs {depth}"
            );
            covered += 1;
        }
    }
    assert!(covered > 1000);
}

#[test]
fn surface_closer_than_the_near_plane_is_cut_away() {
    let camera = Camera::look_at(
        40,
        30,
        30.0,
        30.0,
        DVec3::new(0.0, -1.0, 0.0),
        DVec3::ZERO,
        DVec3::Z,
    );
    // A square facing the camera at depth 0.5, and one behind it at depth 2.
    let square = |d: f32| {
        let y = -1.0 + d;
        [
            [-3.0, y, -3.0],
            [3.0, y, -3.0],
            [3.0, y, 3.0],
            [-3.0, y, 3.0],
        ]
    };
    let positions: Vec<[f32; 3]> = square(0.5).into_iter().chain(square(2.0)).collect();
    let faces = vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]];
    let near_cut = rasterize(
        &positions,
        &faces,
        &camera,
        &RasterOptions {
            near: 1.0,
            threads: 1,
        },
    )
    .unwrap();
    let near_kept = rasterize(
        &positions,
        &faces,
        &camera,
        &RasterOptions {
            near: 0.1,
            threads: 1,
        },
    )
    .unwrap();
    for i in 0..near_cut.face.len() {
        assert!(
            near_cut.face[i] >= 2 && near_cut.face[i] != NO_FACE,
            "the near square is clipped away"
        );
        assert!(near_kept.face[i] < 2, "the near square hides the far one");
        assert!(
            (near_cut.inv_depth[i] - 0.5).abs() < 1e-5
                && (near_kept.inv_depth[i] - 2.0).abs() < 1e-4
        );
    }
}
