//! The ObjectSplat dataflow engine. It knows nothing about 3D: nodes are
//! functions from input folders to output folders; the engine validates graphs,
//! caches results by content, schedules work in parallel (here, or as Slurm jobs)
//! and loads plugins.

pub(crate) mod action;
pub mod check;
pub mod diag;
pub mod exec;
pub mod executor;
pub mod explain;
pub mod graph;
pub mod host;
pub mod job;
pub mod keys;
pub mod node;
pub mod outdir;
pub mod params;
pub use objectsplat_paths as paths;
pub mod plan;
pub mod plugin;
pub mod ports;
pub mod registry;
pub mod report;
pub mod slurm;
pub mod source;
pub mod store;
pub mod syntax;
pub mod testing;
pub mod value;

pub use diag::{Diagnostic, Diagnostics};
pub use node::{
    CheckedInput, Context, DeclaredPorts, InputValue, Node, NodeSpec, Outcome, ParamError,
    PortFolders, PortSpec, ProgressSink, TypeRef,
};
pub use params::{NodeParams, ParamSpec, ParamType, Params};
pub use ports::{Items, NodePorts};
pub use registry::{Origin, Registry};
pub use value::Value;
