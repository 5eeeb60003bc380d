//! The `command` adapter with a real external program (tests/scripts/fake_inpainter.sh
//! run by /bin/sh): its output is used inside the mask and the input outside it;
//! a non-zero exit, a timeout, missing outputs and wrong-size outputs each fail with
//! a message that says so (and quotes stderr); arguments reach the program verbatim,
//! with only whole `{input}`/`{output}` arguments substituted; the node writes one
//! fill per background frame.

mod common;

use objectsplat_completion::external::{ExternalCommand, FillRequest};
use objectsplat_completion::nodes::InpaintBackgroundNode;
use objectsplat_runtime::Outcome;
use std::path::PathBuf;
use std::time::{Duration, Instant};

fn script() -> String {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/scripts/fake_inpainter.sh")
        .display()
        .to_string()
}

/// Asserts `text` contains every one of `parts`, showing `text` when it does not.
fn assert_mentions(text: &str, parts: &[&str]) {
    for part in parts {
        assert!(text.contains(part), "{text}");
    }
}

fn command(mode: &str, extra: &[&str], timeout_s: f64) -> ExternalCommand {
    let mut argv: Vec<String> = vec![
        "sh".into(),
        script(),
        mode.into(),
        "{input}".into(),
        "{output}".into(),
    ];
    argv.extend(extra.iter().map(|s| s.to_string()));
    ExternalCommand {
        argv,
        timeout: Duration::from_secs_f64(timeout_s),
    }
}

/// The error `command` gives for `requests`, run in a fresh work folder.
fn error_of(command: ExternalCommand, requests: &[FillRequest]) -> String {
    let work = tempfile::tempdir().unwrap();
    command.run(requests, work.path()).unwrap_err().to_string()
}

fn request(stem: &str) -> FillRequest {
    let (width, height) = (6u32, 4u32);
    let rgb: Vec<u8> = (0..width * height * 3)
        .map(|v| (v * 5 % 200) as u8)
        .collect();
    let mut mask = vec![0u8; (width * height) as usize];
    mask[7] = 1;
    mask[8] = 1;
    FillRequest {
        stem: stem.into(),
        width,
        height,
        rgb,
        mask,
    }
}

#[test]
fn program_output_is_used_inside_the_mask_only() {
    let work = tempfile::tempdir().unwrap();
    // A stem with spaces and shell metacharacters is just a file name here.
    let requests = [request("frame 0;$(touch pwned)"), request("f1")];
    let filled = command("ok", &[], 30.0)
        .run(&requests, work.path())
        .unwrap();
    assert!(!work.path().join("pwned").exists());
    for (r, out) in requests.iter().zip(&filled) {
        for (p, &m) in r.mask.iter().enumerate() {
            let want: &[u8] = if m != 0 {
                &[255, 255, 255]
            } else {
                &r.rgb[p * 3..p * 3 + 3]
            };
            assert_eq!(&out[p * 3..p * 3 + 3], want, "pixel {p}");
        }
    }
}

#[test]
fn non_zero_exit_fails_with_status_and_stderr() {
    let err = error_of(command("fail", &[], 30.0), &[request("f0")]);
    assert_mentions(&err, &["exit status: 3", "model weights not found"]);
}

#[test]
fn a_hanging_program_is_killed_at_the_timeout() {
    let start = Instant::now();
    let err = error_of(command("hang", &[], 0.5), &[request("f0")]);
    assert!(
        start.elapsed() < Duration::from_secs(10),
        "took {:?}",
        start.elapsed()
    );
    assert_mentions(&err, &["did not finish within 0.5 s", "loading model"]);
}

#[test]
fn missing_and_wrong_size_outputs_are_reported() {
    let err = error_of(
        command("missing", &[], 30.0),
        &[request("f0"), request("f1")],
    );
    assert!(err.contains("did not write f0.png, f1.png"), "{err}");

    let other = common::fixture("inpaint/masks/corner.png");
    let err = error_of(
        command("wrong_size", &[&other.display().to_string()], 30.0),
        &[request("f0")],
    );
    assert!(err.contains("128×128 image for a 6×4 input"), "{err}");
}

#[test]
fn arguments_are_passed_verbatim_and_only_whole_placeholders_substituted() {
    let work = tempfile::tempdir().unwrap();
    let err = command("args", &["x;echo hi", "pre{input}", "$HOME"], 30.0)
        .run(&[request("f0")], work.path())
        .unwrap_err()
        .to_string();
    let input = work.path().join("input").display().to_string();
    assert!(err.contains(&format!("arg:[{input}]")), "{err}");
    for literal in ["arg:[x;echo hi]", "arg:[pre{input}]", "arg:[$HOME]"] {
        assert!(err.contains(literal), "{literal} missing from {err}");
    }
}

#[test]
fn node_writes_one_fill_per_background_frame() {
    let scene = common::build("table");
    let out = scene.root.path().join("run");
    let params = format!(
        "(method: \"command\", command: [\"sh\", {:?}, \"ok\", \"{{input}}\", \"{{output}}\"], timeout_s: 30.0)",
        script()
    );
    let inputs = [
        ("components", scene.components.as_path()),
        ("frames", &scene.frames),
    ];
    let run = common::run(&InpaintBackgroundNode, &inputs, &params, &out);
    assert_eq!(run.outcome, Outcome::Done);
    for f in 0..2 {
        let fill = common::read_rgb(&run.outputs["fills"].join(format!("f{f}.png")));
        for y in 0..common::H {
            for x in 0..common::W {
                let i = ((y * common::W + x) * 3) as usize;
                // Background pixels keep their colour; object pixels got the program's white.
                let want = if common::owner(f, x, y) == common::Owner::Background {
                    common::BACKGROUND_RGB
                } else {
                    [255; 3]
                };
                assert_eq!(&fill[i..i + 3], &want, "frame {f} pixel ({x}, {y})");
            }
        }
    }
}

/// True while `pid` names a live process (a zombie awaiting its reaper is dead).
fn alive(pid: u32) -> bool {
    std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .ok()
        .and_then(|s| {
            s.rsplit(')')
                .next()
                .map(|r| r.trim_start().starts_with('Z'))
        })
        .is_some_and(|zombie| !zombie)
}

#[test]
fn the_timeout_kills_every_process_the_program_started() {
    let work = tempfile::tempdir().unwrap();
    let err = command("hang_with_helper", &[], 0.5)
        .run(&[request("f0")], work.path())
        .unwrap_err()
        .to_string();
    assert!(err.contains("did not finish within 0.5 s"), "{err}");
    let pid: u32 = std::fs::read_to_string(work.path().join("helper.pid"))
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    // The kill is sent before the error returns; allow the kernel a moment to act.
    let start = Instant::now();
    while alive(pid) && start.elapsed() < Duration::from_secs(2) {
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(!alive(pid), "helper process {pid} outlived the timeout");
}
