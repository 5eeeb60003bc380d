//! The plugin side of the exported calls. [`export_plugin!`](crate::export_plugin)
//! wires these into the entry table; a plugin that builds its table by hand (see
//! plugins/examples/fault_injection) calls them directly.
//!
//! Every function here catches panics: unwinding out of an `extern "C"` function
//! aborts the process, and a failing plugin must fail its node only.

use crate::abi::{HostV1, OwnedBuf, STATUS_ERROR, STATUS_OK, STATUS_PANIC};
use crate::declare::{Outcome, Plugin};
use crate::protocol::{OutcomeKind, RunRequest, RunResponse};
use crate::request::Request;
use anyhow::{Result, anyhow};
use std::panic::{AssertUnwindSafe, catch_unwind};

/// Runs `f`, turning its result into a status and a buffer: the JSON answer, the
/// error message (with its causes) or the panic message.
fn guarded(out: *mut OwnedBuf, f: impl FnOnce() -> Result<Vec<u8>>) -> i32 {
    if out.is_null() {
        return STATUS_ERROR;
    }
    let (status, bytes) = match catch_unwind(AssertUnwindSafe(f)) {
        Ok(Ok(bytes)) => (STATUS_OK, bytes),
        Ok(Err(e)) => (STATUS_ERROR, format!("{e:#}").into_bytes()),
        Err(payload) => (STATUS_PANIC, panic_message(payload.as_ref()).into_bytes()),
    };
    // SAFETY: `out` is non-null and the host passes a writable OwnedBuf for the call.
    unsafe { out.write(OwnedBuf::from_vec(bytes)) };
    status
}

fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    payload
        .downcast_ref::<String>()
        .cloned()
        .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_else(|| "panic with a non-string payload".into())
}

/// The `describe` call: the plugin's description as JSON.
///
/// # Safety
/// `out` must be null or point to writable memory for one `OwnedBuf`.
pub unsafe fn describe(plugin: fn() -> &'static Plugin, out: *mut OwnedBuf) -> i32 {
    guarded(out, || Ok(serde_json::to_vec(&plugin().description())?))
}

/// The `run` call: parses the request, runs the node, answers with a [`RunResponse`].
///
/// # Safety
/// `request` must point to `len` readable bytes; `host` must be null or point to a
/// `HostV1` valid for the whole call; `out` as in [`describe`].
pub unsafe fn run(
    plugin: fn() -> &'static Plugin,
    request: *const u8,
    len: usize,
    host: *const HostV1,
    out: *mut OwnedBuf,
) -> i32 {
    guarded(out, || {
        if request.is_null() {
            return Err(anyhow!("the host passed no request"));
        }
        // SAFETY: the caller guarantees `len` readable bytes at `request` for this call.
        let bytes = unsafe { std::slice::from_raw_parts(request, len) };
        // SAFETY: the caller guarantees a null or valid, call-long HostV1.
        let host =
            unsafe { host.as_ref() }.filter(|h| h.struct_size >= std::mem::size_of::<HostV1>());
        run_bytes(plugin(), bytes, host)
    })
}

fn run_bytes(plugin: &Plugin, bytes: &[u8], host: Option<&HostV1>) -> Result<Vec<u8>> {
    let msg: RunRequest = serde_json::from_slice(bytes)
        .map_err(|e| anyhow!("malformed run request from the host: {e}"))?;
    let node = plugin
        .find(&msg.kind)
        .ok_or_else(|| anyhow!("this plugin has no node kind `{}`", msg.kind))?;
    let mut req = Request::from_message(msg, host);
    let outcome = (node.run)(&mut req)?;
    let (outcome, reason) = match outcome {
        Outcome::Done => (OutcomeKind::Done, None),
        Outcome::Skipped(r) => (OutcomeKind::Skipped, Some(r)),
    };
    let response = RunResponse {
        outcome,
        reason,
        notes: req.notes,
        warnings: req.warnings,
        forwards: req.forwards,
    };
    Ok(serde_json::to_vec(&response)?)
}

/// The `free` call: releases a buffer this library handed out.
///
/// # Safety
/// `buf` must come from this library's `describe` or `run` and not be freed twice.
pub unsafe extern "C" fn free(buf: OwnedBuf) {
    // Dropping a Vec<u8> cannot panic, but unwinding here would abort the host: be sure.
    let _ = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: guaranteed by the caller.
        drop(unsafe { buf.reclaim() })
    }));
}

/// Exports a [`Plugin`] from a `cdylib` crate: defines the entry symbol
/// `objectsplat_plugin_entry_v1` and the entry table behind it.
///
/// ```ignore
/// objectsplat_plugin_sdk::export_plugin!(Plugin::new("my_plugin", "1").node(NodeDecl::new("my_node", my_node)));
/// ```
/// The expression is evaluated once, on first use.
#[macro_export]
macro_rules! export_plugin {
    ($plugin:expr) => {
        fn __objectsplat_plugin() -> &'static $crate::Plugin {
            static PLUGIN: ::std::sync::OnceLock<$crate::Plugin> = ::std::sync::OnceLock::new();
            PLUGIN.get_or_init(|| $plugin)
        }

        unsafe extern "C" fn __objectsplat_describe(out: *mut $crate::abi::OwnedBuf) -> i32 {
            // SAFETY: forwarded from the host, which upholds `describe`'s contract.
            unsafe { $crate::export::describe(__objectsplat_plugin, out) }
        }

        unsafe extern "C" fn __objectsplat_run(
            request: *const u8,
            len: usize,
            host: *const $crate::abi::HostV1,
            out: *mut $crate::abi::OwnedBuf,
        ) -> i32 {
            // SAFETY: forwarded from the host, which upholds `run`'s contract.
            unsafe { $crate::export::run(__objectsplat_plugin, request, len, host, out) }
        }

        static __OBJECTSPLAT_ENTRY: $crate::abi::EntryV1 = $crate::abi::EntryV1 {
            abi_version: $crate::abi::ABI_VERSION,
            struct_size: ::std::mem::size_of::<$crate::abi::EntryV1>(),
            plugin_build: $crate::abi::StaticStr::new(concat!(
                env!("CARGO_PKG_NAME"),
                " ",
                env!("CARGO_PKG_VERSION")
            )),
            sdk_build: $crate::abi::StaticStr::new($crate::abi::SDK_BUILD),
            describe: __objectsplat_describe,
            run: __objectsplat_run,
            free: $crate::export::free,
        };

        /// The plugin's entry point (ABI v1).
        #[unsafe(no_mangle)]
        pub extern "C" fn objectsplat_plugin_entry_v1() -> *const $crate::abi::EntryV1 {
            &__OBJECTSPLAT_ENTRY
        }
    };
}
