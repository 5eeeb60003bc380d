//! The engine side of a plugin call: start a child process ([`super::child`]), send
//! the call, pass its progress on, and turn whatever happens to it — an answer, a
//! crash, an exit without answering, a hang past the timeout — into a result. The
//! child runs in a process group of its own, killed whole when the call ends, so a
//! plugin leaves no process behind.

use super::child::{CHILD_ARG, SELF_CAN_HOST};
use super::wire::{self, CANCEL, Call, MAX_LINE, Reply};
use std::io::{BufReader, Read, Write};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::Mutex;
use std::sync::atomic::Ordering;
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// Environment variable naming the executable that hosts plugin children when the
/// running program does not (a test harness, a program embedding the engine).
pub const HOST_ENV: &str = "OBJECTSPLAT_PLUGIN_HOST";

static HOST_PROGRAM: Mutex<Option<PathBuf>> = Mutex::new(None);

/// Names the executable plugin children are started from: one whose `main` calls
/// [`super::child::serve_if_requested`] first (the `objectsplat` CLI does).
pub fn set_host_program(path: PathBuf) {
    *HOST_PROGRAM.lock().unwrap_or_else(|p| p.into_inner()) = Some(path);
}

fn host_program() -> Result<PathBuf, String> {
    if let Some(p) = HOST_PROGRAM
        .lock()
        .unwrap_or_else(|p| p.into_inner())
        .clone()
    {
        return Ok(p);
    }
    if let Some(p) = std::env::var_os(HOST_ENV) {
        return Ok(PathBuf::from(p));
    }
    if SELF_CAN_HOST.load(Ordering::SeqCst) {
        return std::env::current_exe()
            .map_err(|e| format!("cannot find this program to start plugin processes: {e}"));
    }
    Err(format!(
        "plugins run in child processes and this program cannot start them: call \
         objectsplat_runtime::plugin::child::serve_if_requested() first in main, or \
         set_host_program(), or set {HOST_ENV} to an objectsplat executable"
    ))
}

/// Bytes of the child's stderr kept for error messages (the end of it).
const STDERR_TAIL: usize = 4000;

/// How long a child that answered may take to exit before it is killed.
const EXIT_GRACE: Duration = Duration::from_secs(5);

/// Makes `call` in a fresh child and returns its final reply. `progress` receives
/// the child's progress; `cancelled` is polled and forwarded. Errors describe what
/// happened to the child (killed by a signal, exited without answering, timed out),
/// with the end of its stderr.
pub fn call(
    call: &Call,
    timeout: Duration,
    progress: &mut dyn FnMut(u64, u64, &str),
    cancelled: &dyn Fn() -> bool,
) -> Result<Reply, String> {
    let program = host_program()?;
    let mut command = Command::new(&program);
    command
        .arg(CHILD_ARG)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    #[cfg(unix)]
    std::os::unix::process::CommandExt::process_group(&mut command, 0);
    let mut child = command
        .spawn()
        .map_err(|e| format!("cannot start a plugin process ({}): {e}", program.display()))?;
    let group = ProcessGroup(child.id());
    let result = converse(&mut child, call, timeout, progress, cancelled);
    // Whatever the outcome, nothing the plugin started outlives the call.
    group.kill();
    let _ = child.kill();
    let _ = child.wait();
    result
}

fn converse(
    child: &mut Child,
    call: &Call,
    timeout: Duration,
    progress: &mut dyn FnMut(u64, u64, &str),
    cancelled: &dyn Fn() -> bool,
) -> Result<Reply, String> {
    let deadline = Instant::now() + timeout;
    let mut stdin = child
        .stdin
        .take()
        .ok_or("the plugin process has no stdin")?;
    let stdout = child
        .stdout
        .take()
        .ok_or("the plugin process has no stdout")?;
    let stderr = child
        .stderr
        .take()
        .ok_or("the plugin process has no stderr")?;
    let (tail_tx, stderr_tail) = mpsc::channel();
    std::thread::spawn(move || tail_tx.send(keep_tail(stderr)));
    let (tx, rx) = mpsc::channel::<Result<Reply, String>>();
    std::thread::spawn(move || {
        let mut reader = BufReader::new(stdout);
        loop {
            let msg = match wire::read_line(&mut reader, MAX_LINE) {
                Ok(Some(line)) => serde_json::from_slice::<Reply>(&line)
                    .map_err(|e| format!("the plugin process sent a malformed message: {e}")),
                Ok(None) => return,
                Err(e) => Err(format!("the plugin process sent {e}")),
            };
            let stop = msg.is_err();
            if tx.send(msg).is_err() || stop {
                return;
            }
        }
    });
    let mut line = serde_json::to_vec(call).map_err(|e| e.to_string())?;
    line.push(b'\n');
    // A child that died at once cannot read its call; its exit status says why below.
    let _ = stdin.write_all(&line).and_then(|_| stdin.flush());

    let mut cancel_sent = false;
    let answer = loop {
        let now = Instant::now();
        if now >= deadline {
            let tail = finish(child, &stderr_tail);
            return Err(format!(
                "did not finish within {} and was killed{tail}",
                seconds(timeout)
            ));
        }
        match rx.recv_timeout((deadline - now).min(Duration::from_millis(100))) {
            Ok(Ok(Reply::Progress {
                done,
                total,
                message,
            })) => progress(done, total, &message),
            Ok(Ok(reply)) => break Ok(reply),
            Ok(Err(e)) => break Err(e),
            Err(mpsc::RecvTimeoutError::Timeout) => {
                if !cancel_sent && cancelled() {
                    cancel_sent = true;
                    let _ = stdin
                        .write_all(format!("{CANCEL}\n").as_bytes())
                        .and_then(|_| stdin.flush());
                }
            }
            Err(mpsc::RecvTimeoutError::Disconnected) => {
                let status = wait_briefly(child);
                let tail = finish(child, &stderr_tail);
                return Err(match status {
                    Some(s) => format!("{}{tail}", died(s)),
                    None => format!("closed its output without answering{tail}"),
                });
            }
        }
    };
    drop(stdin);
    match answer {
        Ok(reply) => {
            // It answered; it should exit now. A child that lingers is killed by the caller.
            let _ = wait_until(child, Instant::now() + EXIT_GRACE);
            Ok(reply)
        }
        Err(e) => {
            let tail = finish(child, &stderr_tail);
            Err(format!("{e}{tail}"))
        }
    }
}

