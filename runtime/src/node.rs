//! What a node is to the engine: a declared interface (`NodeSpec`) and a `run`
//! function that reads input folders and writes output folders through a `Context`.
//!
//! The engine knows artifact types only by name; every artifact is a folder in the
//! documented encoding of its type (see docs/artifacts.md).

use crate::params::{ParamSpec, ParamType, Params};
use anyhow::{Result, anyhow};
use std::collections::BTreeMap;
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// A port's type: one artifact, or a collection of named items (`[T]`).
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub enum TypeRef {
    One(String),
    List(String),
}

impl TypeRef {
    pub fn parse(text: &str) -> Result<TypeRef, String> {
        let t = text.trim();
        let valid =
            |n: &str| !n.is_empty() && n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_');
        if let Some(inner) = t.strip_prefix('[').and_then(|r| r.strip_suffix(']')) {
            if valid(inner) {
                return Ok(TypeRef::List(inner.to_string()));
            }
        } else if valid(t) {
            return Ok(TypeRef::One(t.to_string()));
        }
        Err(format!(
            "`{t}` is not a type; expected a name like Image or a collection like [Component]"
        ))
    }

    pub fn element(&self) -> &str {
        match self {
            TypeRef::One(n) | TypeRef::List(n) => n,
        }
    }

    pub fn is_list(&self) -> bool {
        matches!(self, TypeRef::List(_))
    }
}

impl fmt::Display for TypeRef {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TypeRef::One(n) => write!(f, "{n}"),
            TypeRef::List(n) => write!(f, "[{n}]"),
        }
    }
}

#[derive(Debug, Clone)]
pub struct PortSpec {
    pub name: String,
    pub ty: TypeRef,
    pub optional: bool,
    pub doc: String,
}

/// The declared interface of a node kind.
#[derive(Debug, Clone)]
pub struct NodeSpec {
    pub kind: String,
    /// Bump when the node's output for the same inputs changes: it is part of every cache key.
    pub version: String,
    pub doc: String,
    pub inputs: Vec<PortSpec>,
    pub outputs: Vec<PortSpec>,
    pub params: Vec<ParamSpec>,
}

impl NodeSpec {
    pub fn new(kind: &str, version: &str) -> NodeSpec {
        NodeSpec {
            kind: kind.into(),
            version: version.into(),
            doc: String::new(),
            inputs: vec![],
            outputs: vec![],
            params: vec![],
        }
    }

    pub fn doc(mut self, doc: &str) -> Self {
        self.doc = doc.into();
        self
    }

    fn port(name: &str, ty: &str, optional: bool, doc: &str) -> PortSpec {
        // Built-in specs are written by us; a typo in a type is a programming error
        // caught by the registry tests, so fall back to a name the registry rejects.
        let ty =
            TypeRef::parse(ty).unwrap_or_else(|_| TypeRef::One(format!("invalid type `{ty}`")));
        PortSpec {
            name: name.into(),
            ty,
            optional,
            doc: doc.into(),
        }
    }

    pub fn input(mut self, name: &str, ty: &str, doc: &str) -> Self {
        self.inputs.push(Self::port(name, ty, false, doc));
        self
    }

    pub fn optional_input(mut self, name: &str, ty: &str, doc: &str) -> Self {
        self.inputs.push(Self::port(name, ty, true, doc));
        self
    }

    pub fn output(mut self, name: &str, ty: &str, doc: &str) -> Self {
        self.outputs.push(Self::port(name, ty, false, doc));
        self
    }

    /// Every port of a [`crate::node_ports!`] type.
    pub fn ports<P: crate::ports::NodePorts>(self) -> Self {
        P::declare(self)
    }

    /// Every parameter of a [`crate::node_params!`] type.
    pub fn params<P: crate::params::NodeParams>(self) -> Self {
        P::declare(self)
    }

    /// A parameter with a default given as RON text (`None` = required).
    pub fn param(mut self, name: &str, ty: ParamType, default: Option<&str>, doc: &str) -> Self {
        self.params.push(ParamSpec {
            name: name.into(),
            ty,
            default: default.map(str::to_string),
            doc: doc.into(),
        });
        self
    }

    pub fn input_port(&self, name: &str) -> Option<&PortSpec> {
        self.inputs.iter().find(|p| p.name == name)
    }

    pub fn output_port(&self, name: &str) -> Option<&PortSpec> {
        self.outputs.iter().find(|p| p.name == name)
    }

    pub fn param_spec(&self, name: &str) -> Option<&ParamSpec> {
        self.params.iter().find(|p| p.name == name)
    }
}

/// How a run ended when it did not fail.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    Done,
    /// Nothing to do; outputs not written (or forwarded from inputs) — the reason is reported.
    Skipped(String),
}

/// Ports a node's params declare (for kinds whose ports the graph gives, like `command`).
#[derive(Debug, Clone)]
pub struct DeclaredPorts {
    pub inputs: Vec<PortSpec>,
    pub outputs: Vec<PortSpec>,
    /// The params that declare the inputs and the outputs: errors about a port point there.
    pub inputs_param: String,
    pub outputs_param: String,
}

