//! Headless Chromium driven through the DevTools protocol over `--remote-debugging-pipe`
//! (JSON messages ending in a NUL byte, commands on fd 3, replies and events on fd 4), so
//! no websocket client is needed. WebGL runs on SwiftShader.
//!
//! Needs Debian's `chromium` (or `$CHROMIUM`). Under `CI=true` a missing browser fails the
//! test; elsewhere [`Browser::launch`] returns `None` after a loud message and the test
//! returns early.

use serde_json::{Value, json};
use std::io::{BufRead, BufReader, Write};
use std::os::fd::AsRawFd;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{Receiver, RecvTimeoutError, channel};
use std::time::{Duration, Instant};

const TIMEOUT: Duration = Duration::from_secs(60);

fn find_chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .flat_map(|name| std::env::split_paths(&path).map(move |dir| dir.join(name)))
        .find(|candidate| candidate.is_file())
}

pub struct Browser {
    child: Child,
    commands: std::io::PipeWriter,
    messages: Receiver<Value>,
    /// Events received while waiting for replies, oldest first.
    pub events: Vec<Value>,
    next_id: u64,
    _profile: tempfile::TempDir,
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Browser {
    /// Starts headless Chromium, or `None` (outside CI) when it is not installed.
    pub fn launch(test: &str) -> Option<Browser> {
        let Some(chromium) = find_chromium() else {
            if std::env::var("CI").as_deref() == Ok("true") {
                panic!(
                    "chromium is not installed (apt-get install -y chromium); CI requires {test}"
                );
            }
            eprintln!(
                "\n!!!!! SKIPPED {test}: no chromium on PATH (apt-get install -y chromium) !!!!!\n"
            );
            return None;
        };
        let profile = tempfile::tempdir().unwrap();
        let (child_reads, commands) = std::io::pipe().unwrap();
        let (replies, child_writes) = std::io::pipe().unwrap();
        let (read_fd, write_fd) = (child_reads.as_raw_fd(), child_writes.as_raw_fd());
        let mut command = Command::new(&chromium);
        command
            .args([
                "--headless",
                "--remote-debugging-pipe",
                "--no-sandbox",
                "--use-angle=swiftshader",
                "--enable-unsafe-swiftshader",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--disable-quic",
                "--disable-extensions",
                "--no-first-run",
                "--no-default-browser-check",
                "--hide-scrollbars",
                "--mute-audio",
            ])
            .arg(format!("--user-data-dir={}", profile.path().display()))
            .arg("about:blank")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::null());
        // SAFETY: between fork and exec the closure only calls fcntl and dup2, which are
        // async-signal-safe; it allocates nothing. It moves the pipe ends onto the fds 3
        // and 4 that --remote-debugging-pipe reads and writes (via fds ≥ 10 first, so
        // neither dup2 can overwrite the other end).
        unsafe {
            command.pre_exec(move || {
                let high_read = libc::fcntl(read_fd, libc::F_DUPFD, 10);
                let high_write = libc::fcntl(write_fd, libc::F_DUPFD, 10);
                if high_read < 0
                    || high_write < 0
                    || libc::dup2(high_read, 3) < 0
                    || libc::dup2(high_write, 4) < 0
                {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
        let child = command
            .spawn()
            .unwrap_or_else(|e| panic!("cannot start {}: {e}", chromium.display()));
        drop(child_reads);
        drop(child_writes);
        let (sender, messages) = channel();
        std::thread::spawn(move || {
            let mut reader = BufReader::new(replies);
            loop {
                let mut message = Vec::new();
                match reader.read_until(0, &mut message) {
                    Ok(0) | Err(_) => return,
                    Ok(_) => {
                        message.pop();
                        let Ok(value) = serde_json::from_slice::<Value>(&message) else {
                            continue;
                        };
                        if sender.send(value).is_err() {
                            return;
                        }
                    }
                }
            }
        });
        Some(Browser {
            child,
            commands,
            messages,
            events: Vec::new(),
            next_id: 1,
            _profile: profile,
        })
    }

    /// Sends a command (to a page when `session` is given) and waits for its result.
    pub fn call(&mut self, session: Option<&str>, method: &str, params: Value) -> Value {
        let id = self.next_id;
        self.next_id += 1;
        let mut message = json!({"id": id, "method": method, "params": params});
        if let Some(s) = session {
            message["sessionId"] = json!(s);
        }
        let mut bytes = serde_json::to_vec(&message).unwrap();
        bytes.push(0);
        self.commands
            .write_all(&bytes)
            .unwrap_or_else(|e| panic!("cannot send {method} to chromium: {e}"));
        let deadline = Instant::now() + TIMEOUT;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.messages.recv_timeout(left) {
                Ok(reply) if reply["id"] == json!(id) => {
                    if let Some(error) = reply.get("error") {
                        panic!("{method} failed: {error}");
                    }
                    return reply["result"].clone();
                }
                Ok(event) => self.events.push(event),
                Err(RecvTimeoutError::Timeout) => panic!("{method}: no reply within {TIMEOUT:?}"),
                Err(RecvTimeoutError::Disconnected) => panic!("{method}: chromium exited"),
            }
        }
    }

    /// Waits for an event named `method` from `session` (already received ones count).
    pub fn wait_event(&mut self, session: &str, method: &str) -> Value {
        let matches = |e: &Value| e["method"] == json!(method) && e["sessionId"] == json!(session);
        if let Some(i) = self.events.iter().position(matches) {
            return self.events.remove(i);
        }
        let deadline = Instant::now() + TIMEOUT;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.messages.recv_timeout(left) {
                Ok(event) if matches(&event) => return event,
                Ok(event) => self.events.push(event),
                Err(_) => panic!("no {method} event within {TIMEOUT:?}"),
            }
        }
    }

    /// Opens a new page of `width`×`height` CSS pixels (device scale 1) at `page`, waits
    /// for its load event, and returns it with console, exception and network logging on.
    pub fn open(&mut self, page: &Path, width: u32, height: u32) -> Page<'_> {
        let target = self.call(None, "Target.createTarget", json!({"url": "about:blank"}));
        let attached = self.call(
            None,
            "Target.attachToTarget",
            json!({"targetId": target["targetId"], "flatten": true}),
        );
        let session = attached["sessionId"].as_str().unwrap().to_string();
        for domain in [
            "Page.enable",
            "Runtime.enable",
            "Log.enable",
            "Network.enable",
        ] {
            self.call(Some(&session), domain, json!({}));
        }
        self.call(
            Some(&session),
            "Emulation.setDeviceMetricsOverride",
            json!({"width": width, "height": height, "deviceScaleFactor": 1, "mobile": false}),
        );
        let url = format!("file://{}", page.display());
        self.call(Some(&session), "Page.navigate", json!({"url": url}));
        self.wait_event(&session, "Page.loadEventFired");
        Page {
            browser: self,
            session,
        }
    }
}

pub struct Page<'a> {
    pub browser: &'a mut Browser,
    pub session: String,
}

