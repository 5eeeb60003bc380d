//! What `objectsplat check` verifies beyond building a plan: that input files exist,
//! and params checked against upstream values already in the cache (a node's
//! [`crate::Node::check_with_inputs`]).

use crate::diag::Diagnostic;
use crate::exec::cached_outputs;
use crate::graph::parse_graph;
use crate::keys::params_key;
use crate::node::ParamError;
use crate::plan::{Override, Plan, param_error_diag};
use crate::store::{Digest, Store};
use anyhow::Result;
use std::collections::BTreeMap;

/// One error per path param (of the needed nodes) naming a file or folder that does
/// not exist: at the param in the graph, or at the `--set` that gave it.
pub fn missing_input_paths(plan: &Plan, overrides: &[Override]) -> Vec<Diagnostic> {
    let decls = match parse_graph(&plan.source) {
        Ok(d) => d.nodes,
        // The plan was built from this source, so it parses; nothing to point at otherwise.
        Err(d) => return d.0,
    };
    let mut diags = Vec::new();
    for i in plan.needed() {
        let node = &plan.nodes[i];
        let Some(decl) = decls.iter().find(|d| d.id == node.id) else {
            continue;
        };
        for (param, path) in &node.input_paths {
            if path.exists() {
                continue;
            }
            let absolute = |p: &std::path::Path| std::path::absolute(p).unwrap_or(p.to_path_buf());
            let e = ParamError::new(
                param.clone(),
                format!(
                    "{} does not exist (expected an existing file or folder; a relative path is \
                     taken from the graph's folder {})",
                    absolute(path).display(),
                    absolute(&plan.source.dir()).display()
                ),
            );
            diags.push(param_error_diag(&plan.source, decl, overrides, &e));
        }
    }
    diags
}

/// What checking params against cached upstream values found: errors, and for each
/// check that could not be made, why.
#[derive(Debug, Default)]
pub struct InputChecks {
    pub errors: Vec<Diagnostic>,
    pub not_checked: Vec<String>,
}

/// Runs every needed node's [`crate::Node::check_with_inputs`] whose inputs are in the
/// cache, resolving upstream values the way `explain` does (nothing runs).
pub fn with_cached_inputs(
    plan: &Plan,
    store: &Store,
    overrides: &[Override],
) -> Result<InputChecks> {
    let decls = parse_graph(&plan.source).map_err(anyhow::Error::new)?.nodes;
    let mut found = InputChecks::default();
    let mut known: BTreeMap<usize, Option<BTreeMap<String, Digest>>> = BTreeMap::new();
    for i in plan.needed() {
        let node = &plan.nodes[i];
        let mut inputs: BTreeMap<String, Digest> = BTreeMap::new();
        let mut missing_from = None;
        for inp in &node.inputs {
            match known
                .get(&inp.from)
                .and_then(Option::as_ref)
                .and_then(|o| o.get(&inp.from_port))
            {
                Some(d) => {
                    inputs.insert(inp.port.clone(), d.clone());
                }
                None => missing_from = Some(inp),
            }
        }
        let wanted = node.reg.node.checked_inputs();
        for w in &wanted {
            let Some(inp) = node.inputs.iter().find(|x| x.port == w.port) else {
                continue;
            };
            if !inputs.contains_key(&w.port) {
                found.not_checked.push(format!(
                    "node `{}` ({}): {} not checked: its input `{}` (from `{}.{}`) is not in the \
                     cache yet; they are checked when the node runs, or by `check` once `{}` has run",
                    node.id,
                    node.kind,
                    w.what,
                    w.port,
                    plan.nodes[inp.from].id,
                    inp.from_port,
                    plan.nodes[inp.from].id
                ));
            }
        }
        let outputs = if missing_from.is_some() {
            None
        } else {
            // A key that cannot be computed (a file it reads is missing) is no hit.
            params_key(plan, i)
                .ok()
                .and_then(|pk| cached_outputs(plan, store, i, &pk, &inputs))
        };
        let ready: Vec<&crate::CheckedInput> = wanted
            .iter()
            .filter(|w| inputs.contains_key(&w.port))
            .collect();
        if !ready.is_empty()
            && let Some(decl) = decls.iter().find(|d| d.id == node.id)
        {
            let stage = store.staging(&format!("check-{}", node.id))?;
            let mut folders = BTreeMap::new();
            let laid_out = (|| -> Result<()> {
                for w in &ready {
                    let dir = stage.join(&w.port);
                    store.materialize(&inputs[&w.port], &dir, false)?;
                    folders.insert(w.port.clone(), dir);
                }
                Ok(())
            })();
            let result =
                laid_out.and_then(|()| node.reg.node.check_with_inputs(&node.params, &folders));
            let _ = std::fs::remove_dir_all(&stage);
            match result {
                Ok(errors) => found.errors.extend(
                    errors
                        .iter()
                        .map(|e| param_error_diag(&plan.source, decl, overrides, e)),
                ),
                Err(e) => found.not_checked.push(format!(
                    "node `{}` ({}): cannot read its cached inputs to check its params: {e:#}",
                    node.id, node.kind
                )),
            }
        }
        known.insert(i, outputs);
    }
    Ok(found)
}
