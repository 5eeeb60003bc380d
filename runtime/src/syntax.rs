//! A RON parser that keeps source spans, so every later error (unknown kind, bad
//! param, missing input) can point at the exact line and column of the graph file.
//!
//! The `ron` crate parses values for serde but forgets where they came from; graph
//! diagnostics need positions, so the graph file itself goes through this parser.

use crate::value::Value;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Span {
    pub start: usize,
    pub end: usize,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Spanned {
    pub span: Span,
    pub kind: SKind,
}

#[derive(Debug, Clone, PartialEq)]
pub enum SKind {
    Unit,
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
    Char(char),
    List(Vec<Spanned>),
    Map(Vec<(Spanned, Spanned)>),
    Tuple(Option<String>, Vec<Spanned>),
    Struct(Option<String>, Vec<(String, Span, Spanned)>),
    Ident(String),
}

#[derive(Debug, Clone, PartialEq)]
pub struct SyntaxError {
    pub offset: usize,
    pub message: String,
}

impl Spanned {
    pub fn to_value(&self) -> Value {
        match &self.kind {
            SKind::Unit => Value::Unit,
            SKind::Bool(b) => Value::Bool(*b),
            SKind::Int(i) => Value::Int(*i),
            SKind::Float(f) => Value::Float(*f),
            SKind::Str(s) => Value::Str(s.clone()),
            SKind::Char(c) => Value::Char(*c),
            SKind::List(items) => Value::List(items.iter().map(Spanned::to_value).collect()),
            SKind::Map(e) => Value::Map(
                e.iter()
                    .map(|(k, v)| (k.to_value(), v.to_value()))
                    .collect(),
            ),
            SKind::Tuple(n, items) => {
                Value::Tuple(n.clone(), items.iter().map(Spanned::to_value).collect())
            }
            SKind::Struct(n, fields) => Value::Struct(
                n.clone(),
                fields
                    .iter()
                    .map(|(k, _, v)| (k.clone(), v.to_value()))
                    .collect(),
            ),
            SKind::Ident(s) => Value::Ident(s.clone()),
        }
    }

    pub fn shape(&self) -> &'static str {
        self.to_value().shape()
    }
}

/// Parses one RON value filling the whole input (comments and `#![enable(..)]` allowed).
pub fn parse(src: &str) -> Result<Spanned, SyntaxError> {
    let mut p = Parser {
        src,
        bytes: src.as_bytes(),
        pos: 0,
        depth: 0,
    };
    p.skip_ws()?;
    while p.peek() == Some(b'#') {
        p.skip_attribute()?;
        p.skip_ws()?;
    }
    let v = p.value()?;
    p.skip_ws()?;
    if p.pos < p.bytes.len() {
        return Err(p.err("expected end of file after the value"));
    }
    Ok(v)
}

/// Deep nesting would overflow the stack; no sensible graph nests this deep.
const MAX_DEPTH: usize = 128;

struct Parser<'a> {
    src: &'a str,
    bytes: &'a [u8],
    pos: usize,
    depth: usize,
}

impl<'a> Parser<'a> {
    fn err(&self, message: impl Into<String>) -> SyntaxError {
        SyntaxError {
            offset: self.pos,
            message: message.into(),
        }
    }

    fn peek(&self) -> Option<u8> {
        self.bytes.get(self.pos).copied()
    }

    fn describe_here(&self) -> String {
        match self.src[self.pos..].chars().next() {
            None => "end of file".into(),
            Some(c) => format!("{c:?}"),
        }
    }

