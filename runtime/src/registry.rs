//! The catalogue of artifact types and node kinds, filled by `nodes/` and by plugins.

use crate::node::{Node, NodeSpec};
use std::collections::BTreeMap;
use std::sync::Arc;

#[derive(Debug, Clone)]
pub struct TypeInfo {
    pub name: String,
    /// The on-disk encoding, for `objectsplat nodes` and plugin authors.
    pub doc: String,
}

/// Where a node kind comes from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Origin {
    Builtin,
    Plugin { path: String, build: String },
}

#[derive(Clone)]
pub struct Registered {
    /// Shared: every plan node of this kind points at it (a graph may hold 100k nodes).
    pub spec: Arc<NodeSpec>,
    pub node: Arc<dyn Node>,
    pub origin: Origin,
}

#[derive(Default, Clone)]
pub struct Registry {
    types: BTreeMap<String, TypeInfo>,
    nodes: BTreeMap<String, Registered>,
}

impl Registry {
    pub fn new() -> Registry {
        Registry::default()
    }

    pub fn add_type(&mut self, name: &str, doc: &str) {
        self.types.insert(
            name.to_string(),
            TypeInfo {
                name: name.to_string(),
                doc: doc.to_string(),
            },
        );
    }

    pub fn has_type(&self, name: &str) -> bool {
        self.types.contains_key(name)
    }

    pub fn types(&self) -> impl Iterator<Item = &TypeInfo> {
        self.types.values()
    }

    /// Registers a built-in node kind.
    pub fn add_node(&mut self, node: Arc<dyn Node>) -> Result<(), String> {
        self.add_node_from(node, Origin::Builtin)
    }

    /// Registers a node kind, refusing name collisions and specs that do not check.
    pub fn add_node_from(&mut self, node: Arc<dyn Node>, origin: Origin) -> Result<(), String> {
        let spec = node.spec();
        if let Some(existing) = self.nodes.get(&spec.kind) {
            let whose = match &existing.origin {
                Origin::Builtin => "a built-in node".to_string(),
                Origin::Plugin { path, .. } => format!("a node of plugin {path}"),
            };
            return Err(format!(
                "node kind `{}` is already defined by {whose}",
                spec.kind
            ));
        }
        self.check_spec(&spec)?;
        self.nodes.insert(
            spec.kind.clone(),
            Registered {
                spec: Arc::new(spec),
                node,
                origin,
            },
        );
        Ok(())
    }

    fn check_spec(&self, spec: &NodeSpec) -> Result<(), String> {
        let k = &spec.kind;
        if k.is_empty() || !k.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(format!(
                "node kind `{k}` must be made of letters, digits and `_`"
            ));
        }
        let mut seen = std::collections::HashSet::new();
        let names = spec
            .inputs
            .iter()
            .chain(&spec.outputs)
            .map(|p| p.name.as_str())
            .chain(spec.params.iter().map(|p| p.name.as_str()));
        for name in names {
            // Port names become folder names (staging, OUT/<node>/<port>).
            if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(format!(
                    "node `{k}`: port or param name {name:?} must be made of letters, digits and `_`"
                ));
            }
        }
        for p in spec.inputs.iter().chain(&spec.outputs) {
            if !self.types.contains_key(p.ty.element()) {
                return Err(format!(
                    "node `{k}` port `{}` has unknown type `{}`",
                    p.name, p.ty
                ));
            }
        }
        for p in &spec.inputs {
            if !seen.insert(("in", p.name.as_str())) {
                return Err(format!("node `{k}` declares input `{}` twice", p.name));
            }
        }
        for p in &spec.outputs {
            if !seen.insert(("out", p.name.as_str())) {
                return Err(format!("node `{k}` declares output `{}` twice", p.name));
            }
        }
        for p in &spec.params {
            if !seen.insert(("param", p.name.as_str())) {
                return Err(format!("node `{k}` declares param `{}` twice", p.name));
            }
            if let Some(d) = &p.default {
                let v = crate::syntax::parse(d)
                    .map_err(|e| {
                        format!("node `{k}` param `{}` default {d:?}: {}", p.name, e.message)
                    })?
                    .to_value();
                p.ty.check(&v)
                    .map(|_| ())
                    .map_err(|e| format!("node `{k}` param `{}` default {d}: {e}", p.name))?;
            }
        }
        Ok(())
    }

    pub fn get(&self, kind: &str) -> Option<&Registered> {
        self.nodes.get(kind)
    }

    pub fn kinds(&self) -> impl Iterator<Item = &Registered> {
        self.nodes.values()
    }

    /// Up to three known kinds close to `kind`, for "did you mean" hints.
    pub fn similar_kinds(&self, kind: &str) -> Vec<&str> {
        crate::diag::similar(kind, self.nodes.keys().map(String::as_str))
    }
}
