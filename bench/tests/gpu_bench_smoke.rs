//! `scripts/gpu-bench.sh --smoke` on whatever adapter there is (lavapipe in CI):
//! every stage of the GPU benchmark runs, every wgpu training item — the
//! objects, the background behind them with both depth terms, the holistic
//! model — runs all its iterations on the device, and the table has a row per
//! component kind for both backends.

use std::path::Path;
use std::process::Command;

#[test]
fn the_gpu_bench_script_runs_every_component_on_the_device() {
    let bench = Path::new(env!("CARGO_BIN_EXE_objectsplat-bench"));
    let bin_dir = bench.parent().expect("a binary lives in a folder");
    if !bin_dir.join("objectsplat").is_file() {
        panic!(
            "{} has no objectsplat binary: run this test through `cargo test --workspace`",
            bin_dir.display()
        );
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let out = tempfile::tempdir().unwrap();
    let output = Command::new(root.join("scripts/gpu-bench.sh"))
        .arg("--smoke")
        .env("OBJECTSPLAT_BIN_DIR", bin_dir)
        .env("OUT_DIR", out.path())
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&output.stdout).to_string()
        + &String::from_utf8_lossy(&output.stderr);
    if !output.status.success()
        && log.contains("no wgpu adapter")
        && std::env::var("OBJECTSPLAT_REQUIRE_ADAPTER").as_deref() != Ok("1")
    {
        eprintln!("SKIPPED (no wgpu adapter)");
        return;
    }
    assert!(
        output.status.success(),
        "gpu-bench.sh --smoke failed:\n{log}"
    );
    let table = std::fs::read_to_string(out.path().join("device-speed.md")).unwrap();
    for kind in [
        "small object",
        "table-sized object",
        "background behind occluders",
        "holistic",
    ] {
        let row = table
            .lines()
            .find(|l| l.contains(&format!("| {kind} |")))
            .unwrap_or_else(|| panic!("no row for {kind}:\n{table}"));
        // | size | kind | it/s cpu | device (cpu) | it/s wgpu | device (wgpu) | ratio |
        let cells: Vec<&str> = row.split('|').map(str::trim).collect();
        assert_eq!(cells[4], "no", "the cpu backend ran device steps: {row}");
        assert_eq!(cells[6], "all", "wgpu items ran host steps: {row}");
        for speed in [cells[3], cells[5]] {
            assert!(speed.parse::<f64>().is_ok_and(|s| s > 0.0), "{row}");
        }
    }
}
