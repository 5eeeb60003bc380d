//! Every graph shipped in graphs/ is documented at its top and passes `objectsplat check`
//! (`--skip-input-files`: their data paths are placeholders for a user's dataset).

use std::process::Command;

#[test]
fn shipped_graphs_check() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut checked = Vec::new();
    for entry in std::fs::read_dir(root.join("graphs")).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_none_or(|e| e != "ron") {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(
            text.starts_with("//"),
            "{} must start with a comment saying what it does",
            path.display()
        );
        let out = Command::new(env!("CARGO_BIN_EXE_objectsplat"))
            .arg("check")
            .arg("--skip-input-files")
            .arg(&path)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}: {}",
            path.display(),
            String::from_utf8_lossy(&out.stderr)
        );
        checked.push(path.file_name().unwrap().to_string_lossy().into_owned());
    }
    checked.sort();
    for expected in [
        "demo.ron",
        "holistic.ron",
        "objectsplat.ron",
        "objectsplat_sam.ron",
        "ablation_no_randomization.ron",
        "photos.ron",
        "sfm_poses_vs_true.ron",
    ] {
        assert!(
            checked.iter().any(|c| c == expected),
            "graphs/{expected} is missing"
        );
    }
}
