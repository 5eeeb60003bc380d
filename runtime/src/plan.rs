//! Validation: graph declarations + registry → an executable plan (a checked DAG).

use crate::diag::{Diagnostic, Diagnostics, did_you_mean, similar};
use crate::graph::{GraphDecl, GraphSource, NodeDecl, parse_graph};
use crate::node::{ParamError, TypeRef};
use crate::params::{ParamType, Params};
use crate::registry::{Registered, Registry};
use crate::slurm::SlurmSettings;
use crate::syntax::{self, SKind, Span, Spanned};
use crate::value::Value;
use petgraph::algo::toposort;
use petgraph::graph::{DiGraph, NodeIndex};
use std::collections::{BTreeMap, HashMap};
use std::path::PathBuf;

/// `--set NODE.PARAM=VALUE`, parsed.
#[derive(Debug, Clone)]
pub struct Override {
    pub node: String,
    pub param: String,
    pub value: Value,
    pub text: String,
    /// The value as typed. A bare word (`dense`) or text that is not RON
    /// (`data/scene.json`) is taken as this string when the param takes a string
    /// (string, enum, path; optional or not).
    pub raw: String,
    /// Why `raw` is not RON, when it is not (then `value` is `raw` as a string).
    pub not_ron: Option<String>,
}

impl Override {
    pub fn parse(arg: &str) -> Result<Override, Diagnostic> {
        let text = format!("--set {arg}");
        let (lhs, rhs) = arg
            .split_once('=')
            .ok_or_else(|| Diagnostic::argument(&text, "expected NODE.PARAM=VALUE"))?;
        let (node, param) = lhs
            .split_once('.')
            .filter(|(n, p)| !n.is_empty() && !p.is_empty())
            .ok_or_else(|| Diagnostic::argument(&text, "expected NODE.PARAM=VALUE"))?;
        let (value, not_ron) = match syntax::parse(rhs) {
            Ok(v) => (v.to_value(), None),
            Err(e) => (Value::Str(rhs.to_string()), Some(e.message)),
        };
        Ok(Override {
            node: node.into(),
            param: param.into(),
            value,
            text,
            raw: rhs.to_string(),
            not_ron,
        })
    }

    /// The value for a param of type `ty`: the RON value, or the text as typed when
    /// it is a bare word or not RON and `ty` takes a string. The caller checks it.
    fn value_for(&self, ty: &ParamType) -> Result<Value, String> {
        fn takes_string(ty: &ParamType) -> bool {
            match ty {
                ParamType::Str | ParamType::Enum(_) | ParamType::Path | ParamType::RelPath => true,
                ParamType::Optional(inner) => takes_string(inner),
                _ => false,
            }
        }
        let bare = self.not_ron.is_some() || matches!(self.value, Value::Ident(_));
        if self.not_ron.is_none() && ty.check(&self.value).is_ok() {
            return Ok(self.value.clone());
        }
        if bare && takes_string(ty) {
            return Ok(Value::Str(self.raw.clone()));
        }
        match &self.not_ron {
            Some(why) => Err(format!(
                "value is not RON: {why} (a bare word is read as a string only where the param \
                 takes one; otherwise write RON, e.g. 3, 0.5, true, [1, 2], \"text\")"
            )),
            None => Ok(self.value.clone()),
        }
    }
}

#[derive(Debug, Clone)]
pub struct PlanInput {
    pub port: String,
    pub from: usize,
    pub from_port: String,
    pub each: bool,
}

#[derive(Clone)]
pub struct PlanNode {
    pub id: String,
    pub kind: String,
    pub reg: Registered,
    pub params: Params,
    /// Path params (absolute) whose content enters the cache key.
    pub input_paths: Vec<(String, PathBuf)>,
    pub inputs: Vec<PlanInput>,
    /// Runs once per item of its `each` input.
    pub fans_out: bool,
    /// Output types as consumers see them (lifted to collections under fan-out).
    pub outputs: BTreeMap<String, TypeRef>,
    /// The node's `slurm: (...)` field, if it has one.
    pub slurm: Option<SlurmSettings>,
}

