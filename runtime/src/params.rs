//! Parameter schemas: what a node accepts, how a RON value is checked and
//! normalised against it, and how nodes read typed values back.

use crate::value::Value;
use serde::de::DeserializeOwned;
use std::collections::BTreeMap;
use std::fmt;

/// The type of one parameter. `Display`/`parse` give the textual form used by
/// `objectsplat nodes` and by plugins' `describe` text.
#[derive(Debug, Clone, PartialEq)]
pub enum ParamType {
    Bool,
    Int {
        min: Option<i64>,
        max: Option<i64>,
    },
    Float {
        min: Option<f64>,
        max: Option<f64>,
    },
    Str,
    /// One of a fixed set of strings.
    Enum(Vec<String>),
    /// An input file or folder, relative to the graph file; its content enters the cache key.
    Path,
    /// A path relative to the node's output folder (never absolute, never `..`), `/`-separated
    /// once checked (see [`crate::paths::normalise_relative`]).
    RelPath,
    List(Box<ParamType>),
    Optional(Box<ParamType>),
    /// Any RON value; the node checks it (e.g. by deserializing into its own types).
    Ron(String),
}

impl ParamType {
    pub fn int() -> Self {
        ParamType::Int {
            min: None,
            max: None,
        }
    }
    pub fn int_range(min: i64, max: i64) -> Self {
        ParamType::Int {
            min: Some(min),
            max: Some(max),
        }
    }
    pub fn float() -> Self {
        ParamType::Float {
            min: None,
            max: None,
        }
    }
    pub fn float_range(min: f64, max: f64) -> Self {
        ParamType::Float {
            min: Some(min),
            max: Some(max),
        }
    }
    pub fn non_negative() -> Self {
        ParamType::Float {
            min: Some(0.0),
            max: None,
        }
    }
    pub fn enumeration(options: &[&str]) -> Self {
        ParamType::Enum(options.iter().map(|s| s.to_string()).collect())
    }
    pub fn list(inner: ParamType) -> Self {
        ParamType::List(Box::new(inner))
    }
    pub fn optional(inner: ParamType) -> Self {
        ParamType::Optional(Box::new(inner))
    }

    /// Checks `v` against the type and returns its normalised form (ints widened
    /// to floats where a float is expected, a bare value under Optional wrapped in `Some`).
    pub fn check(&self, v: &Value) -> Result<Value, String> {
        match (self, v) {
            (ParamType::Bool, Value::Bool(_)) => Ok(v.clone()),
            (ParamType::Int { min, max }, Value::Int(i)) => {
                if min.is_some_and(|m| *i < m) || max.is_some_and(|m| *i > m) {
                    return Err(format!("{i} is out of range {}", range_text(min, max)));
                }
                Ok(v.clone())
            }
            (ParamType::Float { min, max }, Value::Int(_) | Value::Float(_)) => {
                let f = match v {
                    Value::Int(i) => *i as f64,
                    Value::Float(f) => *f,
                    _ => unreachable!("matched Int or Float above"),
                };
                if !f.is_finite() {
                    return Err(format!("{f} is not a finite number"));
                }
                if min.is_some_and(|m| f < m) || max.is_some_and(|m| f > m) {
                    return Err(format!("{f} is out of range {}", range_text(min, max)));
                }
                Ok(Value::Float(f))
            }
            (ParamType::Str, Value::Str(_)) => Ok(v.clone()),
            (ParamType::Enum(options), Value::Str(s)) => {
                if options.iter().any(|o| o == s) {
                    Ok(v.clone())
                } else {
                    Err(format!("{s:?} is not one of {}", quoted_list(options)))
                }
            }
            (ParamType::Path, Value::Str(s)) => {
                if s.is_empty() {
                    Err("the path is empty".into())
                } else {
                    Ok(v.clone())
                }
            }
            (ParamType::RelPath, Value::Str(s)) => crate::paths::normalise_relative(s)
                .map(Value::Str)
                .map_err(|e| format!("{e}: expected a relative path inside the output folder")),
            (ParamType::List(inner), Value::List(items)) => items
                .iter()
                .enumerate()
                .map(|(i, item)| inner.check(item).map_err(|e| format!("item {i}: {e}")))
                .collect::<Result<Vec<_>, _>>()
                .map(Value::List),
            (ParamType::Optional(_), Value::Ident(n)) if n == "None" => Ok(v.clone()),
            (ParamType::Optional(inner), Value::Tuple(Some(n), items))
                if n == "Some" && items.len() == 1 =>
            {
                Ok(some(inner.check(&items[0])?))
            }
            // A bare value where an option is expected means `Some(value)`.
            (ParamType::Optional(inner), other) => Ok(some(inner.check(other)?)),
            (ParamType::Ron(_), _) => Ok(v.clone()),
            (expected, found) => Err(format!(
                "expected {}, found {}",
                expected.describe(),
                found.shape()
            )),
        }
    }

