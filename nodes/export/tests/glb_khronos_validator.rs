//! The exported `.glb` (objects with node transforms: pivot, turn, scale) passes the official
//! Khronos glTF validator (npm `gltf-validator`) with zero errors and zero warnings, and the same harness does report an error on a
//! deliberately broken file (so a pass means something).
//!
//! Needs `node`; the validator is installed from the pinned lockfile with `npm ci` in
//! `nodes/export/tests/validator/` on first use. Without node or npm this test fails (it
//! never skips).

mod common;

use objectsplat_core::artifact::SCENE_GLB;
use objectsplat_export::glb::build_glb;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn validator_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/validator")
}

/// Installs the pinned validator once per test process (both tests share it).
fn ensure_installed(dir: &Path) {
    static INSTALL: std::sync::OnceLock<Result<(), String>> = std::sync::OnceLock::new();
    let result = INSTALL.get_or_init(|| {
        if dir.join("node_modules/gltf-validator").is_dir() {
            return Ok(());
        }
        let out = Command::new("npm")
            .args(["ci", "--no-audit", "--no-fund", "--loglevel=error"])
            .current_dir(dir)
            .output()
            .map_err(|e| format!("cannot run npm: {e}"))?;
        if out.status.success() {
            Ok(())
        } else {
            Err(String::from_utf8_lossy(&out.stderr).into_owned())
        }
    });
    if let Err(e) = result {
        panic!(
            "the Khronos glTF validator is not installed and `npm ci` in {} failed: {e}",
            dir.display()
        );
    }
}

/// Runs the validator; returns (exit code, parsed JSON summary).
fn validate(file: &Path) -> (i32, Value) {
    let dir = validator_dir();
    ensure_installed(&dir);
    let output = Command::new("node")
        .arg(dir.join("validate.mjs"))
        .arg(file)
        .current_dir(&dir)
        .output()
        .unwrap_or_else(|e| {
            panic!("cannot run `node` (Node.js is needed for the glTF validator): {e}")
        });
    let stdout = String::from_utf8_lossy(&output.stdout);
    let report: Value = serde_json::from_str(stdout.trim()).unwrap_or_else(|e| {
        panic!(
            "validator printed no JSON ({e}); stderr: {}",
            String::from_utf8_lossy(&output.stderr)
        )
    });
    (output.status.code().unwrap_or(-1), report)
}

#[test]
fn exported_scene_has_no_validator_errors_or_warnings() {
    let dir = tempfile::tempdir().unwrap();
    let mut objects = common::scene();
    // Objects placed by edits: node transforms with a turn, a scale and a pivot.
    // The chair with view-dependent colour: `_SH_k` attributes.
    let chair = objects[0].clone().with_sh(objectsplat_export::ShColors {
        degree: 2,
        coefficients: (0..8 * 9).map(|i| [i as f32 * 0.01, -0.1, 0.2]).collect(),
    });
    objects[0] = chair.placed(
        objectsplat_export::Placement::at([0.25, 0.25, 0.45])
            .rotated([1.0, 2.0, 3.0], 33.3)
            .scaled(1.5)
            .moved([0.5, -1.0, 0.0]),
    );
    let lamp = objects[1].clone();
    objects[1] = lamp.placed(objectsplat_export::Placement::at([1.1, -0.9, 1.0]));
    // Also a component whose faces are all degenerate (a mesh-less node).
    objects.push(common::cuboid(
        9,
        "empty",
        [0.0; 3],
        [0.0; 3],
        common::CORNER_COLOURS,
    ));
    let path = dir.path().join(SCENE_GLB);
    objectsplat_export::write_glb(
        &path,
        &objects,
        Some(&serde_json::json!({"scene": "synthetic"})),
    )
    .unwrap();
    let (code, report) = validate(&path);
    assert_eq!(report["numErrors"], 0, "validator errors: {report:#}");
    assert_eq!(code, 0);
    assert_eq!(report["numWarnings"], 0, "validator warnings: {report:#}");
    // The validator saw what was written.
    assert_eq!(
        report["info"]["totalTriangleCount"],
        12 + 12 + 2,
        "{report:#}"
    );
    assert_eq!(report["info"]["drawCallCount"], 3, "{report:#}");
}

#[test]
fn validator_harness_reports_a_broken_file() {
    let (bytes, _) = build_glb(&common::scene(), None).unwrap();
    // Break one invariant: claim a POSITION max that does not match the data.
    let glb = gltf::binary::Glb::from_slice(&bytes).unwrap();
    let mut root: gltf_json::Root = serde_json::from_slice(&glb.json).unwrap();
    let position = root.accessors.iter_mut().find(|a| a.max.is_some()).unwrap();
    position.max = Some(serde_json::json!([9.0, 9.0, 9.0]));
    let broken = gltf::binary::Glb {
        header: glb.header,
        json: gltf_json::serialize::to_vec(&root).unwrap().into(),
        bin: glb.bin.clone(),
    }
    .to_vec()
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.glb");
    std::fs::write(&path, broken).unwrap();
    let (code, report) = validate(&path);
    assert_eq!(code, 1, "{report:#}");
    let codes: Vec<&str> = report["messages"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|m| m["code"].as_str())
        .collect();
    assert!(codes.contains(&"ACCESSOR_MAX_MISMATCH"), "{codes:?}");
}