    fn skip_ws(&mut self) -> Result<(), SyntaxError> {
        loop {
            match self.peek() {
                Some(b' ' | b'\t' | b'\n' | b'\r') => self.pos += 1,
                Some(b'/') if self.bytes.get(self.pos + 1) == Some(&b'/') => {
                    while let Some(c) = self.peek() {
                        if c == b'\n' {
                            break;
                        }
                        self.pos += 1;
                    }
                }
                Some(b'/') if self.bytes.get(self.pos + 1) == Some(&b'*') => {
                    let start = self.pos;
                    self.pos += 2;
                    let mut depth = 1;
                    while depth > 0 {
                        match (self.peek(), self.bytes.get(self.pos + 1)) {
                            (None, _) => {
                                return Err(SyntaxError {
                                    offset: start,
                                    message: "unterminated block comment".into(),
                                });
                            }
                            (Some(b'*'), Some(b'/')) => {
                                depth -= 1;
                                self.pos += 2;
                            }
                            (Some(b'/'), Some(b'*')) => {
                                depth += 1;
                                self.pos += 2;
                            }
                            _ => self.pos += 1,
                        }
                    }
                }
                _ => return Ok(()),
            }
        }
    }

    fn skip_attribute(&mut self) -> Result<(), SyntaxError> {
        // `#![enable(...)]`: extensions change nothing for our value model.
        if !self.src[self.pos..].starts_with("#![") {
            return Err(self.err("expected `#![...]` attribute"));
        }
        let mut depth = 0usize;
        while let Some(c) = self.peek() {
            self.pos += 1;
            match c {
                b'[' => depth += 1,
                b']' => {
                    depth -= 1;
                    if depth == 0 {
                        return Ok(());
                    }
                }
                _ => {}
            }
        }
        Err(self.err("unterminated attribute"))
    }

