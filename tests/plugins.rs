//! Plugins end to end: the example plugins are built with cargo as real shared
//! libraries, then loaded by the `objectsplat` binary (and in-process through
//! `plugin::load`). Covers graph runs, caching, failure isolation and refusals.
//!
//! Plugin builds use their own target dir (the outer cargo holds the workspace's
//! build lock) and an unoptimised profile, since the test images are tiny and the
//! build time dominates.

use objectsplat_core::artifact::OBJECTS_JSON;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Output;

mod support;
use support::objectsplat::{command, read_json, report_node, run_graph_ron, stderr};
use support::plugin_build::{build_plugin, scratch_root, workspace};

/// `objectsplat ARGS` in `cwd` with `env`, and no fault variant but the one asked for.
fn objectsplat(args: &[&str], env: &[(&str, &str)], cwd: &Path) -> Output {
    let mut cmd = command(cwd, args);
    cmd.env_remove("OBJECTSPLAT_FAULT_VARIANT");
    cmd.envs(env.iter().copied());
    cmd.output().expect("objectsplat runs")
}

fn status<'a>(report: &'a Value, node: &str) -> &'a str {
    report_node(report, node)["status"].as_str().unwrap()
}

/// Asserts that `what` exited 1, never by a signal (as a crashed host would); returns
/// its stderr.
fn assert_exit_1(out: &Output, what: &str) -> String {
    let err = stderr(out);
    assert_eq!(
        out.status.code(),
        Some(1),
        "{what} exits 1, never by a signal: {err}"
    );
    err
}

fn ran(report: &Value) -> Vec<String> {
    let nodes = report["nodes"].as_array().unwrap();
    nodes
        .iter()
        .filter(|n| n["status"] == "ran")
        .map(|n| n["id"].as_str().unwrap().to_string())
        .collect()
}

fn fresh_dir(name: &str) -> PathBuf {
    let dir = scratch_root().join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn median_fixture(name: &str) -> PathBuf {
    workspace()
        .join("plugins/examples/median_inpaint/tests/fixtures")
        .join(name)
}

#[test]
fn median_plugin_runs_in_a_graph_is_cached_and_reruns_when_its_code_version_changes() {
    let dir = fresh_dir("median");
    for f in ["input.png", "hole.png", "expected.png"] {
        std::fs::copy(median_fixture(f), dir.join(f)).unwrap();
    }
    let lib = dir.join("median_inpaint.so");
    build_plugin("median_inpaint", &[], &[], &lib);
    std::fs::write(
        dir.join("graph.ron"),
        r#"(
  plugins: ["median_inpaint.so"],
  nodes: {
    "photo":    (kind: "load_image", params: (path: "input.png")),
    "hole":     (kind: "load_mask", params: (path: "hole.png")),
    "fill":     (kind: "median_inpaint", inputs: (image: "photo.image", mask: "hole.mask")),
    "save":     (kind: "save_image", inputs: (image: "fill.image"), params: (path: "filled.png")),
    "oracle":   (kind: "load_image", params: (path: "expected.png")),
    "save_ref": (kind: "save_image", inputs: (image: "oracle.image"), params: (path: "expected.png")),
  },
  targets: ["save", "save_ref"],
)"#,
    )
    .unwrap();
    let args = run_graph_ron(&["-j", "2"]);

    let first = objectsplat(&args, &[], &dir);
    assert!(first.status.success(), "{}", stderr(&first));
    let r = read_json(&dir.join("report.json"));
    let mut all = ran(&r);
    all.sort();
    assert_eq!(all, ["fill", "hole", "oracle", "photo", "save", "save_ref"]);
    let fill = report_node(&r, "fill");
    assert_eq!(fill["kind"], "median_inpaint");
    assert_eq!(fill["notes"]["filled_pixels"], "93");
    // Both PNGs are re-encoded by the same built-in save_image, so equal bytes mean
    // the plugin's pixels equal the NumPy oracle's.
    let filled = std::fs::read(dir.join("out/save/file/filled.png")).unwrap();
    assert_eq!(
        filled,
        std::fs::read(dir.join("out/save_ref/file/expected.png")).unwrap()
    );

    let second = objectsplat(&args, &[], &dir);
    assert!(second.status.success(), "{}", stderr(&second));
    let r = read_json(&dir.join("report.json"));
    assert!(
        ran(&r).is_empty(),
        "second run should be fully cached: {:?}",
        ran(&r)
    );
    assert_eq!(status(&r, "fill"), "cached");

    build_plugin(
        "median_inpaint",
        &[],
        &[("OBJECTSPLAT_EXAMPLE_CODE_VERSION", "2")],
        &lib,
    );
    let third = objectsplat(&args, &[], &dir);
    assert!(third.status.success(), "{}", stderr(&third));
    let r = read_json(&dir.join("report.json"));
    // Only the plugin node reruns; its output is byte-identical, so `save` stays cached.
    assert_eq!(ran(&r), ["fill"]);
    assert_eq!(status(&r, "save"), "cached");
    let explain = objectsplat(
        &["explain", "graph.ron", "fill", "--cache", "cache"],
        &[],
        &dir,
    );
    assert!(explain.status.success(), "{}", stderr(&explain));
}

