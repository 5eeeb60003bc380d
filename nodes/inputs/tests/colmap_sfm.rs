//! `colmap_sfm` with the installed COLMAP (Debian's 3.8 in CI):
//! - photos of the synthetic room, rendered from known cameras, are all registered (a
//!   stray photo among them is reported by name), and once the node aligns them to those
//!   cameras every frame's rotation and centre agree with the truth (measured here from
//!   the frames it wrote, not from its own report);
//! - its frames and points are byte for byte what `colmap_scene` makes of the model
//!   folder it writes;
//! - real photos (kapture's maupertuis sample, tests/fixtures/maupertuis) are registered
//!   and agree with the COLMAP model shipped with them, up to a similarity;
//! - an unreadable image, photos without anything in common, photos of two sizes for one
//!   camera and a missing colmap each fail with an error naming the problem.
//!
//! COLMAP is a real dependency: under CI (`CI=true`, where .ci/run installs it) a test
//! that needs it fails when it is missing; elsewhere it prints SKIPPED and passes.

mod common;
use common::{assert_mentions, fixture, installed, node_error, read_json};
use glam::{DMat3, DVec3};
use objectsplat_core::frames::frame_stem;
use objectsplat_core::{Camera, Frames};
use objectsplat_inputs::colmap::{self, ColmapModel};
use objectsplat_inputs::nodes::ColmapScene;
use objectsplat_inputs::sfm_nodes::{ALIGNMENT_JSON, ColmapSfm, REGISTRATION_JSON};
use objectsplat_inputs::similarity::{Similarity, extent, rotation_angle_degrees};
use objectsplat_runtime::Node;
use objectsplat_runtime::testing::run_node;
use std::collections::HashMap;
use std::path::Path;

/// True when colmap can be run; under CI its absence fails the test.
fn colmap_available(test: &str) -> bool {
    installed(test, objectsplat_inputs::colmap_sfm::version("colmap"))
}

/// A path as a RON string literal.
fn ron_path(path: &Path) -> String {
    format!("{:?}", path.display().to_string())
}

/// Renders the synthetic room from `views` cameras into `dir` (frames/, mesh/, points/).
fn render_room(dir: &Path, views: usize, width: u32, height: u32) -> std::path::PathBuf {
    run_node(
        &objectsplat_synth::nodes::SyntheticSceneNode,
        &[],
        &format!("(views: {views}, width: {width}, height: {height}, split: \"all\")"),
        dir,
        None,
    )
    .unwrap();
    dir.join("frames")
}

/// Every written frame against the true camera of the same stem: the largest rotation
/// error (degrees) and camera-centre error (as a fraction of the true centres' extent).
fn pose_errors(written: &Frames, truth: &Frames) -> (f64, f64) {
    let truth: HashMap<&str, Camera> = truth
        .frames
        .iter()
        .map(|f| (frame_stem(&f.name), f.camera()))
        .collect();
    let size = extent(&truth.values().map(Camera::center).collect::<Vec<_>>());
    let (mut rotation, mut centre) = (0.0f64, 0.0f64);
    for f in &written.frames {
        let (got, want) = (f.camera(), truth[frame_stem(&f.name)]);
        rotation = rotation.max(rotation_angle_degrees(got.rotation(), want.rotation()));
        centre = centre.max((got.center() - want.center()).length() / size);
    }
    (rotation, centre)
}

/// A photo among the renders that shows something else: COLMAP cannot register it.
const STRAY: &str = "stray_noise.png";

/// The outcome of [`sfm_on_the_room`].
struct RoomSfm {
    out: std::path::PathBuf,
    run: objectsplat_runtime::testing::NodeRun,
    /// Worst rotation error, degrees.
    rotation: f64,
    /// Worst centre error, as a fraction of the true centres' extent.
    centre: f64,
}

