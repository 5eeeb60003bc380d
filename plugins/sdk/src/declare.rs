//! Declaring a plugin's node kinds from ordinary Rust functions.

use crate::protocol::{Description, NodeDescription, ParamDescription, PortDescription};
use crate::request::Request;

/// How a node run ended when it did not fail.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    Done,
    /// Nothing to do (outputs not written, or forwarded with [`Request::forward`]); the reason is reported.
    Skipped(String),
}

/// A node's code: reads inputs and params from the request, writes its output folders.
/// It must be deterministic and thread-safe (the engine runs nodes concurrently).
pub type NodeFn = fn(&mut Request<'_>) -> anyhow::Result<Outcome>;

/// One node kind: its interface (checked by the host against its registry) and its code.
#[derive(Clone)]
pub struct NodeDecl {
    pub(crate) description: NodeDescription,
    pub(crate) run: NodeFn,
}

impl NodeDecl {
    pub fn new(kind: &str, run: NodeFn) -> NodeDecl {
        NodeDecl {
            description: NodeDescription {
                kind: kind.into(),
                doc: String::new(),
                inputs: vec![],
                outputs: vec![],
                params: vec![],
            },
            run,
        }
    }

    pub fn doc(mut self, doc: &str) -> Self {
        self.description.doc = doc.into();
        self
    }

    fn port(name: &str, ty: &str, optional: bool, doc: &str) -> PortDescription {
        PortDescription {
            name: name.into(),
            ty: ty.into(),
            doc: doc.into(),
            optional,
        }
    }

    /// An input port; `ty` is a type name (`Image`) or a collection (`[Component]`).
    pub fn input(mut self, name: &str, ty: &str, doc: &str) -> Self {
        self.description
            .inputs
            .push(Self::port(name, ty, false, doc));
        self
    }

    pub fn optional_input(mut self, name: &str, ty: &str, doc: &str) -> Self {
        self.description
            .inputs
            .push(Self::port(name, ty, true, doc));
        self
    }

    pub fn output(mut self, name: &str, ty: &str, doc: &str) -> Self {
        self.description
            .outputs
            .push(Self::port(name, ty, false, doc));
        self
    }

    /// A parameter: `ty` in the engine's text form (`float(0..1)`, `enum(a|b)`, `list(ron)`...),
    /// `default` as RON text (`None` = required).
    pub fn param(mut self, name: &str, ty: &str, default: Option<&str>, doc: &str) -> Self {
        self.description.params.push(ParamDescription {
            name: name.into(),
            ty: ty.into(),
            default: default.map(str::to_string),
            doc: doc.into(),
        });
        self
    }

    pub fn kind(&self) -> &str {
        &self.description.kind
    }
}

/// A plugin: a name, one code version for all its nodes, and the nodes.
#[derive(Clone)]
pub struct Plugin {
    name: String,
    version: String,
    nodes: Vec<NodeDecl>,
}

impl Plugin {
    /// `version` enters every cache key of this plugin's nodes: bump it whenever any
    /// node's output for the same inputs and params changes.
    pub fn new(name: &str, version: &str) -> Plugin {
        Plugin {
            name: name.into(),
            version: version.into(),
            nodes: vec![],
        }
    }

    pub fn node(mut self, node: NodeDecl) -> Self {
        self.nodes.push(node);
        self
    }

    pub fn description(&self) -> Description {
        Description {
            plugin: self.name.clone(),
            version: self.version.clone(),
            nodes: self.nodes.iter().map(|n| n.description.clone()).collect(),
        }
    }

    pub(crate) fn find(&self, kind: &str) -> Option<&NodeDecl> {
        self.nodes.iter().find(|n| n.description.kind == kind)
    }
}
