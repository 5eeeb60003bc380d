//! COCO RLE decoding is identical to pycocotools on RLEs it encoded (compressed strings,
//! many with negative deltas), and bad RLEs are errors.

use objectsplat_inputs::rle;
use serde_json::{Value, json};
use std::path::Path;

#[test]
fn compressed_strings_decode_like_pycocotools() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/masks/rle_cases.json");
    let cases: Vec<Value> = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let mut negative_deltas = 0;
    for (i, case) in cases.iter().enumerate() {
        let m = rle::decode(case).unwrap();
        let counts = rle::decode_counts_string(case["counts"].as_str().unwrap()).unwrap();
        negative_deltas += (3..counts.len())
            .filter(|&k| counts[k] < counts[k - 2])
            .count();
        if let Some(rows) = case.get("mask").and_then(Value::as_array) {
            let want: Vec<bool> = rows
                .iter()
                .flat_map(|r| r.as_array().unwrap().iter().map(|v| v.as_u64() == Some(1)))
                .collect();
            assert_eq!(m.data, want, "case {i}");
        } else {
            assert_eq!(
                m.area() as u64,
                case["mask_sum"].as_u64().unwrap(),
                "case {i}"
            );
            assert_eq!(m.area() as u64, case["area"].as_u64().unwrap(), "case {i}");
        }
    }
    assert!(
        negative_deltas > 10,
        "fixtures must exercise negative deltas ({negative_deltas})"
    );
}

#[test]
fn uncompressed_counts_are_column_major() {
    // 2×3 mask, column-major runs: 1 zero, 2 ones, 3 zeros → pixels (x=0,y=1) and (x=1,y=0).
    let m = rle::decode(&json!({"size": [2, 3], "counts": [1, 2, 3]})).unwrap();
    assert_eq!(m.data, [false, true, false, true, false, false]);
}

#[test]
fn size_disagreeing_with_runs_and_bad_characters_are_errors() {
    let e = rle::decode(&json!({"size": [2, 3], "counts": [1, 2, 4]}))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("runs cover 7 pixels but its size is 2×3 = 6"),
        "{e}"
    );
    let e = rle::decode(&json!({"size": [2, 3], "counts": "a~"}))
        .unwrap_err()
        .to_string();
    assert!(e.contains("outside the encoding's range"), "{e}");
    let e = rle::decode(&json!({"size": [2, 3], "counts": "o"}))
        .unwrap_err()
        .to_string();
    assert!(e.contains("ends inside the count"), "{e}");
    let e = rle::decode(&json!({"size": [2], "counts": [6]}))
        .unwrap_err()
        .to_string();
    assert!(e.contains("size"), "{e}");
    let e = rle::decode_counts_string("PPPPPPPPPPPPPP0")
        .unwrap_err()
        .to_string();
    assert!(e.contains("too long"), "{e}");
}