/// A param value the node cannot use, found before anything runs.
#[derive(Debug, Clone)]
pub struct ParamError {
    pub param: String,
    /// Where inside the value, for a problem in a nested struct, map or list: field
    /// names, map keys and list indices (`["1", "target"]` for the second item's
    /// `target`); empty for the whole value. Errors point at that place in the graph.
    pub field: Vec<String>,
    pub message: String,
}

impl ParamError {
    pub fn new(param: impl Into<String>, message: impl Into<String>) -> ParamError {
        ParamError {
            param: param.into(),
            field: Vec::new(),
            message: message.into(),
        }
    }

    /// The same error, about `field` inside the param's value.
    pub fn at<S: ToString>(mut self, field: impl IntoIterator<Item = S>) -> ParamError {
        self.field = field.into_iter().map(|s| s.to_string()).collect();
        self
    }

    /// `schedule.patience`, `edits[1].target`: the field as a path below the param.
    pub fn path(&self) -> String {
        let mut s = self.param.clone();
        for step in &self.field {
            if step.parse::<usize>().is_ok() {
                s.push_str(&format!("[{step}]"));
            } else {
                s.push('.');
                s.push_str(step);
            }
        }
        s
    }
}

/// An input a node's params can be checked against before the node runs (edit targets
/// against a scene's labels), when its value is already in the cache.
#[derive(Debug, Clone)]
pub struct CheckedInput {
    pub port: String,
    /// What is checked, for the line saying it could not be: "edit targets against the
    /// scene's labels".
    pub what: String,
}

/// A node kind. Implementations must be deterministic: the same inputs and params
/// must give byte-identical outputs (that is what makes early cutoff work).
pub trait Node: Send + Sync {
    fn spec(&self) -> NodeSpec;
    fn run(&self, ctx: &mut Context) -> Result<Outcome>;

    /// The ports of one node of this kind given its checked params, when its params
    /// declare them; `None` (the default) keeps the ports of `spec()`.
    fn declared_ports(&self, _params: &Params) -> Result<Option<DeclaredPorts>, ParamError> {
        Ok(None)
    }

    /// Files and folders a run will read that are neither inputs nor named by a
    /// `path` param (those are fingerprinted already): an image folder found beside
    /// a model, the images a JSON lists, a script named in a command line. Called
    /// with the normalised params before the cache is consulted; their fingerprints
    /// ([`crate::store::Store::fingerprint_reads`]) enter the run's cache key, so
    /// replacing one of them reruns the node. A node that reads files it cannot name
    /// in advance must say so in its doc.
    fn reads(&self, _params: &Params) -> Result<Vec<PathBuf>> {
        Ok(Vec::new())
    }

    /// The versions of the external programs a run will start (`COLMAP 3.8 (Commit
    /// Unknown on Unknown without CUDA)`), one line each. They enter the run's cache
    /// key, so installing another version reruns the node (and `explain` says so)
    /// while the node's own code version stays. Called before the cache is consulted,
    /// on every plan: keep it cheap, and describe a missing program ("colmap: not
    /// found") rather than fail, leaving `run` to report it.
    fn tool_versions(&self, _params: &Params) -> Vec<String> {
        Vec::new()
    }

    /// Checks params beyond their declared types (unknown fields inside a `ron`
    /// value, values that contradict each other), before anything runs: every plan
    /// (`check`, `run`, `explain`) calls it. Point nested problems at their field
    /// ([`ParamError::at`]).
    fn check_params(&self, _params: &Params) -> Vec<ParamError> {
        Vec::new()
    }

    /// Inputs whose value lets params be checked further ([`Node::check_with_inputs`]).
    fn checked_inputs(&self) -> Vec<CheckedInput> {
        Vec::new()
    }

    /// Checks params against the values of [`Node::checked_inputs`] (folders, laid out
    /// as `ctx.input` gives them); `objectsplat check` calls it when those values are
    /// in the cache. An `Err` means the input could not be read, not a bad param.
    fn check_with_inputs(
        &self,
        _params: &Params,
        _inputs: &BTreeMap<String, PathBuf>,
    ) -> Result<Vec<ParamError>> {
        Ok(Vec::new())
    }
}

pub use objectsplat_plugin_abi::folders::{InputValue, PortFolders};

/// Receives progress from running nodes (the CLI draws bars from it): `done` of `total`
/// units of the kind of work `what` names (see [`Context::progress`]).
pub trait ProgressSink: Send + Sync {
    fn progress(&self, job: &str, done: u64, total: u64, what: &str);
}

pub struct NoProgress;
impl ProgressSink for NoProgress {
    fn progress(&self, _: &str, _: u64, _: u64, _: &str) {}
}

/// How many threads a job may use.
#[derive(Clone, Copy)]
pub(crate) enum Threads<'a> {
    Fixed(usize),
    /// `jobs` workers shared by the `active` jobs.
    Share {
        jobs: usize,
        active: &'a AtomicUsize,
    },
}