    /// A phrase for error messages: "a float in [0, 1]".
    pub fn describe(&self) -> String {
        match self {
            ParamType::Bool => "a bool (true or false)".into(),
            ParamType::Int { min, max } => format!("an integer{}", range_suffix(min, max)),
            ParamType::Float { min, max } => format!("a number{}", range_suffix(min, max)),
            ParamType::Str => "a string".into(),
            ParamType::Enum(o) => format!("one of {}", quoted_list(o)),
            ParamType::Path => "a path (string)".into(),
            ParamType::RelPath => "a relative path (string)".into(),
            ParamType::List(i) => format!("a list of {}", strip_article(&i.describe())),
            ParamType::Optional(i) => format!("{} or None", i.describe()),
            ParamType::Ron(d) => d.clone(),
        }
    }

    /// Parses the textual form written by `Display`.
    pub fn parse(text: &str) -> Result<ParamType, String> {
        let t = text.trim();
        let inner = |prefix: &str| t.strip_prefix(prefix).and_then(|r| r.strip_suffix(')'));
        Ok(match t {
            "bool" => ParamType::Bool,
            "int" => ParamType::int(),
            "float" => ParamType::float(),
            "string" => ParamType::Str,
            "path" => ParamType::Path,
            "relpath" => ParamType::RelPath,
            "ron" => ParamType::Ron("any RON value".into()),
            _ => {
                if let Some(r) = inner("list(") {
                    ParamType::list(ParamType::parse(r)?)
                } else if let Some(r) = inner("optional(") {
                    ParamType::optional(ParamType::parse(r)?)
                } else if let Some(r) = inner("enum(") {
                    let opts: Vec<String> = r.split('|').map(|s| s.trim().to_string()).collect();
                    if opts.iter().any(String::is_empty) {
                        return Err(format!("empty option in `{t}`"));
                    }
                    ParamType::Enum(opts)
                } else if let Some(r) = inner("int(") {
                    let (a, b) = parse_range::<i64>(r)?;
                    ParamType::Int { min: a, max: b }
                } else if let Some(r) = inner("float(") {
                    let (a, b) = parse_range::<f64>(r)?;
                    ParamType::Float { min: a, max: b }
                } else {
                    return Err(format!(
                        "unknown param type `{t}`; expected bool, int, int(MIN..MAX), float, float(MIN..MAX), string, path, relpath, ron, enum(a|b), list(T) or optional(T)"
                    ));
                }
            }
        })
    }
}

fn some(v: Value) -> Value {
    Value::Tuple(Some("Some".into()), vec![v])
}

fn parse_range<T: std::str::FromStr>(r: &str) -> Result<(Option<T>, Option<T>), String> {
    let (a, b) = r
        .split_once("..")
        .ok_or_else(|| format!("expected MIN..MAX, found `{r}`"))?;
    let p = |s: &str| -> Result<Option<T>, String> {
        let s = s.trim();
        if s.is_empty() {
            Ok(None)
        } else {
            s.parse().map(Some).map_err(|_| format!("bad bound `{s}`"))
        }
    };
    Ok((p(a)?, p(b)?))
}

