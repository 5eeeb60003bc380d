//! `command`: any program (a Python SAM 2 script, a diffusion inpainter, a depth model)
//! as a graph stage, without writing a plugin.
//!
//! The graph declares, in the node's params:
//! - `argv`: the program and its arguments, run directly (no shell). Placeholders inside
//!   an argument are replaced by text: `{in:PORT}` / `{out:PORT}` the folder of an input /
//!   output port, `{script}` the absolute path of `script`, `{options}` the path of
//!   `options.json`, `{opt:NAME}` one option's value (strings bare, anything else as
//!   JSON). Other braces are left alone.
//! - `consumes` / `produces`: the ports, as maps of port name → artifact type
//!   (`{"frames": "Frames"}`, `{"masks": "File"}`, `"[Component]"` for a collection).
//!   They are checked and wired like any node's ports (`Node::declared_ports`).
//! - `script`: the file the program runs, if any; its content is part of the cache key,
//!   so editing the script reruns the stage (the interpreter itself is not).
//! - `options`: values for the program, written to `options.json`.
//! - `timeout_s`: the program is killed past it.
//!
//! The program runs in a private working folder. Each input appears there as a copy
//! (`in/<port>/`, the artifact's documented encoding), so the program may change it
//! freely; each output is an empty folder the program fills, collected as the port's
//! artifact when it exits successfully. An output left empty, or without the file its
//! type is defined by (`frames.json` for Frames, …), is an error naming the port. A
//! non-zero exit, a timeout or an interruption fails the node with the tail of the
//! program's stderr. Like every node, the program must be deterministic: the same inputs
//! must give the same bytes, or its consumers rerun every time.

use crate::process::Program;
use anyhow::{Context as _, Result, bail};
use objectsplat_runtime::{
    Context, DeclaredPorts, Node, NodeParams, NodeSpec, Outcome, ParamError, ParamType, Params,
    PortSpec, Registry, TypeRef, node_params,
};
use serde_json::Value;
use std::collections::BTreeMap;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

pub const KIND: &str = "command";
const OPTIONS_FILE: &str = "options.json";

/// The file a folder of type `name` is defined by (docs/artifacts.md).
fn defining_file(name: &str) -> Option<&'static str> {
    objectsplat_core::artifact::find(name).and_then(|t| t.defining_file)
}

pub struct CommandNode;

node_params! {
    /// The params as the graph gives them.
    struct CommandParams {
        /// the program and its arguments, e.g. ["python3", "{script}", "{in:frames}", "{out:masks}"]
        argv: Vec<String> = required as ParamType::list(ParamType::Str),
        /// the input ports: name → type (each appears as a folder, {in:NAME})
        consumes: BTreeMap<String, String> = "{}"
            as ParamType::Ron("a map of input port name to type, e.g. {\"frames\": \"Frames\"}".into()),
        /// the output ports: name → type (each an empty folder the program fills, {out:NAME})
        produces: BTreeMap<String, String> = required
            as ParamType::Ron("a map of output port name to type, e.g. {\"masks\": \"File\"}".into()),
        /// the file the program runs ({script}); its content is part of the cache key
        script: Option<String> = "None" as ParamType::optional(ParamType::Path),
        /// values for the program: written to options.json ({options}); {opt:NAME} is one value as text
        options: BTreeMap<String, Value> = "{}"
            as ParamType::Ron("a map of names to values (strings, numbers, bools, lists)".into()),
        /// seconds before the program is killed
        timeout_s: f64 = "3600.0" as ParamType::float_range(0.001, 1.0e7),
    }
}

/// The params as the node uses them.
struct Declared {
    argv: Vec<String>,
    consumes: BTreeMap<String, TypeRef>,
    produces: BTreeMap<String, TypeRef>,
    options: BTreeMap<String, Value>,
    script: Option<String>,
    timeout: Duration,
}

fn ports(
    raw: BTreeMap<String, String>,
    name: &str,
) -> Result<BTreeMap<String, TypeRef>, ParamError> {
    raw.into_iter()
        .map(|(port, ty)| {
            if port.is_empty() || !port.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
                return Err(ParamError::new(
                    name,
                    format!("port name {port:?} must be made of letters, digits and `_`"),
                ));
            }
            let ty = TypeRef::parse(&ty)
                .map_err(|e| ParamError::new(name, format!("port `{port}`: {e}")))?;
            Ok((port, ty))
        })
        .collect()
}

