//! `video_frames` with the installed ffmpeg, on a losslessly encoded video made here
//! from known frames, one sharp frame in every four (the others box-blurred):
//! `sharpest` picks exactly the sharp ones, `even` the frames at ⌊(k + ½)·T/N⌋, and
//! every written PNG is the very frame it is named after; asking for more frames than
//! the video has, a file that is no video and a missing ffmpeg each fail naming the
//! problem.
//!
//! Under CI (`CI=true`, where .ci/run installs ffmpeg) a missing ffmpeg fails the tests
//! that need it; elsewhere they print SKIPPED and pass.

mod common;
use common::{assert_mentions, installed, node_error};
use image::RgbImage;
use objectsplat_inputs::sfm_nodes::VideoFrames;
use objectsplat_runtime::testing::run_node;
use std::path::{Path, PathBuf};
use std::process::Command;

const FRAMES: usize = 24;
const W: u32 = 64;
const H: u32 = 48;

fn ffmpeg_available(test: &str) -> bool {
    installed(test, objectsplat_inputs::video::version("ffmpeg"))
}

fn is_sharp(k: usize) -> bool {
    k % 4 == 2
}

/// Frame `k`: a checkerboard shifted by `k` pixels, box-blurred unless [`is_sharp`].
fn frame(k: usize) -> RgbImage {
    let board = RgbImage::from_fn(W, H, |x, y| {
        let on = ((x + k as u32) / 4 + y / 4).is_multiple_of(2);
        let v = if on { 230 } else { 20 };
        image::Rgb([v, (v / 2) + k as u8, 255 - v])
    });
    if is_sharp(k) {
        return board;
    }
    RgbImage::from_fn(W, H, |x, y| {
        let mut sum = [0u32; 3];
        let mut n = 0;
        for dy in -2i32..=2 {
            for dx in -2i32..=2 {
                let (sx, sy) = (x as i32 + dx, y as i32 + dy);
                if sx >= 0 && sy >= 0 && (sx as u32) < W && (sy as u32) < H {
                    let p = board.get_pixel(sx as u32, sy as u32).0;
                    for c in 0..3 {
                        sum[c] += p[c] as u32;
                    }
                    n += 1;
                }
            }
        }
        image::Rgb(sum.map(|s| (s / n) as u8))
    })
}

/// The frames encoded losslessly (FFV1 in Matroska) into `dir/video.mkv`.
fn make_video(dir: &Path) -> PathBuf {
    let src = dir.join("src");
    std::fs::create_dir_all(&src).unwrap();
    for k in 0..FRAMES {
        frame(k).save(src.join(format!("{k:03}.png"))).unwrap();
    }
    let video = dir.join("video.mkv");
    let status = Command::new("ffmpeg")
        .args(["-nostdin", "-loglevel", "error", "-framerate", "10", "-i"])
        .arg(src.join("%03d.png"))
        .args(["-c:v", "ffv1"])
        .arg(&video)
        .status()
        .unwrap();
    assert!(status.success());
    video
}

fn params(video: &Path, frames: usize, pick: &str) -> String {
    format!(
        "(path: {:?}, frames: {frames}, pick: {pick:?})",
        video.display().to_string()
    )
}

/// Runs the node and returns the frame indices it wrote, checking each file's pixels.
fn extract(video: &Path, frames: usize, pick: &str) -> Vec<usize> {
    let out = tempfile::tempdir().unwrap();
    run_node(
        &VideoFrames,
        &[],
        &params(video, frames, pick),
        out.path(),
        None,
    )
    .unwrap();
    let mut names: Vec<String> = std::fs::read_dir(out.path().join("images"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
        .iter()
        .map(|name| {
            let index: usize = name
                .strip_prefix("frame_")
                .and_then(|n| n.strip_suffix(".png"))
                .unwrap()
                .parse()
                .unwrap();
            let written = image::open(out.path().join("images").join(name)).unwrap();
            assert!(
                written.to_rgb8() == frame(index),
                "{name} is not frame {index} of the video"
            );
            index
        })
        .collect()
}

#[test]
fn sharpest_and_even_frames_are_the_expected_frames() {
    if !ffmpeg_available("sharpest_and_even_frames_are_the_expected_frames") {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let video = make_video(dir.path());
    let sharp: Vec<usize> = (0..FRAMES).filter(|&k| is_sharp(k)).collect();
    assert_eq!(extract(&video, FRAMES / 4, "sharpest"), sharp);
    let even: Vec<usize> = (0..5).map(|k| ((2 * k + 1) * FRAMES) / 10).collect();
    assert_eq!(even, [2, 7, 12, 16, 21]);
    assert_eq!(extract(&video, 5, "even"), even);
    assert_eq!(
        extract(&video, FRAMES, "even"),
        (0..FRAMES).collect::<Vec<_>>()
    );

    let e = node_error(&VideoFrames, &[], &params(&video, FRAMES + 1, "even"));
    assert_mentions(&e, &["25 frames asked for", "has only 24"]);
    let text = dir.path().join("notes.mp4");
    std::fs::write(&text, "not a video").unwrap();
    let e = node_error(&VideoFrames, &[], &params(&text, 3, "even"));
    assert_mentions(&e, &["notes.mp4: ffmpeg cannot decode it", "its log:"]);
}

#[test]
fn a_missing_ffmpeg_says_how_to_install_it() {
    let dir = tempfile::tempdir().unwrap();
    let video = dir.path().join("video.mkv");
    std::fs::write(&video, "").unwrap();
    let e = node_error(
        &VideoFrames,
        &[],
        &format!(
            "(path: {:?}, program: \"objectsplat-test-no-such-ffmpeg\")",
            video.display().to_string()
        ),
    );
    assert_mentions(
        &e,
        &[
            "`objectsplat-test-no-such-ffmpeg` is not installed",
            "apt-get install ffmpeg",
        ],
    );
}