/// `name`, or `name(min..max)` with either bound left empty when open.
fn write_range<T: fmt::Display>(
    f: &mut fmt::Formatter<'_>,
    name: &str,
    min: Option<T>,
    max: Option<T>,
) -> fmt::Result {
    if min.is_none() && max.is_none() {
        return write!(f, "{name}");
    }
    let bound = |v: Option<T>| v.map(|v| v.to_string()).unwrap_or_default();
    write!(f, "{name}({}..{})", bound(min), bound(max))
}

impl fmt::Display for ParamType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ParamType::Bool => write!(f, "bool"),
            ParamType::Int { min, max } => write_range(f, "int", *min, *max),
            ParamType::Float { min, max } => write_range(f, "float", *min, *max),
            ParamType::Str => write!(f, "string"),
            ParamType::Enum(o) => write!(f, "enum({})", o.join("|")),
            ParamType::Path => write!(f, "path"),
            ParamType::RelPath => write!(f, "relpath"),
            ParamType::List(i) => write!(f, "list({i})"),
            ParamType::Optional(i) => write!(f, "optional({i})"),
            ParamType::Ron(_) => write!(f, "ron"),
        }
    }
}

fn range_text<T: fmt::Display>(min: &Option<T>, max: &Option<T>) -> String {
    match (min, max) {
        (Some(a), Some(b)) => format!("[{a}, {b}]"),
        (Some(a), None) => format!("≥ {a}"),
        (None, Some(b)) => format!("≤ {b}"),
        (None, None) => "any".into(),
    }
}

fn range_suffix<T: fmt::Display>(min: &Option<T>, max: &Option<T>) -> String {
    match (min, max) {
        (None, None) => String::new(),
        _ => format!(" in {}", range_text(min, max)),
    }
}

fn strip_article(s: &str) -> &str {
    s.strip_prefix("an ")
        .or_else(|| s.strip_prefix("a "))
        .unwrap_or(s)
}

