//! A tiny synthetic capture: a red square plate seen from a few cameras above it,
//! written as a Component folder plus a Points folder.

#![allow(dead_code)]

use glam::DVec3;
use objectsplat_core::component::{self, OTHER, OWN};
use objectsplat_core::{Camera, ComponentInfo, Frame, Frames, Image, Points, Split};
use std::path::Path;

pub const W: u32 = 64;
pub const H: u32 = 48;
pub const RED: [f32; 3] = [0.8, 0.2, 0.2];
pub const GREY: [f32; 3] = [0.5, 0.5, 0.5];

pub fn cameras() -> Vec<(Camera, Split)> {
    cameras_sized(W, H)
}

/// The same cameras (same focal length) with a `w`×`h` image: a wider frame sees more around the plate.
pub fn cameras_sized(w: u32, h: u32) -> Vec<(Camera, Split)> {
    let eyes = [
        (DVec3::new(0.0, -0.4, 2.2), Split::Train),
        (DVec3::new(0.5, 0.2, 2.0), Split::Train),
        (DVec3::new(-0.5, 0.3, 2.1), Split::Train),
        (DVec3::new(0.2, -0.5, 2.3), Split::Train),
        (DVec3::new(-0.2, 0.1, 2.2), Split::Test),
    ];
    eyes.iter()
        .map(|&(eye, split)| {
            (
                Camera::look_at(w, h, 56.0, 56.0, eye, DVec3::ZERO, DVec3::Y),
                split,
            )
        })
        .collect()
}

/// Whether the ray through pixel (i, j) hits the square |x|, |y| ≤ 0.5 in the plane z = 0.
pub fn pixel_sees_square(cam: &Camera, i: u32, j: u32) -> bool {
    let d_cam = DVec3::new(
        (i as f64 + 0.5 - cam.cx) / cam.fx,
        (j as f64 + 0.5 - cam.cy) / cam.fy,
        1.0,
    );
    let d = cam.rotation().transpose() * d_cam;
    let o = cam.center();
    if d.z.abs() < 1e-12 {
        return false;
    }
    let t = -o.z / d.z;
    let p = o + d * t;
    t > 0.0 && p.x.abs() <= 0.5 && p.y.abs() <= 0.5
}

pub fn write_component(dir: &Path) {
    write_component_sized(dir, W, H)
}

/// The plate component written to a temporary folder and read back as a trainer
/// would: (the folder, which must outlive the data; the data; the plate's points).
pub fn plate() -> (
    tempfile::TempDir,
    objectsplat_train::trainer::ComponentData,
    Points,
) {
    plate_sized(W, H)
}

/// [`plate`] with `w`×`h` views.
pub fn plate_sized(
    w: u32,
    h: u32,
) -> (
    tempfile::TempDir,
    objectsplat_train::trainer::ComponentData,
    Points,
) {
    let (dir, data) = plate_read(w, h);
    let points = data.component_points(&points(), None).unwrap();
    (dir, data, points)
}

/// The plate component with `w`×`h` views written to a temporary folder and read
/// back as training data.
pub fn plate_read(
    w: u32,
    h: u32,
) -> (tempfile::TempDir, objectsplat_train::trainer::ComponentData) {
    let dir = tempfile::tempdir().unwrap();
    write_component_sized(dir.path(), w, h);
    let data = objectsplat_train::trainer::ComponentData::read(dir.path(), 2).unwrap();
    (dir, data)
}

/// The plate component with `w`×`h` views.
pub fn write_component_sized(dir: &Path, w: u32, h: u32) {
    let info = ComponentInfo::object(1, "plate");
    info.write(dir).unwrap();
    std::fs::create_dir_all(dir.join("images")).unwrap();
    let mut frames = Vec::new();
    for (k, (cam, split)) in cameras_sized(w, h).into_iter().enumerate() {
        let name = format!("v{k}");
        let img = Image::from_fn(w, h, 3, |i, j, c| {
            if pixel_sees_square(&cam, i, j) {
                RED[c as usize]
            } else {
                GREY[c as usize]
            }
        });
        img.save_png8(&dir.join(format!("images/{name}.png")))
            .unwrap();
        let mask: Vec<u8> = (0..h)
            .flat_map(|j| (0..w).map(move |i| (i, j)))
            .map(|(i, j)| {
                if pixel_sees_square(&cam, i, j) {
                    OWN
                } else {
                    OTHER
                }
            })
            .collect();
        let frame = Frame::new(&name, format!("images/{name}.png"), &cam, split);
        component::write_mask(dir, &frame, &mask).unwrap();
        frames.push(frame);
    }
    Frames::write_json(dir, &frames).unwrap();
}

