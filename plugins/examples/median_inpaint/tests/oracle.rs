//! median_inpaint against the NumPy oracle (tests/fixtures/make_fixtures.py),
//! called through its exported entry table as the host calls it.

use median_inpaint::objectsplat_plugin_entry_v1;
use objectsplat_plugin_sdk::artifacts::{IMAGE_PNG, MASK_PNG};
use objectsplat_plugin_sdk::core::Image;
use objectsplat_plugin_sdk::protocol::OutcomeKind;
use objectsplat_plugin_sdk::testing;
use std::path::Path;

fn fixture(name: &str) -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// Image and Mask artifact folders holding copies of the fixture files.
fn artifacts(dir: &Path, image: &str, mask: &str) -> (std::path::PathBuf, std::path::PathBuf) {
    let (img_dir, mask_dir) = (dir.join("image"), dir.join("mask"));
    std::fs::create_dir_all(&img_dir).unwrap();
    std::fs::create_dir_all(&mask_dir).unwrap();
    std::fs::copy(fixture(image), img_dir.join(IMAGE_PNG)).unwrap();
    std::fs::copy(fixture(mask), mask_dir.join(MASK_PNG)).unwrap();
    (img_dir, mask_dir)
}

fn fill(image: &str, mask: &str) -> (testing::RunResult, tempfile::TempDir) {
    let dir = tempfile::tempdir().unwrap();
    let (img_dir, mask_dir) = artifacts(dir.path(), image, mask);
    let out = dir.path().join("out");
    std::fs::create_dir_all(&out).unwrap();
    let result = testing::run(
        objectsplat_plugin_entry_v1(),
        "median_inpaint",
        &[("image", &img_dir), ("mask", &mask_dir)],
        &[("image", &out)],
        &[("connectivity", "\"8\"")],
        dir.path(),
    )
    .unwrap();
    (result, dir)
}

#[test]
fn eight_bit_rgb_matches_the_numpy_oracle_and_keeps_known_pixels() {
    let (result, dir) = fill("input.png", "hole.png");
    let response = result.expect("the node succeeds");
    assert_eq!(response.outcome, OutcomeKind::Done);
    let got = Image::load(&dir.path().join("out/image.png")).unwrap();
    assert_eq!(got, Image::load(&fixture("expected.png")).unwrap());
    let input = Image::load(&fixture("input.png")).unwrap();
    let mask = Image::load(&fixture("hole.png")).unwrap();
    for (p, hole) in mask.data.iter().enumerate() {
        if *hole == 0.0 {
            assert_eq!(
                got.data[p * 3..p * 3 + 3],
                input.data[p * 3..p * 3 + 3],
                "pixel {p} outside the mask changed"
            );
        }
    }
}

#[test]
fn sixteen_bit_grey_stays_sixteen_bit_and_matches_the_oracle() {
    let (result, dir) = fill("input16.png", "mask16.png");
    result.expect("the node succeeds");
    let out = dir.path().join("out");
    assert_eq!(
        objectsplat_plugin_sdk::artifacts::image_bit_depth(&out).unwrap(),
        16
    );
    assert_eq!(
        Image::load(&out.join(IMAGE_PNG)).unwrap(),
        Image::load(&fixture("expected16.png")).unwrap()
    );
}

#[test]
fn an_empty_mask_skips_and_forwards_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let (img_dir, mask_dir) = artifacts(dir.path(), "input.png", "hole.png");
    let blank = Image::new(24, 16, 1);
    blank.save_png8(&mask_dir.join(MASK_PNG)).unwrap();
    let response = testing::run(
        objectsplat_plugin_entry_v1(),
        "median_inpaint",
        &[("image", &img_dir), ("mask", &mask_dir)],
        &[("image", dir.path())],
        &[("connectivity", "\"4\"")],
        dir.path(),
    )
    .unwrap()
    .expect("skipping is not a failure");
    assert_eq!(response.outcome, OutcomeKind::Skipped);
    assert_eq!(
        response.forwards,
        vec![("image".to_string(), "image".to_string())]
    );
}

#[test]
fn a_mask_covering_everything_fails_with_a_reason() {
    let mut image = Image::from_fn(3, 2, 1, |x, y, _| (x + y) as f32 / 8.0);
    let mut known = vec![false; 6];
    let e = median_inpaint::median_fill(&mut image, &mut known, &[(1, 0)]).unwrap_err();
    assert!(e.to_string().contains("covers the whole image"));
}