impl Page<'_> {
    fn call(&mut self, method: &str, params: Value) -> Value {
        let session = self.session.clone();
        self.browser.call(Some(&session), method, params)
    }

    /// Evaluates `expression` (awaiting a promise) and returns its JSON value, or the
    /// exception's text as the error.
    pub fn try_eval(&mut self, expression: &str) -> Result<Value, String> {
        let result = self.call(
            "Runtime.evaluate",
            json!({"expression": expression, "awaitPromise": true, "returnByValue": true}),
        );
        if let Some(details) = result.get("exceptionDetails") {
            return Err(details["exception"]["description"]
                .as_str()
                .map(str::to_string)
                .unwrap_or_else(|| details.to_string()));
        }
        Ok(result["result"]["value"].clone())
    }

    pub fn eval(&mut self, expression: &str) -> Value {
        self.try_eval(expression)
            .unwrap_or_else(|e| panic!("`{expression}` threw: {e}"))
    }

    /// A screenshot of the CSS-pixel rectangle (x, y, width, height).
    pub fn screenshot(&mut self, clip: [f64; 4]) -> image::RgbaImage {
        use base64::Engine as _;
        let shot = self.call(
            "Page.captureScreenshot",
            json!({"format": "png", "clip": {"x": clip[0], "y": clip[1], "width": clip[2], "height": clip[3], "scale": 1}}),
        );
        let bytes = base64::engine::general_purpose::STANDARD
            .decode(shot["data"].as_str().unwrap())
            .unwrap();
        image::load_from_memory(&bytes).unwrap().to_rgba8()
    }

    /// A mouse event at CSS pixel (x, y) of the page: `kind` is mousePressed, mouseMoved
    /// or mouseReleased; the left button, with `modifiers` (1 Alt, 2 Ctrl, 4 Meta, 8 Shift).
    pub fn mouse(&mut self, kind: &str, x: f64, y: f64, modifiers: u32) {
        let buttons = if kind == "mouseReleased" { 0 } else { 1 };
        self.call(
            "Input.dispatchMouseEvent",
            json!({"type": kind, "x": x, "y": y, "button": "left", "buttons": buttons, "clickCount": 1, "modifiers": modifiers}),
        );
    }

    /// Presses and releases a key (`key` as KeyboardEvent.key has it, `code` its code).
    pub fn key(&mut self, key: &str, code: &str, key_code: u32) {
        self.key_with(key, code, key_code, 0);
    }

    /// [`Page::key`] with modifiers held (1 Alt, 2 Ctrl, 4 Meta, 8 Shift).
    pub fn key_with(&mut self, key: &str, code: &str, key_code: u32, modifiers: u32) {
        for kind in ["keyDown", "keyUp"] {
            self.call(
                "Input.dispatchKeyEvent",
                json!({"type": kind, "key": key, "code": code, "windowsVirtualKeyCode": key_code, "modifiers": modifiers}),
            );
        }
    }

    /// Console errors, uncaught exceptions and error log entries seen so far.
    pub fn errors(&self) -> Vec<String> {
        self.browser
            .events
            .iter()
            .filter(|e| e["sessionId"] == json!(self.session))
            .filter_map(|e| match e["method"].as_str()? {
                "Runtime.exceptionThrown" => Some(e["params"]["exceptionDetails"].to_string()),
                "Runtime.consoleAPICalled"
                    if matches!(e["params"]["type"].as_str(), Some("error" | "assert")) =>
                {
                    Some(e["params"]["args"].to_string())
                }
                "Log.entryAdded" if e["params"]["entry"]["level"] == json!("error") => {
                    Some(e["params"]["entry"].to_string())
                }
                _ => None,
            })
            .collect()
    }

    /// The URLs of every request the page made so far.
    pub fn requests(&self) -> Vec<String> {
        self.browser
            .events
            .iter()
            .filter(|e| {
                e["sessionId"] == json!(self.session)
                    && e["method"] == json!("Network.requestWillBeSent")
            })
            .filter_map(|e| e["params"]["request"]["url"].as_str().map(str::to_string))
            .collect()
    }
}

/// A JSON array of `N` numbers, as a page's script returns a point or a rectangle.
pub fn numbers<const N: usize>(v: &Value) -> [f64; N] {
    let values: Vec<f64> = v
        .as_array()
        .unwrap_or_else(|| panic!("not an array: {v}"))
        .iter()
        .map(|x| x.as_f64().unwrap_or_else(|| panic!("not a number: {x}")))
        .collect();
    values
        .try_into()
        .unwrap_or_else(|v: Vec<f64>| panic!("{} numbers, not {N}", v.len()))
}

/// A JSON array of strings, as a page's script returns a list of names.
pub fn strings(v: &Value) -> Vec<String> {
    v.as_array()
        .unwrap_or_else(|| panic!("not an array: {v}"))
        .iter()
        .map(|x| {
            x.as_str()
                .unwrap_or_else(|| panic!("not a string: {x}"))
                .to_string()
        })
        .collect()
}
