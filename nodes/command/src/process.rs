//! Running an external program: an argv list started directly (never through a shell),
//! in a working folder, with stdin closed and stdout discarded. Its stderr is drained on
//! a thread (a chatty program cannot block on a full pipe) and the last few KB are
//! returned, or quoted in the error when the program fails. A program that reports on
//! stdout too (COLMAP prints its progress and some errors there) can instead write both
//! streams into a log file ([`Program::run_logged`]), whose tail is quoted the same way.
//! Past the timeout, or when the run is interrupted, the program is killed with every
//! process it started (it runs in its own process group on Unix); processes it leaves
//! behind when it exits are killed too.

use anyhow::{Context, Result, bail};
use std::ffi::OsString;
use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use wait_timeout::ChildExt;

/// How much of the program's stderr is kept.
pub const STDERR_TAIL: usize = 4000;

/// How often a waiting run checks whether it was interrupted.
const POLL: Duration = Duration::from_millis(200);

/// One program run.
pub struct Program<'a> {
    /// What the program is, for messages (e.g. "inpainting command").
    pub what: &'a str,
    /// The program and its arguments; must not be empty.
    pub argv: Vec<OsString>,
    pub workdir: &'a Path,
    pub timeout: Duration,
    /// Polled while the program runs; `true` kills it.
    pub cancelled: &'a dyn Fn() -> bool,
}

impl Program<'_> {
    /// Runs the program to completion; returns the tail of its stderr ("(empty)" when
    /// it wrote none). A non-zero exit, a timeout or an interruption is an error that
    /// names the program and quotes that tail.
    pub fn run(&self) -> Result<String> {
        self.run_with(None)
    }

    /// Runs the program with its stdout and stderr both written to `log` (created or
    /// truncated), in the order the program wrote them; returns the log's tail, which a
    /// failure quotes instead of stderr's.
    pub fn run_logged(&self, log: &Path) -> Result<String> {
        self.run_with(Some(log))
    }

    fn run_with(&self, log: Option<&Path>) -> Result<String> {
        let Some((program, args)) = self.argv.split_first() else {
            bail!("the {} is empty", self.what);
        };
        let name = program.to_string_lossy().into_owned();
        let mut command = Command::new(program);
        command
            .args(args)
            .current_dir(self.workdir)
            .stdin(Stdio::null());
        match log {
            Some(path) => {
                let file = std::fs::File::create(path)
                    .with_context(|| format!("{}: cannot create the log", path.display()))?;
                let clone = file
                    .try_clone()
                    .with_context(|| format!("{}: cannot share the log", path.display()))?;
                command.stdout(clone).stderr(file);
            }
            None => {
                command.stdout(Stdio::null()).stderr(Stdio::piped());
            }
        }
        // Its own process group, so a kill reaches the processes it starts too (a shell's
        // children, a Python script's workers).
        #[cfg(unix)]
        std::os::unix::process::CommandExt::process_group(&mut command, 0);
        let mut child = command
            .spawn()
            .with_context(|| format!("cannot start {} {name:?}", self.what))?;
        let receiver = child.stderr.take().map(|mut stderr_pipe| {
            let (sender, receiver) = std::sync::mpsc::channel();
            std::thread::spawn(move || {
                let mut buf = Vec::new();
                let _ = stderr_pipe.read_to_end(&mut buf);
                let _ = sender.send(buf);
            });
            receiver
        });
        // The pipe closes when the program and every process it started have exited;
        // grandchildren that outlive a killed program must not hang the node. A log file
        // is read as it stands once the program is gone.
        let collect_stderr = || match (&receiver, log) {
            (Some(receiver), _) => receiver
                .recv_timeout(Duration::from_secs(2))
                .map(|b| tail(&b))
                .unwrap_or_else(|_| {
                    "(not available: processes started by the command still hold it)".into()
                }),
            (None, Some(path)) => std::fs::read(path)
                .map(|b| tail(&b))
                .unwrap_or_else(|e| format!("(the log {} cannot be read: {e})", path.display())),
            (None, None) => "(not captured)".into(),
        };
        let stream = if log.is_some() { "its log" } else { "stderr" };
        let started = Instant::now();
        let status = loop {
            let left = self.timeout.saturating_sub(started.elapsed());
            if let Some(status) = child
                .wait_timeout(left.min(POLL))
                .with_context(|| format!("cannot wait for {} {name:?}", self.what))?
            {
                break status;
            }
            let timed_out = started.elapsed() >= self.timeout;
            if timed_out || (self.cancelled)() {
                kill_group(&mut child);
                let stderr = collect_stderr();
                if timed_out {
                    bail!(
                        "{} {name:?} did not finish within {:.1} s and was killed; {stream}:\n{stderr}",
                        self.what,
                        self.timeout.as_secs_f64()
                    );
                }
                bail!(
                    "{} {name:?} was killed: the run was interrupted; {stream}:\n{stderr}",
                    self.what
                );
            }
        };
        // Whatever it started and left running goes with it.
        kill_group(&mut child);
        let stderr = collect_stderr();
        if !status.success() {
            bail!(
                "{} {name:?} failed ({status}); {stream}:\n{stderr}",
                self.what
            );
        }
        Ok(stderr)
    }
}

/// Kills the program and every process of its group, then reaps it. Errors mean it
/// exited in the meantime.
fn kill_group(child: &mut std::process::Child) {
    #[cfg(unix)]
    if let Ok(pid) = i32::try_from(child.id()) {
        // SAFETY: kill(2) with a negative pid signals the process group the child leads
        // (it was started with process_group(0)); it touches no memory of ours.
        unsafe {
            libc::kill(-pid, libc::SIGKILL);
        }
    }
    let _ = child.kill();
    let _ = child.wait();
}

/// The last [`STDERR_TAIL`] characters of `bytes` as text ("(empty)" for none).
pub fn tail(bytes: &[u8]) -> String {
    let text = String::from_utf8_lossy(bytes);
    let text = text.trim_end();
    if text.is_empty() {
        return "(empty)".into();
    }
    match text.char_indices().rev().nth(STDERR_TAIL) {
        Some((cut, _)) => format!("…{}", &text[cut..]),
        None => text.to_string(),
    }
}
