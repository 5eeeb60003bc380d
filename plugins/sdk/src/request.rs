//! What a plugin node sees while it runs: its inputs, outputs, params and the host's services.

use crate::abi::HostV1;
use crate::protocol::{InputArg, RunRequest};
use anyhow::{Context as _, Result, anyhow};
use objectsplat_plugin_abi::folders::{InputValue, PortFolders};
use serde::de::DeserializeOwned;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// One node run. Mirrors the engine's `Context` so built-in nodes port over easily.
pub struct Request<'h> {
    kind: String,
    job: String,
    item: Option<String>,
    threads: usize,
    scratch: PathBuf,
    folders: PortFolders,
    params: BTreeMap<String, String>,
    host: Option<&'h HostV1>,
    pub(crate) notes: Vec<(String, String)>,
    pub(crate) warnings: Vec<String>,
    pub(crate) forwards: Vec<(String, String)>,
}

impl<'h> Request<'h> {
    /// Builds a request from the host's message. `host` may be `None` (tests, no services).
    pub(crate) fn from_message(msg: RunRequest, host: Option<&'h HostV1>) -> Request<'h> {
        let inputs = msg
            .inputs
            .into_iter()
            .map(|(port, InputArg { dir, items })| {
                let dir = PathBuf::from(dir);
                let value = match items {
                    Some(items) => InputValue::Items {
                        dir,
                        items: items
                            .into_iter()
                            .map(|(n, p)| (n, PathBuf::from(p)))
                            .collect(),
                    },
                    None => InputValue::One(dir),
                };
                (port, value)
            })
            .collect();
        Request {
            kind: msg.kind,
            job: msg.job,
            item: msg.item,
            threads: msg.threads.max(1),
            scratch: PathBuf::from(msg.scratch),
            folders: PortFolders {
                inputs,
                outputs: msg
                    .outputs
                    .into_iter()
                    .map(|(k, v)| (k, PathBuf::from(v)))
                    .collect(),
            },
            params: msg.params,
            host,
            notes: vec![],
            warnings: vec![],
            forwards: vec![],
        }
    }

    /// A request for calling a node function directly (unit tests of a plugin crate):
    /// inputs and outputs are folders, params are RON text per name (all of them: no
    /// defaults are applied here, unlike in a graph).
    pub fn for_test(
        kind: &str,
        inputs: &[(&str, &Path)],
        outputs: &[(&str, &Path)],
        params: &[(&str, &str)],
        scratch: &Path,
    ) -> Request<'static> {
        let msg = RunRequest {
            kind: kind.into(),
            job: kind.into(),
            item: None,
            threads: 1,
            scratch: scratch.to_string_lossy().into_owned(),
            inputs: inputs
                .iter()
                .map(|(k, p)| {
                    (
                        k.to_string(),
                        InputArg {
                            dir: p.to_string_lossy().into_owned(),
                            items: None,
                        },
                    )
                })
                .collect(),
            outputs: outputs
                .iter()
                .map(|(k, p)| (k.to_string(), p.to_string_lossy().into_owned()))
                .collect(),
            params: params
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect(),
        };
        Request::from_message(msg, None)
    }

    pub fn kind(&self) -> &str {
        &self.kind
    }

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

    /// The empty folder to write an output into (for `[T]`: one sub-folder per item).
    pub fn output(&self, port: &str) -> Result<PathBuf> {
        self.folders.output(port)
    }

    /// The canonical RON text of a param.
    pub fn param_text(&self, name: &str) -> Result<&str> {
        self.params
            .get(name)
            .map(String::as_str)
            .ok_or_else(|| anyhow!("parameter `{name}` is not declared"))
    }

    /// Reads a param as `T` (via serde from its RON text). The engine normalises an
    /// `optional(T)` value `Some(x)` to plain `x`, so `Option` fields accept both.
    pub fn param<T: DeserializeOwned>(&self, name: &str) -> Result<T> {
        let text = self.param_text(name)?;
        ron::Options::default()
            .with_default_extension(ron::extensions::Extensions::IMPLICIT_SOME)
            .from_str(text)
            .with_context(|| format!("parameter `{name}` = {text}"))
    }

    /// The item name when the node runs once per item of a fanned-out input.
    pub fn item(&self) -> Option<&str> {
        self.item.as_deref()
    }

    /// The engine's label for this run, for messages.
    pub fn job(&self) -> &str {
        &self.job
    }

    /// Worker threads this run may use.
    pub fn threads(&self) -> usize {
        self.threads
    }

    /// A private scratch folder, deleted after the run.
    pub fn scratch(&self) -> &Path {
        &self.scratch
    }

    /// A fact for the run report.
    pub fn note(&mut self, key: &str, value: impl std::fmt::Display) {
        self.notes.push((key.to_string(), value.to_string()));
    }

    pub fn warn(&mut self, message: impl std::fmt::Display) {
        self.warnings.push(message.to_string());
    }

    /// Makes an output the very same artifact as an input (no copy).
    pub fn forward(&mut self, input: &str, output: &str) -> Result<()> {
        self.folders.check_forward(input, output)?;
        self.forwards.push((input.to_string(), output.to_string()));
        Ok(())
    }

    /// Progress for the host's progress bars: `done` of `total` units of the kind of work
    /// `message` names (the same text for every unit of a kind, so the host can sum them).
    pub fn progress(&self, done: u64, total: u64, message: &str) {
        if let Some(host) = self.host {
            // SAFETY: the host table and its ctx are valid for the whole run call, which
            // outlives this request ('h); the message is borrowed only during the call.
            unsafe { (host.progress)(host.ctx, done, total, message.as_ptr(), message.len()) }
        }
    }

    /// True once the run was interrupted; long loops should return an error early.
    pub fn cancelled(&self) -> bool {
        match self.host {
            // SAFETY: as in `progress`.
            Some(host) => unsafe { (host.cancelled)(host.ctx) != 0 },
            None => false,
        }
    }
}
