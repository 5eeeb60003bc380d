//! A plugin's node kind as an engine `Node`: each run is one `run` call made by a
//! child process ([`super::host`]), with a JSON request in and a JSON response out.
//! Whatever the library does to its process fails this node only; a run that
//! answers `done` must have written every output it did not forward.

use super::PluginLibrary;
use super::abi::{STATUS_ERROR, STATUS_OK, STATUS_PANIC};
use super::host;
use super::protocol::{InputArg, OutcomeKind, RunRequest, RunResponse};
use super::spec::TIMEOUT_PARAM;
use super::wire::{self, Call, Reply};
use crate::node::{Context, InputValue, Node, NodeSpec, Outcome, TypeRef};
use anyhow::{Result, anyhow, bail};
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

pub struct PluginNode {
    pub(crate) spec: NodeSpec,
    pub(crate) library: Arc<PluginLibrary>,
}

/// Notes and warnings a run may add, and the length of each; beyond them the
/// report would only get longer, not clearer.
const MAX_NOTES: usize = 100;
const MAX_NOTE_TEXT: usize = 1000;

impl Node for PluginNode {
    fn spec(&self) -> NodeSpec {
        self.spec.clone()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let plugin = self.library.description.plugin.clone();
        let timeout: f64 = ctx.param(TIMEOUT_PARAM)?;
        let mut req = request(&self.spec.kind, ctx)?;
        // The engine's own param; the library never declared it.
        req.params.remove(TIMEOUT_PARAM);
        let call = Call::Run {
            library: self.library.path.clone(),
            digest: self.library.digest.clone(),
            request: serde_json::to_string(&req)?,
        };
        let reply = {
            let view: &Context = ctx;
            host::call(
                &call,
                Duration::from_secs_f64(timeout),
                &mut |done, total, msg| view.progress(done, total, msg),
                &|| view.cancelled(),
            )
            .map_err(|e| {
                anyhow!(
                    "plugin `{plugin}` running `{}`: its process {e}",
                    self.spec.kind
                )
            })?
        };
        let (status, body) = match reply {
            Reply::Answer { status, body } => (status, body),
            Reply::Refused { message } => bail!("plugin `{plugin}`: {message}"),
            other => bail!("plugin `{plugin}`: its process answered the run with {other:?}"),
        };
        let response: RunResponse = match status {
            STATUS_OK => serde_json::from_str(&body).map_err(|e| {
                anyhow!("plugin `{plugin}` answered with a malformed response: {e}")
            })?,
            STATUS_ERROR => bail!("plugin `{plugin}`: {}", wire::bounded(&body)),
            STATUS_PANIC => bail!("plugin `{plugin}` panicked: {}", wire::bounded(&body)),
            other => bail!(
                "plugin `{plugin}` returned unknown status {other}: {}",
                wire::bounded(&body)
            ),
        };
        let note = |t: &str| wire::bounded_to(t, MAX_NOTE_TEXT);
        for (key, value) in response.notes.iter().take(MAX_NOTES) {
            ctx.note(&note(key), note(value));
        }
        for warning in response.warnings.iter().take(MAX_NOTES) {
            ctx.warn(note(warning));
        }
        for (input, output) in &response.forwards {
            ctx.forward(input, output)
                .map_err(|e| anyhow!("plugin `{plugin}`: {e}"))?;
        }
        let outcome = match response.outcome {
            OutcomeKind::Done => Outcome::Done,
            OutcomeKind::Skipped => Outcome::Skipped(note(
                response
                    .reason
                    .as_deref()
                    .unwrap_or("skipped by the plugin"),
            )),
        };
        if outcome == Outcome::Done {
            self.check_outputs(ctx, &plugin)?;
        }
        Ok(outcome)
    }
}

impl PluginNode {
    /// A run that says `done` wrote every output it did not forward: an empty output
    /// folder (or an empty item of a collection) is the plugin's failure, reported on
    /// its own node rather than on the consumer that would trip over it.
    fn check_outputs(&self, ctx: &Context, plugin: &str) -> Result<()> {
        let is_empty = |dir: &Path| {
            std::fs::read_dir(dir)
                .map(|mut d| d.next().is_none())
                .unwrap_or(true)
        };
        for port in &self.spec.outputs {
            if ctx.forwarded.contains_key(&port.name) {
                continue;
            }
            let dir = ctx.output(&port.name)?;
            let empty: Vec<String> = match &port.ty {
                TypeRef::One(_) if is_empty(&dir) => vec![String::new()],
                TypeRef::One(_) => vec![],
                // A collection may have no items; an item must hold something.
                TypeRef::List(_) => std::fs::read_dir(&dir)?
                    .flatten()
                    .filter(|e| e.path().is_dir() && is_empty(&e.path()))
                    .map(|e| format!(" item {:?}", e.file_name()))
                    .collect(),
            };
            if let Some(first) = empty.first() {
                bail!(
                    "plugin `{plugin}` finished `{}` without writing its output `{}`{first} (an empty folder); \
                     a node with nothing to write should skip, or forward an input",
                    self.spec.kind,
                    port.name
                );
            }
        }
        Ok(())
    }
}

fn utf8(path: &Path) -> Result<String> {
    path.to_str().map(str::to_string).ok_or_else(|| {
        anyhow!(
            "{}: plugins receive UTF-8 paths and this one is not",
            path.display()
        )
    })
}

fn request(kind: &str, ctx: &Context) -> Result<RunRequest> {
    let mut inputs = std::collections::BTreeMap::new();
    for (port, value) in &ctx.folders.inputs {
        let arg = match value {
            InputValue::One(dir) => InputArg {
                dir: utf8(dir)?,
                items: None,
            },
            InputValue::Items { dir, items } => InputArg {
                dir: utf8(dir)?,
                items: Some(
                    items
                        .iter()
                        .map(|(n, p)| Ok((n.clone(), utf8(p)?)))
                        .collect::<Result<_>>()?,
                ),
            },
        };
        inputs.insert(port.clone(), arg);
    }
    Ok(RunRequest {
        kind: kind.to_string(),
        job: ctx.job.clone(),
        item: ctx.item.clone(),
        threads: ctx.threads(),
        scratch: utf8(&ctx.scratch)?,
        inputs,
        outputs: ctx
            .folders
            .outputs
            .iter()
            .map(|(k, p)| Ok((k.clone(), utf8(p)?)))
            .collect::<Result<_>>()?,
        params: ctx
            .params
            .iter()
            .map(|(k, v)| (k.clone(), v.to_ron()))
            .collect(),
    })
}
