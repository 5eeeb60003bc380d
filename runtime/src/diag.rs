//! Errors about user input (graph files, `--set` overrides) that point at a place.

use crate::syntax::{Span, line_col};
use std::fmt;
use std::path::{Path, PathBuf};

/// Where a diagnostic points.
#[derive(Debug, Clone, PartialEq)]
pub enum Location {
    File {
        path: PathBuf,
        line: usize,
        column: usize,
    },
    /// A command-line argument such as `--set train.seed=3`.
    Argument(String),
}

#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostic {
    pub location: Location,
    pub message: String,
    /// The source line with a caret under the column, when known.
    pub snippet: Option<String>,
}

impl Diagnostic {
    pub fn at(path: &Path, src: &str, span: Span, message: impl Into<String>) -> Diagnostic {
        let (line, column) = line_col(src, span.start);
        let start = src.floor_char_boundary(span.start.min(src.len()));
        let end = src.floor_char_boundary(span.end.min(src.len())).max(start);
        let line_start = src[..start].rfind('\n').map_or(0, |i| i + 1);
        let line_end = src[start..].find('\n').map_or(src.len(), |i| start + i);
        let text = &src[line_start..line_end];
        let width = src[start..end]
            .lines()
            .next()
            .map_or(1, |l| l.chars().count())
            .max(1);
        let snippet = snippet(line, text, column - 1, width);
        Diagnostic {
            location: Location::File {
                path: path.to_path_buf(),
                line,
                column,
            },
            message: message.into(),
            snippet: Some(snippet),
        }
    }

    pub fn argument(arg: &str, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            location: Location::Argument(arg.to_string()),
            message: message.into(),
            snippet: None,
        }
    }

    /// `file:line:column: message` (or `argument ...: message`), one line.
    pub fn headline(&self) -> String {
        match &self.location {
            Location::File { path, line, column } => {
                format!("{}:{line}:{column}: {}", path.display(), self.message)
            }
            Location::Argument(a) => format!("{a}: {}", self.message),
        }
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.headline())?;
        if let Some(s) = &self.snippet {
            write!(f, "\n{s}")?;
        }
        Ok(())
    }
}

/// Characters of a source line shown on each side of the column (a generated graph
/// may hold megabytes on one line; the snippet shows the neighbourhood, marked `…`).
const SNIPPET_CONTEXT: usize = 60;

/// `line | text` with a caret line under `column` (0-based, in characters), the
/// text cut to [`SNIPPET_CONTEXT`] characters either side.
fn snippet(line: usize, text: &str, column: usize, width: usize) -> String {
    let chars = text.chars().count();
    let from = column.saturating_sub(SNIPPET_CONTEXT);
    let to = chars.min(column + width.min(SNIPPET_CONTEXT) + SNIPPET_CONTEXT);
    let shown: String = text.chars().skip(from).take(to - from).collect();
    let (lead, tail) = (
        if from > 0 { "…" } else { "" },
        if to < chars { "…" } else { "" },
    );
    let room = to.saturating_sub(column).max(1);
    format!(
        "{line:>5} | {lead}{shown}{tail}\n      | {}{}",
        " ".repeat(column - from + lead.chars().count()),
        "^".repeat(width.min(room).min(SNIPPET_CONTEXT))
    )
}

/// One or more diagnostics; validation reports every independent problem it finds.
#[derive(Debug, Clone, PartialEq)]
pub struct Diagnostics(pub Vec<Diagnostic>);

impl fmt::Display for Diagnostics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, d) in self.0.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "error: {d}")?;
        }
        Ok(())
    }
}

impl std::error::Error for Diagnostics {}
impl std::error::Error for Diagnostic {}

/// `text` cut to `max` bytes (at a character boundary), saying how much was left
/// out: for messages that quote what a user, a file or a plugin supplied.
pub fn bounded(text: &str, max: usize) -> String {
    if text.len() <= max {
        return text.to_string();
    }
    let cut = text.floor_char_boundary(max);
    format!(
        "{}… [{} more bytes not shown]",
        &text[..cut],
        text.len() - cut
    )
}

/// Candidates within a small edit distance of `word`, closest first.
pub fn similar<'a>(word: &str, candidates: impl Iterator<Item = &'a str>) -> Vec<&'a str> {
    let mut scored: Vec<(usize, &str)> = candidates
        .map(|c| (edit_distance(word, c), c))
        .filter(|(d, c)| *d <= word.len().max(c.len()).div_ceil(3))
        .collect();
    scored.sort();
    scored.into_iter().take(3).map(|(_, c)| c).collect()
}

fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut cur = vec![i + 1; b.len() + 1];
        for (j, cb) in b.iter().enumerate() {
            cur[j + 1] = (prev[j] + usize::from(ca != *cb))
                .min(prev[j + 1] + 1)
                .min(cur[j] + 1);
        }
        prev = cur;
    }
    prev[b.len()]
}

/// ", did you mean `x`?" or "".
pub fn did_you_mean(options: &[&str]) -> String {
    match options {
        [] => String::new(),
        [one] => format!("; did you mean `{one}`?"),
        many => format!(
            "; did you mean one of {}?",
            many.iter()
                .map(|s| format!("`{s}`"))
                .collect::<Vec<_>>()
                .join(", ")
        ),
    }
}
