//! A PLY file whose header lies, or whose data is damaged, is an error that names the
//! file and where the problem is; nothing panics and nothing allocates from a lying count.

use objectsplat_core::Mesh;
use objectsplat_core::ply::Ply;
use proptest::prelude::*;
use std::path::Path;

mod common;
use common::assert_mentions;

const GOOD_BINARY: &[u8] = include_bytes!("fixtures/ply/odd_binary_le.ply");
const GOOD_BE: &[u8] = include_bytes!("fixtures/ply/odd_binary_be.ply");
const GOOD_ASCII: &[u8] = include_bytes!("fixtures/ply/odd_ascii.ply");

fn header(body_format: &str, element: &str) -> Vec<u8> {
    format!("ply\nformat {body_format} 1.0\n{element}end_header\n").into_bytes()
}

fn error_of(bytes: &[u8]) -> String {
    Ply::from_bytes(bytes, "lying.ply").unwrap_err().to_string()
}

#[test]
fn count_beyond_file_end_names_element_and_offset_without_allocating() {
    let mut bytes = header(
        "binary_little_endian",
        "element vertex 18446744073709551615\nproperty float x\n",
    );
    bytes.extend_from_slice(&[0; 8]);
    let e = error_of(&bytes);
    assert!(e.starts_with("lying.ply: "), "{e}");
    assert_mentions(&e, &["\"vertex\"", "only 8 bytes remain at byte 100"]);
    let mut ascii = header(
        "ascii",
        "element vertex 999999999999\nproperty float x\nproperty float y\n",
    );
    ascii.extend_from_slice(b"1 2\n3 4\n");
    let e = error_of(&ascii);
    assert!(e.contains("\"vertex\" declares 999999999999 rows"), "{e}");
}

#[test]
fn huge_list_count_is_refused_before_reading_items() {
    let mut bytes = header(
        "binary_little_endian",
        "element face 1\nproperty list uint int vertex_indices\n",
    );
    bytes.extend_from_slice(&u32::MAX.to_le_bytes());
    bytes.extend_from_slice(&[0; 12]);
    let e = error_of(&bytes);
    assert_mentions(&e, &["element \"face\" row 0 property \"vertex_indices\""]);
    assert_mentions(
        &e,
        &["4294967295 int items needs 17179869180 bytes but only 12 remain"],
    );
}

#[test]
fn negative_list_count_is_refused() {
    let mut bytes = header(
        "binary_big_endian",
        "element face 1\nproperty list char int vertex_indices\n",
    );
    bytes.push(0xff);
    let e = error_of(&bytes);
    assert!(e.contains("negative list count -1"), "{e}");
    let mut ascii = header(
        "ascii",
        "element face 1\nproperty list char int vertex_indices\n",
    );
    ascii.extend_from_slice(b"-3 0 1 2\n");
    assert!(error_of(&ascii).contains("negative list count -3"));
}

#[test]
fn unknown_type_and_float_list_count_name_the_header_line() {
    let e = error_of(&header("ascii", "element vertex 1\nproperty float17 x\n"));
    assert_mentions(&e, &["header line 4", "unknown property type \"float17\""]);
    let e = error_of(&header(
        "ascii",
        "element face 1\nproperty list float int idx\n",
    ));
    assert_mentions(&e, &["list count type float is not an integer type"]);
    let e = error_of(b"ply\nformat binary_middle_endian 1.0\nend_header\n");
    assert!(e.contains("unknown format"), "{e}");
    let e = error_of(b"PLY\n");
    assert!(e.contains("not a PLY file"), "{e}");
    let e = error_of(b"ply\nformat ascii 1.0\nelement vertex 1\n");
    assert!(e.contains("without `end_header`"), "{e}");
}

#[test]
fn truncated_data_names_row_property_and_offset() {
    // Cut the little-endian plyfile fixture inside its face element. Rows: vertex 32 bytes;
    // face = quality (8) + ushort count (2) + items (4 each) + tag (2): 24, 28, 24 bytes.
    let end_of_header = GOOD_BINARY
        .windows(11)
        .position(|w| w == b"end_header\n")
        .unwrap()
        + 11;
    let faces_start = end_of_header + 5 * 32;
    let e = error_of(&GOOD_BINARY[..faces_start + 24 + 8 + 2 + 5]);
    assert_mentions(&e, &["element \"face\" row 1 property \"vertex_indices\""]);
    assert!(e.contains("needs 16 bytes but only 5 remain"), "{e}");
    let e = error_of(&GOOD_BINARY[..faces_start + 24 + 28 + 3]);
    let quality_at = faces_start + 24 + 28;
    assert_mentions(
        &e,
        &[&format!(
            "element \"face\" row 2 property \"quality\" at byte {quality_at}: file ends"
        )],
    );
    // Fewer bytes than the rows' minimum size: refused up front, before any row is read.
    let e = error_of(&GOOD_BINARY[..faces_start + 3]);
    assert!(e.contains(&format!("\"face\" declares 3 rows of at least 12 bytes but only 3 bytes remain at byte {faces_start}")), "{e}");
    // The last line is "1 3.25": drop the item, keep its count.
    assert!(GOOD_ASCII.ends_with(b"\n1 3.25\n"));
    let text_cut = GOOD_ASCII.len() - 5;
    let e = error_of(&GOOD_ASCII[..text_cut]);
    assert_mentions(&e, &["element \"edge\" row 2 property \"weights\""]);
}

#[test]
fn ascii_value_out_of_range_names_the_token() {
    let mut bytes = header("ascii", "element vertex 1\nproperty uchar red\n");
    bytes.extend_from_slice(b"256\n");
    let e = error_of(&bytes);
    assert_mentions(
        &e,
        &["row 0 property \"red\" at byte 68: 256 does not fit in uchar"],
    );
}

#[test]
fn mesh_reader_names_the_file_for_bad_indices() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.ply");
    let mut bytes = header(
        "ascii",
        "element vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n",
    );
    bytes.extend_from_slice(b"0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n");
    std::fs::write(&path, bytes).unwrap();
    let e = Mesh::read_ply(&path).unwrap_err().to_string();
    assert_mentions(&e, &["bad.ply", "face 0 refers to vertex 7"]);
    let missing = Mesh::read_ply(Path::new("/nonexistent/x.ply"))
        .unwrap_err()
        .to_string();
    assert_mentions(&missing, &["/nonexistent/x.ply: cannot read"]);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
        let mut with_magic = b"ply\nformat binary_little_endian 1.0\n".to_vec();
        with_magic.extend_from_slice(&bytes);
        let _ = Ply::from_bytes(&bytes, "fuzz.ply");
        let _ = Ply::from_bytes(&with_magic, "fuzz.ply");
    }

    #[test]
    fn mutated_valid_files_never_panic(
        which in 0usize..3,
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
        cut in any::<prop::sample::Index>(),
    ) {
        let mut bytes = [GOOD_BINARY, GOOD_BE, GOOD_ASCII][which].to_vec();
        for (at, value) in edits {
            let i = at.index(bytes.len());
            bytes[i] = value;
        }
        let keep = cut.index(bytes.len() + 1);
        if let Ok(ply) = Ply::from_bytes(&bytes, "fuzz.ply") {
            let _ = Mesh::from_ply(&ply, Path::new("fuzz.ply"));
        }
        let _ = Ply::from_bytes(&bytes[..keep], "fuzz.ply");
    }
}
