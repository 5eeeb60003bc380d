//! The wgpu id rasterizer (`objectsplat_masks::gpu_raster`) gives exactly the CPU
//! rasterizer's nearest face at every pixel, and the `gt_masks` node gives the same masks
//! on both backends: on the synthetic scene and on meshes built to stress the fill rule,
//! near-plane and guard-band clipping, and depth ties. The oracle is the CPU path; the
//! tolerance is zero differing pixels.
//!
//! Needs a wgpu adapter (a GPU, or Mesa lavapipe on the CPU). Without one each test prints
//! "SKIPPED (no wgpu adapter): …" and passes, unless OBJECTSPLAT_REQUIRE_ADAPTER=1.

use glam::DVec3;
use objectsplat_core::masks::read_objects;
use objectsplat_core::{Camera, IdMap};
use objectsplat_gpu::{AdapterChoice, GpuContext};
use objectsplat_masks::gpu_raster::IdRasterizer;
use objectsplat_masks::nodes::GtMasksNode;
use objectsplat_masks::{RasterOptions, rasterize};
use objectsplat_runtime::testing::run_node;
use objectsplat_synth::nodes::SyntheticSceneNode;
use objectsplat_synth::{SyntheticParams, scene};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use std::sync::Arc;

/// The near plane the `gt_masks` node uses.
const NEAR: f64 = 0.01;

fn adapter_or_skip() -> Option<Arc<GpuContext>> {
    let err = match GpuContext::shared(AdapterChoice::Auto) {
        Ok((ctx, _)) => return Some(ctx),
        Err(err) => err,
    };
    let required = std::env::var("OBJECTSPLAT_REQUIRE_ADAPTER").as_deref() == Ok("1");
    assert!(
        !required,
        "OBJECTSPLAT_REQUIRE_ADAPTER=1 but no wgpu adapter: {err:#}"
    );
    println!("SKIPPED (no wgpu adapter): {err:#}");
    None
}

/// Asserts the device's nearest faces equal the CPU's, pixel for pixel.
fn assert_same_faces(
    gpu: &IdRasterizer,
    positions: &[[f32; 3]],
    faces: &[[u32; 3]],
    camera: &Camera,
    what: &str,
) {
    let cpu = rasterize(
        positions,
        faces,
        camera,
        &RasterOptions {
            near: NEAR,
            threads: 2,
        },
    )
    .unwrap();
    let device = gpu.rasterize_faces(positions, faces, camera, NEAR).unwrap();
    assert_eq!(device.len(), cpu.face.len(), "{what}: pixel count");
    let differing: Vec<(u32, u32, u32, u32)> = (0..device.len())
        .filter(|&i| device[i] != cpu.face[i])
        .map(|i| {
            let w = camera.width as usize;
            ((i % w) as u32, (i / w) as u32, cpu.face[i], device[i])
        })
        .collect();
    let (count, total) = (differing.len(), device.len());
    let first = &differing[..count.min(8)];
    assert!(
        differing.is_empty(),
        "{what}: {count} of {total} pixels differ; first (x, y, cpu face, wgpu face): {first:?}"
    );
}

/// A camera at the origin looking down +z (world = camera axes).
fn axis_camera(width: u32, height: u32, focal: f64) -> Camera {
    let mut world_to_camera = [[0.0; 4]; 4];
    for (i, row) in world_to_camera.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    Camera {
        width,
        height,
        fx: focal,
        fy: focal,
        cx: width as f64 / 2.0,
        cy: height as f64 / 2.0,
        world_to_camera,
    }
}

/// The world point at depth `z` that projects to pixel coordinates `(u, v)`.
fn unproject(camera: &Camera, u: f64, v: f64, z: f64) -> [f32; 3] {
    [
        ((u - camera.cx) / camera.fx * z) as f32,
        ((v - camera.cy) / camera.fy * z) as f32,
        z as f32,
    ]
}

#[test]
fn synthetic_scene_matches_cpu_in_every_frame() {
    let Some(ctx) = adapter_or_skip() else { return };
    let gpu = IdRasterizer::new(&ctx).unwrap();
    let scene = scene::generate(&SyntheticParams {
        points: 10,
        threads: 2,
        ..SyntheticParams::default()
    })
    .unwrap();
    let (positions, faces) = (&scene.mesh.positions, &scene.mesh.faces);
    for (i, camera) in scene.cameras().iter().enumerate() {
        assert_same_faces(&gpu, positions, faces, camera, &format!("frame {i}"));
    }
    // Odd sizes leave partial tiles at the right and bottom.
    for (i, camera) in scene.cameras().iter().enumerate().step_by(5) {
        let camera = camera.scaled(333, 217);
        let what = format!("frame {i} at 333×217");
        assert_same_faces(&gpu, positions, faces, &camera, &what);
    }
}