fn quoted_list(options: &[String]) -> String {
    options
        .iter()
        .map(|o| format!("{o:?}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// One declared parameter.
#[derive(Debug, Clone)]
pub struct ParamSpec {
    pub name: String,
    pub ty: ParamType,
    /// Default as RON text; `None` = required.
    pub default: Option<String>,
    pub doc: String,
}

/// A node's parameters after validation: every declared name has a normalised value.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Params {
    pub(crate) values: BTreeMap<String, Value>,
}

impl Params {
    pub fn new(values: BTreeMap<String, Value>) -> Params {
        Params { values }
    }

    pub fn value(&self, name: &str) -> Option<&Value> {
        self.values.get(name)
    }

    /// Reads a parameter as `T` (via serde). Node code calls this; the graph was
    /// validated against the schema, so an error here means the schema and the
    /// requested type disagree — reported as a node failure, never a panic.
    pub fn get<T: DeserializeOwned>(&self, name: &str) -> anyhow::Result<T> {
        let v = self
            .values
            .get(name)
            .ok_or_else(|| anyhow::anyhow!("parameter `{name}` is not declared"))?;
        v.deserialize()
            .map_err(|e| anyhow::anyhow!("parameter `{name}` = {v}: {e}"))
    }

    /// All parameters as a [`node_params!`](crate::node_params) type.
    pub fn read_as<P: NodeParams>(&self) -> anyhow::Result<P> {
        P::read(self)
    }

    /// Canonical text of all parameters (sorted), used in cache keys.
    pub fn canonical(&self) -> String {
        Value::Struct(
            None,
            self.values
                .iter()
                .map(|(k, v)| (k.clone(), v.clone()))
                .collect(),
        )
        .to_ron()
    }

    pub fn iter(&self) -> impl Iterator<Item = (&String, &Value)> {
        self.values.iter()
    }
}

/// A node's parameters as one Rust type: [`node_params!`](crate::node_params) declares the
/// struct, and from the same lines the schema ([`NodeParams::declare`]) and the typed
/// reading ([`NodeParams::read`]), so the two cannot disagree.
pub trait NodeParams: Sized {
    /// Adds every parameter (name, type, default, doc) to `spec`, in declaration order.
    fn declare(spec: crate::NodeSpec) -> crate::NodeSpec;
    /// The validated values as the struct; an error names the param that does not read.
    fn try_read(params: &Params) -> Result<Self, crate::ParamError>;
    /// The validated values as the struct.
    fn read(params: &Params) -> anyhow::Result<Self> {
        Self::try_read(params).map_err(|e| anyhow::anyhow!(e.message))
    }
}

/// One doc text from the lines of a doc comment (as `///` gives them: each with a leading space).
pub fn doc_text(lines: &[&str]) -> String {
    lines
        .iter()
        .map(|l| l.trim())
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join(" ")
}

/// Declares a node's parameters once, as a struct that implements [`NodeParams`]:
///
/// ```
/// use objectsplat_runtime::{NodeSpec, ParamType, Params, node_params, value::Value};
///
/// node_params! {
///     /// What `blur` takes.
///     pub struct BlurParams {
///         /// Kernel radius in pixels.
///         radius: i64 = "2" as ParamType::int_range(0, 64),
///         /// The image to blur, relative to the graph.
///         path: String = required as ParamType::Path,
///     }
/// }
///
/// let spec = NodeSpec::new("blur", "1").params::<BlurParams>();
/// assert_eq!(spec.params[0].name, "radius");
/// assert_eq!(spec.params[0].default.as_deref(), Some("2"));
/// assert_eq!(spec.params[1].default, None);
/// assert_eq!(spec.params[1].doc, "The image to blur, relative to the graph.");
///
/// // What `run` gets back: the validated values, typed.
/// let values = [("radius", Value::Int(5)), ("path", Value::Str("in.png".into()))];
/// let params = Params::new(values.map(|(k, v)| (k.to_string(), v)).into());
/// let blur: BlurParams = params.read_as().unwrap();
/// assert_eq!((blur.radius, blur.path.as_str()), (5, "in.png"));
/// ```
///
/// Each field is `name: RustType = DEFAULT as PARAM_TYPE`, where `DEFAULT` is the default's
/// RON text or `required`. The field's doc comment is the parameter's doc.
#[macro_export]
macro_rules! node_params {
    (
        $(#[$meta:meta])*
        $vis:vis struct $name:ident {
            $(
                $(#[doc = $doc:literal])*
                $field:ident : $ty:ty = $default:tt as $param_type:expr
            ),* $(,)?
        }
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone)]
        $vis struct $name {
            $(
                $(#[doc = $doc])*
                pub $field: $ty,
            )*
        }

        impl $crate::params::NodeParams for $name {
            fn declare(spec: $crate::NodeSpec) -> $crate::NodeSpec {
                spec $(
                    .param(
                        stringify!($field),
                        $param_type,
                        $crate::node_params!(@default $default),
                        &$crate::params::doc_text(&[$($doc),*]),
                    )
                )*
            }

            fn try_read(params: &$crate::Params) -> ::std::result::Result<Self, $crate::ParamError> {
                Ok($name {
                    $(
                        $field: params.get::<$ty>(stringify!($field)).map_err(|e| {
                            $crate::ParamError::new(stringify!($field), format!("{e:#}"))
                        })?,
                    )*
                })
            }
        }
    };
    (@default required) => { None };
    (@default $text:literal) => { Some($text) };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn types_check_normalise_and_roundtrip_their_text() {
        let f = ParamType::float_range(0.0, 1.0);
        assert_eq!(f.check(&Value::Int(1)).unwrap(), Value::Float(1.0));
        assert!(
            f.check(&Value::Float(2.0))
                .unwrap_err()
                .contains("out of range")
        );
        assert!(
            ParamType::Bool
                .check(&Value::Int(1))
                .unwrap_err()
                .contains("expected a bool")
        );
        assert!(
            ParamType::RelPath
                .check(&Value::Str("../x".into()))
                .is_err()
        );
        for t in [
            "bool",
            "int(1..)",
            "float(0..1)",
            "enum(ns|telea)",
            "list(optional(string))",
            "path",
            "relpath",
            "ron",
        ] {
            assert_eq!(ParamType::parse(t).unwrap().to_string(), t);
        }
        assert!(ParamType::parse("floaty").is_err());
    }
}