#[derive(Clone)]
pub struct Plan {
    pub source: GraphSource,
    pub nodes: Vec<PlanNode>,
    /// Topological order (indices into `nodes`).
    pub order: Vec<usize>,
    pub targets: Vec<usize>,
    pub plugins: Vec<PathBuf>,
    /// The graph's `slurm: (...)` field (defaults for every Slurm job).
    pub slurm: SlurmSettings,
}

impl Plan {
    pub fn index(&self, id: &str) -> Option<usize> {
        self.nodes.iter().position(|n| n.id == id)
    }

    /// Indices of the targets and all their ancestors, in topological order.
    pub fn needed(&self) -> Vec<usize> {
        let mut need = vec![false; self.nodes.len()];
        let mut stack: Vec<usize> = self.targets.clone();
        while let Some(i) = stack.pop() {
            if !need[i] {
                need[i] = true;
                stack.extend(self.nodes[i].inputs.iter().map(|inp| inp.from));
            }
        }
        self.order.iter().copied().filter(|&i| need[i]).collect()
    }
}

/// Reads only the `plugins` list (plugins must be loaded before kinds are checked).
pub fn declared_plugins(source: &GraphSource) -> Result<Vec<(PathBuf, Span)>, Diagnostics> {
    let decl = parse_graph(source)?;
    Ok(decl
        .plugins
        .iter()
        .map(|(p, s)| (source.dir().join(p), *s))
        .collect())
}

pub fn build_plan(
    source: &GraphSource,
    registry: &Registry,
    overrides: &[Override],
    targets: &[String],
) -> Result<Plan, Diagnostics> {
    let decl = parse_graph(source)?;
    check(source, decl, registry, overrides, targets)
}

