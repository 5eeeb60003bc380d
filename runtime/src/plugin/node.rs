//! A plugin's node kind as an engine `Node`: each run becomes one `run` call
//! through the entry table, with a JSON request in and a JSON response out.

use super::abi::{HostV1, OwnedBuf, STATUS_ERROR, STATUS_OK, STATUS_PANIC};
use super::library::{LoadedLibrary, take};
use super::protocol::{InputArg, OutcomeKind, RunRequest, RunResponse};
use crate::node::{Context, InputValue, Node, NodeSpec, Outcome, ProgressSink};
use anyhow::{Result, anyhow, bail};
use std::ffi::c_void;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

pub struct PluginNode {
    pub(crate) spec: NodeSpec,
    pub(crate) library: Arc<LoadedLibrary>,
}

impl Node for PluginNode {
    fn spec(&self) -> NodeSpec {
        self.spec.clone()
    }

    fn run(&self, ctx: &mut Context) -> Result<Outcome> {
        let request = serde_json::to_vec(&request(&self.spec.kind, ctx)?)?;
        let services = HostServices {
            job: ctx.job.clone(),
            progress: ctx.progress,
            cancel: ctx.cancel,
        };
        let host = HostV1 {
            struct_size: std::mem::size_of::<HostV1>(),
            ctx: &services as *const HostServices as *const c_void,
            progress: host_progress,
            cancelled: host_cancelled,
        };
        let entry = self.library.entry;
        let mut out = OwnedBuf {
            ptr: std::ptr::null_mut(),
            len: 0,
            cap: 0,
        };
        // SAFETY: request bytes, host table and `services` outlive the call; `out` is a valid slot.
        let status = unsafe { (entry.run)(request.as_ptr(), request.len(), &host, &mut out) };
        let bytes = take(entry, out);
        let plugin = &self.library.description.plugin;
        let response: RunResponse = match status {
            STATUS_OK => serde_json::from_slice(&bytes).map_err(|e| {
                anyhow!("plugin `{plugin}` answered with a malformed response: {e}")
            })?,
            STATUS_ERROR => bail!("plugin `{plugin}`: {}", String::from_utf8_lossy(&bytes)),
            STATUS_PANIC => bail!(
                "plugin `{plugin}` panicked: {}",
                String::from_utf8_lossy(&bytes)
            ),
            other => bail!(
                "plugin `{plugin}` returned unknown status {other}: {}",
                String::from_utf8_lossy(&bytes)
            ),
        };
        for (key, value) in response.notes {
            ctx.note(&key, value);
        }
        for warning in response.warnings {
            ctx.warn(warning);
        }
        for (input, output) in &response.forwards {
            ctx.forward(input, output)
                .map_err(|e| anyhow!("plugin `{plugin}`: {e}"))?;
        }
        Ok(match response.outcome {
            OutcomeKind::Done => Outcome::Done,
            OutcomeKind::Skipped => Outcome::Skipped(
                response
                    .reason
                    .unwrap_or_else(|| "skipped by the plugin".into()),
            ),
        })
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
    for (port, value) in &ctx.inputs {
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
        threads: ctx.threads,
        scratch: utf8(&ctx.scratch)?,
        inputs,
        outputs: ctx
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

/// What the host callbacks reach through `HostV1::ctx`; only thread-safe parts of
/// the context, since a plugin may report from its worker threads.
struct HostServices<'a> {
    job: String,
    progress: &'a dyn ProgressSink,
    cancel: &'a AtomicBool,
}

unsafe extern "C" fn host_progress(
    ctx: *const c_void,
    done: u64,
    total: u64,
    msg: *const u8,
    len: usize,
) {
    // Unwinding into the plugin's frames would abort the process: contain any panic.
    let _ = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        // SAFETY: ctx is the HostServices this run passed, alive for the whole run call.
        let services = unsafe { &*(ctx as *const HostServices) };
        let message = if msg.is_null() {
            String::new()
        } else {
            // SAFETY: the plugin passes len readable bytes for the duration of the call.
            String::from_utf8_lossy(unsafe { std::slice::from_raw_parts(msg, len) }).into_owned()
        };
        services
            .progress
            .progress(&services.job, done, total, &message);
    }));
}

unsafe extern "C" fn host_cancelled(ctx: *const c_void) -> u8 {
    // SAFETY: as in host_progress.
    let services = unsafe { &*(ctx as *const HostServices) };
    u8::from(services.cancel.load(Ordering::Relaxed))
}
