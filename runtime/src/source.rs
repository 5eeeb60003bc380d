//! A graph file's path and text: where diagnostics point, what paths resolve against.
//! Its own module so that the graph parser and the Slurm settings reader, which both
//! point into it, depend on it and not on each other.

use crate::diag::{Diagnostic, Diagnostics};
use crate::syntax::Span;
use std::path::{Path, PathBuf};

#[derive(Debug, Clone)]
pub struct GraphSource {
    pub path: PathBuf,
    pub text: String,
}

impl GraphSource {
    pub fn read(path: &Path) -> Result<GraphSource, Diagnostics> {
        let bytes = std::fs::read(path).map_err(|e| {
            Diagnostics(vec![Diagnostic::argument(
                &path.display().to_string(),
                format!("cannot read graph file: {e}"),
            )])
        })?;
        let text = String::from_utf8(bytes).map_err(|e| {
            let bytes = e.as_bytes();
            let at = e.utf8_error().valid_up_to();
            // The valid prefix locates the bad byte; its line is shown up to that byte.
            let valid = std::str::from_utf8(&bytes[..at]).expect("valid_up_to is valid UTF-8");
            let mut d = Diagnostic::at(
                path,
                valid,
                crate::syntax::Span {
                    start: at,
                    end: at,
                },
                format!(
                    "the graph file is not UTF-8 text (byte 0x{:02x} at offset {at}); save it as UTF-8",
                    bytes[at]
                ),
            );
            d.snippet = None;
            Diagnostics(vec![d])
        })?;
        Ok(GraphSource {
            path: path.to_path_buf(),
            text,
        })
    }

    pub fn diag(&self, span: Span, message: impl Into<String>) -> Diagnostic {
        Diagnostic::at(&self.path, &self.text, span, message)
    }

    /// The folder graph-relative paths resolve against.
    pub fn dir(&self) -> PathBuf {
        match self.path.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        }
    }

    /// The graph's name: its file stem (`graphs/demo.ron` → `demo`).
    pub fn name(&self) -> String {
        self.path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "graph".into())
    }
}
