//! `render` draws every member from the frames' cameras: object pixels show the object's
//! colour, uncovered pixels the backdrop colour or, when wired, the frame's background
//! fill; an orbit circles the objects; the unbuilt wgpu backend is a clear error.

mod common;

use objectsplat_core::{Image, Split};
use objectsplat_scene::load_scene;
use objectsplat_scene::nodes::Render;
use objectsplat_scene::render::orbit_cameras;

fn near(a: &[f32], b: [f32; 3], tol: f32) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
}

#[test]
fn a_moved_object_reveals_the_fill_where_it_was() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = common::composed_scene(tmp.path());
    let cam = common::front_camera(64, 64);
    let frames = common::write_frames_from(
        tmp.path(),
        cam,
        &[("f0", Split::Test), ("f1", Split::Train)],
    );
    let moved = common::edited(
        &scene,
        "[Move(target: Id(3), by: (0, 0, 1.2))]",
        &tmp.path().join("edit"),
    )
    .unwrap();
    // A fill with a colour no member has.
    let fills = tmp.path().join("fills");
    std::fs::create_dir_all(&fills).unwrap();
    Image::from_fn(64, 64, 3, |_, _, c| [0.4, 0.0, 0.4][c as usize])
        .save_png8(&fills.join("f0.png"))
        .unwrap();

    let run = common::run(
        &Render,
        &[("scene", &moved), ("frames", &frames), ("fills", &fills)],
        "(background: [1.0, 1.0, 1.0])",
        &tmp.path().join("render"),
    );
    let out = &run.outputs["images"];
    assert!(
        out.join("f0.png").is_file() && !out.join("f1.png").exists(),
        "test views only by default"
    );
    let img = Image::load(&out.join("f0.png")).unwrap();
    let px = |(x, y): (u32, u32)| img.data[((y * 64 + x) * 3) as usize..][..3].to_vec();
    // Where the chair was (centroid of its first triangle), the wall is behind it, so the
    // wall shows; the wall does not cover the image corner, where the fill shows instead
    // of the white backdrop colour.
    let was_chair = common::pixel_of(&cam, [-0.6 + 0.25 / 3.0, 0.0, -0.25 / 3.0]);
    assert!(
        near(&px(was_chair), [0.2, 0.3, 0.8], 0.02),
        "{:?}",
        px(was_chair)
    );
    assert!(near(&px((0, 0)), [0.4, 0.0, 0.4], 0.01), "{:?}", px((0, 0)));
    let now_chair = common::pixel_of(&cam, [-0.6 + 0.25 / 3.0, 0.0, 1.2 - 0.25 / 3.0]);
    assert!(
        near(&px(now_chair), [0.9, 0.1, 0.1], 0.02),
        "{:?}",
        px(now_chair)
    );
    let cup = common::pixel_of(&cam, [0.6 + 0.2 / 3.0, 0.0, -0.2 / 3.0]);
    assert!(near(&px(cup), [0.1, 0.9, 0.1], 0.02), "{:?}", px(cup));

    // Without a fill, the uncovered corner shows the backdrop colour.
    let run = common::run(
        &Render,
        &[("scene", &moved), ("frames", &frames)],
        "(views: \"all\")",
        &tmp.path().join("r2"),
    );
    let img = Image::load(&run.outputs["images"].join("f1.png")).unwrap();
    assert!(near(&img.data[..3], [0.0, 0.0, 0.0], 0.01));
}

