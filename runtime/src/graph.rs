//! The graph file: RON text → declarations with spans (no registry knowledge yet).
//!
//! ```ron
//! (
//!   nodes: {
//!     "scene": (kind: "synthetic_scene", params: (seed: 7)),
//!     "train": (kind: "train", inputs: (component: each("parts.components"))),
//!   },
//!   targets: ["train"],
//!   plugins: ["../target/release/libmy_plugin.so"],
//!   slurm: (partition: "gpu"),
//! )
//! ```

use crate::diag::{Diagnostic, Diagnostics};
pub use crate::source::GraphSource;
use crate::syntax::{self, SKind, Span, Spanned};

/// `"node.port"` or `each("node.port")`.
#[derive(Debug, Clone, PartialEq)]
pub struct PortRef {
    pub node: String,
    pub port: String,
    pub each: bool,
    pub span: Span,
}

#[derive(Debug, Clone)]
pub struct InputDecl {
    pub port: String,
    pub port_span: Span,
    pub source: PortRef,
}

#[derive(Debug, Clone)]
pub struct ParamDecl {
    pub name: String,
    pub name_span: Span,
    pub value: Spanned,
}

#[derive(Debug, Clone)]
pub struct NodeDecl {
    pub id: String,
    pub id_span: Span,
    pub kind: String,
    pub kind_span: Span,
    pub params: Vec<ParamDecl>,
    pub inputs: Vec<InputDecl>,
    /// Its `slurm: (...)` field as written: options for its Slurm jobs (and, on a node
    /// that does not fan out, the request to run it as one). The parser keeps an
    /// executor's settings as syntax; the executor's own module reads them
    /// (`slurm::SlurmSettings::parse`, when the plan is built).
    pub slurm: Option<Spanned>,
    pub span: Span,
}

#[derive(Debug, Clone)]
pub struct GraphDecl {
    pub nodes: Vec<NodeDecl>,
    pub targets: Vec<(String, Span)>,
    pub plugins: Vec<(String, Span)>,
    /// The graph's `slurm: (...)` field as written: defaults for every Slurm job of the
    /// graph (read like a node's).
    pub slurm: Option<Spanned>,
}

pub fn parse_graph(src: &GraphSource) -> Result<GraphDecl, Diagnostics> {
    let root = syntax::parse(&src.text).map_err(|e| {
        Diagnostics(vec![src.diag(
            Span {
                start: e.offset,
                end: e.offset + 1,
            },
            format!("syntax error: {}", e.message),
        )])
    })?;
    let mut diags = Vec::new();
    let fields = match &root.kind {
        SKind::Struct(_, fields) => fields,
        SKind::Unit => &Vec::new(),
        _ => {
            return Err(Diagnostics(vec![src.diag(
                root.span,
                format!(
                    "expected the graph as a struct `(nodes: {{...}}, targets: [...])`, found {}",
                    root.shape()
                ),
            )]));
        }
    };
    let mut graph = GraphDecl {
        nodes: vec![],
        targets: vec![],
        plugins: vec![],
        slurm: None,
    };
    let mut saw_nodes = false;
    for (name, name_span, value) in fields {
        match name.as_str() {
            "nodes" => {
                saw_nodes = true;
                match &value.kind {
                    SKind::Map(entries) => {
                        let mut seen = std::collections::HashSet::new();
                        for (k, v) in entries {
                            match parse_node(src, k, v) {
                                Ok(n) => {
                                    if !seen.insert(n.id.clone()) {
                                        diags.push(src.diag(
                                            k.span,
                                            format!("node id {:?} is defined twice", n.id),
                                        ));
                                    } else {
                                        graph.nodes.push(n);
                                    }
                                }
                                Err(mut d) => diags.append(&mut d),
                            }
                        }
                    }
                    _ => diags.push(src.diag(
                        value.span,
                        format!(
                            "expected `nodes` to be a map {{\"id\": (kind: ...), ...}}, found {}",
                            value.shape()
                        ),
                    )),
                }
            }
            "targets" | "plugins" => match string_list(value) {
                Ok(list) => {
                    if name == "targets" {
                        graph.targets = list;
                    } else {
                        graph.plugins = list;
                    }
                }
                Err((span, msg)) => diags.push(src.diag(span, format!("`{name}`: {msg}"))),
            },
            "slurm" => graph.slurm = Some(value.clone()),
            other => diags.push(src.diag(
                *name_span,
                format!(
                    "unknown graph field `{other}`; expected `nodes`, `targets`, `plugins` or `slurm`"
                ),
            )),
        }
    }
    if !saw_nodes {
        diags.push(src.diag(
            root.span,
            "the graph has no `nodes` field; expected `(nodes: {...})`",
        ));
    }
    if diags.is_empty() {
        Ok(graph)
    } else {
        Err(Diagnostics(diags))
    }
}

