//! Frames from a video, by ffmpeg: a number of frames spread evenly over it, or the
//! sharpest frame of each of as many equal stretches of it.
//!
//! ffmpeg decodes the video twice. The first pass writes every frame as a small grey
//! thumbnail (8×8 to count frames, 128×128 to measure sharpness: the variance of a
//! 4-neighbour Laplacian, which motion blur lowers); the second writes the chosen
//! frames, found by their index, as PNGs named `frame_<index>.png` (`index` counts the
//! video's frames from 0). Both passes keep every decoded frame (no frame-rate
//! conversion), so an index means the same frame in both.

use crate::installed::Tool;
use anyhow::{Context as _, Result, bail};
use objectsplat_command::process::Program;
use std::ffi::OsString;
use std::path::Path;
use std::time::Duration;

/// How frames are chosen.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pick {
    /// Frame `⌊(k + ½)·T/N⌋` for k = 0…N−1 of T frames.
    Even,
    /// The sharpest frame of each stretch `[⌊k·T/N⌋, ⌊(k+1)·T/N⌋)`; ties to the earlier.
    Sharpest,
}

impl Pick {
    pub const NAMES: [&'static str; 2] = ["even", "sharpest"];

    pub fn parse(name: &str) -> Result<Pick> {
        Ok(match name {
            "even" => Pick::Even,
            "sharpest" => Pick::Sharpest,
            other => bail!("pick {other:?} is not even or sharpest"),
        })
    }
}

/// Side of the thumbnails sharpness is measured on.
const SHARPNESS_SIDE: usize = 128;
/// Side of the thumbnails that only count frames.
const COUNT_SIDE: usize = 8;

/// The installed ffmpeg's version line, e.g. "ffmpeg version 5.1.9-0+deb12u1"; an error
/// says how to install it when it is missing.
pub fn version(program: &str) -> Result<String> {
    let ffmpeg = Tool {
        name: "ffmpeg",
        package: "ffmpeg",
        note: "",
    };
    let text = ffmpeg.output(program, "-version")?;
    match text
        .lines()
        .next()
        .filter(|l| l.starts_with("ffmpeg version"))
    {
        Some(line) => Ok(line
            .split(" Copyright")
            .next()
            .unwrap_or(line)
            .trim()
            .to_string()),
        None => {
            bail!("{program:?} does not look like ffmpeg: `{program} -version` printed {text:?}")
        }
    }
}

/// What was extracted.
#[derive(Debug)]
pub struct Extracted {
    /// Frames in the video.
    pub total: usize,
    /// The chosen frame indices, increasing.
    pub chosen: Vec<usize>,
}

/// One ffmpeg call for `video`, with its common arguments.
struct Ffmpeg<'a> {
    program: &'a str,
    video: &'a Path,
    workdir: &'a Path,
    timeout: Duration,
    cancelled: &'a dyn Fn() -> bool,
}

impl Ffmpeg<'_> {
    fn run(&self, log_name: &str, filter: &str, output: &[&str]) -> Result<()> {
        let mut argv: Vec<OsString> = vec![self.program.into()];
        argv.extend(["-nostdin", "-hide_banner", "-loglevel", "error", "-i"].map(OsString::from));
        argv.push(self.video.into());
        argv.extend(
            ["-map", "0:v:0", "-fps_mode", "passthrough", "-vf", filter]
                .into_iter()
                .chain(output.iter().copied())
                .map(OsString::from),
        );
        Program {
            what: "ffmpeg",
            argv,
            workdir: self.workdir,
            timeout: self.timeout,
            cancelled: self.cancelled,
        }
        .run_logged(&self.workdir.join(log_name))
        .map(drop)
    }
}