    fn value(&mut self) -> Result<Spanned, SyntaxError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(self.err(format!("values nested deeper than {MAX_DEPTH} levels")));
        }
        let r = self.value_inner();
        self.depth -= 1;
        r
    }

    fn value_inner(&mut self) -> Result<Spanned, SyntaxError> {
        let start = self.pos;
        let kind = match self.peek() {
            None => return Err(self.err("expected a value, found end of file")),
            Some(b'"') => SKind::Str(self.string()?),
            Some(b'r') if matches!(self.bytes.get(self.pos + 1), Some(b'"' | b'#')) => {
                SKind::Str(self.raw_string()?)
            }
            Some(b'\'') => SKind::Char(self.char_lit()?),
            Some(b'[') => {
                self.pos += 1;
                SKind::List(self.values_until(b']', "list")?)
            }
            Some(b'{') => {
                self.pos += 1;
                SKind::Map(self.items_until(b'}', "in map", |p, _| {
                    let k = p.value()?;
                    let v = p.colon_then_value("map key")?;
                    Ok((k, v))
                })?)
            }
            Some(b'(') => self.paren_body(None)?,
            Some(c) if c == b'-' || c == b'+' || c == b'.' || c.is_ascii_digit() => {
                self.number()?
            }
            Some(c) if c.is_ascii_alphabetic() || c == b'_' => {
                let ident = self.ident();
                match ident.as_str() {
                    "true" => SKind::Bool(true),
                    "false" => SKind::Bool(false),
                    "inf" => SKind::Float(f64::INFINITY),
                    "NaN" => SKind::Float(f64::NAN),
                    _ => {
                        let save = self.pos;
                        self.skip_ws()?;
                        if self.peek() == Some(b'(') {
                            self.paren_body(Some(ident))?
                        } else {
                            self.pos = save;
                            SKind::Ident(ident)
                        }
                    }
                }
            }
            Some(_) => {
                return Err(self.err(format!("expected a value, found {}", self.describe_here())));
            }
        };
        Ok(Spanned {
            span: Span {
                start,
                end: self.pos,
            },
            kind,
        })
    }

    /// Comma-separated values up to and including `close` (a trailing comma is allowed).
    fn values_until(&mut self, close: u8, what: &str) -> Result<Vec<Spanned>, SyntaxError> {
        self.items_until(close, &format!("in {what}"), |p, _| p.value())
    }

    /// Comma-separated items up to and including `close` (a trailing comma is allowed).
    /// `item` reads one, given those before it; `place` ends the message for a missing
    /// separator ("expected `,` or `]` in list").
    fn items_until<T>(
        &mut self,
        close: u8,
        place: &str,
        mut item: impl FnMut(&mut Self, &[T]) -> Result<T, SyntaxError>,
    ) -> Result<Vec<T>, SyntaxError> {
        let mut items = Vec::new();
        loop {
            self.skip_ws()?;
            if self.peek() == Some(close) {
                self.pos += 1;
                return Ok(items);
            }
            let next = item(self, &items)?;
            items.push(next);
            self.skip_ws()?;
            match self.peek() {
                Some(b',') => self.pos += 1,
                Some(c) if c == close => {
                    self.pos += 1;
                    return Ok(items);
                }
                _ => {
                    return Err(self.err(format!(
                        "expected `,` or `{}` {place}, found {}",
                        close as char,
                        self.describe_here()
                    )));
                }
            }
        }
    }

    /// `: value` after a map key or field name (`after` names it for the error).
    fn colon_then_value(&mut self, after: &str) -> Result<Spanned, SyntaxError> {
        self.skip_ws()?;
        if self.peek() != Some(b':') {
            return Err(self.err(format!(
                "expected `:` after {after}, found {}",
                self.describe_here()
            )));
        }
        self.pos += 1;
        self.skip_ws()?;
        self.value()
    }

    fn ident(&mut self) -> String {
        let start = self.pos;
        while let Some(c) = self.peek() {
            if c.is_ascii_alphanumeric() || c == b'_' {
                self.pos += 1;
            } else {
                break;
            }
        }
        self.src[start..self.pos].to_string()
    }

    /// After `(` (optionally preceded by a name): a struct if the first item is `ident:`.
    fn paren_body(&mut self, name: Option<String>) -> Result<SKind, SyntaxError> {
        self.pos += 1; // '('
        self.skip_ws()?;
        if self.peek() == Some(b')') {
            self.pos += 1;
            return Ok(match name {
                None => SKind::Unit,
                Some(n) => SKind::Struct(Some(n), Vec::new()),
            });
        }
        if self.looks_like_field() {
            let fields = self.items_until(b')', "after a field", |p, fields| p.field(fields))?;
            Ok(SKind::Struct(name, fields))
        } else {
            let items = self.values_until(b')', "tuple")?;
            Ok(SKind::Tuple(name, items))
        }
    }

    /// `name: value` in a struct, refused when `before` already has the name.
    fn field(
        &mut self,
        before: &[(String, Span, Spanned)],
    ) -> Result<(String, Span, Spanned), SyntaxError> {
        let kstart = self.pos;
        if !self
            .peek()
            .is_some_and(|c| c.is_ascii_alphabetic() || c == b'_')
        {
            return Err(self.err(format!(
                "expected a field name, found {}",
                self.describe_here()
            )));
        }
        let key = self.ident();
        let kspan = Span {
            start: kstart,
            end: self.pos,
        };
        if before.iter().any(|(k, _, _)| *k == key) {
            return Err(SyntaxError {
                offset: kstart,
                message: format!("field `{key}` appears twice"),
            });
        }
        let v = self.colon_then_value(&format!("field `{key}`"))?;
        Ok((key, kspan, v))
    }

    fn looks_like_field(&self) -> bool {
        let mut i = self.pos;
        if !self
            .bytes
            .get(i)
            .is_some_and(|c| c.is_ascii_alphabetic() || *c == b'_')
        {
            return false;
        }
        while self
            .bytes
            .get(i)
            .is_some_and(|c| c.is_ascii_alphanumeric() || *c == b'_')
        {
            i += 1;
        }
        while self.bytes.get(i).is_some_and(|c| c.is_ascii_whitespace()) {
            i += 1;
        }
        self.bytes.get(i) == Some(&b':')
    }

    fn number(&mut self) -> Result<SKind, SyntaxError> {
        let start = self.pos;
        let negative = match self.peek() {
            Some(b'-') => {
                self.pos += 1;
                true
            }
            Some(b'+') => {
                self.pos += 1;
                false
            }
            _ => false,
        };
        if self.src[self.pos..].starts_with("inf") {
            self.pos += 3;
            return Ok(SKind::Float(if negative {
                f64::NEG_INFINITY
            } else {
                f64::INFINITY
            }));
        }
        if self.src[self.pos..].starts_with("NaN") {
            self.pos += 3;
            return Ok(SKind::Float(f64::NAN));
        }
        if self.src[self.pos..].starts_with("0x")
            || self.src[self.pos..].starts_with("0b")
            || self.src[self.pos..].starts_with("0o")
        {
            let radix = match self.bytes[self.pos + 1] {
                b'x' => 16,
                b'b' => 2,
                _ => 8,
            };
            self.pos += 2;
            let dstart = self.pos;
            while self
                .peek()
                .is_some_and(|c| c.is_ascii_alphanumeric() || c == b'_')
            {
                self.pos += 1;
            }
            let digits: String = self.src[dstart..self.pos]
                .chars()
                .filter(|c| *c != '_')
                .collect();
            let v = i64::from_str_radix(&digits, radix).map_err(|_| SyntaxError {
                offset: start,
                message: format!("invalid integer `{}`", &self.src[start..self.pos]),
            })?;
            return Ok(SKind::Int(if negative { -v } else { v }));
        }
        let mut is_float = false;
        while let Some(c) = self.peek() {
            match c {
                b'0'..=b'9' | b'_' => self.pos += 1,
                b'.' => {
                    is_float = true;
                    self.pos += 1;
                }
                b'e' | b'E' => {
                    is_float = true;
                    self.pos += 1;
                    if matches!(self.peek(), Some(b'+' | b'-')) {
                        self.pos += 1;
                    }
                }
                _ => break,
            }
        }
        let text: String = self.src[start..self.pos]
            .chars()
            .filter(|c| *c != '_')
            .collect();
        if text.is_empty() || text == "-" || text == "+" {
            return Err(SyntaxError {
                offset: start,
                message: "expected a number".into(),
            });
        }
        if is_float {
            text.parse::<f64>()
                .map(SKind::Float)
                .map_err(|_| SyntaxError {
                    offset: start,
                    message: format!("invalid number `{text}`"),
                })
        } else {
            text.parse::<i64>()
                .map(SKind::Int)
                .map_err(|_| SyntaxError {
                    offset: start,
                    message: format!("invalid integer `{text}` (integers must fit in 64 bits)"),
                })
        }
    }

    fn escape(&mut self, out: &mut String) -> Result<(), SyntaxError> {
        // At the character after the backslash.
        let c = self.peek().ok_or_else(|| self.err("unterminated escape"))?;
        self.pos += 1;
        match c {
            b'n' => out.push('\n'),
            b't' => out.push('\t'),
            b'r' => out.push('\r'),
            b'0' => out.push('\0'),
            b'\\' => out.push('\\'),
            b'"' => out.push('"'),
            b'\'' => out.push('\''),
            b'u' => {
                if self.peek() != Some(b'{') {
                    return Err(self.err("expected `{` after `\\u`"));
                }
                self.pos += 1;
                let s = self.pos;
                while self.peek().is_some_and(|c| c.is_ascii_hexdigit()) {
                    self.pos += 1;
                }
                let code = u32::from_str_radix(&self.src[s..self.pos], 16)
                    .ok()
                    .and_then(char::from_u32);
                if self.peek() != Some(b'}') {
                    return Err(self.err("expected `}` closing `\\u{...}`"));
                }
                self.pos += 1;
                out.push(code.ok_or_else(|| self.err("invalid unicode escape"))?);
            }
            _ => {
                return Err(SyntaxError {
                    offset: self.pos - 2,
                    message: format!("unknown escape `\\{}`", c as char),
                });
            }
        }
        Ok(())
    }

    fn string(&mut self) -> Result<String, SyntaxError> {
        let start = self.pos;
        self.pos += 1;
        let mut out = String::new();
        loop {
            let rest = &self.src[self.pos..];
            let Some(c) = rest.chars().next() else {
                return Err(SyntaxError {
                    offset: start,
                    message: "unterminated string".into(),
                });
            };
            self.pos += c.len_utf8();
            match c {
                '"' => return Ok(out),
                '\\' => self.escape(&mut out)?,
                c => out.push(c),
            }
        }
    }

    fn raw_string(&mut self) -> Result<String, SyntaxError> {
        let start = self.pos;
        self.pos += 1; // r
        let mut hashes = 0;
        while self.peek() == Some(b'#') {
            hashes += 1;
            self.pos += 1;
        }
        if self.peek() != Some(b'"') {
            return Err(self.err("expected `\"` in raw string"));
        }
        self.pos += 1;
        let close = format!("\"{}", "#".repeat(hashes));
        match self.src[self.pos..].find(&close) {
            Some(i) => {
                let s = self.src[self.pos..self.pos + i].to_string();
                self.pos += i + close.len();
                Ok(s)
            }
            None => Err(SyntaxError {
                offset: start,
                message: "unterminated raw string".into(),
            }),
        }
    }

    fn char_lit(&mut self) -> Result<char, SyntaxError> {
        let start = self.pos;
        self.pos += 1;
        let mut s = String::new();
        match self.src[self.pos..].chars().next() {
            Some('\\') => {
                self.pos += 1;
                self.escape(&mut s)?;
            }
            Some(c) => {
                self.pos += c.len_utf8();
                s.push(c);
            }
            None => {
                return Err(SyntaxError {
                    offset: start,
                    message: "unterminated char".into(),
                });
            }
        }
        if self.peek() != Some(b'\'') {
            return Err(SyntaxError {
                offset: start,
                message: "expected `'` closing a char".into(),
            });
        }
        self.pos += 1;
        // The escape wrote exactly one char.
        Ok(s.chars().next().unwrap_or('\0'))
    }
}

