//! RON values as the engine sees them: parameters, graph entries, `--set` overrides.
//!
//! `Value` is span-free; its canonical text (`to_ron`) is what enters cache keys and
//! what typed parameters are deserialized from (via the `ron` crate), so two
//! spellings of the same value hash alike (struct fields and map entries sorted,
//! floats in shortest round-trip form).

use serde::de::DeserializeOwned;
use std::fmt::Write;

#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Unit,
    Bool(bool),
    Int(i64),
    Float(f64),
    Str(String),
    Char(char),
    List(Vec<Value>),
    Map(Vec<(Value, Value)>),
    /// `(a, b)` or `Name(a, b)`; `Some(x)` is `Tuple(Some("Some"), [x])`.
    Tuple(Option<String>, Vec<Value>),
    /// `(a: 1)` or `Name(a: 1)`.
    Struct(Option<String>, Vec<(String, Value)>),
    /// A bare identifier: a unit enum variant or unit struct, e.g. `None`.
    Ident(String),
}

impl Value {
    /// A short name of the value's shape, for error messages.
    pub fn shape(&self) -> &'static str {
        match self {
            Value::Unit => "()",
            Value::Bool(_) => "a bool",
            Value::Int(_) => "an integer",
            Value::Float(_) => "a float",
            Value::Str(_) => "a string",
            Value::Char(_) => "a char",
            Value::List(_) => "a list",
            Value::Map(_) => "a map",
            Value::Tuple(..) => "a tuple",
            Value::Struct(..) => "a struct",
            Value::Ident(_) => "an identifier",
        }
    }

    pub fn as_str(&self) -> Option<&str> {
        match self {
            Value::Str(s) => Some(s),
            _ => None,
        }
    }

    /// Canonical RON text.
    pub fn to_ron(&self) -> String {
        let mut s = String::new();
        self.write_ron(&mut s);
        s
    }

    fn write_ron(&self, out: &mut String) {
        match self {
            Value::Unit => out.push_str("()"),
            Value::Bool(b) => out.push_str(if *b { "true" } else { "false" }),
            Value::Int(i) => {
                let _ = write!(out, "{i}");
            }
            Value::Float(f) => out.push_str(&format_float(*f)),
            Value::Str(s) => write_string(out, s),
            Value::Char(c) => {
                out.push('\'');
                match c {
                    '\'' => out.push_str("\\'"),
                    '\\' => out.push_str("\\\\"),
                    '\n' => out.push_str("\\n"),
                    c => out.push(*c),
                }
                out.push('\'');
            }
            Value::List(items) => {
                write_separated(out, "[", items, "]", |out, v| v.write_ron(out));
            }
            Value::Map(entries) => {
                let mut sorted: Vec<(String, &Value)> =
                    entries.iter().map(|(k, v)| (k.to_ron(), v)).collect();
                sorted.sort_by(|a, b| a.0.cmp(&b.0));
                write_separated(out, "{", sorted, "}", |out, (k, v)| {
                    out.push_str(&k);
                    out.push(':');
                    v.write_ron(out);
                });
            }
            Value::Tuple(name, items) => {
                out.push_str(name.as_deref().unwrap_or(""));
                write_separated(out, "(", items, ")", |out, v| v.write_ron(out));
            }
            Value::Struct(name, fields) => {
                let mut sorted: Vec<&(String, Value)> = fields.iter().collect();
                sorted.sort_by(|a, b| a.0.cmp(&b.0));
                out.push_str(name.as_deref().unwrap_or(""));
                write_separated(out, "(", sorted, ")", |out, (k, v)| {
                    out.push_str(k);
                    out.push(':');
                    v.write_ron(out);
                });
            }
            Value::Ident(s) => out.push_str(s),
        }
    }

    /// What changed from `self` to `now`, one `path: before → after` line per changed
    /// leaf: struct fields and map entries by name (`schedule.patience`), list and
    /// tuple items by index (`edits[1].target`) when the lengths agree; a changed
    /// shape, name or length is one line for the whole value. `path` names `self`.
    pub fn diff(&self, now: &Value, path: &str) -> Vec<String> {
        let mut out = Vec::new();
        diff_into(self, now, path, &mut out);
        out
    }

    /// Deserializes into a typed value through the canonical RON text.
    pub fn deserialize<T: DeserializeOwned>(&self) -> Result<T, String> {
        ron::from_str(&self.to_ron()).map_err(|e| e.code.to_string())
    }
}