/// Extracts `count` frames of `video` into `out` as `frame_<index>.png` (8-bit RGB),
/// working in `workdir`.
#[allow(clippy::too_many_arguments)]
pub fn extract(
    program: &str,
    video: &Path,
    count: usize,
    pick: Pick,
    out: &Path,
    workdir: &Path,
    timeout: Duration,
    cancelled: &dyn Fn() -> bool,
) -> Result<Extracted> {
    if !video.is_file() {
        bail!("{}: no such video file", video.display());
    }
    let ffmpeg = Ffmpeg {
        program,
        video,
        workdir,
        timeout,
        cancelled,
    };
    let side = match pick {
        Pick::Even => COUNT_SIDE,
        Pick::Sharpest => SHARPNESS_SIDE,
    };
    let thumbs = workdir.join("thumbnails.gray");
    ffmpeg
        .run(
            "thumbnails.log",
            &format!("scale={side}:{side}:flags=area,format=gray"),
            &["-f", "rawvideo", &thumbs.display().to_string()],
        )
        .with_context(|| format!("{}: ffmpeg cannot decode it", video.display()))?;
    let bytes =
        std::fs::read(&thumbs).with_context(|| format!("{}: cannot read", thumbs.display()))?;
    let frame_bytes = side * side;
    let total = bytes.len() / frame_bytes;
    if total == 0 {
        bail!("{}: ffmpeg found no video frames in it", video.display());
    }
    if count > total {
        bail!(
            "{}: {count} frames asked for, but the video has only {total}",
            video.display()
        );
    }
    let chosen: Vec<usize> = match pick {
        Pick::Even => (0..count)
            .map(|k| ((2 * k + 1) * total) / (2 * count))
            .collect(),
        Pick::Sharpest => {
            let sharpness: Vec<f64> = bytes
                .chunks_exact(frame_bytes)
                .map(|f| laplacian_variance(f, side))
                .collect();
            (0..count)
                .map(|k| {
                    let (start, end) = (k * total / count, (k + 1) * total / count);
                    // Stretches are never empty (count ≤ total); ties keep the earliest.
                    (start..end).fold(start, |best, i| {
                        if sharpness[i] > sharpness[best] {
                            i
                        } else {
                            best
                        }
                    })
                })
                .collect()
        }
    };
    std::fs::remove_file(&thumbs).ok();

    let staged = workdir.join("frames");
    std::fs::create_dir_all(&staged)
        .with_context(|| format!("{}: cannot create", staged.display()))?;
    let wanted: Vec<String> = chosen.iter().map(|i| format!("eq(n\\,{i})")).collect();
    ffmpeg.run(
        "frames.log",
        &format!("select={}", wanted.join("+")),
        &[
            "-pix_fmt",
            "rgb24",
            &staged.join("%06d.png").display().to_string(),
        ],
    )?;
    // ffmpeg numbers its outputs 1, 2, … in the order of the chosen frames.
    for (k, index) in chosen.iter().enumerate() {
        let from = staged.join(format!("{:06}.png", k + 1));
        let to = out.join(format!("frame_{index:06}.png"));
        std::fs::rename(&from, &to).with_context(|| {
            format!(
                "ffmpeg did not write frame {index} of {} ({})",
                video.display(),
                from.display()
            )
        })?;
    }
    Ok(Extracted { total, chosen })
}

/// Variance of the 4-neighbour Laplacian over the inside of a `side`×`side` grey image.
fn laplacian_variance(pixels: &[u8], side: usize) -> f64 {
    let at = |x: usize, y: usize| pixels[y * side + x] as f64;
    let (mut sum, mut sum_sq, mut n) = (0.0, 0.0, 0.0);
    for y in 1..side - 1 {
        for x in 1..side - 1 {
            let l = at(x - 1, y) + at(x + 1, y) + at(x, y - 1) + at(x, y + 1) - 4.0 * at(x, y);
            sum += l;
            sum_sq += l * l;
            n += 1.0;
        }
    }
    let mean = sum / n;
    sum_sq / n - mean * mean
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_blurred_image_is_less_sharp() {
        let side = 16;
        let checker: Vec<u8> = (0..side * side)
            .map(|i| {
                if (i % side + i / side) % 2 == 0 {
                    200
                } else {
                    40
                }
            })
            .collect();
        let flat = vec![120u8; side * side];
        assert!(laplacian_variance(&checker, side) > 1000.0);
        assert_eq!(laplacian_variance(&flat, side), 0.0);
    }
}