/// A 5×5 grid of red points on the square, and a few grey ones off it.
pub fn points() -> Points {
    let mut positions = Vec::new();
    let mut colors = Vec::new();
    for a in 0..5 {
        for b in 0..5 {
            positions.push([-0.4 + 0.2 * a as f32, -0.4 + 0.2 * b as f32, 0.0]);
            colors.push([204, 51, 51]);
        }
    }
    for k in 0..4 {
        positions.push([1.5 + 0.1 * k as f32, 1.2, 0.0]);
        colors.push([128, 128, 128]);
    }
    Points { positions, colors }
}

/// Settings for a short training run on this plate: the reference learning rates are
/// tuned for 30k steps, so a few hundred steps need larger ones, and densification
/// limited to what 64×48 views resolve; one sample per pixel (the loop's behaviour is
/// what these tests check; supersampling has its own in `objectsplat-raster`).
/// `extra` adds or replaces schedule overrides.
pub fn short_run_settings(
    iterations: u64,
    seed: u64,
    extra: serde_json::Value,
) -> objectsplat_train::trainer::TrainSettings {
    let mut overrides = serde_json::json!({
        "lr_sh_dc": 0.03,
        "lr_opacity": 0.1,
        "lr_vertices_start": 4e-3,
        "lr_vertices_end": 4e-4,
        "densify_until": 30,
        "densify_always_largest": 0,
        "supersample": 1,
        "object_supersample": 1,
    });
    let extra = extra
        .as_object()
        .expect("extra overrides are a JSON object");
    for (key, value) in extra {
        overrides[key] = value.clone();
    }
    let schedule = objectsplat_train::Schedule::new(
        iterations,
        overrides.as_object().expect("built as an object above"),
    )
    .expect("valid test schedule");
    settings_with(schedule, seed)
}

/// The trainer's settings for `schedule`: random backgrounds, cropping on, saves
/// every minute, no resume folder.
pub fn settings_with(
    schedule: objectsplat_train::Schedule,
    seed: u64,
) -> objectsplat_train::trainer::TrainSettings {
    objectsplat_train::trainer::TrainSettings {
        schedule,
        seed,
        background_randomization: true,
        fixed_background: [0.0; 3],
        init: objectsplat_train::init::InitSettings::default(),
        world_scale: 1.0,
        checkpoint: Default::default(),
        crop: true,
        select_on: Default::default(),
        resume_dir: None,
        save_seconds: 60.0,
        threads: 1,
        thread_budget: None,
    }
}

/// Every parameter's bit pattern (vertices, SH, opacity logits), for exact comparisons.
pub fn parameter_bits(m: &objectsplat_raster::Model<f32>) -> Vec<u32> {
    m.vertices
        .iter()
        .flatten()
        .chain(m.sh.iter().flatten().flatten())
        .chain(&m.opacity_logits)
        .map(|x| x.to_bits())
        .collect()
}

/// The wgpu backend on the shared adapter, or `None` after printing why the test
/// is skipped; with `OBJECTSPLAT_REQUIRE_ADAPTER=1` a missing adapter fails instead.
pub fn wgpu_backend() -> Option<objectsplat_raster_gpu::WgpuBackend> {
    use objectsplat_gpu::{AdapterChoice, GpuContext};
    use objectsplat_raster_gpu::WgpuBackend;
    let err = match GpuContext::shared(AdapterChoice::Auto) {
        Ok((ctx, _)) => return Some(WgpuBackend::new(ctx).unwrap()),
        Err(err) => err,
    };
    let required = std::env::var("OBJECTSPLAT_REQUIRE_ADAPTER").is_ok_and(|v| v == "1");
    assert!(
        !required,
        "no wgpu adapter but OBJECTSPLAT_REQUIRE_ADAPTER=1: {err:#}"
    );
    eprintln!("SKIPPED (no wgpu adapter): {err:#}");
    None
}

/// Area-weighted mean |cos| between each face's normal and `truth(centroid)`
/// (what `evaluate` calls normal consistency, against an analytic surface).
pub fn normal_consistency(
    vertices: &[[f32; 3]],
    faces: &[[u32; 3]],
    truth: impl Fn([f64; 3]) -> [f64; 3],
) -> f64 {
    let (mut sum, mut area) = (0.0, 0.0);
    for face in faces {
        let corners = face.map(|v| vertices[v as usize].map(|x| x as f64));
        let m = objectsplat_core::geometry::triangle_cross(&corners);
        let twice = (m[0] * m[0] + m[1] * m[1] + m[2] * m[2]).sqrt();
        if twice == 0.0 {
            continue;
        }
        let centroid = [0, 1, 2].map(|k| corners.iter().map(|c| c[k]).sum::<f64>() / 3.0);
        let t = truth(centroid);
        sum += 0.5 * (m[0] * t[0] + m[1] * t[1] + m[2] * t[2]).abs();
        area += 0.5 * twice;
    }
    sum / area
}
