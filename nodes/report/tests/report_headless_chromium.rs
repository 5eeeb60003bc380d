//! The report opens in a real browser: headless Chromium renders `index.html` to a
//! screenshot that is not blank and shows the status colours of the graph drawing.
//!
//! Needs Debian's `chromium` (or `$CHROMIUM`). Under `CI=true` a missing browser fails the
//! test; elsewhere it is skipped with a loud message.

mod common;

use objectsplat_report::dag::status_colour;
use objectsplat_report::{NodeStatus, render_report};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// `CHROMIUM` when set, else the first Chromium or Chrome executable on `PATH`.
fn find_chromium() -> Option<PathBuf> {
    std::env::var_os("CHROMIUM").map(PathBuf::from).or_else(|| {
        let path = std::env::var_os("PATH")?;
        let names = ["chromium", "chromium-browser", "google-chrome"];
        names
            .iter()
            .flat_map(|name| std::env::split_paths(&path).map(move |dir| dir.join(name)))
            .find(|candidate| candidate.is_file())
    })
}

/// Chromium, or `None` with a loud skip notice when it is not installed; CI requires it.
fn chromium_or_skip() -> Option<PathBuf> {
    let found = find_chromium();
    if found.is_none() {
        let in_ci = std::env::var("CI").as_deref() == Ok("true");
        assert!(
            !in_ci,
            "chromium is not installed (apt-get install -y chromium); CI requires this test"
        );
        eprintln!(
            "\n!!!!! SKIPPED report_renders_in_headless_chromium: no chromium on PATH (apt-get install -y chromium) !!!!!\n"
        );
    }
    found
}

fn screenshot(chromium: &Path, page: &Path, out: &Path, profile: &Path) {
    let mut child = Command::new(chromium)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--hide-scrollbars",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(format!("--screenshot={}", out.display()))
        .arg("--window-size=1200,2000")
        .arg(format!("file://{}", page.display()))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start {}: {e}", chromium.display()));
    let deadline = Instant::now() + Duration::from_secs(120);
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut stderr = String::new();
            std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut stderr).unwrap();
            assert!(status.success(), "chromium failed ({status}): {stderr}");
            return;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("chromium did not finish the screenshot within 120 s");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

fn hex_rgb(hex: &str) -> [i32; 3] {
    let v = u32::from_str_radix(hex.trim_start_matches('#'), 16).unwrap();
    [
        (v >> 16) as i32 & 255,
        (v >> 8) as i32 & 255,
        v as i32 & 255,
    ]
}

#[test]
fn report_renders_in_headless_chromium() {
    let Some(chromium) = chromium_or_skip() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let data = common::synthetic_report::report_data(dir.path());
    let page = render_report(&dir.path().join("report"), &data).unwrap();
    let shot = dir.path().join("shot.png");
    screenshot(&chromium, &page, &shot, &dir.path().join("profile"));
    if let Some(keep) = std::env::var_os("OBJECTSPLAT_KEEP_SCREENSHOT") {
        std::fs::copy(&shot, keep).unwrap();
    }

    let img = image::open(&shot)
        .expect("chromium wrote a PNG screenshot")
        .to_rgb8();
    assert_eq!(img.dimensions(), (1200, 2000));
    let mut colours = std::collections::HashSet::new();
    let (mut sum, mut sum_sq) = (0.0f64, 0.0f64);
    for p in img.pixels() {
        colours.insert(p.0);
        let luma = 0.299 * p[0] as f64 + 0.587 * p[1] as f64 + 0.114 * p[2] as f64;
        sum += luma;
        sum_sq += luma * luma;
    }
    let n = (img.width() * img.height()) as f64;
    let variance = sum_sq / n - (sum / n).powi(2);
    assert!(
        colours.len() > 200,
        "only {} distinct colours: blank page?",
        colours.len()
    );
    assert!(variance > 100.0, "luma variance {variance:.1}: blank page?");
    // The graph drawing is on screen: each status colour fills a node box (≥ 1000 px).
    for status in [
        NodeStatus::Ran,
        NodeStatus::Cached,
        NodeStatus::Skipped,
        NodeStatus::Failed,
    ] {
        let want = hex_rgb(status_colour(status));
        let hits = img
            .pixels()
            .filter(|p| (0..3).all(|k| (p[k] as i32 - want[k]).abs() <= 3))
            .count();
        assert!(
            hits >= 1000,
            "{status:?} colour {want:?} covers only {hits} px"
        );
    }
}