/// Ends the child's process group and returns the end of its stderr as
/// `"; its stderr ends: …"` (empty when it wrote nothing).
fn finish(child: &mut Child, stderr_tail: &mpsc::Receiver<String>) -> String {
    ProcessGroup(child.id()).kill();
    let _ = child.kill();
    let _ = child.wait();
    // The pipe closes once every process holding it is gone; one that left the group
    // could hold it open, so the wait is bounded.
    let tail = stderr_tail
        .recv_timeout(Duration::from_secs(2))
        .unwrap_or_default();
    let tail = tail.trim();
    if tail.is_empty() {
        String::new()
    } else {
        format!("; its stderr ends:\n{tail}")
    }
}

/// The exit status, if the child exits within a second of closing its output.
fn wait_briefly(child: &mut Child) -> Option<std::process::ExitStatus> {
    wait_until(child, Instant::now() + Duration::from_secs(1))
}

fn wait_until(child: &mut Child, deadline: Instant) -> Option<std::process::ExitStatus> {
    loop {
        match child.try_wait() {
            Ok(Some(s)) => return Some(s),
            Ok(None) if Instant::now() < deadline => std::thread::sleep(Duration::from_millis(5)),
            _ => return None,
        }
    }
}

/// What an exit without an answer means, in words.
fn died(status: std::process::ExitStatus) -> String {
    #[cfg(unix)]
    if let Some(sig) = std::os::unix::process::ExitStatusExt::signal(&status) {
        let name = match sig {
            4 => " (SIGILL: illegal instruction)",
            6 => " (SIGABRT: aborted, e.g. abort() or a stack overflow)",
            7 => " (SIGBUS: bus error)",
            8 => " (SIGFPE: arithmetic error)",
            9 => " (SIGKILL: killed)",
            11 => " (SIGSEGV: invalid memory access)",
            _ => "",
        };
        return format!("crashed: killed by signal {sig}{name}");
    }
    match status.code() {
        Some(code) => {
            format!("exited (status {code}) without answering: the library ended its process")
        }
        None => format!("ended ({status}) without answering"),
    }
}

fn seconds(d: Duration) -> String {
    let s = d.as_secs_f64();
    if s.fract() == 0.0 {
        format!("{s:.0} s")
    } else {
        format!("{s} s")
    }
}

/// Reads a pipe to its end, keeping the last [`STDERR_TAIL`] bytes.
fn keep_tail(mut pipe: impl Read) -> String {
    let mut tail: Vec<u8> = Vec::new();
    let mut buf = [0u8; 8192];
    while let Ok(n) = pipe.read(&mut buf) {
        if n == 0 {
            break;
        }
        tail.extend_from_slice(&buf[..n]);
        if tail.len() > 2 * STDERR_TAIL {
            tail.drain(..tail.len() - STDERR_TAIL);
        }
    }
    let start = tail.len().saturating_sub(STDERR_TAIL);
    let text = String::from_utf8_lossy(&tail[start..]).into_owned();
    if start > 0 {
        format!("…{text}")
    } else {
        text
    }
}

/// The process group a child leads (its id is the child's pid).
struct ProcessGroup(u32);

impl ProcessGroup {
    fn kill(&self) {
        #[cfg(unix)]
        if let Ok(pgid) = libc::pid_t::try_from(self.0) {
            // SAFETY: kill(2) with a negative pid signals that process group only; the
            // group was created for this child by spawn (process_group(0)).
            unsafe { libc::kill(-pgid, libc::SIGKILL) };
        }
    }
}