#[test]
fn orbit_cameras_circle_the_objects_at_the_frames_distance() {
    let tmp = tempfile::tempdir().unwrap();
    let scene_dir = common::composed_scene(tmp.path());
    let scene = load_scene(&scene_dir).unwrap();
    let cam = common::front_camera(48, 32);
    let frames = common::write_frames_from(tmp.path(), cam, &[("f0", Split::Test)]);
    let frame = objectsplat_core::Frame::new("f0", "images/f0.png", &cam, Split::Test);
    let cams = orbit_cameras(&scene, &[frame], 8).unwrap();
    assert_eq!(cams.len(), 8);
    // Objects span x ∈ [−0.85, 0.8], y ∈ [0, 0.5], z ∈ [−0.25, 0.75]: focus (−0.025, 0.25, 0.25).
    let focus = glam::DVec3::new(-0.025, 0.25, 0.25);
    let expected_radius = (cam.center() - focus).truncate().length();
    for c in &cams {
        let (u, v, _) = c.project(focus).unwrap();
        assert!(
            (u - 24.0).abs() < 1e-4 && (v - 16.0).abs() < 1e-4,
            "focus at ({u}, {v})"
        );
        let offset = c.center() - focus;
        assert!((offset.z - (cam.center().z - focus.z)).abs() < 1e-6);
        assert!((offset.truncate().length() - expected_radius).abs() < 1e-6);
    }
    assert!(
        (cams[0].center() - cam.center()).length() < 1e-6,
        "the orbit starts at the first frame"
    );

    let run = common::run(
        &Render,
        &[("scene", &scene_dir), ("frames", &frames)],
        "(views: \"orbit\", orbit_count: 3)",
        &tmp.path().join("r"),
    );
    let names: Vec<String> = std::fs::read_dir(&run.outputs["images"])
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    assert_eq!(names, ["orbit_000.png", "orbit_001.png", "orbit_002.png"]);
}

#[test]
fn the_wgpu_backend_renders_what_the_cpu_backend_renders() {
    let tmp = tempfile::tempdir().unwrap();
    let scene = common::composed_scene(tmp.path());
    // Off-centre, so that no pixel centre lies exactly on a triangle edge: there the
    // window is exactly 0 in the CPU's arithmetic and a rounding error away from it on
    // the GPU (fused multiply-adds), and with σ = 1e-3 that is the difference between
    // transparent and opaque.
    let target = glam::DVec3::new(0.0123, 0.0, 0.0071);
    let eye = target - 4.0 * glam::DVec3::Y;
    let camera = objectsplat_core::Camera::look_at(16, 16, 16.0, 16.0, eye, target, glam::DVec3::Z);
    let frames = common::write_frames_from(tmp.path(), camera, &[("f0", Split::Test)]);
    let render = |backend: &str| {
        objectsplat_runtime::testing::run_node(
            &Render,
            &[("scene", &scene), ("frames", &frames)],
            &format!("(backend: \"{backend}\")"),
            &tmp.path().join(backend),
            None,
        )
    };
    let cpu = render("cpu").unwrap();
    match render("wgpu") {
        Ok(gpu) => {
            assert!(
                gpu.notes
                    .iter()
                    .any(|(k, v)| k == "backend" && v.starts_with("wgpu on ")),
                "{:?}",
                gpu.notes
            );
            let a = Image::load(&cpu.outputs["images"].join("f0.png")).unwrap();
            let b = Image::load(&gpu.outputs["images"].join("f0.png")).unwrap();
            // 8-bit PNGs of renders that agree to 1e-4: at most one code value apart.
            let worst = a
                .data
                .iter()
                .zip(&b.data)
                .map(|(x, y)| (x - y).abs())
                .fold(0.0f32, f32::max);
            let differing: Vec<usize> = (0..a.data.len())
                .filter(|&i| (a.data[i] - b.data[i]).abs() > 1.0 / 255.0 + 1e-6)
                .map(|i| i / 3)
                .collect();
            assert!(
                worst <= 1.0 / 255.0 + 1e-6,
                "largest difference {worst} at pixels {differing:?}"
            );
        }
        Err(err) => {
            if std::env::var("OBJECTSPLAT_REQUIRE_ADAPTER").is_ok_and(|v| v == "1") {
                panic!("no wgpu adapter but OBJECTSPLAT_REQUIRE_ADAPTER=1: {err:#}");
            }
            assert!(format!("{err:#}").contains("no usable adapter"), "{err:#}");
        }
    }
}