#[test]
fn shared_edges_and_vertices_on_pixel_centres_follow_the_same_fill_rule() {
    let Some(ctx) = adapter_or_skip() else { return };
    let gpu = IdRasterizer::new(&ctx).unwrap();
    let camera = axis_camera(61, 45, 40.0);
    // Grids of quads whose corners fall on pixel centres (offset 0.5), pixel corners
    // (offset 0) and in between, split along alternating diagonals with both windings,
    // so many pixel centres lie exactly on shared edges and vertices.
    for (grid, (offset, step)) in [(0.5, 2.0), (0.0, 3.0), (0.25, 1.0), (0.5, 5.0)]
        .into_iter()
        .enumerate()
    {
        let (mut positions, mut faces) = (Vec::new(), Vec::new());
        let n = (70.0 / step) as u32;
        for j in 0..=n {
            for i in 0..=n {
                let (u, v) = (
                    offset - 4.0 + i as f64 * step,
                    offset - 4.0 + j as f64 * step,
                );
                positions.push(unproject(&camera, u, v, 2.0));
            }
        }
        let at = |i: u32, j: u32| j * (n + 1) + i;
        for j in 0..n {
            for i in 0..n {
                let [a, b, c, d] = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
                // Alternate diagonals and, with them, windings.
                faces.extend(if (i + j) % 2 == 0 {
                    [[a, b, c], [a, d, c]]
                } else {
                    [[a, b, d], [b, c, d]]
                });
            }
        }
        assert_same_faces(&gpu, &positions, &faces, &camera, &format!("grid {grid}"));
    }
    // A fan of 24 thin triangles around a vertex on a pixel centre.
    let centre = (30.5, 22.5);
    let mut positions = vec![unproject(&camera, centre.0, centre.1, 3.0)];
    let mut faces = Vec::new();
    for k in 0..24u32 {
        let angle = k as f64 * std::f64::consts::TAU / 24.0;
        let (u, v) = (centre.0 + 20.0 * angle.cos(), centre.1 + 20.0 * angle.sin());
        positions.push(unproject(&camera, u.round() + 0.5, v.round() + 0.5, 3.0));
        faces.push([0, k + 1, (k + 1) % 24 + 1]);
    }
    assert_same_faces(&gpu, &positions, &faces, &camera, "fan");
}

#[test]
fn triangles_crossing_the_near_plane_and_the_guard_band_are_clipped_alike() {
    let Some(ctx) = adapter_or_skip() else { return };
    let gpu = IdRasterizer::new(&ctx).unwrap();
    // A room of 4 m whose walls, floor and ceiling are two triangles each, huge floor
    // triangles reaching 10 km, and cameras placed close to walls and corners so that
    // triangles cross the near plane and project far outside the guard band.
    let mut positions: Vec<[f32; 3]> = Vec::new();
    let mut faces: Vec<[u32; 3]> = Vec::new();
    let mut quad = |corners: [[f32; 3]; 4]| {
        let base = positions.len() as u32;
        positions.extend(corners);
        faces.push([base, base + 1, base + 2]);
        faces.push([base, base + 2, base + 3]);
    };
    let (lo, hi) = (-2.0f32, 2.0f32);
    for axis in 0..3 {
        for side in [lo, hi] {
            let corner = |s: f32, t: f32| {
                let mut p = [0.0f32; 3];
                p[axis] = side;
                p[(axis + 1) % 3] = s;
                p[(axis + 2) % 3] = t;
                p
            };
            quad([
                corner(lo, lo),
                corner(hi, lo),
                corner(hi, hi),
                corner(lo, hi),
            ]);
        }
    }
    let far = 1.0e4f32;
    quad([
        [-far, -far, -1.0],
        [far, -far, -1.0],
        [far, far, -1.0],
        [-far, far, -1.0],
    ]);
    let mut rng = Pcg64::seed_from_u64(11);
    for view in 0..12 {
        let eye = DVec3::new(
            rng.random_range(-1.99..1.99),
            rng.random_range(-1.99..1.99),
            rng.random_range(-0.99..1.99),
        );
        // Every third camera sits 5–15 mm from a wall, closer than some corners' near-plane crossings.
        let eye = if view % 3 == 0 {
            DVec3::new(1.99 - rng.random_range(0.0..0.01), eye.y, eye.z)
        } else {
            eye
        };
        let target = eye
            + DVec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            );
        let camera = Camera::look_at(73, 55, 30.0, 30.0, eye, target, DVec3::Z);
        let what = format!("room view {view}");
        assert_same_faces(&gpu, &positions, &faces, &camera, &what);
    }
}

