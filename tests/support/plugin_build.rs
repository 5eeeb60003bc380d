//! Builds the example plugins with cargo as real shared libraries, for tests that load
//! them through the `objectsplat` binary.
//!
//! Plugin builds use their own target dir (the outer cargo holds the workspace's build
//! lock) and an unoptimised profile, since the test inputs are tiny and the build time
//! dominates.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Mutex;

/// Serialises plugin builds: cargo locks the target dir anyway, and the copy that
/// follows each build must see that build's library, not a concurrent variant's.
static BUILD: Mutex<()> = Mutex::new(());

pub fn workspace() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Scratch space shared by the plugin tests (and their plugin builds).
pub fn scratch_root() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("plugin-tests")
}

/// Builds `plugins/examples/<example>` with `features` and build-time `env`, and
/// copies the library to `dest`.
pub fn build_plugin(example: &str, features: &[&str], env: &[(&str, &str)], dest: &Path) {
    let _guard = BUILD.lock().unwrap_or_else(|p| p.into_inner());
    let target_dir = scratch_root().join("build");
    let manifest = workspace()
        .join("plugins/examples")
        .join(example)
        .join("Cargo.toml");
    let mut cmd = Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()));
    cmd.arg("build")
        .arg("--manifest-path")
        .arg(&manifest)
        .arg("--target-dir")
        .arg(&target_dir)
        .args([
            "--config",
            "profile.dev.opt-level=0",
            "--config",
            "profile.dev.package.\"*\".opt-level=0",
        ])
        .args(["--config", "profile.dev.debug=0"])
        .env_remove("OBJECTSPLAT_EXAMPLE_CODE_VERSION");
    if !features.is_empty() {
        cmd.arg("--features").arg(features.join(","));
    }
    for (k, v) in env {
        cmd.env(k, v);
    }
    let out = cmd.output().expect("cargo runs");
    assert!(
        out.status.success(),
        "building {example} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lib = target_dir.join("debug").join(format!(
        "{}{example}{}",
        std::env::consts::DLL_PREFIX,
        std::env::consts::DLL_SUFFIX
    ));
    std::fs::create_dir_all(dest.parent().expect("dest is a file path")).unwrap();
    std::fs::copy(&lib, dest).unwrap_or_else(|e| panic!("{}: {e}", lib.display()));
}
