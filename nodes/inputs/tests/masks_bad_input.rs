//! Bad mask input is an error naming the file and the problem; the .npy and RLE parsers
//! never panic on arbitrary bytes.

use objectsplat_inputs::masks_import::{self, MaskFormat, OverlapPolicy};
use objectsplat_inputs::{npy, rle};
use proptest::prelude::*;
use std::path::{Path, PathBuf};

mod common;
use common::{assert_mentions, copy_dir};

fn fixture(name: &str) -> PathBuf {
    common::fixture("masks").join(name)
}

fn import_err(source: &Path, format: MaskFormat, policy: OverlapPolicy) -> String {
    let out = tempfile::tempdir().unwrap();
    let e = masks_import::import(
        source,
        format,
        policy,
        &fixture("frames"),
        out.path(),
        |_, _| {},
    )
    .unwrap_err();
    format!("{e:#}")
}

#[test]
fn mask_png_of_the_wrong_size_names_file_and_sizes() {
    let dir = tempfile::tempdir().unwrap();
    copy_dir(&fixture("davis"), dir.path());
    image::GrayImage::new(15, 12)
        .save(dir.path().join("f001.png"))
        .unwrap();
    let e = import_err(dir.path(), MaskFormat::Davis, OverlapPolicy::LowerId);
    assert_mentions(
        &e,
        &["f001.png: mask is 15×12 but frame \"f001.jpg\" is 16×12"],
    );
}

#[test]
fn exact_multiple_of_the_frame_size_is_sampled_down() {
    let dir = tempfile::tempdir().unwrap();
    let mut big = image::GrayImage::new(32, 24);
    big.put_pixel(3, 3, image::Luma([4])); // sampled by frame pixel (1, 1): x·2 + 1
    big.put_pixel(0, 0, image::Luma([4])); // between samples: ignored
    big.save(dir.path().join("f000.png")).unwrap();
    let out = tempfile::tempdir().unwrap();
    masks_import::import(
        dir.path(),
        MaskFormat::Davis,
        OverlapPolicy::LowerId,
        &fixture("frames"),
        out.path(),
        |_, _| {},
    )
    .unwrap();
    let map = objectsplat_core::IdMap::load(&out.path().join("f000.png")).unwrap();
    assert_eq!(map.data.iter().filter(|&&v| v != 0).count(), 1);
    assert_eq!(map.get(1, 1), 1);
}

#[test]
fn rle_whose_size_disagrees_with_the_frame_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (rle, want) in [
        (
            r#"[{"segmentation": {"size": [12, 15], "counts": [180]}}]"#,
            "f000.json mask 0: mask is 15×12 but frame \"f000.jpg\" is 16×12",
        ),
        (
            r#"[{"segmentation": {"size": [12, 16], "counts": [100]}}]"#,
            "f000.json: mask 0: RLE runs cover 100 pixels but its size is 12×16 = 192",
        ),
    ] {
        std::fs::write(dir.path().join("f000.json"), rle).unwrap();
        let e = import_err(dir.path(), MaskFormat::CocoRle, OverlapPolicy::LowerId);
        assert_mentions(&e, &[want]);
    }
}

#[test]
fn instance_without_a_label_names_both_files() {
    let dir = tempfile::tempdir().unwrap();
    copy_dir(&fixture("gsam"), dir.path());
    std::fs::write(
        dir.path().join("json_data/mask_f002.json"),
        r#"{"labels": {"7": {"instance_id": 7, "class_name": "chair"}}}"#,
    )
    .unwrap();
    let e = import_err(dir.path(), MaskFormat::GroundedSam2, OverlapPolicy::LowerId);
    assert_mentions(
        &e,
        &["mask_f002.json: instance id 3 appears in", "mask_f002.npy"],
    );
}

#[test]
fn higher_score_without_scores_says_which_policy_to_use() {
    let e = import_err(
        &fixture("sav"),
        MaskFormat::PerObjectPng,
        OverlapPolicy::HigherScore,
    );
    assert_mentions(
        &e,
        &["001/f000.png: has no score", "use lower_id or smaller_area"],
    );
}

#[test]
fn unknown_names_and_missing_folders_are_errors() {
    assert!(
        MaskFormat::parse("yolo")
            .unwrap_err()
            .to_string()
            .contains("davis")
    );
    assert!(
        OverlapPolicy::parse("largest")
            .unwrap_err()
            .to_string()
            .contains("lower_id")
    );
    let e = import_err(
        Path::new("/nonexistent/masks"),
        MaskFormat::Davis,
        OverlapPolicy::LowerId,
    );
    assert_mentions(&e, &["/nonexistent/masks: mask source is not a folder"]);
}

/// A version 1.0 .npy file's magic and `header`, before any data.
fn npy_header(header: &str) -> Vec<u8> {
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
    bytes.extend_from_slice(header.as_bytes());
    bytes
}

#[test]
fn npy_header_that_lies_is_refused() {
    let mut bytes =
        npy_header("{'descr': '<u2', 'fortran_order': False, 'shape': (1000000, 1000000), }");
    bytes.extend_from_slice(&[0; 8]);
    let e = npy::parse(&bytes).unwrap_err();
    assert_mentions(&e, &["needs 2000000000000 data bytes but the file has 8"]);
}

#[test]
fn npy_fortran_order_and_big_endian_read_correctly() {
    // 2×3 array [[1,2,3],[4,5,6]] stored column-major as big-endian u2.
    let mut bytes = npy_header("{'descr': '>u2', 'fortran_order': True, 'shape': (2, 3), }");
    for v in [1u16, 4, 2, 5, 3, 6] {
        bytes.extend_from_slice(&v.to_be_bytes());
    }
    let a = npy::parse(&bytes).unwrap();
    assert_eq!((a.height, a.width, a.data), (2, 3, vec![1, 2, 3, 4, 5, 6]));
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn npy_parser_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..200), mutate in any::<prop::sample::Index>()) {
        let _ = npy::parse(&bytes);
        let mut valid = std::fs::read(fixture("gsam/mask_data/mask_f000.npy")).unwrap();
        let i = mutate.index(valid.len());
        valid[i] = bytes.first().copied().unwrap_or(0);
        let _ = npy::parse(&valid);
        let _ = npy::parse(&valid[..i]);
    }

    #[test]
    fn rle_decoder_never_panics(counts in "[0-~]{0,40}", h in 0u64..40, w in 0u64..40) {
        let _ = rle::decode(&serde_json::json!({"size": [h, w], "counts": counts}));
    }
}
