//! A transforms.json `file_path` becomes a frame name and so an output file name:
//! written with Windows separators it names the same file as with `/`; written to
//! climb out (`..\` after a folder, as a hostile or careless dataset may), it is
//! refused with the frame it came from, and nothing is written outside the output.

use objectsplat_core::Frames;
use objectsplat_inputs::nodes::NerfstudioScene;
use objectsplat_runtime::testing::run_node;
use std::path::Path;

const POSE: &str = "[[1,0,0,0],[0,1,0,0],[0,0,1,3],[0,0,0,1]]";

fn dataset(dir: &Path, file_paths: &[&str]) -> String {
    let images = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/colmap/images");
    std::fs::create_dir_all(dir.join("data/images")).unwrap();
    for e in std::fs::read_dir(images).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), dir.join("data/images").join(e.file_name())).unwrap();
    }
    let frames: Vec<String> = file_paths
        .iter()
        .map(|p| {
            format!(
                r#"{{"file_path": {}, "transform_matrix": {POSE}}}"#,
                serde_json::to_string(p).unwrap()
            )
        })
        .collect();
    let json = dir.join("data/transforms.json");
    std::fs::write(
        &json,
        format!(
            r#"{{"fl_x": 40, "fl_y": 40, "cx": 32, "cy": 24, "w": 64, "h": 48, "frames": [{}]}}"#,
            frames.join(",")
        ),
    )
    .unwrap();
    format!("(path: {:?}, split: \"all\")", json.display().to_string())
}

#[test]
fn windows_separators_name_the_same_files() {
    let dir = tempfile::tempdir().unwrap();
    let params = dataset(
        dir.path(),
        &[
            r"images\camera000001_frame000000.png",
            r".\images\camera000002_frame000000.png",
        ],
    );
    let run = run_node(
        &NerfstudioScene,
        &[],
        &params,
        &dir.path().join("out"),
        None,
    )
    .unwrap();
    let frames = Frames::read(&run.outputs["frames"]).unwrap();
    let names: Vec<&str> = frames.frames.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "images/camera000001_frame000000.png",
            "images/camera000002_frame000000.png"
        ]
    );
    assert!(
        run.outputs["frames"]
            .join("images/camera000001_frame000000.png")
            .is_file()
    );
}

#[test]
fn a_file_path_climbing_out_is_refused_and_nothing_is_written_outside() {
    let dir = tempfile::tempdir().unwrap();
    // As an output name it would climb out of the frames folder. The image it names is
    // there whichever way `\` is read (as a separator, or as part of a file name, as a
    // dataset unpacked on Linux can hold), so reading it never fails first.
    let name = r"images/x/..\..\images\camera000001_frame000000.png";
    let params = dataset(dir.path(), &[name]);
    std::fs::create_dir_all(dir.path().join("data/images/x")).unwrap();
    std::fs::copy(
        dir.path().join("data/images/camera000001_frame000000.png"),
        dir.path().join("data").join(name),
    )
    .unwrap();
    let out = dir.path().join("a/b/out");
    let e = run_node(&NerfstudioScene, &[], &params, &out, None)
        .err()
        .expect("refused")
        .to_string();
    assert!(e.contains("climbs out of its folder"), "{e}");
    let mut written = Vec::new();
    for d in [
        dir.path().to_path_buf(),
        dir.path().join("a"),
        dir.path().join("a/b"),
    ] {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            written.push(e.file_name().to_string_lossy().into_owned());
        }
    }
    written.sort();
    assert_eq!(written, ["a", "b", "data", "out"], "{written:?}");
}
