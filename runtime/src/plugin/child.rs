//! The plugin child process: loads one library, makes one ABI v1 call, reports back
//! over the wire protocol ([`super::wire`]) and exits. Whatever the library does —
//! abort, segfault, overflow its stack, call `exit`, hang — happens in this process,
//! so the engine sees a failed node, never its own death.
//!
//! An executable becomes able to host plugin children by calling
//! [`serve_if_requested`] first thing in `main`: started with [`CHILD_ARG`] it
//! serves and exits; otherwise it records that the engine may start children from
//! this very executable.

use super::abi::{HostV1, OwnedBuf};
use super::library::{self, take};
use super::wire::{self, CANCEL, Call, Reply};
use std::ffi::c_void;
use std::io::Write;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, OnceLock};

/// The first argument that turns an engine executable into a plugin child.
pub const CHILD_ARG: &str = "--objectsplat-plugin-child";

/// Set when this executable can serve [`CHILD_ARG`] (see [`serve_if_requested`]).
pub(crate) static SELF_CAN_HOST: AtomicBool = AtomicBool::new(false);

/// Call first in `main`. Started as a plugin child, this serves the call and exits
/// the process; otherwise it returns, and plugins loaded by this process run in
/// children started from this executable.
pub fn serve_if_requested() {
    if std::env::args_os().nth(1).is_some_and(|a| a == CHILD_ARG) {
        std::process::exit(serve());
    }
    SELF_CAN_HOST.store(true, Ordering::SeqCst);
}

/// The protocol channel (the original stdout) and the cancellation flag.
struct Channel {
    out: Mutex<Box<dyn Write + Send>>,
    cancelled: AtomicBool,
}

static CHANNEL: OnceLock<Channel> = OnceLock::new();

fn send(reply: &Reply) {
    let Some(ch) = CHANNEL.get() else { return };
    // Serialising plain strings and numbers cannot fail.
    let mut line = serde_json::to_vec(reply).unwrap_or_default();
    line.push(b'\n');
    // A poisoned lock only means a plugin thread panicked mid-write of a whole line.
    let mut out = ch.out.lock().unwrap_or_else(|p| p.into_inner());
    // The engine being gone is handled by the stdin watcher; nothing to do here.
    let _ = out.write_all(&line).and_then(|_| out.flush());
}

fn serve() -> i32 {
    let Some(out) = sys::take_stdout() else {
        eprintln!("objectsplat plugin child: cannot set up its output channel");
        return 3;
    };
    let _ = CHANNEL.set(Channel {
        out: Mutex::new(out),
        cancelled: AtomicBool::new(false),
    });
    let stdin = std::io::stdin();
    let mut input = stdin.lock();
    let call: Call = match wire::read_line(&mut input, wire::MAX_LINE)
        .ok()
        .flatten()
        .and_then(|l| serde_json::from_slice(&l).ok())
    {
        Some(c) => c,
        None => {
            eprintln!("objectsplat plugin child: no call on stdin (this mode is for the engine)");
            return 2;
        }
    };
    drop(input);
    std::thread::spawn(watch_engine);
    let reply = match call {
        Call::Describe { library } => match library::open(&library) {
            Ok(lib) => Reply::Described {
                digest: lib.digest.clone(),
                build: lib.build.clone(),
                description: lib.description_json.clone(),
            },
            Err(message) => Reply::Refused {
                message: wire::bounded(&message),
            },
        },
        Call::Run {
            library,
            digest,
            request,
        } => match library::open(&library) {
            Ok(lib) if lib.digest != digest => Reply::Refused {
                message:
                    "the library file changed since it was loaded; run again to use the new build"
                        .into(),
            },
            Ok(lib) => run(lib.entry, request.as_bytes()),
            Err(message) => Reply::Refused {
                message: wire::bounded(&message),
            },
        },
    };
    send(&reply);
    0
}