fn check(
    src: &GraphSource,
    decl: GraphDecl,
    registry: &Registry,
    overrides: &[Override],
    cli_targets: &[String],
) -> Result<Plan, Diagnostics> {
    let mut diags = Vec::new();
    let ids: HashMap<&str, usize> = decl
        .nodes
        .iter()
        .enumerate()
        .map(|(i, n)| (n.id.as_str(), i))
        .collect();

    // Overrides must name a node and a param that exist.
    for o in overrides {
        match ids.get(o.node.as_str()) {
            None => diags.push(Diagnostic::argument(
                &o.text,
                format!(
                    "no node `{}` in {}{}",
                    o.node,
                    src.path.display(),
                    did_you_mean(&similar(&o.node, ids.keys().copied()))
                ),
            )),
            Some(&i) => {
                if let Some(reg) = registry.get(&decl.nodes[i].kind)
                    && reg.spec.param_spec(&o.param).is_none()
                {
                    let names: Vec<&str> =
                        reg.spec.params.iter().map(|p| p.name.as_str()).collect();
                    diags.push(Diagnostic::argument(
                        &o.text,
                        format!(
                            "node `{}` ({}) has no param `{}`; it has {}",
                            o.node,
                            reg.spec.kind,
                            o.param,
                            list_or_none(&names)
                        ),
                    ));
                }
            }
        }
    }

    // Kinds and params.
    let mut nodes: Vec<Option<PlanNode>> = Vec::new();
    for n in &decl.nodes {
        let Some(reg) = registry.get(&n.kind) else {
            let hint = did_you_mean(&registry.similar_kinds(&n.kind));
            diags.push(src.diag(
                n.kind_span,
                format!(
                    "unknown node kind {:?}{hint} (`objectsplat nodes` lists every kind)",
                    n.kind
                ),
            ));
            nodes.push(None);
            continue;
        };
        let checked = check_params(src, n, reg, overrides).and_then(|(params, paths)| {
            Ok((
                declared_ports(src, n, reg, registry, &params)?,
                params,
                paths,
                slurm_settings(src, n.slurm.as_ref(), Some(&n.id))?,
            ))
        });
        match checked {
            Ok((reg, params, input_paths, slurm)) => nodes.push(Some(PlanNode {
                id: n.id.clone(),
                kind: n.kind.clone(),
                reg,
                params,
                input_paths,
                inputs: vec![],
                fans_out: n.inputs.iter().any(|i| i.source.each),
                outputs: BTreeMap::new(),
                slurm,
            })),
            Err(mut d) => {
                diags.append(&mut d);
                nodes.push(None);
            }
        }
    }

    // Wiring: ports exist, sources exist, required inputs present.
    let mut dag = DiGraph::<usize, ()>::new();
    let idx: Vec<NodeIndex> = (0..decl.nodes.len()).map(|i| dag.add_node(i)).collect();
    for (i, n) in decl.nodes.iter().enumerate() {
        let Some(spec) = nodes[i].as_ref().map(|p| p.reg.spec.clone()) else {
            continue;
        };
        let eachs: Vec<_> = n.inputs.iter().filter(|x| x.source.each).collect();
        if eachs.len() > 1 {
            diags.push(src.diag(
                eachs[1].source.span,
                format!("node {:?}: only one input may use each(...)", n.id),
            ));
        }
        for inp in &n.inputs {
            if spec.input_port(&inp.port).is_none() {
                let names = spec.inputs.iter().map(|p| p.name.as_str());
                let what = ("input port", "inputs");
                let message = no_such(&n.id, &n.kind, what, &inp.port, names);
                diags.push(src.diag(inp.port_span, message));
                continue;
            }
            let Some(&from) = ids.get(inp.source.node.as_str()) else {
                diags.push(src.diag(
                    inp.source.span,
                    format!(
                        "node {:?} input `{}` refers to node {:?}, which does not exist{}",
                        n.id,
                        inp.port,
                        inp.source.node,
                        did_you_mean(&similar(&inp.source.node, ids.keys().copied()))
                    ),
                ));
                continue;
            };
            dag.add_edge(idx[from], idx[i], ());
            if let Some(p) = nodes[i].as_mut() {
                p.inputs.push(PlanInput {
                    port: inp.port.clone(),
                    from,
                    from_port: inp.source.port.clone(),
                    each: inp.source.each,
                });
            }
        }
        for port in spec.inputs.iter().filter(|p| !p.optional) {
            if !n.inputs.iter().any(|x| x.port == port.name) {
                diags.push(src.diag(
                    n.span,
                    format!(
                        "node {:?} ({}) is missing required input `{}` (type {}); expected `inputs: ({}: \"node.port\")`",
                        n.id, n.kind, port.name, port.ty, port.name
                    ),
                ));
            }
        }
    }

    // Cycles.
    let order = match toposort(&dag, None) {
        Ok(o) => o.into_iter().map(|ix| dag[ix]).collect::<Vec<_>>(),
        Err(cycle) => {
            let at = dag[cycle.node_id()];
            let n = &decl.nodes[at];
            diags.push(src.diag(
                n.id_span,
                format!(
                    "node {:?} is part of a cycle; a graph must be acyclic",
                    n.id
                ),
            ));
            return Err(Diagnostics(diags));
        }
    };

    // Types, in topological order so sources' lifted output types are known.
    for &i in &order {
        let Some(node) = nodes[i].as_ref() else {
            continue;
        };
        let spec = node.reg.spec.clone();
        let mut outputs = BTreeMap::new();
        for out in &spec.outputs {
            let ty = match (&out.ty, node.fans_out) {
                (TypeRef::One(t), true) => TypeRef::List(t.clone()),
                (TypeRef::List(_), true) => {
                    diags.push(src.diag(
                        decl.nodes[i].kind_span,
                        format!(
                            "node {:?} uses each(...) but its output `{}` is already a collection ({}); collections of collections are not supported",
                            node.id, out.name, out.ty
                        ),
                    ));
                    out.ty.clone()
                }
                (t, false) => t.clone(),
            };
            outputs.insert(out.name.clone(), ty);
        }
        for inp_decl in &decl.nodes[i].inputs {
            let Some(port) = spec.input_port(&inp_decl.port) else {
                continue;
            };
            let Some(&from) = ids.get(inp_decl.source.node.as_str()) else {
                continue;
            };
            let Some(src_node) = nodes[from].as_ref() else {
                continue;
            };
            let Some(src_ty) = src_node.outputs.get(&inp_decl.source.port) else {
                let names = src_node.outputs.keys().map(String::as_str);
                let what = ("output port", "outputs");
                let port = &inp_decl.source.port;
                let message = no_such(&src_node.id, &src_node.kind, what, port, names);
                diags.push(src.diag(inp_decl.source.span, message));
                continue;
            };
            let ok = match (&port.ty, inp_decl.source.each) {
                (TypeRef::One(t), true) => *src_ty == TypeRef::List(t.clone()),
                (TypeRef::List(_), true) => false,
                (t, false) => src_ty == t,
            };
            if !ok {
                let wanted = if inp_decl.source.each {
                    format!("each(...) over a collection [{}]", port.ty.element())
                } else {
                    port.ty.to_string()
                };
                let mut hint = String::new();
                if let (TypeRef::One(t), TypeRef::List(s), false) =
                    (&port.ty, src_ty, inp_decl.source.each)
                    && t == s
                {
                    hint = format!(
                        "; to run once per item write each(\"{}.{}\")",
                        inp_decl.source.node, inp_decl.source.port
                    );
                }
                diags.push(src.diag(
                    inp_decl.source.span,
                    format!(
                        "type mismatch: node {:?} input `{}` expects {wanted}, but \"{}.{}\" is {src_ty}{hint}",
                        node.id, inp_decl.port, inp_decl.source.node, inp_decl.source.port
                    ),
                ));
            }
        }
        if let Some(n) = nodes[i].as_mut() {
            n.outputs = outputs;
        }
    }

    // Targets: the command line wins over the graph's list; default = every sink.
    let mut targets = Vec::new();
    if !cli_targets.is_empty() {
        for t in cli_targets {
            match ids.get(t.as_str()) {
                Some(&i) => targets.push(i),
                None => diags.push(Diagnostic::argument(
                    &format!("--target {t}"),
                    format!(
                        "no node `{t}` in {}{}",
                        src.path.display(),
                        did_you_mean(&similar(t, ids.keys().copied()))
                    ),
                )),
            }
        }
    } else if !decl.targets.is_empty() {
        for (t, span) in &decl.targets {
            match ids.get(t.as_str()) {
                Some(&i) => targets.push(i),
                None => diags.push(src.diag(
                    *span,
                    format!(
                        "target {t:?} is not a node of this graph{}",
                        did_you_mean(&similar(t, ids.keys().copied()))
                    ),
                )),
            }
        }
    } else {
        targets = (0..decl.nodes.len())
            .filter(|&i| dag.neighbors(idx[i]).next().is_none())
            .collect();
    }

    let slurm = slurm_settings(src, decl.slurm.as_ref(), None)
        .unwrap_or_else(|mut d| {
            diags.append(&mut d);
            None
        })
        .unwrap_or_default();
    if !diags.is_empty() {
        return Err(Diagnostics(diags));
    }
    let nodes: Vec<PlanNode> = nodes
        .into_iter()
        .map(|n| n.expect("every node checked without a diagnostic"))
        .collect();
    Ok(Plan {
        source: src.clone(),
        nodes,
        order,
        targets,
        plugins: decl
            .plugins
            .iter()
            .map(|(p, _)| src.dir().join(p))
            .collect(),
        slurm,
    })
}