/// `colmap_sfm` on the room rendered from `views` cameras (plus [`STRAY`] when `stray`),
/// aligned to them, its frames measured against the true cameras. Every render must be
/// registered, and nothing else.
fn sfm_on_the_room(dir: &Path, views: usize, (width, height): (u32, u32), stray: bool) -> RoomSfm {
    let truth_dir = render_room(&dir.join("room"), views, width, height);
    if stray {
        noise_png(&truth_dir.join("images").join(STRAY), 7, (width, height));
    }
    let out = dir.join("sfm");
    let started = std::time::Instant::now();
    let run = run_node(
        &ColmapSfm,
        &[("reference", &truth_dir)],
        &format!(
            "(path: Some({}), split: \"all\")",
            ron_path(&truth_dir.join("images"))
        ),
        &out,
        None,
    )
    .unwrap();
    let seconds = started.elapsed().as_secs_f64();
    let registration = read_json(&out.join("model").join(REGISTRATION_JSON));
    assert_eq!(registration["registered"].as_array().unwrap().len(), views);
    if stray {
        // A partial registration is reported by name, in the run report and the model.
        assert_eq!(registration["unregistered"], serde_json::json!([STRAY]));
        assert_eq!(run.warnings.len(), 1, "{:?}", run.warnings);
        let expected = format!(
            "1 of {} images were not registered (not in the largest model): {STRAY}",
            views + 1
        );
        assert_eq!(run.warnings[0], expected);
    } else {
        assert!(registration["unregistered"].as_array().unwrap().is_empty());
        assert!(run.warnings.is_empty(), "{:?}", run.warnings);
    }
    let truth = Frames::read(&truth_dir).unwrap();
    let written = Frames::read(&out.join("frames")).unwrap();
    assert_eq!(written.frames.len(), views);
    let (rotation, centre) = pose_errors(&written, &truth);
    println!(
        "{views} views at {width}×{height}: all registered in {seconds:.1} s; rotations within \
         {rotation:.3}°, centres within {:.3} % of their extent",
        centre * 100.0
    );
    RoomSfm {
        out,
        run,
        rotation,
        centre,
    }
}

/// A stray photo among the renders is reported, not silently dropped.
#[test]
fn synthetic_room_is_registered_and_aligned_to_its_true_cameras() {
    if !colmap_available("synthetic_room_is_registered_and_aligned_to_its_true_cameras") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let RoomSfm {
        out,
        run,
        rotation,
        centre,
    } = sfm_on_the_room(dir.path(), 24, (320, 240), true);
    // Measured 0.57° and 0.48 % (COLMAP 3.8, 2026-11-27); COLMAP is not bit-reproducible.
    assert!(rotation <= 1.0, "rotation error {rotation}°");
    assert!(centre <= 0.015, "centre error {} %", centre * 100.0);
    // The node's own account of the fit says the same.
    let alignment = read_json(&out.join("model").join(ALIGNMENT_JSON));
    assert_eq!(alignment["matched"], 24);
    assert!((alignment["max_rotation_error_degrees"].as_f64().unwrap() - rotation).abs() < 1e-6);
    let scale_note = &run.notes.iter().find(|(k, _)| k == "scale").unwrap().1;
    assert!(scale_note.starts_with("the reference's"), "{scale_note}");

    // colmap_scene reads the model folder it wrote into the very same frames and points.
    let images = dir.path().join("room/frames/images");
    let again = dir.path().join("colmap_scene");
    run_node(
        &ColmapScene,
        &[],
        &format!(
            "(path: {}, images: Some({}), split: \"all\")",
            ron_path(&out.join("model")),
            ron_path(&images)
        ),
        &again,
        None,
    )
    .unwrap();
    let bytes = |p: &Path| std::fs::read(p).unwrap();
    assert!(bytes(&out.join("frames/frames.json")) == bytes(&again.join("frames/frames.json")));
    assert!(bytes(&out.join("points/points.ply")) == bytes(&again.join("points/points.ply")));
    for f in &Frames::read(&out.join("frames")).unwrap().frames {
        let image = Path::new(&f.image);
        assert!(bytes(&out.join("frames").join(image)) == bytes(&again.join("frames").join(image)));
    }
}