#[test]
fn coplanar_overlapping_triangles_break_depth_ties_by_face_order() {
    let Some(ctx) = adapter_or_skip() else { return };
    let gpu = IdRasterizer::new(&ctx).unwrap();
    let camera = axis_camera(64, 48, 45.0);
    let mut rng = Pcg64::seed_from_u64(5);
    let (mut positions, mut faces): (Vec<[f32; 3]>, Vec<[u32; 3]>) = (Vec::new(), Vec::new());
    // Three tilted planes z = z0 + a·x + b·y, each with many overlapping triangles whose
    // interpolated depths differ only by rounding; some triangles are exact duplicates
    // (same vertices, either winding) whose depths tie bit for bit.
    for plane in 0..3 {
        let (z0, a, b) = (
            2.0 + plane as f64 * 0.3,
            rng.random_range(-0.4..0.4),
            rng.random_range(-0.4..0.4),
        );
        let on_plane = |x: f64, y: f64| [x as f32, y as f32, (z0 + a * x + b * y) as f32];
        for _ in 0..40 {
            let corner = |rng: &mut Pcg64| {
                on_plane(rng.random_range(-1.6..1.6), rng.random_range(-1.2..1.2))
            };
            let tri = [corner(&mut rng), corner(&mut rng), corner(&mut rng)];
            let copies = if rng.random_range(0..4) == 0 { 3 } else { 1 };
            for copy in 0..copies {
                let base = positions.len() as u32;
                positions.extend(tri);
                faces.push(if copy % 2 == 0 {
                    [base, base + 1, base + 2]
                } else {
                    [base, base + 2, base + 1]
                });
            }
        }
    }
    // Shuffled face order, so that ties are not always won by the earliest plane.
    for i in (1..faces.len()).rev() {
        let j = rng.random_range(0..=i);
        faces.swap(i, j);
    }
    assert_same_faces(&gpu, &positions, &faces, &camera, "coplanar overlaps");
}

#[test]
fn random_triangle_soups_match_cpu() {
    let Some(ctx) = adapter_or_skip() else { return };
    let gpu = IdRasterizer::new(&ctx).unwrap();
    for seed in 0..6u64 {
        let mut rng = Pcg64::seed_from_u64(100 + seed);
        let camera = Camera::look_at(
            rng.random_range(20..120),
            rng.random_range(20..90),
            rng.random_range(20.0..90.0),
            rng.random_range(20.0..90.0),
            DVec3::new(0.0, -3.0, 0.0),
            DVec3::new(
                rng.random_range(-0.5..0.5),
                0.0,
                rng.random_range(-0.5..0.5),
            ),
            DVec3::Z,
        );
        let mut positions = Vec::new();
        let mut faces = Vec::new();
        for _ in 0..400 {
            // Centres from behind the camera to far ahead; sizes from sub-pixel to huge.
            let centre = [
                rng.random_range(-3.0..3.0),
                rng.random_range(-3.5..6.0),
                rng.random_range(-3.0..3.0),
            ];
            let size = 10f32.powf(rng.random_range(-2.5..1.5));
            let base = positions.len() as u32;
            for _ in 0..3 {
                positions.push(std::array::from_fn(|d| {
                    centre[d] + size * rng.random_range(-1.0f32..1.0)
                }));
            }
            faces.push([base, base + 1, base + 2]);
        }
        assert_same_faces(&gpu, &positions, &faces, &camera, &format!("soup {seed}"));
    }
}

#[test]
fn gt_masks_node_writes_the_same_masks_on_both_backends() {
    let Some(_ctx) = adapter_or_skip() else {
        return;
    };
    let tmp = tempfile::tempdir().unwrap();
    let scene_params = "(views: 6, width: 96, height: 72, points: 50)";
    let scene_dir = tmp.path().join("scene");
    let scene = run_node(&SyntheticSceneNode, &[], scene_params, &scene_dir, None).unwrap();
    let inputs = [
        ("frames", scene.outputs["frames"].as_path()),
        ("mesh", scene.outputs["mesh"].as_path()),
    ];
    let masks_on = |backend: &str| {
        let params = format!("(backend: \"{backend}\")");
        run_node(
            &GtMasksNode,
            &inputs,
            &params,
            &tmp.path().join(backend),
            None,
        )
        .unwrap()
    };
    let (cpu, wgpu) = (masks_on("cpu"), masks_on("wgpu"));
    let note = |run: &objectsplat_runtime::testing::NodeRun| {
        run.notes
            .iter()
            .find(|(k, _)| k == "backend")
            .map(|(_, v)| v.clone())
            .unwrap_or_default()
    };
    assert!(note(&cpu).starts_with("cpu"), "{:?}", cpu.notes);
    assert!(note(&wgpu).starts_with("wgpu"), "{:?}", wgpu.notes);
    let (cpu_dir, wgpu_dir) = (&cpu.outputs["masks"], &wgpu.outputs["masks"]);
    assert_eq!(
        read_objects(cpu_dir).unwrap(),
        read_objects(wgpu_dir).unwrap()
    );
    for i in 0..6 {
        let name = format!("frame_{i:03}.png");
        let a = IdMap::load(&cpu_dir.join(&name)).unwrap();
        let b = IdMap::load(&wgpu_dir.join(&name)).unwrap();
        assert_eq!(a, b, "{name}");
        assert!(
            a.data.iter().any(|&v| v != 0 && v != u16::MAX),
            "{name} has objects"
        );
    }
}