/// Everything a running node may touch. Nodes write only into their output folders
/// and their scratch folder; both live inside the cache's staging area.
pub struct Context<'a> {
    pub(crate) job: String,
    pub(crate) item: Option<String>,
    pub(crate) folders: PortFolders,
    pub(crate) forwarded: BTreeMap<String, String>,
    pub(crate) params: &'a Params,
    pub(crate) notes: Vec<(String, String)>,
    pub(crate) measurements: BTreeMap<String, serde_json::Value>,
    pub(crate) warnings: Vec<String>,
    pub(crate) threads: Threads<'a>,
    pub(crate) scratch: PathBuf,
    pub(crate) resume: PathBuf,
    pub(crate) progress: &'a dyn ProgressSink,
    pub(crate) cancel: &'a AtomicBool,
}

impl<'a> Context<'a> {
    /// The folder of a single-artifact input (or of the item, under fan-out).
    pub fn input(&self, port: &str) -> Result<&Path> {
        self.folders.input(port)
    }

    /// `None` when an optional input is not wired.
    pub fn input_opt(&self, port: &str) -> Option<&Path> {
        self.folders.input_opt(port)
    }

    /// The items of a collection input, in order: (item name, folder).
    pub fn input_items(&self, port: &str) -> Result<&[(String, PathBuf)]> {
        self.folders.input_items(port)
    }

    /// The empty folder to write an output into. For a collection output (`[T]`),
    /// write one sub-folder per item, named by the item.
    pub fn output(&self, port: &str) -> Result<PathBuf> {
        self.folders.output(port)
    }

    /// Makes an output the very same artifact as an input (no copy), e.g. when a
    /// node passes data through unchanged.
    pub fn forward(&mut self, input: &str, output: &str) -> Result<()> {
        self.folders.check_forward(input, output)?;
        self.forwarded.insert(output.to_string(), input.to_string());
        Ok(())
    }

    pub fn params(&self) -> &Params {
        self.params
    }

    pub fn param<T: serde::de::DeserializeOwned>(&self, name: &str) -> Result<T> {
        self.params.get(name)
    }

    /// All parameters as the node's declared type (see [`crate::node_params!`]).
    pub fn params_as<P: crate::params::NodeParams>(&self) -> Result<P> {
        P::read(self.params)
    }

    /// Every port's folder as the node's declared type (see [`crate::node_ports!`]).
    pub fn ports_as<P: crate::ports::NodePorts>(&self) -> Result<P> {
        P::read(self)
    }

    /// The item name when the node runs once per item of a fanned-out input.
    pub fn item(&self) -> Option<&str> {
        self.item.as_deref()
    }

    /// Worker threads this run may use: the scheduler's workers over the jobs
    /// running when it asks (at least 1), unless the run fixed a count per job.
    /// Asked again later, a job started beside a short one (an item passed
    /// through) gets the cores that one freed.
    pub fn threads(&self) -> usize {
        match self.threads {
            Threads::Fixed(n) => n,
            Threads::Share { jobs, active } => (jobs / active.load(Ordering::SeqCst).max(1)).max(1),
        }
    }

    /// A private scratch folder, deleted after the run.
    pub fn scratch(&self) -> &Path {
        &self.scratch
    }

    /// A folder kept across runs of this very action (same cache key) until one
    /// of them succeeds, then deleted: a long node saves its progress here so
    /// that a run killed half-way resumes where it stopped. Created on demand
    /// by the node; whatever it holds must let the node finish with the same
    /// outputs an uninterrupted run gives.
    pub fn resume(&self) -> &Path {
        &self.resume
    }

    /// A fact for the run report (e.g. `backend` = `cpu (no GPU adapter)`).
    pub fn note(&mut self, key: &str, value: impl fmt::Display) {
        self.notes.push((key.to_string(), value.to_string()));
    }

    /// What this run measured about itself and must not write into an output (a timing
    /// curve, a peak memory): outputs may depend only on inputs, or a recomputed item
    /// would change its digest and rerun everything below it. A measurement is kept with
    /// the action record, so a cache hit reports the producing run's, and appears in the
    /// run report (`--json`, `OUT/run.json`) under the node's or item's `measurements`;
    /// it never enters a key or a digest. A second value under one name replaces the first.
    pub fn measurement(&mut self, name: &str, value: impl serde::Serialize) -> Result<()> {
        let value = serde_json::to_value(value)
            .map_err(|e| anyhow!("measurement `{name}` is not representable as JSON: {e}"))?;
        self.measurements.insert(name.to_string(), value);
        Ok(())
    }

    pub fn warn(&mut self, message: impl fmt::Display) {
        self.warnings.push(message.to_string());
    }

    /// `done` of `total` units of one kind of work, `what` naming the kind (`training`,
    /// `rendering`): the terminal's whole-run line sums each kind's units over the run's
    /// jobs to estimate what is left, so `what` stays the same for the units of one kind
    /// (no frame or item names in it).
    pub fn progress(&self, done: u64, total: u64, what: &str) {
        self.progress.progress(&self.job, done, total, what);
    }

    /// True once the run was interrupted; long loops should return early with an error.
    pub fn cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }
}