/// The must-hold at full size (48 views, 640×480): minutes of COLMAP on two
/// cores, so run by hand for docs/benchmarks.md:
/// `cargo test --release -p objectsplat-inputs --test colmap_sfm -- --ignored --nocapture`
#[test]
#[ignore = "minutes of COLMAP; the must-hold measurement behind docs/benchmarks.md"]
fn synthetic_room_at_48_views_640x480_meets_the_must_hold() {
    if !colmap_available("synthetic_room_at_48_views_640x480_meets_the_must_hold") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let RoomSfm {
        rotation, centre, ..
    } = sfm_on_the_room(dir.path(), 48, (640, 480), false);
    assert!(rotation <= 0.5, "rotation error {rotation}°");
    assert!(centre <= 0.01, "centre error {} %", centre * 100.0);
}

/// Each image's camera centre and world→camera rotation, by name.
fn poses(model: &ColmapModel) -> HashMap<String, (DVec3, DMat3)> {
    model
        .images
        .values()
        .map(|img| {
            let (r, t) = (img.pose.rotation(), img.pose.translation());
            (img.name.clone(), (-(r.transpose() * t), r))
        })
        .collect()
}

/// One reconstruction of the Maupertuis sample: the worst relative rotation between
/// two of its views against the shipped model (degrees), and the worst camera centre
/// after the best similarity between the two frames (share of their extent).
fn maupertuis_errors() -> (f64, f64) {
    let dir = tempfile::tempdir().unwrap();
    let sample = fixture("maupertuis");
    // The sample's own intrinsics (its cameras.txt and kapture's sensors.txt agree);
    // DSP-SIFT on 960-pixel copies, because these JPEGs are compressed to 0.07 bits per
    // pixel: full-size SIFT features match blocking artefacts, not the building.
    let params = format!(
        "(path: Some({}), camera_model: \"SIMPLE_PINHOLE\", camera_params: Some([1847.53, 959.5, 539.5]), \
         max_image_size: 960, domain_size_pooling: true, \
         colmap_options: {{\"Mapper.abs_pose_min_num_inliers\": 15}}, split: \"all\")",
        ron_path(&sample.join("images"))
    );
    let run = run_node(&ColmapSfm, &[], &params, dir.path(), None).unwrap();
    let ours = poses(&colmap::read_model(&dir.path().join("model")).unwrap());
    let shipped = poses(&colmap::read_model(&sample.join("sparse")).unwrap());
    assert_eq!(ours.len(), 4, "registered: {:?}", ours.keys());
    let scale_note = &run.notes.iter().find(|(k, _)| k == "scale").unwrap().1;
    assert!(scale_note.starts_with("arbitrary"), "{scale_note}");

    let mut names: Vec<&String> = shipped.keys().collect();
    names.sort();
    // Relative rotations do not depend on either model's frame.
    let mut worst_rotation = 0.0f64;
    for (i, a) in names.iter().enumerate() {
        for b in &names[i + 1..] {
            let relative = |p: &HashMap<String, (DVec3, DMat3)>| p[*a].1 * p[*b].1.transpose();
            worst_rotation =
                worst_rotation.max(rotation_angle_degrees(relative(&ours), relative(&shipped)));
        }
    }
    // Centres after the least-squares similarity between the two frames.
    let source: Vec<DVec3> = names.iter().map(|n| ours[*n].0).collect();
    let target: Vec<DVec3> = names.iter().map(|n| shipped[*n].0).collect();
    let s = Similarity::fit(&source, &target).unwrap();
    let worst_centre = source
        .iter()
        .zip(&target)
        .map(|(p, q)| (s.apply(*p) - *q).length())
        .fold(0.0, f64::max)
        / extent(&target);
    println!(
        "maupertuis: relative rotations within {worst_rotation:.3}°, centres within {:.3} % of their extent",
        worst_centre * 100.0
    );
    (worst_rotation, worst_centre)
}

#[test]
fn maupertuis_photos_agree_with_the_model_shipped_with_them() {
    if !colmap_available("maupertuis_photos_agree_with_the_model_shipped_with_them") {
        return;
    }
    // Measured 0.25–1.02° and 0.15–0.75 % over 11 runs (COLMAP 3.8, 2026-11-27). COLMAP
    // is not reproducible, its `random_seed` and one thread included, and one run of
    // about ten registered a view 21° off: a reconstruction may be tried three times.
    let within = |(rotation, centre): (f64, f64)| rotation <= 3.0 && centre <= 0.03;
    let mut errors = maupertuis_errors();
    for _ in 1..3 {
        if within(errors) {
            break;
        }
        errors = maupertuis_errors();
    }
    let (worst_rotation, worst_centre) = errors;
    assert!(
        worst_rotation <= 3.0,
        "relative rotation error {worst_rotation}°"
    );
    assert!(
        worst_centre <= 0.03,
        "centre error {} %",
        worst_centre * 100.0
    );
}

