//! The messages between the engine and a plugin's child process (one JSON value per
//! line). The child speaks ABI v1 to the library and this to the engine; the engine
//! never loads plugin code itself.
//!
//! Engine → child (stdin): one [`Call`] line, then `"cancel"` lines when the run is
//! interrupted. Closing stdin means the engine is gone: the child kills itself and
//! everything it started. Child → engine (its original stdout; the library's own
//! prints go to stderr): any number of [`Reply::Progress`] lines, then one final reply.

use serde::{Deserialize, Serialize};
use std::io::{self, BufRead, Read};
use std::path::PathBuf;

#[derive(Debug, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Call {
    /// Load the library, check its entry table and describe it.
    Describe { library: PathBuf },
    /// Load the library (it must still have `digest`) and run one node.
    Run {
        library: PathBuf,
        digest: String,
        /// The ABI v1 run request, passed to the library byte for byte.
        request: String,
    },
}

/// The line that asks a running child to report cancellation to its plugin.
pub const CANCEL: &str = "cancel";

#[derive(Debug, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Reply {
    Progress {
        done: u64,
        total: u64,
        message: String,
    },
    /// The library loaded and described itself.
    Described {
        digest: String,
        build: String,
        /// The describe JSON, already parsed once by the child.
        description: String,
    },
    /// The library cannot be used (not a library, wrong ABI, changed since loaded...).
    Refused { message: String },
    /// The ABI v1 answer: a status and its buffer (JSON, error or panic message).
    Answer { status: i32, body: String },
}

/// Longest line either side reads (a describe text or a run answer with its notes).
pub const MAX_LINE: usize = 16 << 20;

/// Longest error, panic or refusal text passed on; the rest is cut with a note, so a
/// plugin that fails with megabytes of text cannot flood the terminal or the report.
pub const MAX_MESSAGE: usize = 4 << 10;

/// Reads one line of at most `max` bytes (without its newline); `None` at the end.
pub fn read_line(reader: &mut impl BufRead, max: usize) -> io::Result<Option<Vec<u8>>> {
    let mut line = Vec::new();
    let n = reader
        .by_ref()
        .take(max as u64 + 1)
        .read_until(b'\n', &mut line)?;
    if n == 0 {
        return Ok(None);
    }
    if line.last() == Some(&b'\n') {
        line.pop();
    } else if line.len() > max {
        return Err(io::Error::other(format!(
            "a message longer than {} MiB",
            max >> 20
        )));
    }
    Ok(Some(line))
}

/// `text` cut to [`MAX_MESSAGE`] bytes, saying how much was left out.
pub fn bounded(text: &str) -> String {
    bounded_to(text, MAX_MESSAGE)
}

pub use crate::diag::bounded as bounded_to;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_are_bounded_and_messages_cut_with_a_note() {
        let mut r = io::Cursor::new(b"abc\ndefgh\nxy".to_vec());
        assert_eq!(read_line(&mut r, 4).unwrap().unwrap(), b"abc");
        assert!(read_line(&mut r, 4).is_err());
        let mut r = io::Cursor::new(b"xy".to_vec());
        assert_eq!(read_line(&mut r, 4).unwrap().unwrap(), b"xy");
        assert!(read_line(&mut r, 4).unwrap().is_none());
        assert_eq!(bounded_to("héllo", 2), "h… [5 more bytes not shown]");
        assert_eq!(bounded_to("hello", 5), "hello");
    }
}
