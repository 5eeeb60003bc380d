//! Running a user's inpainting program (e.g. a diffusion inpainter) on image+mask
//! pairs through files.
//!
//! Protocol, in a fresh working folder:
//! - `input/<stem>.png`: the frame, 8-bit RGB;
//! - `input/<stem>_mask.png`: 8-bit grey, 255 = fill, 0 = keep;
//! - `output/`: empty; the program must write `output/<stem>.png` for every pair,
//!   the same size as the input (any colour type the `image` crate reads).
//!
//! The command is an argv list run directly, never through a shell. An argument
//! that is exactly `{input}` or `{output}` is replaced by the folder's path; nothing
//! else is substituted, so file names never end up inside a command string. The
//! program runs through `objectsplat_command::process` (the runner the generic
//! `command` stage uses): stdout discarded, the last few KB of stderr in error
//! messages, and it runs in a process group of its own: at the timeout the whole
//! group is killed (the program and everything it started), and processes it leaves
//! behind when it exits are killed too. Pixels outside the mask are taken from the
//! input, whatever the program wrote there.
//!
//! Cache key: the argv, the program file and every file or folder an absolute
//! argument names ([`ExternalCommand::reads`]), so editing the script reruns the
//! node. Files the program opens on its own (weights it finds by itself, say) cannot
//! be known in advance and are not part of the key: name them in the argv.

use anyhow::{Context, Result, bail};
use objectsplat_command::process::Program;
use objectsplat_core::image::{read_rgb8, write_gray8, write_rgb8};
use std::path::{Path, PathBuf};
use std::time::Duration;

#[derive(Debug, Clone, PartialEq)]
pub struct ExternalCommand {
    pub argv: Vec<String>,
    pub timeout: Duration,
}

/// One image to fill: `rgb` is `width × height × 3`, `mask` non-zero = fill.
#[derive(Debug, Clone)]
pub struct FillRequest {
    pub stem: String,
    pub width: u32,
    pub height: u32,
    pub rgb: Vec<u8>,
    pub mask: Vec<u8>,
}

impl ExternalCommand {
    /// The files the command's output depends on besides its inputs: the program
    /// (found on `PATH` when named without a folder) and every absolute argument that
    /// names an existing file or folder (a script, a weights file, a model folder).
    pub fn reads(argv: &[String]) -> Vec<PathBuf> {
        let mut out = Vec::new();
        if let Some(program) = argv.first() {
            let program = Path::new(program);
            if program.components().count() > 1 || program.is_absolute() {
                out.push(program.to_path_buf());
            } else if let Some(found) = std::env::var_os("PATH").and_then(|paths| {
                std::env::split_paths(&paths)
                    .map(|d| d.join(program))
                    .find(|p| p.is_file())
            }) {
                out.push(found);
            }
        }
        for arg in argv.iter().skip(1) {
            let p = Path::new(arg);
            if p.is_absolute() && p.exists() {
                out.push(p.to_path_buf());
            }
        }
        out
    }

    /// Runs the program once on all `requests` inside `workdir` and returns the
    /// filled RGB images in request order.
    pub fn run(&self, requests: &[FillRequest], workdir: &Path) -> Result<Vec<Vec<u8>>> {
        let Some(program) = self.argv.first() else {
            bail!(
                "the inpainting command is empty: give it as a list, e.g. [\"python3\", \"fill.py\", \"{{input}}\", \"{{output}}\"]"
            );
        };
        let input = workdir.join("input");
        let output = workdir.join("output");
        for dir in [&input, &output] {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("{}: cannot create folder", dir.display()))?;
        }
        for r in requests {
            if r.stem.is_empty() || r.stem.contains(['/', '\\']) || r.stem.starts_with('.') {
                bail!("frame stem {:?} cannot be used as a file name", r.stem);
            }
            write_rgb8(
                &input.join(format!("{}.png", r.stem)),
                &r.rgb,
                r.width,
                r.height,
            )?;
            let mask: Vec<u8> = r
                .mask
                .iter()
                .map(|&m| if m != 0 { 255 } else { 0 })
                .collect();
            write_gray8(
                &input.join(format!("{}_mask.png", r.stem)),
                &mask,
                r.width,
                r.height,
            )?;
        }

        let argv = self
            .argv
            .iter()
            .map(|a| match a.as_str() {
                "{input}" => input.clone().into_os_string(),
                "{output}" => output.clone().into_os_string(),
                other => other.into(),
            })
            .collect();
        let stderr = Program {
            what: "inpainting command",
            argv,
            workdir,
            timeout: self.timeout,
            cancelled: &|| false,
        }
        .run()?;

        let missing: Vec<String> = requests
            .iter()
            .map(|r| format!("{}.png", r.stem))
            .filter(|name| !output.join(name).is_file())
            .collect();
        if !missing.is_empty() {
            bail!(
                "inpainting command {program:?} exited successfully but did not write {} in {}; stderr:\n{stderr}",
                missing.join(", "),
                output.display()
            );
        }
        requests
            .iter()
            .map(|r| {
                let path = output.join(format!("{}.png", r.stem));
                let (w, h, filled) = read_rgb8(&path)?;
                if (w, h) != (r.width, r.height) {
                    bail!(
                        "{}: the inpainting command wrote a {w}×{h} image for a {}×{} input",
                        path.display(),
                        r.width,
                        r.height
                    );
                }
                Ok(composite(&r.rgb, &filled, &r.mask))
            })
            .collect()
    }
}

/// `filled` inside the mask, `original` outside it.
pub fn composite(original: &[u8], filled: &[u8], mask: &[u8]) -> Vec<u8> {
    let mut out = original.to_vec();
    for (p, &m) in mask.iter().enumerate() {
        if m != 0 {
            out[p * 3..p * 3 + 3].copy_from_slice(&filled[p * 3..p * 3 + 3]);
        }
    }
    out
}