/// An RGB PNG of seeded noise, `width`×`height` (nothing another one can match).
fn noise_png(path: &Path, seed: u32, (width, height): (u32, u32)) {
    let mut state = seed.wrapping_mul(2_654_435_761).max(1);
    let img = image::RgbImage::from_fn(width, height, |_, _| {
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            (state >> 24) as u8
        };
        image::Rgb([next(), next(), next()])
    });
    img.save(path).unwrap();
}

#[test]
fn an_unreadable_image_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let photos = dir.path().join("photos");
    std::fs::create_dir_all(&photos).unwrap();
    noise_png(&photos.join("a.png"), 1, (96, 72));
    std::fs::write(photos.join("b.jpg"), b"not a JPEG at all").unwrap();
    let e = node_error(
        &ColmapSfm,
        &[],
        &format!("(path: Some({}))", ron_path(&photos)),
    );
    assert_mentions(&e, &["b.jpg", "cannot be read as an image"]);

    let empty = dir.path().join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    std::fs::write(empty.join("notes.txt"), "no photos").unwrap();
    let e = node_error(
        &ColmapSfm,
        &[],
        &format!("(path: Some({}))", ron_path(&empty)),
    );
    assert_mentions(&e, &["no PNG or JPEG images", "notes.txt"]);
}

#[test]
fn photos_with_nothing_in_common_register_nothing() {
    if !colmap_available("photos_with_nothing_in_common_register_nothing") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let photos = dir.path().join("photos");
    std::fs::create_dir_all(&photos).unwrap();
    for seed in 1..=3 {
        noise_png(&photos.join(format!("noise_{seed}.png")), seed, (96, 72));
    }
    let e = node_error(
        &ColmapSfm,
        &[],
        &format!("(path: Some({}))", ron_path(&photos)),
    );
    assert_mentions(
        &e,
        &[
            "registered none of the 3 images",
            "COLMAP's mapper",
            "its log:",
        ],
    );

    // One camera for photos of two sizes: COLMAP skips one, and the node says why.
    noise_png(&photos.join("noise_9.png"), 9, (64, 64));
    let e = node_error(
        &ColmapSfm,
        &[],
        &format!("(path: Some({}))", ron_path(&photos)),
    );
    assert_mentions(
        &e,
        &[
            "COLMAP's feature extraction skipped 1 image(s): noise_9.png",
            "set it to false",
        ],
    );
}

#[test]
fn a_missing_colmap_says_how_to_install_it() {
    let dir = tempfile::tempdir().unwrap();
    let photos = dir.path().join("photos");
    std::fs::create_dir_all(&photos).unwrap();
    noise_png(&photos.join("a.png"), 1, (96, 72));
    let params =
        |program: &str| format!("(path: Some({}), program: {program:?})", ron_path(&photos));
    let e = node_error(&ColmapSfm, &[], &params("objectsplat-test-no-such-colmap"));
    assert_mentions(
        &e,
        &[
            "`objectsplat-test-no-such-colmap` is not installed",
            "apt-get install colmap",
        ],
    );
    let e = node_error(&ColmapSfm, &[], &params("/nonexistent/bin/colmap"));
    assert_mentions(&e, &["/nonexistent/bin/colmap: no such program"]);

    // Planning does not fail on it: the key names the missing program instead.
    let spec_params = objectsplat_runtime::Params::new(
        [(
            "program".to_string(),
            objectsplat_runtime::Value::Str("objectsplat-test-no-such-colmap".into()),
        )]
        .into(),
    );
    let versions = ColmapSfm.tool_versions(&spec_params);
    assert_eq!(versions.len(), 1);
    assert!(versions[0].contains("is not installed"), "{versions:?}");
}