/// Reads the engine's lines: `cancel` sets the flag the plugin polls; the end of
/// input means the engine is gone, and this process (with all it started) follows.
fn watch_engine() {
    let stdin = std::io::stdin();
    let mut input = stdin.lock();
    loop {
        match wire::read_line(&mut input, 64) {
            Ok(Some(line)) if line == CANCEL.as_bytes() => {
                if let Some(ch) = CHANNEL.get() {
                    ch.cancelled.store(true, Ordering::SeqCst);
                }
            }
            Ok(Some(_)) => {}
            Ok(None) | Err(_) => sys::exit_with_group(),
        }
    }
}

fn run(entry: &super::abi::EntryV1, request: &[u8]) -> Reply {
    let host = HostV1 {
        struct_size: std::mem::size_of::<HostV1>(),
        ctx: std::ptr::null(),
        progress: host_progress,
        cancelled: host_cancelled,
    };
    let mut out = OwnedBuf {
        ptr: std::ptr::null_mut(),
        len: 0,
        cap: 0,
    };
    // SAFETY: request and host outlive the call; `out` is a valid slot.
    let status = unsafe { (entry.run)(request.as_ptr(), request.len(), &host, &mut out) };
    let bytes = take(entry, out);
    let body = if status == super::abi::STATUS_OK {
        // JSON is passed whole (cut JSON would not parse); its size is bounded by the line limit.
        if bytes.len() > wire::MAX_LINE / 2 {
            return Reply::Answer {
                status: super::abi::STATUS_ERROR,
                body: format!(
                    "its answer is {} MiB, over the {} MiB a run may return (notes and warnings belong in short text)",
                    bytes.len() >> 20,
                    wire::MAX_LINE >> 21
                ),
            };
        }
        String::from_utf8_lossy(&bytes).into_owned()
    } else {
        wire::bounded(&String::from_utf8_lossy(&bytes))
    };
    Reply::Answer { status, body }
}

unsafe extern "C" fn host_progress(
    _ctx: *const c_void,
    done: u64,
    total: u64,
    msg: *const u8,
    len: usize,
) {
    // Unwinding into the plugin's frames would abort the process: contain any panic.
    let _ = std::panic::catch_unwind(|| {
        let message = if msg.is_null() {
            String::new()
        } else {
            // SAFETY: the plugin passes len readable bytes for the duration of the call.
            let bytes = unsafe { std::slice::from_raw_parts(msg, len) };
            wire::bounded_to(&String::from_utf8_lossy(bytes), 500)
        };
        send(&Reply::Progress {
            done,
            total,
            message,
        });
    });
}

unsafe extern "C" fn host_cancelled(_ctx: *const c_void) -> u8 {
    u8::from(
        CHANNEL
            .get()
            .is_some_and(|c| c.cancelled.load(Ordering::Relaxed)),
    )
}

#[cfg(unix)]
mod sys {
    use std::os::fd::FromRawFd;

    /// A handle on the original stdout for the protocol; fd 1 then points at stderr,
    /// so whatever the library prints cannot corrupt a message.
    pub fn take_stdout() -> Option<Box<dyn std::io::Write + Send>> {
        use std::io::Write;
        let _ = std::io::stdout().flush();
        // SAFETY: dup and dup2 only manipulate this process's descriptor table; the
        // duplicate is owned by the File returned below and by nothing else.
        unsafe {
            let fd = libc::dup(1);
            if fd < 0 || libc::dup2(2, 1) < 0 {
                return None;
            }
            libc::fcntl(fd, libc::F_SETFD, libc::FD_CLOEXEC);
            Some(Box::new(std::fs::File::from_raw_fd(fd)))
        }
    }

    /// The engine is gone: end this process group (this child and anything the
    /// plugin started; the engine made the child a group leader).
    pub fn exit_with_group() -> ! {
        // SAFETY: kill(0, ...) signals this process's own group; no memory involved.
        unsafe { libc::kill(0, libc::SIGKILL) };
        std::process::exit(1)
    }
}

#[cfg(not(unix))]
mod sys {
    /// Without descriptor duplication the protocol shares stdout with the library:
    /// a library that prints to stdout there breaks its own runs (not the engine).
    pub fn take_stdout() -> Option<Box<dyn std::io::Write + Send>> {
        Some(Box::new(std::io::stdout()))
    }

    pub fn exit_with_group() -> ! {
        std::process::exit(1)
    }
}
