//! The fuzz target for the data readers: every reader of a file a user (or a
//! downloaded dataset) supplies gets arbitrary bytes and mutations of a valid file,
//! and must answer with a value or an error, never a panic or an abort. Run briefly
//! with the test suite (a few hundred cases per reader); raise the count with
//! `PROPTEST_CASES=100000 cargo test --release -p objectsplat-inputs --test fuzz`.
//!
//! Binary COLMAP models, `.npy` arrays, COCO RLE counts and PLY files are fuzzed in
//! colmap_bad_input.rs, masks_bad_input.rs and ply_bad_input.rs; this file covers
//! the others: COLMAP text models, nerfstudio transforms.json, frames.json, label
//! PNGs, the objects.json of a Masks artifact, and COCO-RLE mask folders through the
//! whole import.

use objectsplat_core::Frames;
use objectsplat_core::artifact::{FRAMES_JSON, OBJECTS_JSON};
use objectsplat_inputs::masks_import::{self, MaskFormat, OverlapPolicy};
use objectsplat_inputs::{colmap, label_png, nerfstudio};
use proptest::prelude::*;

/// `PROPTEST_CASES` when set (a longer fuzzing session), else the brief default.
fn cases(brief: u32) -> u32 {
    std::env::var("PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(brief)
}

mod common;
use common::fixture;

/// One edit of a valid file: overwrite, insert or delete a byte at a position.
#[derive(Debug, Clone)]
enum Edit {
    Set(prop::sample::Index, u8),
    Insert(prop::sample::Index, u8),
    Delete(prop::sample::Index),
    Truncate(prop::sample::Index),
}

fn edits() -> impl Strategy<Value = Vec<Edit>> {
    let edit = prop_oneof![
        (any::<prop::sample::Index>(), any::<u8>()).prop_map(|(i, b)| Edit::Set(i, b)),
        (any::<prop::sample::Index>(), any::<u8>()).prop_map(|(i, b)| Edit::Insert(i, b)),
        any::<prop::sample::Index>().prop_map(Edit::Delete),
        any::<prop::sample::Index>().prop_map(Edit::Truncate),
    ];
    proptest::collection::vec(edit, 1..6)
}

fn mutate(mut bytes: Vec<u8>, edits: &[Edit]) -> Vec<u8> {
    for e in edits {
        if bytes.is_empty() {
            break;
        }
        match e {
            Edit::Set(i, b) => {
                let i = i.index(bytes.len());
                bytes[i] = *b;
            }
            Edit::Insert(i, b) => {
                let i = i.index(bytes.len() + 1);
                bytes.insert(i, *b);
            }
            Edit::Delete(i) => {
                let i = i.index(bytes.len());
                bytes.remove(i);
            }
            Edit::Truncate(i) => {
                let i = i.index(bytes.len());
                bytes.truncate(i);
            }
        }
    }
    bytes
}

/// Numbers are where readers go wrong (sizes, counts, ids): also splice digits,
/// signs and exponents into text formats.
fn numeric_edits() -> impl Strategy<Value = Vec<(prop::sample::Index, String)>> {
    proptest::collection::vec(
        (
            any::<prop::sample::Index>(),
            prop_oneof![
                Just("-1".to_string()),
                Just("0".to_string()),
                Just("1e308".to_string()),
                Just("NaN".to_string()),
                Just("18446744073709551616".to_string()),
                Just("4294967295".to_string()),
                "[0-9]{1,12}",
            ],
        ),
        1..4,
    )
}

fn splice(text: &str, edits: &[(prop::sample::Index, String)]) -> String {
    let mut s = text.to_string();
    for (i, insert) in edits {
        let at = s.floor_char_boundary(i.index(s.len() + 1));
        s.insert_str(at, insert);
    }
    s
}

fn colmap_text_files() -> Vec<(&'static str, Vec<u8>)> {
    ["cameras.txt", "images.txt", "points3D.txt"]
        .into_iter()
        .map(|n| {
            (
                n,
                std::fs::read(fixture("colmap/classic_txt").join(n)).unwrap(),
            )
        })
        .collect()
}

const TRANSFORMS: &str = r#"{"fl_x": 40, "fl_y": 41, "cx": 32, "cy": 24, "w": 64, "h": 48,
  "camera_model": "OPENCV", "k1": 0, "applied_scale": 1.0,
  "frames": [
    {"file_path": "images/a.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]], "mask_path": "masks/a.png"},
    {"file_path": "b.png", "fl_x": 20, "camera_angle_x": 0.8, "transform_matrix": [[0,-1,0,1],[1,0,0,0],[0,0,1,2]], "is_bad": false}
  ],
  "test_frames": [{"file_path": "c.png", "transform_matrix": [[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]]}]}"#;

proptest! {
    #![proptest_config(ProptestConfig { cases: cases(256), ..ProptestConfig::default() })]

    #[test]
    fn colmap_text_models(which in 0usize..3, edits in edits(), numbers in numeric_edits()) {
        let dir = tempfile::tempdir().unwrap();
        for (i, (name, bytes)) in colmap_text_files().into_iter().enumerate() {
            let bytes = if i == which {
                let text = String::from_utf8_lossy(&mutate(bytes, &edits)).into_owned();
                splice(&text, &numbers).into_bytes()
            } else {
                bytes
            };
            std::fs::write(dir.path().join(name), bytes).unwrap();
        }
        let _ = colmap::read_text(dir.path());
    }

    #[test]
    fn nerfstudio_transforms(edits in edits(), numbers in numeric_edits()) {
        let dir = tempfile::tempdir().unwrap();
        let text = String::from_utf8_lossy(&mutate(TRANSFORMS.as_bytes().to_vec(), &edits)).into_owned();
        let path = dir.path().join("transforms.json");
        std::fs::write(&path, splice(&text, &numbers)).unwrap();
        if let Ok(t) = nerfstudio::read(&path, &nerfstudio::Roots::default()) {
            let _ = t.views(glam::DMat4::IDENTITY);
        }
    }

    #[test]
    fn frames_json(edits in edits(), numbers in numeric_edits()) {
        let dir = tempfile::tempdir().unwrap();
        let valid = std::fs::read(fixture("masks/frames").join(FRAMES_JSON)).unwrap();
        let text = String::from_utf8_lossy(&mutate(valid, &edits)).into_owned();
        std::fs::write(dir.path().join(FRAMES_JSON), splice(&text, &numbers)).unwrap();
        let _ = Frames::read(dir.path());
    }

    #[test]
    fn label_pngs(edits in edits(), which in 0usize..2) {
        let dir = tempfile::tempdir().unwrap();
        let name = ["davis/f000.png", "davis/f001.png"][which];
        let bytes = mutate(std::fs::read(fixture("masks").join(name)).unwrap(), &edits);
        let path = dir.path().join("m.png");
        std::fs::write(&path, bytes).unwrap();
        let _ = label_png::read(&path);
    }

    #[test]
    fn objects_json(text in "\\PC{0,80}", edits in edits()) {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join(OBJECTS_JSON), &text).unwrap();
        let _ = objectsplat_core::masks::read_objects(dir.path());
        let valid = br#"{"1": "chair", "7": "table", "65535": "x"}"#.to_vec();
        std::fs::write(dir.path().join(OBJECTS_JSON), mutate(valid, &edits)).unwrap();
        let _ = objectsplat_core::masks::read_objects(dir.path());
    }
}

proptest! {
    // The whole import writes a Masks artifact per case: fewer cases.
    #![proptest_config(ProptestConfig { cases: cases(64), ..ProptestConfig::default() })]

    #[test]
    fn coco_rle_mask_folders(which in 0usize..3, edits in edits(), numbers in numeric_edits()) {
        let dir = tempfile::tempdir().unwrap();
        let source = dir.path().join("coco");
        std::fs::create_dir(&source).unwrap();
        for (i, name) in ["f000.json", "f001.json", "f002.json"].iter().enumerate() {
            let bytes = std::fs::read(fixture("masks/coco_rle").join(name)).unwrap();
            let bytes = if i == which {
                let text = String::from_utf8_lossy(&mutate(bytes, &edits)).into_owned();
                splice(&text, &numbers).into_bytes()
            } else {
                bytes
            };
            std::fs::write(source.join(name), bytes).unwrap();
        }
        let _ = masks_import::import(
            &source,
            MaskFormat::CocoRle,
            OverlapPolicy::parse("lower_id").unwrap(),
            &fixture("masks/frames"),
            &dir.path().join("out"),
            |_, _| {},
        );
    }
}