#[test]
fn colorkey_plugin_is_listed_with_its_interface_and_runs_through_the_host() {
    let dir = fresh_dir("colorkey");
    let lib = dir.join("colorkey_masks.so");
    build_plugin("colorkey_masks", &[], &[], &lib);

    let listing = objectsplat(&["nodes", "--plugin", lib.to_str().unwrap()], &[], &dir);
    assert!(listing.status.success(), "{}", stderr(&listing));
    let text = format!("\n{}", String::from_utf8_lossy(&listing.stdout));
    let entry = text
        .split("\ncolorkey_masks (")
        .nth(1)
        .expect("colorkey_masks is listed");
    assert!(entry.starts_with("v1+lib."), "{entry}");
    assert!(entry.contains("[plugin "), "{entry}");
    assert!(
        entry.contains("in  frames: Frames") && entry.contains("out masks: Masks"),
        "{entry}"
    );
    assert!(
        entry.contains("param keys: list(ron) (required)"),
        "{entry}"
    );

    // This test binary cannot host plugin processes; the objectsplat binary can.
    objectsplat_runtime::plugin::set_host_program(PathBuf::from(env!("CARGO_BIN_EXE_objectsplat")));
    let mut reg = objectsplat_catalogue::builtin_registry();
    objectsplat_runtime::plugin::load(&mut reg, &lib).unwrap();
    // Loading the same library again is a no-op, not a collision.
    objectsplat_runtime::plugin::load(&mut reg, &lib).unwrap();
    let node = reg.get("colorkey_masks").unwrap().node.clone();
    let frames = workspace().join("plugins/examples/colorkey_masks/tests/fixtures/frames");
    let keys = r#"(keys: [(id: 3, label: "chair", rgb: (200, 30, 30), tolerance: 12)])"#;
    let run = objectsplat_runtime::testing::run_node(
        node.as_ref(),
        &[("frames", &frames)],
        keys,
        &dir.join("out"),
        None,
    )
    .unwrap();
    let masks = &run.outputs["masks"];
    assert!(masks.join("view_a.png").is_file() && masks.join("view_b.png").is_file());
    let labels: Value =
        serde_json::from_str(&std::fs::read_to_string(masks.join(OBJECTS_JSON)).unwrap()).unwrap();
    assert_eq!(labels, serde_json::json!({"3": "chair"}));
    let chair_pixels: u64 = run
        .notes
        .iter()
        .find(|(k, _)| k == "pixels_chair")
        .unwrap()
        .1
        .parse()
        .unwrap();
    assert!(
        chair_pixels >= 2 * 35,
        "two 5×7 keyed rectangles, found {chair_pixels}"
    );

    // It stands in for `gt_masks`: a graph wiring it into `partition` validates.
    std::fs::write(
        dir.join("graph.ron"),
        r#"(
  plugins: ["colorkey_masks.so"],
  nodes: {
    "scene": (kind: "synthetic_scene", params: (seed: 7, views: 8)),
    "masks": (kind: "colorkey_masks", inputs: (frames: "scene.frames"),
              params: (keys: [(id: 1, label: "chair", rgb: (200, 30, 30), tolerance: 12)])),
    "parts": (kind: "partition", inputs: (frames: "scene.frames", masks: "masks.masks")),
  },
  targets: ["parts"],
)"#,
    )
    .unwrap();
    let check = objectsplat(&["check", "graph.ron"], &[], &dir);
    assert!(check.status.success(), "{}", stderr(&check));

    let missing = objectsplat_runtime::testing::run_node(
        node.as_ref(),
        &[("frames", &frames)],
        "()",
        &dir.join("o2"),
        None,
    );
    assert!(
        missing
            .err()
            .unwrap()
            .to_string()
            .contains("required param `keys` missing")
    );
}

