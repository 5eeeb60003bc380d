//! Running one node outside a graph, for node crates' own tests.

use crate::node::{Context, InputValue, NoProgress, Node, Outcome, PortFolders};
use crate::params::Params;
use crate::syntax;
use crate::value::Value;
use anyhow::{Context as _, Result, anyhow, bail};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

/// The result of [`run_node`].
pub struct NodeRun {
    pub outcome: Outcome,
    /// Output folders by port (forwarded outputs point at the input folder).
    pub outputs: BTreeMap<String, PathBuf>,
    pub notes: Vec<(String, String)>,
    /// What the run measured about itself ([`Context::measurement`]).
    pub measurements: BTreeMap<String, serde_json::Value>,
    pub warnings: Vec<String>,
}

/// Runs `node` with `inputs` (port → folder; a collection input is a folder with
/// one sub-folder per item) and `params` as RON struct text (e.g. `(radius: 3)`),
/// writing outputs under `out_dir/<port>/`. Params missing from `params` take the
/// spec's defaults; values are checked against the spec as in a graph.
pub fn run_node(
    node: &dyn Node,
    inputs: &[(&str, &Path)],
    params: &str,
    out_dir: &Path,
    item: Option<&str>,
) -> Result<NodeRun> {
    let spec = node.spec();
    let parsed = syntax::parse(params)
        .map_err(|e| anyhow!("params {params:?}: {}", e.message))?
        .to_value();
    let given: Vec<(String, Value)> = match parsed {
        Value::Struct(_, f) => f,
        Value::Unit => vec![],
        other => bail!("params must be a struct, found {}", other.shape()),
    };
    let mut values = BTreeMap::new();
    for (k, _) in &given {
        if spec.param_spec(k).is_none() {
            bail!("node {} has no param `{k}`", spec.kind);
        }
    }
    for ps in &spec.params {
        let v = match given.iter().find(|(k, _)| *k == ps.name) {
            Some((_, v)) => v.clone(),
            None => match &ps.default {
                Some(d) => syntax::parse(d)
                    .map_err(|e| anyhow!("default of {}: {}", ps.name, e.message))?
                    .to_value(),
                None => bail!("required param `{}` missing", ps.name),
            },
        };
        let v = ps
            .ty
            .check(&v)
            .map_err(|e| anyhow!("param `{}`: {e}", ps.name))?;
        values.insert(ps.name.clone(), v);
    }
    let params = Params::new(values);
    let mut spec = spec;
    if let Some(ports) = node
        .declared_ports(&params)
        .map_err(|e| anyhow!("param `{}`: {}", e.param, e.message))?
    {
        spec.inputs = ports.inputs;
        spec.outputs = ports.outputs;
    }
    let mut input_map = BTreeMap::new();
    for (port, path) in inputs {
        let ps = spec
            .input_port(port)
            .ok_or_else(|| anyhow!("node {} has no input `{port}`", spec.kind))?;
        let value = if ps.ty.is_list() {
            let mut items: Vec<(String, PathBuf)> = std::fs::read_dir(path)
                .with_context(|| format!("{}: cannot list collection", path.display()))?
                .filter_map(|e| e.ok())
                .filter(|e| e.path().is_dir())
                .map(|e| (e.file_name().to_string_lossy().into_owned(), e.path()))
                .collect();
            items.sort();
            InputValue::Items {
                dir: path.to_path_buf(),
                items,
            }
        } else {
            InputValue::One(path.to_path_buf())
        };
        input_map.insert(port.to_string(), value);
    }
    let mut outputs = BTreeMap::new();
    for o in &spec.outputs {
        let d = out_dir.join(&o.name);
        std::fs::create_dir_all(&d)?;
        outputs.insert(o.name.clone(), d);
    }
    let scratch = out_dir.join(".scratch");
    std::fs::create_dir_all(&scratch)?;
    let cancel = AtomicBool::new(false);
    let mut ctx = Context {
        job: spec.kind.clone(),
        item: item.map(str::to_string),
        folders: PortFolders {
            inputs: input_map,
            outputs: outputs.clone(),
        },
        forwarded: BTreeMap::new(),
        params: &params,
        notes: vec![],
        measurements: BTreeMap::new(),
        warnings: vec![],
        threads: crate::node::Threads::Fixed(2),
        scratch: scratch.clone(),
        resume: out_dir.join(".resume"),
        progress: &NoProgress,
        cancel: &cancel,
    };
    let outcome = node.run(&mut ctx)?;
    for (out, inp) in &ctx.forwarded {
        if let Some(p) = ctx.input_opt(inp) {
            outputs.insert(out.clone(), p.to_path_buf());
        }
    }
    let _ = std::fs::remove_dir_all(&scratch);
    Ok(NodeRun {
        outcome,
        outputs,
        notes: ctx.notes,
        measurements: ctx.measurements,
        warnings: ctx.warnings,
    })
}
