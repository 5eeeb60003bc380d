//! The JSON messages of ABI v1, host side (mirrors plugins/sdk/src/protocol.rs).
//! Unknown fields are ignored so that a plugin may send additions that are safe to
//! ignore; anything that changes meaning bumps the ABI version instead.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

#[derive(Debug, Clone, Deserialize)]
pub struct Description {
    pub plugin: String,
    pub version: String,
    pub nodes: Vec<NodeDescription>,
}

#[derive(Debug, Clone, Deserialize)]
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

#[derive(Debug, Clone, Deserialize)]
pub struct PortDescription {
    pub name: String,
    #[serde(rename = "type")]
    pub ty: String,
    #[serde(default)]
    pub doc: String,
    #[serde(default)]
    pub optional: bool,
}

#[derive(Debug, Clone, Deserialize)]
pub struct ParamDescription {
    pub name: String,
    #[serde(rename = "type")]
    pub ty: String,
    #[serde(default)]
    pub default: Option<String>,
    #[serde(default)]
    pub doc: String,
}

#[derive(Debug, Clone, Serialize)]
pub struct InputArg {
    pub dir: String,
    pub items: Option<Vec<(String, String)>>,
}

#[derive(Debug, Clone, Serialize)]
pub struct RunRequest {
    pub kind: String,
    pub job: String,
    pub item: Option<String>,
    pub threads: usize,
    pub scratch: String,
    pub inputs: BTreeMap<String, InputArg>,
    pub outputs: BTreeMap<String, String>,
    pub params: BTreeMap<String, String>,
}

#[derive(Debug, Clone, Copy, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum OutcomeKind {
    Done,
    Skipped,
}

#[derive(Debug, Clone, Deserialize)]
pub struct RunResponse {
    pub outcome: OutcomeKind,
    #[serde(default)]
    pub reason: Option<String>,
    #[serde(default)]
    pub notes: Vec<(String, String)>,
    #[serde(default)]
    pub warnings: Vec<String>,
    #[serde(default)]
    pub forwards: Vec<(String, String)>,
}
