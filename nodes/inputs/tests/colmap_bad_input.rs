//! Damaged or unsupported COLMAP models are errors naming the file and the problem;
//! the binary parsers never panic on arbitrary or mutated bytes.

use objectsplat_inputs::colmap;
use objectsplat_inputs::colmap_scene;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

mod common;
use common::assert_mentions;

fn fixture(name: &str) -> PathBuf {
    common::fixture("colmap").join(name)
}

fn copy_model(from: &str) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for e in std::fs::read_dir(fixture(from)).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), dir.path().join(e.file_name())).unwrap();
    }
    dir
}

#[test]
fn truncated_binary_files_name_file_offset_and_field() {
    for (file, keep) in [
        ("cameras.bin", 30),
        ("images.bin", 100),
        ("points3D.bin", 70),
        ("frames.bin", 50),
    ] {
        let dir = copy_model("rig_bin");
        let path = dir.path().join(file);
        let bytes = std::fs::read(&path).unwrap();
        std::fs::write(&path, &bytes[..keep]).unwrap();
        let e = format!("{:#}", colmap::read_model(dir.path()).unwrap_err());
        assert!(e.contains(&path.display().to_string()), "{file}: {e}");
        assert!(
            e.contains("byte ") && (e.contains("file ends") || e.contains("do not fit")),
            "{file}: {e}"
        );
    }
}

#[test]
fn lying_record_count_is_refused_before_allocating() {
    let dir = copy_model("classic_bin");
    let path = dir.path().join("points3D.bin");
    let mut bytes = std::fs::read(&path).unwrap();
    bytes[..8].copy_from_slice(&u64::MAX.to_le_bytes());
    std::fs::write(&path, bytes).unwrap();
    let e = colmap::read_model(dir.path()).unwrap_err().to_string();
    assert_mentions(
        &e,
        &["points3D.bin: byte 0: number of 3D points is 18446744073709551615"],
    );
}

#[test]
fn a_camera_model_without_undistortion_names_the_undistortion_step() {
    let dir = copy_model("distorted_txt");
    let path = dir.path().join("cameras.txt");
    let text = std::fs::read_to_string(&path).unwrap();
    // FOV (fx, fy, cx, cy, omega) has no undistortion here.
    std::fs::write(
        &path,
        text.replace(
            "1 SIMPLE_RADIAL 64 48 50 32 24 0.01",
            "1 FOV 64 48 50 50 32 24 0.9",
        ),
    )
    .unwrap();
    let model = colmap::read_model(dir.path()).unwrap();
    let e = colmap_scene::views(&model, &fixture("images"))
        .unwrap_err()
        .to_string();
    assert_mentions(
        &e,
        &["camera 1 uses the model FOV, which is not undistorted here"],
    );
    assert!(e.contains("colmap image_undistorter"), "{e}");
}

#[test]
fn image_pose_that_disagrees_with_its_rig_and_frame_is_refused() {
    let dir = copy_model("rig_txt");
    let path = dir.path().join("images.txt");
    let text = std::fs::read_to_string(&path).unwrap();
    // Image 2 is camera 2 of frame 1; move it 1 cm along x.
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let i = lines.iter().position(|l| l.starts_with("2 ")).unwrap();
    let mut words: Vec<String> = lines[i].split(' ').map(str::to_string).collect();
    words[5] = (words[5].parse::<f64>().unwrap() + 0.01).to_string();
    lines[i] = words.join(" ");
    std::fs::write(&path, lines.join("\n")).unwrap();
    let e = colmap::read_model(dir.path()).unwrap_err().to_string();
    assert_mentions(&e, &["image 2", "disagrees with rig 1 ∘ frame 1"]);
}

#[test]
fn text_errors_name_file_and_line() {
    let dir = copy_model("classic_txt");
    let path = dir.path().join("cameras.txt");
    std::fs::write(&path, "# c\n1 PINHOLE 64 48 50 51 32\n").unwrap();
    let e = colmap::read_model(dir.path()).unwrap_err().to_string();
    assert_mentions(&e, &["cameras.txt:2: line ends before camera parameter"]);
    std::fs::write(&path, "1 PINHOLE_X 64 48 50 51 32 24\n").unwrap();
    let e = colmap::read_model(dir.path()).unwrap_err().to_string();
    assert_mentions(&e, &["cameras.txt:1: unknown camera model \"PINHOLE_X\""]);
    let e = colmap::read_model(Path::new("/nonexistent"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("no COLMAP sparse model here"), "{e}");
}

#[test]
fn image_referring_to_a_missing_camera_is_refused() {
    let dir = copy_model("classic_txt");
    std::fs::write(
        dir.path().join("cameras.txt"),
        "1 PINHOLE 64 48 50 51 32 24\n",
    )
    .unwrap();
    let e = colmap::read_model(dir.path()).unwrap_err().to_string();
    assert_mentions(
        &e,
        &["refers to camera 2, which the cameras file does not define"],
    );
}

fn read(dir: &str, file: &str) -> Vec<u8> {
    std::fs::read(fixture(dir).join(file)).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1500, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let _ = colmap::parse_binary_files(&bytes, &bytes, &bytes);
        let _ = colmap::parse_binary_files(&read("rig_bin", "cameras.bin"), &bytes, &bytes);
        let _ = colmap::parse_binary_files(&read("rig_bin", "cameras.bin"), &read("rig_bin", "images.bin"), &bytes);
        let _ = colmap::parse_rig_files(&bytes, &bytes);
    }

    #[test]
    fn mutated_model_files_never_panic(
        which in 0usize..5,
        edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..6),
        cut in any::<prop::sample::Index>(),
    ) {
        let names = ["cameras.bin", "images.bin", "points3D.bin", "rigs.bin", "frames.bin"];
        let mut files: Vec<Vec<u8>> = names.iter().map(|n| read("rig_bin", n)).collect();
        let target = &mut files[which];
        for (at, value) in edits {
            let i = at.index(target.len());
            target[i] = value;
        }
        let keep = cut.index(target.len() + 1);
        target.truncate(keep);
        let _ = colmap::parse_binary_files(&files[0], &files[1], &files[2]);
        let _ = colmap::parse_rig_files(&files[3], &files[4]);
    }
}