/// A fresh folder with the fault-injection plugin and a graph where its `bad` node (with
/// `bad_fields` after its inputs) feeds `save_bad` and an independent branch resizes
/// the same photo into `save_small`.
fn faulty_stage_dir(name: &str, bad_fields: &str) -> PathBuf {
    let dir = fresh_dir(name);
    std::fs::copy(median_fixture("input.png"), dir.join("input.png")).unwrap();
    build_plugin("fault_injection", &[], &[], &dir.join("fault_injection.so"));
    let graph = format!(
        r#"(
  plugins: ["fault_injection.so"],
  nodes: {{
    "photo":      (kind: "load_image", params: (path: "input.png")),
    "bad":        (kind: "faulty_stage", inputs: (image: "photo.image"){bad_fields}),
    "save_bad":   (kind: "save_image", inputs: (image: "bad.image"), params: (path: "bad.png")),
    "small":      (kind: "resize_image", inputs: (image: "photo.image"), params: (factor: 2)),
    "save_small": (kind: "save_image", inputs: (image: "small.image"), params: (path: "small.png")),
  }},
  targets: ["save_bad", "save_small"],
)"#
    );
    std::fs::write(dir.join("graph.ron"), graph).unwrap();
    dir
}

/// Runs [`faulty_stage_dir`]'s graph with `bad` in fault `mode`, and asserts that the run
/// exits 1 with an `error:` line naming `cause`; returns its stderr and its report.
fn fail_in_mode(dir: &Path, mode: &str, cause: &str) -> (String, Value) {
    let set = format!("bad.mode=\"{mode}\"");
    let out = objectsplat(&run_graph_ron(&["--set", &set]), &[], dir);
    let err = assert_exit_1(&out, &format!("mode {mode}: a failed node"));
    assert!(
        err.lines()
            .any(|l| l.starts_with("error:") && l.contains(cause)),
        "mode {mode}: {err}"
    );
    (err, read_json(&dir.join("report.json")))
}

#[test]
fn a_failing_or_panicking_plugin_node_fails_alone_and_the_run_exits_non_zero() {
    let dir = faulty_stage_dir("faults", "");
    for (mode, message) in [
        ("error", "injected failure: faulty_stage refused its input"),
        ("panic", "panicked: injected panic in faulty_stage"),
    ] {
        let (_, r) = fail_in_mode(&dir, mode, message);
        assert_eq!(r["ok"], false);
        assert_eq!(status(&r, "bad"), "failed");
        assert_ne!(status(&r, "save_bad"), "ran");
        assert!(
            ["ran", "cached"].contains(&status(&r, "save_small")),
            "other branches finish"
        );
        let save_small = report_node(&r, "save_small");
        assert!(
            save_small["outputs"]["file"].is_string(),
            "save_small produced its file: {save_small}"
        );
    }
    let out = objectsplat(
        &["run", "graph.ron", "--cache", "cache", "--out", "out"],
        &[],
        &dir,
    );
    assert!(out.status.success(), "mode pass works: {}", stderr(&out));
}

