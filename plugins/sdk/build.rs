//! Records the compiler version so a plugin's entry table can name the toolchain
//! it was built with (shown by `objectsplat nodes`, useful in bug reports).

fn main() {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let version = std::process::Command::new(&rustc)
        .arg("--version")
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .unwrap_or_else(|| "rustc (unknown version)".into());
    println!("cargo:rustc-env=OBJECTSPLAT_SDK_RUSTC={version}");
    println!("cargo:rerun-if-env-changed=RUSTC");
}
