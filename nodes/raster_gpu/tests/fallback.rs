//! With OBJECTSPLAT_NO_GPU=1 no adapter is acquired, nothing panics, the
//! reason is clear, and "auto" falls back to the CPU backend while "wgpu"
//! is an error. Runs in a child process so the variable affects nothing else.
use objectsplat_gpu::{AdapterChoice, GpuContext};
use objectsplat_raster_gpu::backend_for;

const CHILD_ENV: &str = "OBJECTSPLAT_WGPU_FALLBACK_CHILD";

fn checks_in_child() {
    let err = GpuContext::acquire(AdapterChoice::Auto).unwrap_err();
    assert_eq!(format!("{err:#}"), "disabled by OBJECTSPLAT_NO_GPU");
    let err = GpuContext::shared(AdapterChoice::Lavapipe).unwrap_err();
    assert!(format!("{err:#}").contains("OBJECTSPLAT_NO_GPU"));
    let (backend, why) = backend_for("auto", 2).unwrap();
    assert_eq!(backend.name(), "cpu");
    assert!(
        why.contains("cpu") && why.contains("OBJECTSPLAT_NO_GPU"),
        "{why}"
    );
    let err = backend_for("wgpu", 2)
        .err()
        .expect("wgpu must fail without an adapter");
    assert!(format!("{err:#}").contains("OBJECTSPLAT_NO_GPU"), "{err:#}");
    let (backend, _) = backend_for("cpu", 2).unwrap();
    assert_eq!(backend.name(), "cpu");
    assert!(backend_for("vulkan", 2).is_err());
}

#[test]
fn no_gpu_env_gives_a_clear_reason_and_a_cpu_fallback() {
    if std::env::var(CHILD_ENV).is_ok() {
        checks_in_child();
        return;
    }
    let exe = std::env::current_exe().unwrap();
    let out = std::process::Command::new(exe)
        .args([
            "--exact",
            "no_gpu_env_gives_a_clear_reason_and_a_cpu_fallback",
            "--nocapture",
        ])
        .env(CHILD_ENV, "1")
        .env("OBJECTSPLAT_NO_GPU", "1")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "child failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("1 passed"));
}
