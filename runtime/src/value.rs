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
                out.push('[');
                for (i, v) in items.iter().enumerate() {
                    if i > 0 {
                        out.push(',');
                    }
                    v.write_ron(out);
                }
                out.push(']');
            }
            Value::Map(entries) => {
                let mut sorted: Vec<(String, &Value)> =
                    entries.iter().map(|(k, v)| (k.to_ron(), v)).collect();
                sorted.sort_by(|a, b| a.0.cmp(&b.0));
                out.push('{');
                for (i, (k, v)) in sorted.iter().enumerate() {
                    if i > 0 {
                        out.push(',');
                    }
                    out.push_str(k);
                    out.push(':');
                    v.write_ron(out);
                }
                out.push('}');
            }
            Value::Tuple(name, items) => {
                if let Some(n) = name {
                    out.push_str(n);
                }
                out.push('(');
                for (i, v) in items.iter().enumerate() {
                    if i > 0 {
                        out.push(',');
                    }
                    v.write_ron(out);
                }
                out.push(')');
            }
            Value::Struct(name, fields) => {
                let mut sorted: Vec<&(String, Value)> = fields.iter().collect();
                sorted.sort_by(|a, b| a.0.cmp(&b.0));
                if let Some(n) = name {
                    out.push_str(n);
                }
                out.push('(');
                for (i, (k, v)) in sorted.iter().enumerate() {
                    if i > 0 {
                        out.push(',');
                    }
                    out.push_str(k);
                    out.push(':');
                    v.write_ron(out);
                }
                out.push(')');
            }
            Value::Ident(s) => out.push_str(s),
        }
    }

    /// Deserializes into a typed value through the canonical RON text.
    pub fn deserialize<T: DeserializeOwned>(&self) -> Result<T, String> {
        ron::from_str(&self.to_ron()).map_err(|e| e.code.to_string())
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
}