impl Declared {
    fn read(params: &Params) -> Result<Declared, ParamError> {
        let p = CommandParams::try_read(params).map_err(|mut e| {
            let hint = match e.param.as_str() {
                "consumes" | "produces" => {
                    "; expected a map of port name to type, e.g. {\"frames\": \"Frames\"}"
                }
                "options" => "; expected a map of names to values",
                _ => "",
            };
            e.message.push_str(hint);
            e
        })?;
        let argv = p.argv;
        let consumes = ports(p.consumes, "consumes")?;
        let produces = ports(p.produces, "produces")?;
        let options = p.options;
        // The program runs in its own folder, so the script's path must not be relative
        // (the engine resolves it against the graph's folder, which may itself be relative).
        let script = p
            .script
            .map(|s| {
                std::path::absolute(&s)
                    .map(|p| p.display().to_string())
                    .map_err(|e| ParamError::new("script", format!("{s}: {e}")))
            })
            .transpose()?;
        if argv.is_empty() {
            return Err(ParamError::new(
                "argv",
                "the command is empty: give the program and its arguments, e.g. [\"python3\", \"{script}\", \"{in:frames}\", \"{out:masks}\"]",
            ));
        }
        if produces.is_empty() {
            return Err(ParamError::new(
                "produces",
                "declare at least one output port, e.g. {\"masks\": \"File\"}",
            ));
        }
        if let Some(port) = consumes.keys().find(|p| produces.contains_key(*p)) {
            return Err(ParamError::new(
                "produces",
                format!("`{port}` is declared both as an input and as an output"),
            ));
        }
        let d = Declared {
            argv,
            consumes,
            produces,
            options,
            script,
            timeout: Duration::from_secs_f64(p.timeout_s),
        };
        // Every placeholder must name something declared; substituting with dummy
        // folders finds the ones that do not.
        for arg in &d.argv {
            d.substitute(arg, Path::new(""), &BTreeMap::new())
                .map_err(|e| ParamError::new("argv", e))?;
        }
        Ok(d)
    }

    /// `arg` with its placeholders replaced; `inputs`/`outputs` come from `folders`
    /// (missing ones stand for empty paths while checking).
    fn substitute(
        &self,
        arg: &str,
        workdir: &Path,
        folders: &BTreeMap<String, PathBuf>,
    ) -> Result<String, String> {
        let mut out = String::new();
        let mut rest = arg;
        while let Some(open) = rest.find('{') {
            out.push_str(&rest[..open]);
            let after = &rest[open + 1..];
            let Some(close) = after.find('}') else {
                out.push_str(&rest[open..]);
                return Ok(out);
            };
            let inner = &after[..close];
            let folder = |port: &str, declared: &BTreeMap<String, TypeRef>, side: &str| {
                if !declared.contains_key(port) {
                    let names: Vec<&str> = declared.keys().map(String::as_str).collect();
                    return Err(format!(
                        "{{{inner}}} names the {side} port `{port}`, which is not declared; the {side}s are {}",
                        if names.is_empty() {
                            "none".to_string()
                        } else {
                            names.join(", ")
                        }
                    ));
                }
                Ok(folders
                    .get(&format!("{side}:{port}"))
                    .map(|p| p.display().to_string())
                    .unwrap_or_default())
            };
            let value = if let Some(port) = inner.strip_prefix("in:") {
                folder(port, &self.consumes, "input")?
            } else if let Some(port) = inner.strip_prefix("out:") {
                folder(port, &self.produces, "output")?
            } else if let Some(name) = inner.strip_prefix("opt:") {
                match self.options.get(name) {
                    Some(Value::String(s)) => s.clone(),
                    Some(v) => v.to_string(),
                    None => {
                        return Err(format!(
                            "{{{inner}}} names the option `{name}`, which `options` does not give"
                        ));
                    }
                }
            } else if inner == "script" {
                self.script
                    .clone()
                    .ok_or_else(|| "{script} is used but no `script` is given".to_string())?
            } else if inner == "options" {
                workdir.join(OPTIONS_FILE).display().to_string()
            } else {
                // Not a placeholder: keep the braces.
                format!("{{{inner}}}")
            };
            out.push_str(&value);
            rest = &after[close + 1..];
        }
        out.push_str(rest);
        Ok(out)
    }
}

fn port_specs(ports: &BTreeMap<String, TypeRef>, doc: &str) -> Vec<PortSpec> {
    ports
        .iter()
        .map(|(name, ty)| PortSpec {
            name: name.clone(),
            ty: ty.clone(),
            optional: false,
            doc: doc.into(),
        })
        .collect()
}