#[test]
fn a_plugin_that_crashes_exits_or_hangs_fails_only_its_node() {
    let dir = faulty_stage_dir("crashes", ", params: (plugin_timeout_s: 2)");
    for (mode, message) in [
        ("abort", "killed by signal 6 (SIGABRT"),
        ("segfault", "killed by signal 11 (SIGSEGV"),
        ("stack_overflow", "has overflowed its stack"),
        ("exit", "exited (status 0) without answering"),
        ("hang", "did not finish within 2 s and was killed"),
        ("no_output", "without writing its output `image`"),
        ("huge_error", "more bytes not shown"),
    ] {
        let (err, r) = fail_in_mode(&dir, mode, "plugin `fault_injection`");
        assert!(
            err.contains(message),
            "mode {mode}: {message:?} not in {err}"
        );
        assert!(
            err.len() < 64 << 10,
            "mode {mode}: {} bytes of stderr",
            err.len()
        );
        assert_eq!(status(&r, "bad"), "failed", "mode {mode}");
        assert_ne!(status(&r, "save_bad"), "ran", "mode {mode}");
        assert!(
            dir.join("out/save_small/file/small.png").is_file(),
            "mode {mode}: the other branch wrote its output"
        );
        let reason = report_node(&r, "bad")["reason"].as_str().unwrap();
        assert!(
            reason.len() < 16 << 10,
            "mode {mode}: {} bytes of reason",
            reason.len()
        );
    }
}

#[test]
fn libraries_that_are_not_valid_plugins_are_refused_with_a_clear_message() {
    let dir = fresh_dir("refusals");
    let refused = |lib: &Path, env: &[(&str, &str)], expected: &str| {
        let out = objectsplat(&["nodes", "--plugin", lib.to_str().unwrap()], env, &dir);
        let err = assert_exit_1(&out, "refusal");
        assert!(
            err.starts_with(&format!("error: plugin {}: ", lib.display())),
            "{err}"
        );
        assert!(err.contains(expected), "expected {expected:?} in {err}");
    };

    let text = dir.join("notes.so");
    std::fs::write(&text, "this is not a library\n").unwrap();
    refused(&text, &[], "not a shared library this system can load");

    let no_entry = dir.join("no_entry.so");
    build_plugin("fault_injection", &["no_entry"], &[], &no_entry);
    refused(
        &no_entry,
        &[],
        "not an ObjectSplat plugin: no `objectsplat_plugin_entry_v1` symbol",
    );

    let lib = dir.join("fault_injection.so");
    build_plugin("fault_injection", &[], &[], &lib);
    let variant = |v| [("OBJECTSPLAT_FAULT_VARIANT", v)];
    refused(
        &lib,
        &variant("wrong_abi"),
        "built for ABI v999, this objectsplat speaks v1",
    );
    refused(
        &lib,
        &variant("malformed_describe"),
        "its describe text is malformed: EOF while parsing a list",
    );
    refused(
        &lib,
        &variant("kind_collision"),
        "node kind `load_image` is already defined by a built-in node",
    );
    refused(
        &lib,
        &variant("unknown_type"),
        "node `faulty_stage` port `image` has unknown type `Picture`",
    );

    // The same refusal when the library comes from a graph's `plugins` list.
    std::fs::write(
        dir.join("graph.ron"),
        r#"(plugins: ["fault_injection.so"], nodes: {"a": (kind: "load_image", params: (path: "x.png"))}, targets: ["a"])"#,
    )
    .unwrap();
    let out = objectsplat(&["check", "graph.ron"], &variant("wrong_abi"), &dir);
    assert_eq!(out.status.code(), Some(1));
    assert!(
        stderr(&out).contains("built for ABI v999, this objectsplat speaks v1"),
        "{}",
        stderr(&out)
    );
    // `check` wants the graph's input file to exist.
    std::fs::write(dir.join("x.png"), b"").unwrap();
    let out = objectsplat(&["check", "graph.ron"], &[], &dir);
    assert!(
        out.status.success(),
        "the same library loads without the fault: {}",
        stderr(&out)
    );
}
