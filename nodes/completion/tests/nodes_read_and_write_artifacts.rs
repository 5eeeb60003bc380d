//! The `inpaint`, `fill_holes` and `inpaint_background` nodes through the runtime's
//! `run_node`: artifacts are decoded and encoded as documented (Image = image.png,
//! Mask = mask.png, Images = <frame stem>.png) and the results are the peers' (OpenCV
//! fixture values, SciPy's filled horse); bad params and mismatched sizes fail with
//! a message naming the problem.

mod common;

use common::{fixture, read_gray, read_rgb, run_error};
use objectsplat_completion::nodes::{FillHolesNode, InpaintBackgroundNode, InpaintNode};
use objectsplat_core::artifact::{IMAGE_PNG, MASK_PNG};
use objectsplat_core::image::{write_gray8, write_rgb8};
use objectsplat_runtime::Outcome;
use std::path::{Path, PathBuf};

/// The folder `root/name`, created, for an artifact of one file.
fn artifact_dir(root: &Path, name: &str) -> PathBuf {
    let dir = root.join(name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// An artifact folder `root/name` holding the fixture `rel` as `file`.
fn artifact(root: &Path, name: &str, file: &str, rel: &str) -> PathBuf {
    let dir = artifact_dir(root, name);
    std::fs::copy(fixture(rel), dir.join(file)).unwrap();
    dir
}

#[test]
fn inpaint_node_reproduces_opencv_on_an_rgb_photo() {
    let tmp = tempfile::tempdir().unwrap();
    let image = artifact(tmp.path(), "image", IMAGE_PNG, "inpaint/images/coffee.png");
    let mask = artifact(tmp.path(), "mask", MASK_PNG, "inpaint/masks/blobs.png");
    let run = common::run(
        &InpaintNode,
        &[("image", &image), ("mask", &mask)],
        "(method: \"telea\", radius: 3.0)",
        &tmp.path().join("out"),
    );
    assert_eq!(run.outcome, Outcome::Done);
    let out = read_rgb(&run.outputs["image"].join(IMAGE_PNG));
    let m = read_gray(&fixture("inpaint/masks/blobs.png"));
    let expected = std::fs::read(fixture("inpaint/expected/coffee_blobs_telea_r3_u8.bin")).unwrap();
    let got: Vec<u8> = m
        .iter()
        .enumerate()
        .filter(|(_, v)| **v != 0)
        .flat_map(|(p, _)| out[p * 3..p * 3 + 3].to_vec())
        .collect();
    assert_eq!(got, expected);
}

#[test]
fn inpaint_node_keeps_sixteen_bit_depth() {
    let tmp = tempfile::tempdir().unwrap();
    let (w, h) = (9u32, 7u32);
    let samples: Vec<u16> = (0..w * h).map(|i| (i * 900) as u16).collect();
    let dir = artifact_dir(tmp.path(), "image");
    let bytes: Vec<u8> = samples.iter().flat_map(|v| v.to_ne_bytes()).collect();
    image::save_buffer_with_format(
        dir.join(IMAGE_PNG),
        &bytes,
        w,
        h,
        image::ExtendedColorType::L16,
        image::ImageFormat::Png,
    )
    .unwrap();
    let mdir = artifact_dir(tmp.path(), "mask");
    let mut mask = vec![0u8; (w * h) as usize];
    mask[30] = 255;
    write_gray8(&mdir.join(MASK_PNG), &mask, w, h).unwrap();
    let inputs = [("image", dir.as_path()), ("mask", &mdir)];
    let run = common::run(&InpaintNode, &inputs, "()", &tmp.path().join("out"));
    let out = image::open(run.outputs["image"].join(IMAGE_PNG)).unwrap();
    let image::DynamicImage::ImageLuma16(buf) = out else {
        panic!("bit depth lost: {:?}", out.color())
    };
    let out = buf.into_raw();
    for (i, (&a, &b)) in out.iter().zip(&samples).enumerate() {
        if i != 30 {
            assert_eq!(a, b, "pixel {i} outside the mask changed");
        }
    }
    // A linear ramp's hole is filled between its neighbours' values.
    assert!(
        out[30] > samples[29] - 2000 && out[30] < samples[31] + 2000,
        "{}",
        out[30]
    );
}

#[test]
fn inpaint_node_rejects_a_mask_of_another_size() {
    let tmp = tempfile::tempdir().unwrap();
    let image = artifact(tmp.path(), "image", IMAGE_PNG, "inpaint/images/camera.png");
    let mask = artifact(tmp.path(), "mask", MASK_PNG, "fill_holes/horse.png");
    let inputs = [("image", image.as_path()), ("mask", &mask)];
    let err = run_error(&InpaintNode, &inputs, "()", &tmp.path().join("out"));
    assert!(err.contains("mask is 400×328"), "{err}");
}

#[test]
fn fill_holes_node_matches_scipy_on_the_horse() {
    let tmp = tempfile::tempdir().unwrap();
    let mask = artifact(tmp.path(), "mask", MASK_PNG, "fill_holes/horse.png");
    let inputs = [("mask", mask.as_path())];
    for n in [4, 8] {
        let out = tmp.path().join(format!("out{n}"));
        let run = common::run(
            &FillHolesNode,
            &inputs,
            &format!("(connectivity: {n})"),
            &out,
        );
        let got = read_gray(&run.outputs["mask"].join(MASK_PNG));
        let want = read_gray(&fixture(&format!("fill_holes/horse_filled_{n}.png")));
        assert_eq!(got, want, "connectivity {n}");
    }
    let err = run_error(
        &FillHolesNode,
        &inputs,
        "(connectivity: 6)",
        &tmp.path().join("bad"),
    );
    assert!(err.contains("4 or 8"), "{err}");
}

#[test]
fn background_node_fills_object_pixels_with_builtin_ns_and_from_a_folder() {
    let scene = common::build("table");
    let inputs = [
        ("components", scene.components.as_path()),
        ("frames", scene.frames.as_path()),
    ];
    let run = common::run(
        &InpaintBackgroundNode,
        &inputs,
        "(method: \"ns\")",
        &scene.root.path().join("ns"),
    );
    assert_eq!(run.outcome, Outcome::Done);
    assert!(
        run.notes
            .iter()
            .any(|(k, v)| k == "use" && v.contains("never fed to metrics"))
    );
    let fill = read_rgb(&run.outputs["fills"].join("f0.png"));
    // Everything around the objects is background grey, so NS fills grey.
    assert!(
        fill.chunks(3).all(|p| p == common::BACKGROUND_RGB),
        "fill is not uniformly background"
    );

    // Precomputed fills: white images; only object pixels take them.
    let folder = scene.root.path().join("precomputed");
    std::fs::create_dir_all(&folder).unwrap();
    for f in 0..2 {
        let white = vec![255u8; (common::W * common::H * 3) as usize];
        write_rgb8(
            &folder.join(format!("f{f}.png")),
            &white,
            common::W,
            common::H,
        )
        .unwrap();
    }
    let params = format!(
        "(method: \"folder\", path: {:?})",
        folder.display().to_string()
    );
    let run = common::run(
        &InpaintBackgroundNode,
        &inputs,
        &params,
        &scene.root.path().join("folder"),
    );
    let fill = read_rgb(&run.outputs["fills"].join("f1.png"));
    let whites = fill.chunks(3).filter(|p| *p == [255, 255, 255]).count();
    let objects = (0..common::H)
        .flat_map(|y| (0..common::W).map(move |x| (x, y)))
        .filter(|&(x, y)| common::owner(1, x, y) != common::Owner::Background)
        .count();
    assert_eq!(whites, objects);

    std::fs::remove_file(folder.join("f1.png")).unwrap();
    let err = run_error(
        &InpaintBackgroundNode,
        &inputs,
        &params,
        &scene.root.path().join("folder2"),
    );
    assert!(
        err.contains("no precomputed fill for frame \"f1\""),
        "{err}"
    );
}