impl Node for CommandNode {
    fn spec(&self) -> NodeSpec {
        NodeSpec::new(KIND, "1")
            .doc("Runs a program (argv, no shell) as a stage: its ports are declared by `consumes` / `produces`, inputs appear as folders (copies) and outputs are the folders it writes. Placeholders in argv: {in:PORT}, {out:PORT}, {script}, {options}, {opt:NAME}. The script's content is part of the cache key; stderr's tail is quoted when it fails.")
            .params::<CommandParams>()
    }

    fn declared_ports(&self, params: &Params) -> Result<Option<DeclaredPorts>, ParamError> {
        let d = Declared::read(params)?;
        Ok(Some(DeclaredPorts {
            inputs: port_specs(&d.consumes, "declared by `consumes`"),
            outputs: port_specs(&d.produces, "declared by `produces`"),
            inputs_param: "consumes".into(),
            outputs_param: "produces".into(),
        }))
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let d = Declared::read(ctx.params())
            .map_err(|e| anyhow::anyhow!("{}: {}", e.param, e.message))?;
        // Folders are handed to a program running elsewhere: make them absolute.
        let absolute = |p: &Path| {
            std::path::absolute(p).with_context(|| format!("{}: no absolute path", p.display()))
        };
        let workdir = absolute(ctx.scratch())?;
        let mut folders = BTreeMap::new();
        for port in d.consumes.keys() {
            let src = ctx
                .input_opt(port)
                .with_context(|| format!("input `{port}` is not connected"))?;
            let copy = workdir.join("in").join(port);
            // The program gets its own, writable copy of every input.
            objectsplat_core::files::tree_file_by_file(src, &copy, &|from, to| {
                objectsplat_runtime::store::copy_writable(from, to)
            })?;
            folders.insert(format!("input:{port}"), copy);
        }
        for port in d.produces.keys() {
            folders.insert(format!("output:{port}"), absolute(&ctx.output(port)?)?);
        }
        let options = Value::Object(d.options.clone().into_iter().collect());
        std::fs::write(
            workdir.join(OPTIONS_FILE),
            serde_json::to_string_pretty(&options)?,
        )
        .with_context(|| format!("{}: cannot write", workdir.join(OPTIONS_FILE).display()))?;
        let argv: Vec<OsString> = d
            .argv
            .iter()
            .map(|a| d.substitute(a, &workdir, &folders).map(OsString::from))
            .collect::<Result<_, String>>()
            .map_err(|e| anyhow::anyhow!("argv: {e}"))?;
        ctx.progress(0, 1, &format!("running {}", d.argv[0]));
        let stderr = {
            let ctx_ref: &Context = ctx;
            Program {
                what: "command",
                argv,
                workdir: &workdir,
                timeout: d.timeout,
                cancelled: &|| ctx_ref.cancelled(),
            }
            .run()?
        };
        for (port, ty) in &d.produces {
            check_output(
                port,
                ty,
                &folders[&format!("output:{port}")],
                &d.argv[0],
                &stderr,
            )?;
        }
        ctx.progress(1, 1, "done");
        ctx.note("program", &d.argv[0]);
        if let Some(last) = stderr.lines().last().filter(|_| stderr != "(empty)") {
            ctx.note("stderr (last line)", last);
        }
        Ok(Outcome::Done)
    }
}

/// An output must hold something, and the file its type is defined by.
fn check_output(port: &str, ty: &TypeRef, dir: &Path, program: &str, stderr: &str) -> Result<()> {
    let empty = std::fs::read_dir(dir)
        .with_context(|| format!("{}: cannot list output `{port}`", dir.display()))?
        .next()
        .is_none();
    if empty {
        bail!(
            "command {program:?} exited successfully but wrote nothing into output `{port}` ({ty}, {}); stderr:\n{stderr}",
            dir.display()
        );
    }
    // Types without a defining file (File, Images) only need to be non-empty.
    if let (TypeRef::One(t), Some(file)) = (ty, defining_file(ty.element()))
        && !dir.join(file).is_file()
    {
        bail!(
            "command {program:?} wrote output `{port}` ({t}) without {file} ({}); see docs/artifacts.md for the {t} encoding; stderr:\n{stderr}",
            dir.display()
        );
    }
    Ok(())
}

pub fn register(reg: &mut Registry) {
    reg.add_node(Arc::new(CommandNode))
        .expect("the command kind is unique");
}
