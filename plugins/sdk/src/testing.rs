//! Calling a plugin through its entry table in-process, exactly as the host does
//! (JSON in, status + JSON or message out, buffers freed by the plugin), so plugin
//! crates can test their exported surface without loading a shared library.

use crate::abi::{ABI_VERSION, EntryV1, OwnedBuf, STATUS_OK};
use crate::protocol::{Description, InputArg, RunRequest, RunResponse};
use anyhow::{Result, anyhow, bail};
use std::collections::BTreeMap;
use std::path::Path;

/// Takes a buffer the plugin filled and gives it back through the plugin's `free`.
fn take(entry: &EntryV1, buf: OwnedBuf) -> String {
    let text = if buf.ptr.is_null() {
        String::new()
    } else {
        // SAFETY: the plugin filled ptr/len with initialised bytes it still owns.
        String::from_utf8_lossy(unsafe { std::slice::from_raw_parts(buf.ptr, buf.len) })
            .into_owned()
    };
    // SAFETY: the buffer came from this plugin's describe/run and is freed once.
    unsafe { (entry.free)(buf) };
    text
}

fn checked(entry: *const EntryV1) -> Result<&'static EntryV1> {
    // SAFETY: entry functions return a pointer to a static table (or null).
    let entry = unsafe { entry.as_ref() }.ok_or_else(|| anyhow!("entry function returned null"))?;
    if entry.abi_version != ABI_VERSION {
        bail!(
            "entry table speaks ABI v{}, this SDK v{ABI_VERSION}",
            entry.abi_version
        );
    }
    Ok(entry)
}

/// The plugin's description, via `describe`.
pub fn describe(entry: *const EntryV1) -> Result<Description> {
    let entry = checked(entry)?;
    let mut out = OwnedBuf::empty();
    // SAFETY: `out` is a valid OwnedBuf slot.
    let status = unsafe { (entry.describe)(&mut out) };
    let text = take(entry, out);
    if status != STATUS_OK {
        bail!("describe failed (status {status}): {text}");
    }
    Ok(serde_json::from_str(&text)?)
}

/// A node run's answer: the response, or the status and message of a failure.
pub type RunResult = std::result::Result<RunResponse, (i32, String)>;

/// Runs `kind` via `run`: `Ok(Ok(response))`, or `Ok(Err((status, message)))` when the
/// node failed or panicked. Params are RON text per name, all of them (no defaults).
pub fn run(
    entry: *const EntryV1,
    kind: &str,
    inputs: &[(&str, &Path)],
    outputs: &[(&str, &Path)],
    params: &[(&str, &str)],
    scratch: &Path,
) -> Result<RunResult> {
    let entry = checked(entry)?;
    let utf8 = |p: &Path| {
        p.to_str()
            .map(str::to_string)
            .ok_or_else(|| anyhow!("{}: path is not UTF-8", p.display()))
    };
    let mut input_map = BTreeMap::new();
    for (port, dir) in inputs {
        input_map.insert(
            port.to_string(),
            InputArg {
                dir: utf8(dir)?,
                items: None,
            },
        );
    }
    let mut output_map = BTreeMap::new();
    for (port, dir) in outputs {
        output_map.insert(port.to_string(), utf8(dir)?);
    }
    let request = RunRequest {
        kind: kind.into(),
        job: kind.into(),
        item: None,
        threads: 1,
        scratch: utf8(scratch)?,
        inputs: input_map,
        outputs: output_map,
        params: params
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect(),
    };
    let bytes = serde_json::to_vec(&request)?;
    let mut out = OwnedBuf::empty();
    // SAFETY: request bytes live across the call; no host services (null); `out` is valid.
    let status = unsafe { (entry.run)(bytes.as_ptr(), bytes.len(), std::ptr::null(), &mut out) };
    let text = take(entry, out);
    if status != STATUS_OK {
        return Ok(Err((status, text)));
    }
    Ok(Ok(serde_json::from_str(&text)?))
}
