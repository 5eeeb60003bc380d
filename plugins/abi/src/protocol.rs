//! The JSON messages that cross the boundary (ABI v1). docs/plugins.md shows them
//! with examples. Fields a plugin in another language may leave out default when
//! read; anything that changes meaning bumps the ABI version instead.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// What `describe` returns: the plugin's name, its code version and its node kinds.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct Description {
    pub plugin: String,
    /// Bump when any node's output for the same inputs changes: it enters cache keys.
    pub version: String,
    pub nodes: Vec<NodeDescription>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct NodeDescription {
    pub kind: String,
    #[serde(default)]
    pub doc: String,
    #[serde(default)]
    pub inputs: Vec<PortDescription>,
    pub outputs: Vec<PortDescription>,
    #[serde(default)]
    pub params: Vec<ParamDescription>,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct PortDescription {
    pub name: String,
    /// A registry type name (`Image`, `Frames`...) or a collection (`[Component]`).
    #[serde(rename = "type")]
    pub ty: String,
    #[serde(default)]
    pub doc: String,
    #[serde(default)]
    pub optional: bool,
}

#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct ParamDescription {
    pub name: String,
    /// A param type in the engine's text form: `float(0..1)`, `enum(a|b)`, `list(string)`...
    #[serde(rename = "type")]
    pub ty: String,
    /// RON text; absent = required.
    #[serde(default)]
    pub default: Option<String>,
    #[serde(default)]
    pub doc: String,
}

/// One input as the node receives it.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct InputArg {
    /// The artifact folder (for a collection: the folder holding one sub-folder per item).
    pub dir: String,
    /// For a collection input: `[item name, item folder]` in order; absent for one artifact.
    #[serde(default)]
    pub items: Option<Vec<(String, String)>>,
}

/// What the host sends to `run`.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct RunRequest {
    pub kind: String,
    /// The engine's label for this run (node id, plus the item under fan-out).
    pub job: String,
    pub item: Option<String>,
    pub threads: usize,
    pub scratch: String,
    pub inputs: BTreeMap<String, InputArg>,
    /// Output port → empty folder to write the artifact into.
    pub outputs: BTreeMap<String, String>,
    /// Param name → canonical RON text of its validated value.
    pub params: BTreeMap<String, String>,
}

#[derive(Debug, Clone, Copy, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum OutcomeKind {
    Done,
    Skipped,
}

/// What `run` returns on success.
#[derive(Debug, Clone, Serialize, Deserialize, PartialEq)]
pub struct RunResponse {
    pub outcome: OutcomeKind,
    /// Why the node skipped (present when `outcome` is `skipped`).
    #[serde(default)]
    pub reason: Option<String>,
    #[serde(default)]
    pub notes: Vec<(String, String)>,
    #[serde(default)]
    pub warnings: Vec<String>,
    /// `[input port, output port]` pairs: the output is the very same artifact as the input.
    #[serde(default)]
    pub forwards: Vec<(String, String)>,
}