fn diff_into(was: &Value, now: &Value, path: &str, out: &mut Vec<String>) {
    if was == now {
        return;
    }
    let join = |key: &str| {
        if path.is_empty() {
            key.to_string()
        } else {
            format!("{path}.{key}")
        }
    };
    let keyed =
        |entries: &[(String, &Value)], other: &[(String, &Value)], out: &mut Vec<String>| {
            let mut keys: Vec<&String> = entries.iter().chain(other).map(|(k, _)| k).collect();
            keys.sort();
            keys.dedup();
            let find = |list: &[(String, &Value)], k: &str| {
                list.iter().find(|(n, _)| n == k).map(|(_, v)| (*v).clone())
            };
            for k in keys {
                match (find(entries, k), find(other, k)) {
                    (Some(a), Some(b)) => diff_into(&a, &b, &join(k), out),
                    (Some(a), None) => out.push(format!("{}: {a} → (not set)", join(k))),
                    (None, Some(b)) => out.push(format!("{}: (not set) → {b}", join(k))),
                    (None, None) => {}
                }
            }
        };
    match (was, now) {
        (Value::Struct(n1, f1), Value::Struct(n2, f2)) if n1 == n2 => {
            let a: Vec<(String, &Value)> = f1.iter().map(|(k, v)| (k.clone(), v)).collect();
            let b: Vec<(String, &Value)> = f2.iter().map(|(k, v)| (k.clone(), v)).collect();
            keyed(&a, &b, out);
        }
        (Value::Map(e1), Value::Map(e2)) => {
            let key = |k: &Value| k.as_str().map_or_else(|| k.to_ron(), str::to_string);
            let a: Vec<(String, &Value)> = e1.iter().map(|(k, v)| (key(k), v)).collect();
            let b: Vec<(String, &Value)> = e2.iter().map(|(k, v)| (key(k), v)).collect();
            keyed(&a, &b, out);
        }
        (Value::List(a), Value::List(b)) if a.len() == b.len() => {
            for (i, (x, y)) in a.iter().zip(b).enumerate() {
                diff_into(x, y, &format!("{path}[{i}]"), out);
            }
        }
        (Value::Tuple(n1, a), Value::Tuple(n2, b)) if n1 == n2 && a.len() == b.len() => {
            // `Some(x)` → `Some(y)` reads as `x → y`.
            if a.len() == 1 && n1.as_deref() == Some("Some") {
                return diff_into(&a[0], &b[0], path, out);
            }
            for (i, (x, y)) in a.iter().zip(b).enumerate() {
                diff_into(x, y, &format!("{path}.{i}"), out);
            }
        }
        _ => out.push(format!("{path}: {was} → {now}")),
    }
}

fn format_float(f: f64) -> String {
    if f.is_nan() {
        "NaN".into()
    } else if f.is_infinite() {
        if f > 0.0 { "inf".into() } else { "-inf".into() }
    } else {
        let s = format!("{f:?}");
        if s.contains(['.', 'e', 'E']) {
            s
        } else {
            format!("{s}.0")
        }
    }
}

/// `open`, the items written by `write` and separated by commas, `close`.
fn write_separated<T>(
    out: &mut String,
    open: &str,
    items: impl IntoIterator<Item = T>,
    close: &str,
    mut write: impl FnMut(&mut String, T),
) {
    out.push_str(open);
    for (i, item) in items.into_iter().enumerate() {
        if i > 0 {
            out.push(',');
        }
        write(out, item);
    }
    out.push_str(close);
}

fn write_string(out: &mut String, s: &str) {
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c if (c as u32) < 0x20 => {
                let _ = write!(out, "\\u{{{:x}}}", c as u32);
            }
            c => out.push(c),
        }
    }
    out.push('"');
}

impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.to_ron())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn canonical_text_sorts_fields_and_roundtrips_through_ron() {
        let v = Value::Struct(
            None,
            vec![
                ("b".into(), Value::Float(1.0)),
                (
                    "a".into(),
                    Value::List(vec![Value::Int(1), Value::Float(1e-5)]),
                ),
            ],
        );
        assert_eq!(v.to_ron(), "(a:[1,1e-5],b:1.0)");
        #[derive(serde::Deserialize, Debug, PartialEq)]
        struct S {
            a: Vec<f64>,
            b: f64,
        }
        assert_eq!(
            v.deserialize::<S>().unwrap(),
            S {
                a: vec![1.0, 1e-5],
                b: 1.0
            }
        );
        let s = Value::Str("q\"\\\n".into());
        assert_eq!(s.deserialize::<String>().unwrap(), "q\"\\\n");
    }

    #[test]
    fn diff_names_each_changed_field_by_its_path() {
        let parse = |t: &str| crate::syntax::parse(t).unwrap().to_value();
        let was = parse(
            r#"(iterations: 600, schedule: {"patience": 300, "lr": 0.1}, edits: [Remove(target: "a"), Remove(target: "b")], seed: 1)"#,
        );
        let now = parse(
            r#"(iterations: 300, schedule: {"patience": 200, "lr": 0.1, "sigma": 2.0}, edits: [Remove(target: "a"), Remove(target: "c")], seed: 1)"#,
        );
        assert_eq!(
            was.diff(&now, ""),
            [
                r#"edits[1].target: "b" → "c""#,
                "iterations: 600 → 300",
                "schedule.patience: 300 → 200",
                "schedule.sigma: (not set) → 2.0",
            ]
        );
        assert_eq!(
            parse("[1, 2]").diff(&parse("[1, 2, 3]"), "xs"),
            ["xs: [1,2] → [1,2,3]"]
        );
        assert!(was.diff(&was, "").is_empty());
    }
}