/// A node of `kind` has no port or param `name` among `names`; `what` names the thing,
/// singular and plural (`("param", "params")`).
fn no_such<'a>(
    node: &str,
    kind: &str,
    (what, plural): (&str, &str),
    name: &str,
    names: impl Iterator<Item = &'a str>,
) -> String {
    let names: Vec<&str> = names.collect();
    format!(
        "node {node:?} ({kind}) has no {what} `{name}`{}; its {plural} are {}",
        did_you_mean(&similar(name, names.iter().copied())),
        list_or_none(&names)
    )
}

fn list_or_none(names: &[&str]) -> String {
    if names.is_empty() {
        "none".into()
    } else {
        names
            .iter()
            .map(|n| format!("`{n}`"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

type CheckedParams = (Params, Vec<(String, PathBuf)>);

/// The node's registration with the ports its params declare, for kinds that declare
/// ports in the graph (`Node::declared_ports`); other kinds keep their spec.
fn declared_ports(
    src: &GraphSource,
    n: &NodeDecl,
    reg: &Registered,
    registry: &Registry,
    params: &Params,
) -> Result<Registered, Vec<Diagnostic>> {
    let at = |param: &str| {
        n.params
            .iter()
            .find(|p| p.name == param)
            .map_or(n.span, |p| p.value.span)
    };
    let ports = match reg.node.declared_ports(params) {
        Ok(None) => return Ok(reg.clone()),
        Ok(Some(ports)) => ports,
        Err(e) => {
            return Err(vec![src.diag(
                at(&e.param),
                format!(
                    "node {:?} ({}) param `{}`: {}",
                    n.id, n.kind, e.param, e.message
                ),
            )]);
        }
    };
    let mut diags = Vec::new();
    for (list, param) in [
        (&ports.inputs, &ports.inputs_param),
        (&ports.outputs, &ports.outputs_param),
    ] {
        for p in list {
            let t = p.ty.element();
            if !registry.has_type(t) {
                let hint = did_you_mean(&similar(t, registry.types().map(|t| t.name.as_str())));
                diags.push(src.diag(
                    at(param),
                    format!(
                        "node {:?} ({}) declares port `{}` of unknown type `{t}`{hint}",
                        n.id, n.kind, p.name
                    ),
                ));
            }
        }
    }
    if !diags.is_empty() {
        return Err(diags);
    }
    let mut reg = reg.clone();
    let spec = std::sync::Arc::make_mut(&mut reg.spec);
    spec.inputs = ports.inputs;
    spec.outputs = ports.outputs;
    Ok(reg)
}

fn check_params(
    src: &GraphSource,
    n: &NodeDecl,
    reg: &Registered,
    overrides: &[Override],
) -> Result<CheckedParams, Vec<Diagnostic>> {
    let spec = &reg.spec;
    let mut diags = Vec::new();
    let mut values = BTreeMap::new();
    let mut input_paths = Vec::new();
    for p in &n.params {
        if spec.param_spec(&p.name).is_none() {
            let names = spec.params.iter().map(|p| p.name.as_str());
            let message = no_such(&n.id, &n.kind, ("param", "params"), &p.name, names);
            diags.push(src.diag(p.name_span, message));
        }
    }
    for ps in &spec.params {
        let over = overrides
            .iter()
            .rev()
            .find(|o| o.node == n.id && o.param == ps.name);
        let declared = n.params.iter().find(|p| p.name == ps.name);
        let (value, report): (Value, Box<dyn Fn(String) -> Diagnostic>) = match (over, declared) {
            (Some(o), _) => {
                let text = o.text.clone();
                let report: Box<dyn Fn(String) -> Diagnostic> =
                    Box::new(move |m| Diagnostic::argument(&text, m));
                match o.value_for(&ps.ty) {
                    Ok(v) => (v, report),
                    Err(msg) => {
                        diags.push(report(format!(
                            "node {:?} param `{}`: {msg} (expected {})",
                            n.id,
                            ps.name,
                            ps.ty.describe()
                        )));
                        continue;
                    }
                }
            }
            (None, Some(d)) => {
                let span = d.value.span;
                (d.value.to_value(), Box::new(move |m| src.diag(span, m)))
            }
            (None, None) => match &ps.default {
                Some(def) => match syntax::parse(def) {
                    Ok(v) => (
                        v.to_value(),
                        Box::new(|m| Diagnostic::argument("(default)", m)),
                    ),
                    Err(e) => {
                        diags.push(src.diag(
                            n.kind_span,
                            format!("default of `{}` does not parse: {}", ps.name, e.message),
                        ));
                        continue;
                    }
                },
                None => {
                    diags.push(src.diag(
                        n.span,
                        format!(
                            "node {:?} ({}) is missing required param `{}` ({}); expected `params: ({}: ...)`",
                            n.id,
                            n.kind,
                            ps.name,
                            ps.ty.describe(),
                            ps.name
                        ),
                    ));
                    continue;
                }
            },
        };
        match ps.ty.check(&value) {
            Ok(normalised) => {
                let normalised = if is_path_type(&ps.ty) {
                    resolve_paths(normalised, &src.dir(), &ps.name, &mut input_paths)
                } else {
                    normalised
                };
                values.insert(ps.name.clone(), normalised);
            }
            Err(msg) => diags.push(report(format!(
                "node {:?} param `{}`: {msg} (expected {})",
                n.id,
                ps.name,
                ps.ty.describe()
            ))),
        }
    }
    if !diags.is_empty() {
        return Err(diags);
    }
    let params = Params::new(values);
    let diags: Vec<Diagnostic> = reg
        .node
        .check_params(&params)
        .iter()
        .map(|e| param_error_diag(src, n, overrides, e))
        .collect();
    if diags.is_empty() {
        Ok((params, input_paths))
    } else {
        Err(diags)
    }
}

/// Makes graph-relative path params absolute and records them for fingerprinting.
fn resolve_paths(
    v: Value,
    dir: &std::path::Path,
    name: &str,
    out: &mut Vec<(String, PathBuf)>,
) -> Value {
    match v {
        Value::Str(s) => {
            let abs = dir.join(&s);
            out.push((name.to_string(), abs.clone()));
            Value::Str(abs.to_string_lossy().into_owned())
        }
        Value::Tuple(Some(n), mut items) if n == "Some" && items.len() == 1 => {
            let inner = resolve_paths(items.remove(0), dir, name, out);
            Value::Tuple(Some(n), vec![inner])
        }
        other => other,
    }
}

fn is_path_type(t: &ParamType) -> bool {
    match t {
        ParamType::Path => true,
        ParamType::Optional(inner) => is_path_type(inner),
        _ => false,
    }
}

/// Where a node's [`ParamError`] points: the nested field in the graph file, the
/// `--set` that gave the value, or the node (a default value).
pub(crate) fn param_error_diag(
    src: &GraphSource,
    n: &NodeDecl,
    overrides: &[Override],
    e: &ParamError,
) -> Diagnostic {
    let message = format!(
        "node {:?} ({}) param `{}`: {}",
        n.id,
        n.kind,
        e.path(),
        e.message
    );
    if let Some(o) = overrides
        .iter()
        .rev()
        .find(|o| o.node == n.id && o.param == e.param)
    {
        return Diagnostic::argument(&o.text, message);
    }
    match n.params.iter().find(|p| p.name == e.param) {
        Some(p) => src.diag(nested_span(&p.value, &e.field), message),
        None => src.diag(n.span, format!("{message} (its default value)")),
    }
}

/// The span of `field` inside `value`: a struct field's or map key's name when the
/// path ends there, else the deepest value the path reaches.
fn nested_span(value: &Spanned, field: &[String]) -> Span {
    let Some((step, rest)) = field.split_first() else {
        return value.span;
    };
    let (key, next) = match &value.kind {
        SKind::Struct(_, fields) => match fields.iter().find(|(k, _, _)| k == step) {
            Some((_, key, v)) => (*key, v),
            None => return value.span,
        },
        SKind::Map(entries) => {
            let found = entries
                .iter()
                .find(|(k, _)| matches!(&k.kind, SKind::Str(s) | SKind::Ident(s) if s == step));
            match found {
                Some((k, v)) => (k.span, v),
                None => return value.span,
            }
        }
        SKind::List(items) | SKind::Tuple(_, items) => {
            match step.parse::<usize>().ok().and_then(|i| items.get(i)) {
                Some(v) => (v.span, v),
                None => return value.span,
            }
        }
        _ => return value.span,
    };
    if rest.is_empty() {
        key
    } else {
        nested_span(next, rest)
    }
}

/// A `slurm: (...)` field read by the Slurm module (absent: none).
fn slurm_settings(
    src: &GraphSource,
    written: Option<&Spanned>,
    node: Option<&str>,
) -> Result<Option<SlurmSettings>, Vec<Diagnostic>> {
    written
        .map(|v| SlurmSettings::parse(src, v, node))
        .transpose()
}
