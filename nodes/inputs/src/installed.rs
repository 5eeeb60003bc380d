//! Whether an external program (COLMAP, ffmpeg) is installed, and what it says about
//! itself: the text a version or help flag prints, or an error saying how to install it.

use anyhow::{Result, bail};

/// What a program is, for the messages about it.
pub struct Tool<'a> {
    /// Its name in messages: "COLMAP".
    pub name: &'a str,
    /// The Debian package that installs it: "colmap".
    pub package: &'a str,
    /// More to say after the install line, e.g. that it needs no GPU ("" for nothing).
    pub note: &'a str,
}

impl Tool<'_> {
    /// The stdout of `program flag` (a name looked up on PATH, or a path).
    pub fn output(&self, program: &str, flag: &str) -> Result<String> {
        let output = std::process::Command::new(program)
            .arg(flag)
            .stdin(std::process::Stdio::null())
            .output();
        match output {
            Ok(o) => Ok(String::from_utf8_lossy(&o.stdout).into_owned()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                if program.contains('/') {
                    bail!(
                        "{program}: no such program; point `program` at the {} binary",
                        self.package
                    )
                }
                bail!(
                    "`{program}` is not installed (not found on PATH). Install {}: on Debian or \
                     Ubuntu `apt-get install {}`{}; or set `program` to the {} binary",
                    self.name,
                    self.package,
                    self.note,
                    self.package
                )
            }
            Err(e) => bail!("cannot start {program:?}: {e}"),
        }
    }
}