/// 1-based line and column (in characters) of a byte offset.
pub fn line_col(src: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(src.len());
    let before = &src[..src.floor_char_boundary(offset)];
    let line = before.matches('\n').count() + 1;
    let col = before
        .rsplit('\n')
        .next()
        .map(|l| l.chars().count())
        .unwrap_or(0)
        + 1;
    (line, col)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_graph_shaped_ron_with_spans() {
        let src = "// comment\n(\n  nodes: { \"a\": (kind: \"x\", params: (n: -3, f: 1e3, s: r#\"q\"#)) },\n  t: [each(\"a.b\"), None, Some(1)],\n)";
        let v = parse(src).unwrap();
        let SKind::Struct(None, fields) = &v.kind else {
            panic!("{v:?}")
        };
        assert_eq!(fields[0].0, "nodes");
        assert_eq!(line_col(src, fields[0].1.start), (3, 3));
        assert_eq!(
            v.to_value().to_ron(),
            "(nodes:{\"a\":(kind:\"x\",params:(f:1000.0,n:-3,s:\"q\"))},t:[each(\"a.b\"),None,Some(1)])"
        );
    }

    #[test]
    fn errors_carry_offsets() {
        let e = parse("(a: 1,\n b: [1, 2\n)").unwrap_err();
        assert_eq!(line_col("(a: 1,\n b: [1, 2\n)", e.offset), (3, 1));
        assert!(e.message.contains("expected `,` or `]`"), "{}", e.message);
        assert!(parse("(a: 1, a: 2)").unwrap_err().message.contains("twice"));
        assert!(parse(&"[".repeat(1000)).is_err());
    }
}