fn string_list(v: &Spanned) -> Result<Vec<(String, Span)>, (Span, String)> {
    match &v.kind {
        SKind::List(items) => items
            .iter()
            .map(|i| match &i.kind {
                SKind::Str(s) => Ok((s.clone(), i.span)),
                _ => Err((i.span, format!("expected a string, found {}", i.shape()))),
            })
            .collect(),
        _ => Err((
            v.span,
            format!("expected a list of strings, found {}", v.shape()),
        )),
    }
}

fn valid_id(id: &str) -> bool {
    !id.is_empty()
        && id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

fn parse_node(src: &GraphSource, key: &Spanned, v: &Spanned) -> Result<NodeDecl, Vec<Diagnostic>> {
    let id = match &key.kind {
        SKind::Str(s) if valid_id(s) => s.clone(),
        SKind::Str(s) => {
            return Err(vec![src.diag(
                key.span,
                format!("node id {s:?} must be non-empty and made of letters, digits, `_` and `-`"),
            )]);
        }
        _ => {
            return Err(vec![src.diag(
                key.span,
                format!("expected a node id string, found {}", key.shape()),
            )]);
        }
    };
    let SKind::Struct(_, fields) = &v.kind else {
        return Err(vec![src.diag(
            v.span,
            format!(
                "node {id:?}: expected `(kind: \"...\", params: (...), inputs: (...))`, found {}",
                v.shape()
            ),
        )]);
    };
    let mut diags = Vec::new();
    let mut kind = None;
    let mut params = Vec::new();
    let mut inputs = Vec::new();
    let mut slurm = None;
    for (name, name_span, value) in fields {
        match name.as_str() {
            "kind" => match &value.kind {
                SKind::Str(s) => kind = Some((s.clone(), value.span)),
                _ => diags.push(src.diag(value.span, format!("node {id:?}: `kind` must be a string, found {}", value.shape()))),
            },
            "params" => match &value.kind {
                SKind::Struct(_, pf) => {
                    params = pf
                        .iter()
                        .map(|(n, s, v)| ParamDecl { name: n.clone(), name_span: *s, value: v.clone() })
                        .collect()
                }
                SKind::Unit => {}
                _ => diags.push(src.diag(
                    value.span,
                    format!("node {id:?}: `params` must be a struct `(name: value, ...)`, found {}", value.shape()),
                )),
            },
            "inputs" => match &value.kind {
                SKind::Struct(_, inf) => {
                    for (port, port_span, r) in inf {
                        match parse_ref(r) {
                            Ok(source) => inputs.push(InputDecl { port: port.clone(), port_span: *port_span, source }),
                            Err(msg) => diags.push(src.diag(r.span, format!("node {id:?} input `{port}`: {msg}"))),
                        }
                    }
                }
                SKind::Unit => {}
                _ => diags.push(src.diag(
                    value.span,
                    format!("node {id:?}: `inputs` must be a struct `(port: \"node.port\", ...)`, found {}", value.shape()),
                )),
            },
            "slurm" => slurm = Some(value.clone()),
            "doc" => {}
            other => diags.push(src.diag(
                *name_span,
                format!("node {id:?}: unknown field `{other}`; expected `kind`, `params`, `inputs`, `slurm` or `doc`"),
            )),
        }
    }
    let Some((kind, kind_span)) = kind else {
        diags.push(src.diag(
            v.span,
            format!("node {id:?} has no `kind`; expected `kind: \"<node kind>\"`"),
        ));
        return Err(diags);
    };
    if !diags.is_empty() {
        return Err(diags);
    }
    Ok(NodeDecl {
        id,
        id_span: key.span,
        kind,
        kind_span,
        params,
        inputs,
        slurm,
        span: v.span,
    })
}

fn parse_ref(v: &Spanned) -> Result<PortRef, String> {
    let (text, each) = match &v.kind {
        SKind::Str(s) => (s.as_str(), false),
        SKind::Tuple(Some(name), items) if name == "each" && items.len() == 1 => {
            match &items[0].kind {
                SKind::Str(s) => (s.as_str(), true),
                _ => return Err("expected each(\"node.port\")".into()),
            }
        }
        _ => {
            return Err(format!(
                "expected \"node.port\" or each(\"node.port\"), found {}",
                v.shape()
            ));
        }
    };
    match text.split_once('.') {
        Some((n, p)) if valid_id(n) && !p.is_empty() && !p.contains('.') => Ok(PortRef {
            node: n.to_string(),
            port: p.to_string(),
            each,
            span: v.span,
        }),
        _ => Err(format!(
            "{text:?} is not a port reference; expected \"node.port\""
        )),
    }
}
