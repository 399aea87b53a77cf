//! A small DevTools client: Debian's Chromium driven over
//! `--remote-debugging-pipe`.
//!
//! Ours rather than the `headless_chrome` crate: that crate generates
//! bindings for the whole DevTools protocol, one crate compile of about
//! 166 s on two cores that sat on the critical path of CI's host test
//! build, for the 17 methods the rig uses ([`METHODS`]). The pipe needs no
//! WebSocket and no HTTP: Chromium reads commands from its fd 3 and writes
//! answers and events to its fd 4, each message one JSON object ended by a
//! NUL byte. One page target, attached in flat mode (commands carry its
//! `sessionId`).
//!
//! Bounds: every call waits at most [`CALL_LIMIT`] for its answer, the
//! first one (Chromium's start) at most [`START_LIMIT`], a navigation's
//! load at most the limit its caller gives; a message is at most
//! [`MAX_MESSAGE`] bytes; at most [`EVENT_BOUND`] events are kept (only
//! the few kinds a wait looks for, the oldest dropped at the bound). An
//! error answer is an [`Error::Answer`] naming the method, code and
//! message; Chromium ending is an [`Error::Ended`] with its exit status
//! and the end of its stderr. The process (in a process group of its own)
//! is killed with its children on drop and its profile directory removed.

use std::collections::VecDeque;
use std::fmt;
use std::io::{BufRead, BufReader, PipeReader, PipeWriter, Read, Write};
use std::os::fd::AsRawFd;
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use serde_json::{json, Value};

/// The DevTools methods the rig calls (the whole of what this client
/// speaks).
pub const METHODS: [&str; 17] = [
    "Target.getTargets",
    "Target.createTarget",
    "Target.attachToTarget",
    "Page.enable",
    "Page.setLifecycleEventsEnabled",
    "Page.navigate",
    "Page.getLayoutMetrics",
    "Page.captureScreenshot",
    "Runtime.evaluate",
    "Input.dispatchMouseEvent",
    "Input.dispatchKeyEvent",
    "Input.insertText",
    "DOM.setFileInputFiles",
    "Emulation.setDeviceMetricsOverride",
    "Emulation.clearDeviceMetricsOverride",
    "Network.enable",
    "Network.emulateNetworkConditions",
];

/// Longest wait for the answer to one call.
pub const CALL_LIMIT: Duration = Duration::from_secs(40);

/// Longest wait for Chromium's first answer (its start).
pub const START_LIMIT: Duration = Duration::from_secs(30);

/// Largest message read from Chromium (a full-page screenshot in base64
/// is a few MB); a larger one ends the connection with an error.
pub const MAX_MESSAGE: usize = 64 << 20;

/// Events kept for a wait (the oldest is dropped at the bound).
pub const EVENT_BOUND: usize = 64;

/// Messages from the reader thread not yet taken (answers and kept
/// events); the reader waits when it is full.
const QUEUE: usize = 256;

/// The events a wait may look for; every other event is dropped as it is
/// read (`Network.*` after `Network.enable` would otherwise pile up).
const KEPT_EVENTS: [&str; 4] = [
    "Page.lifecycleEvent",
    "Inspector.targetCrashed",
    "Target.targetCrashed",
    "Target.detachedFromTarget",
];

/// Longest wait for the exit status of a Chromium whose pipe closed.
const STATUS_LIMIT: Duration = Duration::from_secs(2);

/// Lines of Chromium's stderr quoted when it ends.
const LOG_TAIL: usize = 15;

/// What went wrong talking to Chromium.
#[derive(Debug)]
pub enum Error {
    /// Chromium could not be started.
    Launch(String),
    /// Chromium answered `method` with an error.
    Answer {
        /// The method called.
        method: String,
        /// The protocol's error code.
        code: i64,
        /// The protocol's error message.
        message: String,
    },
    /// Chromium ended (or closed its pipe) while `method` waited.
    Ended {
        /// The method (or event) waited for.
        method: String,
        /// Its exit status, as far as known.
        status: String,
        /// The last lines of its stderr.
        log: String,
    },
    /// No answer to `method` within `limit`.
    Timeout {
        /// The method (or event) waited for.
        method: String,
        /// How long it waited.
        limit: Duration,
    },
    /// Writing to or reading from the pipe failed.
    Io {
        /// The method being sent.
        method: String,
        /// The error.
        error: std::io::Error,
    },
    /// The page could not do what was asked (navigation refused, a script
    /// threw, no such element, a tab crashed).
    Page(String),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Launch(m) => write!(f, "starting Chromium: {m}"),
            Error::Answer {
                method,
                code,
                message,
            } => write!(f, "{method}: Chromium answered error {code}: {message}"),
            Error::Ended {
                method,
                status,
                log,
            } => write!(
                f,
                "Chromium ended ({status}) while waiting for {method}; the end of its stderr:\n{log}"
            ),
            Error::Timeout { method, limit } => {
                write!(f, "{method}: no answer from Chromium in {limit:?}")
            }
            Error::Io { method, error } => write!(f, "{method}: the DevTools pipe: {error}"),
            Error::Page(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for Error {}

/// The connection and the process it talks to, shared by the
/// [`Browser`] and its [`Tab`].
struct Conn {
    state: Mutex<State>,
    child: Mutex<Child>,
    /// Chromium's stderr.
    log: PathBuf,
}

struct State {
    to_chromium: PipeWriter,
    from_reader: Receiver<Value>,
    next_id: u64,
    events: VecDeque<Value>,
    /// Set once the reader has ended (Chromium gone).
    ended: bool,
}

impl Conn {
    fn state(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn ended(&self, method: &str) -> Error {
        let status = {
            // Its pipe closes as it ends, a moment before its status can be
            // read: a short bounded wait for it.
            let mut child = self.child.lock().unwrap_or_else(|e| e.into_inner());
            let start = Instant::now();
            loop {
                match child.try_wait() {
                    Ok(Some(s)) => break s.to_string(),
                    Ok(None) if start.elapsed() < STATUS_LIMIT => {
                        std::thread::sleep(Duration::from_millis(10));
                    }
                    Ok(None) => break "still running, its pipe closed".to_string(),
                    Err(e) => break format!("status unknown: {e}"),
                }
            }
        };
        let text = std::fs::read_to_string(&self.log).unwrap_or_default();
        let lines: Vec<&str> = text.lines().collect();
        let log = lines[lines.len().saturating_sub(LOG_TAIL)..].join("\n");
        Error::Ended {
            method: method.to_string(),
            status,
            log,
        }
    }

    /// Sends `method` (to the page `session`, or the browser) and waits
    /// at most `limit` for its answer's `result`.
    fn call(
        &self,
        session: Option<&str>,
        method: &str,
        params: Value,
        limit: Duration,
    ) -> Result<Value, Error> {
        let mut st = self.state();
        if st.ended {
            return Err(self.ended(method));
        }
        st.next_id += 1;
        let id = st.next_id;
        let mut msg = json!({"id": id, "method": method, "params": params});
        if let Some(s) = session {
            msg["sessionId"] = Value::String(s.to_string());
        }
        let mut bytes = msg.to_string().into_bytes();
        bytes.push(0);
        if let Err(error) = st.to_chromium.write_all(&bytes) {
            return Err(if error.kind() == std::io::ErrorKind::BrokenPipe {
                st.ended = true;
                self.ended(method)
            } else {
                Error::Io {
                    method: method.to_string(),
                    error,
                }
            });
        }
        let deadline = Instant::now() + limit;
        loop {
            let v = self.next(&mut st, method, deadline, limit)?;
            match v.get("id").and_then(Value::as_u64) {
                Some(got) if got == id => {
                    if let Some(e) = v.get("error") {
                        return Err(Error::Answer {
                            method: method.to_string(),
                            code: e.get("code").and_then(Value::as_i64).unwrap_or(0),
                            message: e
                                .get("message")
                                .and_then(Value::as_str)
                                .unwrap_or_default()
                                .to_string(),
                        });
                    }
                    return Ok(v.get("result").cloned().unwrap_or(Value::Null));
                }
                // The late answer of a call that timed out: nobody waits.
                Some(_) => {}
                None => keep_event(&mut st.events, v),
            }
        }
    }

    /// Waits at most `limit` for an event `f` accepts (one kept earlier
    /// or one still to come) and takes it.
    fn wait_event(
        &self,
        what: &str,
        limit: Duration,
        mut f: impl FnMut(&Value) -> Result<bool, Error>,
    ) -> Result<Value, Error> {
        let mut st = self.state();
        let mut i = 0;
        while i < st.events.len() {
            if f(&st.events[i])? {
                return Ok(st.events.remove(i).unwrap_or_default());
            }
            i += 1;
        }
        let deadline = Instant::now() + limit;
        loop {
            let v = self.next(&mut st, what, deadline, limit)?;
            if v.get("id").is_some() {
                continue;
            }
            if f(&v)? {
                return Ok(v);
            }
            keep_event(&mut st.events, v);
        }
    }

    /// Drops the events kept so far.
    fn forget_events(&self) {
        self.state().events.clear();
    }

    /// The next message from the reader, by `deadline`.
    fn next(
        &self,
        st: &mut State,
        what: &str,
        deadline: Instant,
        limit: Duration,
    ) -> Result<Value, Error> {
        let left = deadline.saturating_duration_since(Instant::now());
        match st.from_reader.recv_timeout(left) {
            Ok(v) => Ok(v),
            Err(RecvTimeoutError::Timeout) => Err(Error::Timeout {
                method: what.to_string(),
                limit,
            }),
            Err(RecvTimeoutError::Disconnected) => {
                st.ended = true;
                Err(self.ended(what))
            }
        }
    }
}

/// Keeps `v`, dropping the oldest event at [`EVENT_BOUND`].
fn keep_event(events: &mut VecDeque<Value>, v: Value) {
    if events.len() >= EVENT_BOUND {
        events.pop_front();
    }
    events.push_back(v);
}

/// Reads Chromium's messages until its pipe closes (or a message is
/// larger than [`MAX_MESSAGE`], or not JSON); passes on answers and the
/// [`KEPT_EVENTS`]. Ending drops the sender: waits then see Chromium gone.
fn read_messages(from: PipeReader, to: SyncSender<Value>) {
    let mut from = BufReader::new(from);
    let mut buf = Vec::new();
    loop {
        buf.clear();
        let limit = (MAX_MESSAGE + 1) as u64;
        match (&mut from).take(limit).read_until(0, &mut buf) {
            Ok(0) | Err(_) => return,
            Ok(_) => {}
        }
        if buf.pop() != Some(0) {
            // Too long, or cut off by the end of the pipe.
            return;
        }
        let Ok(v) = serde_json::from_slice::<Value>(&buf) else {
            return;
        };
        let keep = v.get("id").is_some()
            || v.get("method")
                .and_then(Value::as_str)
                .is_some_and(|m| KEPT_EVENTS.contains(&m));
        if keep && to.send(v).is_err() {
            return;
        }
    }
}

/// Headless Chromium with its DevTools pipe. Killed (with its children)
/// on drop, its profile directory removed.
pub struct Browser {
    conn: Arc<Conn>,
    /// The process's id (and its process group's).
    pid: i32,
    /// The profile directory and the stderr log.
    dir: PathBuf,
}

impl Browser {
    /// Starts `chromium` headless with a fresh profile, a window of
    /// `window` CSS pixels and `extra` switches; returns once it answers.
    pub fn launch(chromium: &Path, window: (u32, u32), extra: &[&str]) -> Result<Browser, Error> {
        static RUN: AtomicU32 = AtomicU32::new(0);
        let dir = std::env::temp_dir().join(format!(
            "hans-web-e2e-chromium-{}-{}",
            std::process::id(),
            RUN.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&dir);
        let launch = |what: &str, e: std::io::Error| Error::Launch(format!("{what}: {e}"));
        std::fs::create_dir_all(dir.join("profile")).map_err(|e| launch("profile directory", e))?;
        let log = dir.join("stderr.log");
        let stderr = std::fs::File::create(&log).map_err(|e| launch("stderr log", e))?;
        // Commands: we write, Chromium reads its fd 3. Answers and events:
        // Chromium writes its fd 4, we read.
        let (cmd_read, cmd_write) = std::io::pipe().map_err(|e| launch("pipe", e))?;
        let (ans_read, ans_write) = std::io::pipe().map_err(|e| launch("pipe", e))?;
        let (cmd_fd, ans_fd) = (cmd_read.as_raw_fd(), ans_write.as_raw_fd());
        let mut cmd = Command::new(chromium);
        cmd.arg("--remote-debugging-pipe")
            .arg(format!("--user-data-dir={}", dir.join("profile").display()))
            .arg("--headless")
            .arg(format!("--window-size={},{}", window.0, window.1))
            .args(SWITCHES)
            .args(extra)
            .arg("about:blank")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(stderr)
            // Its own process group: the drop kills its children too.
            .process_group(0);
        // SAFETY: between fork and exec only async-signal-safe calls
        // (fcntl, dup2) on descriptors this process owns. Both ends are
        // first copied above 10 (close-on-exec) so that placing one on 3
        // or 4 cannot overwrite the other; dup2 clears close-on-exec on 3
        // and 4 only.
        unsafe {
            cmd.pre_exec(move || {
                let a = libc::fcntl(cmd_fd, libc::F_DUPFD_CLOEXEC, 10);
                let b = libc::fcntl(ans_fd, libc::F_DUPFD_CLOEXEC, 10);
                if a < 0 || b < 0 || libc::dup2(a, 3) < 0 || libc::dup2(b, 4) < 0 {
                    return Err(std::io::Error::last_os_error());
                }
                Ok(())
            });
        }
        let child = cmd
            .spawn()
            .map_err(|e| launch(&chromium.display().to_string(), e))?;
        // Chromium's ends are its own now: with ours closed, its death
        // closes the answer pipe.
        drop((cmd_read, ans_write));
        let pid = i32::try_from(child.id()).unwrap_or(i32::MAX);
        let (tx, rx) = mpsc::sync_channel(QUEUE);
        std::thread::Builder::new()
            .name("chromium-pipe".into())
            .spawn(move || read_messages(ans_read, tx))
            .map_err(|e| launch("the pipe's reader thread", e))?;
        let browser = Browser {
            conn: Arc::new(Conn {
                state: Mutex::new(State {
                    to_chromium: cmd_write,
                    from_reader: rx,
                    next_id: 0,
                    events: VecDeque::new(),
                    ended: false,
                }),
                child: Mutex::new(child),
                log,
            }),
            pid,
            dir,
        };
        browser
            .conn
            .call(None, "Target.getTargets", json!({}), START_LIMIT)
            .map_err(|e| Error::Launch(e.to_string()))?;
        Ok(browser)
    }

    /// The process's id (also its process group's).
    pub fn pid(&self) -> u32 {
        self.pid.unsigned_abs()
    }

    /// A new page (about:blank), attached.
    pub fn new_tab(&self) -> Result<Tab, Error> {
        let c = &self.conn;
        let t = c.call(
            None,
            "Target.createTarget",
            json!({"url": "about:blank"}),
            CALL_LIMIT,
        )?;
        let target = str_field(&t, "targetId", "Target.createTarget")?;
        let a = c.call(
            None,
            "Target.attachToTarget",
            json!({"targetId": target, "flatten": true}),
            CALL_LIMIT,
        )?;
        let session = str_field(&a, "sessionId", "Target.attachToTarget")?;
        let tab = Tab {
            conn: Arc::clone(c),
            session,
            target,
            loading: Mutex::new(None),
        };
        tab.call("Page.enable", json!({}))?;
        tab.call("Page.setLifecycleEventsEnabled", json!({"enabled": true}))?;
        Ok(tab)
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        // SIGKILL to the whole process group (Chromium is its leader),
        // then reap the leader; nothing to wait for beyond that.
        // SAFETY: kill(2) with a negative pid names our child's group.
        unsafe {
            libc::kill(-self.pid, libc::SIGKILL);
        }
        let mut child = self.conn.child.lock().unwrap_or_else(|e| e.into_inner());
        let _ = child.kill();
        let _ = child.wait();
        drop(child);
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// Common Chromium switches for a quiet, deterministic browser that only
/// shows our page: no background traffic, updates, extensions, crash
/// reporting or first-run UI, no throttling of a page in the background,
/// no GPU, sRGB colours (stable screenshots), no sandbox (it refuses to
/// run as root, as CI does; the browser only shows our own page on
/// 127.0.0.1).
const SWITCHES: &[&str] = &[
    "--no-sandbox",
    "--disable-gpu",
    "--no-first-run",
    "--no-default-browser-check",
    "--disable-background-networking",
    "--disable-background-timer-throttling",
    "--disable-backgrounding-occluded-windows",
    "--disable-renderer-backgrounding",
    "--disable-breakpad",
    "--disable-client-side-phishing-detection",
    "--disable-component-extensions-with-background-pages",
    "--disable-default-apps",
    "--disable-dev-shm-usage",
    "--disable-extensions",
    "--disable-features=TranslateUI",
    "--disable-hang-monitor",
    "--disable-ipc-flooding-protection",
    "--disable-popup-blocking",
    "--disable-prompt-on-repost",
    "--disable-sync",
    "--force-color-profile=srgb",
    "--metrics-recording-only",
    "--enable-automation",
    "--password-store=basic",
    "--use-mock-keychain",
    // The host-name check's test opens `gw.localhost`, which Chromium
    // resolves itself to ::1 and 127.0.0.1 and tries on ::1 first (seen:
    // two connections to a listener on [::1] and none to 127.0.0.1):
    // whatever else listened on [::1] with the gateway's port number
    // answered instead (CI: ERR_SOCKET_NOT_CONNECTED). The gateway listens
    // on 127.0.0.1 only. (`localhost` itself is not mapped: mapped, the
    // QEMU test's navigation to it met an empty answer once; not
    // understood yet, see the closing note of 2026-11-30.)
    "--host-resolver-rules=MAP gw.localhost 127.0.0.1",
];

fn str_field(v: &Value, name: &str, method: &str) -> Result<String, Error> {
    v.get(name)
        .and_then(Value::as_str)
        .map(str::to_string)
        .ok_or_else(|| Error::Page(format!("{method}: no {name} in the answer {v}")))
}

/// One page of the [`Browser`].
pub struct Tab {
    conn: Arc<Conn>,
    session: String,
    /// Its target's id.
    target: String,
    /// The loader of the navigation [`Tab::navigate_to`] started and
    /// [`Tab::wait_until_navigated`] has not yet seen loaded.
    loading: Mutex<Option<String>>,
}

impl Tab {
    /// Calls `method` on this page (answer within [`CALL_LIMIT`]).
    pub fn call(&self, method: &str, params: Value) -> Result<Value, Error> {
        self.conn
            .call(Some(&self.session), method, params, CALL_LIMIT)
    }

    /// Starts loading `url` (see [`Tab::wait_until_navigated`]); an error
    /// if the browser refuses it (its `errorText`).
    pub fn navigate_to(&self, url: &str) -> Result<&Tab, Error> {
        self.conn.forget_events();
        let r = self.call("Page.navigate", json!({"url": url}))?;
        if let Some(e) = r.get("errorText").and_then(Value::as_str) {
            return Err(Error::Page(format!("navigating to {url}: {e}")));
        }
        // No loader: a navigation within the document, already done.
        *self.loading.lock().unwrap_or_else(|e| e.into_inner()) = r
            .get("loaderId")
            .and_then(Value::as_str)
            .map(str::to_string);
        Ok(self)
    }

    /// Waits (at most `crate::WAIT`) until the navigation
    /// [`Tab::navigate_to`] started has fired the page's `load`.
    pub fn wait_until_navigated(&self) -> Result<&Tab, Error> {
        let Some(loader) = self
            .loading
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .take()
        else {
            return Ok(self);
        };
        let (session, target) = (self.session.as_str(), self.target.as_str());
        self.conn
            .wait_event("the page's load event", crate::WAIT, |e| {
                let ours = e.get("sessionId").and_then(Value::as_str) == Some(session);
                let p = &e["params"];
                let gone = || Error::Page(format!("the page went away while loading: {e}"));
                match e.get("method").and_then(Value::as_str).unwrap_or_default() {
                    "Page.lifecycleEvent" => Ok(ours
                        && p["name"] == "load"
                        && p["loaderId"].as_str() == Some(loader.as_str())),
                    "Inspector.targetCrashed" if ours => Err(gone()),
                    "Target.detachedFromTarget" if p["sessionId"].as_str() == Some(session) => {
                        Err(gone())
                    }
                    "Target.targetCrashed" if p["targetId"].as_str() == Some(target) => Err(gone()),
                    _ => Ok(false),
                }
            })?;
        Ok(self)
    }

    /// Evaluates the script expression `expr` (its promise awaited if
    /// `await_promise`) and returns its value (`Runtime.RemoteObject`'s
    /// `value`, by value); an error if it throws.
    pub fn evaluate(&self, expr: &str, await_promise: bool) -> Result<Value, Error> {
        let r = self.call(
            "Runtime.evaluate",
            json!({"expression": expr, "awaitPromise": await_promise, "returnByValue": true}),
        )?;
        thrown(&r)?;
        Ok(r["result"].get("value").cloned().unwrap_or(Value::Null))
    }

    /// Clicks the element with id `id` with the left mouse button at its
    /// middle, scrolled to the middle of the window first unless it is
    /// wholly in view.
    pub fn click_id(&self, id: &str) -> Result<(), Error> {
        let at = self.evaluate(
            &format!(
                "(() => {{ const e = document.getElementById({}); if (!e) return null; \
                 const inView = r => r.top >= 0 && r.left >= 0 && r.bottom <= innerHeight && r.right <= innerWidth; \
                 if (!inView(e.getBoundingClientRect())) \
                   e.scrollIntoView({{block: 'center', inline: 'center', behavior: 'instant'}}); \
                 const r = e.getBoundingClientRect(); \
                 return {{x: r.left + r.width / 2, y: r.top + r.height / 2}}; }})()",
                Value::String(id.to_string())
            ),
            false,
        )?;
        let (Some(x), Some(y)) = (at["x"].as_f64(), at["y"].as_f64()) else {
            return Err(Error::Page(format!("no element #{id} on the page")));
        };
        for kind in ["mouseMoved", "mousePressed", "mouseReleased"] {
            let mut p = json!({"type": kind, "x": x, "y": y});
            if kind != "mouseMoved" {
                p["button"] = json!("left");
                p["clickCount"] = json!(1);
            }
            self.call("Input.dispatchMouseEvent", p)?;
        }
        Ok(())
    }

    /// Types `text` into the focused element, as an input method does.
    pub fn send_character(&self, text: &str) -> Result<&Tab, Error> {
        self.call("Input.insertText", json!({"text": text}))?;
        Ok(self)
    }

    /// Presses and releases the key `key` (`Enter`, `Tab`, `Escape`,
    /// `Backspace`, `Delete`).
    pub fn press_key(&self, key: &str) -> Result<&Tab, Error> {
        let (code, text) = match key {
            "Backspace" => (8, None),
            "Tab" => (9, None),
            "Enter" => (13, Some("\r")),
            "Escape" => (27, None),
            "Delete" => (46, None),
            _ => return Err(Error::Page(format!("press_key: unknown key {key:?}"))),
        };
        let mut down = json!({
            "type": "rawKeyDown", "key": key, "code": key,
            "windowsVirtualKeyCode": code, "nativeVirtualKeyCode": code,
        });
        if let Some(t) = text {
            down["type"] = json!("keyDown");
            down["text"] = json!(t);
        }
        self.call("Input.dispatchKeyEvent", down)?;
        self.call(
            "Input.dispatchKeyEvent",
            json!({
                "type": "keyUp", "key": key, "code": key,
                "windowsVirtualKeyCode": code, "nativeVirtualKeyCode": code,
            }),
        )?;
        Ok(self)
    }

    /// Sets the files of the file input with id `id`.
    pub fn set_input_files(&self, id: &str, files: &[&str]) -> Result<(), Error> {
        let r = self.call(
            "Runtime.evaluate",
            json!({"expression": format!("document.getElementById({})", Value::String(id.to_string()))}),
        )?;
        thrown(&r)?;
        let Some(object) = r["result"].get("objectId").and_then(Value::as_str) else {
            return Err(Error::Page(format!("no element #{id} on the page")));
        };
        self.call(
            "DOM.setFileInputFiles",
            json!({"files": files, "objectId": object}),
        )?;
        Ok(())
    }
}

/// An error if `Runtime.evaluate`'s answer `r` says the script threw.
fn thrown(r: &Value) -> Result<(), Error> {
    match r.get("exceptionDetails") {
        None => Ok(()),
        Some(d) => {
            let text = d["exception"]["description"]
                .as_str()
                .or_else(|| d["text"].as_str())
                .unwrap_or_default();
            Err(Error::Page(format!("the script threw: {text}")))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every process (not a zombie) with its state and parent.
    fn processes() -> Vec<(u32, u32)> {
        let mut found = Vec::new();
        for e in std::fs::read_dir("/proc").unwrap().flatten() {
            let Ok(pid) = e.file_name().to_string_lossy().parse::<u32>() else {
                continue;
            };
            let Ok(stat) = std::fs::read_to_string(e.path().join("stat")) else {
                continue;
            };
            // After the command's closing parenthesis: state, ppid.
            let Some(rest) = stat.rsplit_once(") ").map(|(_, r)| r) else {
                continue;
            };
            let f: Vec<&str> = rest.split(' ').collect();
            if f[0] != "Z" {
                found.push((pid, f[1].parse().unwrap_or(0)));
            }
        }
        found
    }

    /// `pid` and its descendants that are running.
    fn tree(pid: u32) -> Vec<u32> {
        let all = processes();
        let mut found = vec![pid];
        let mut i = 0;
        while i < found.len() {
            let parent = found[i];
            found.extend(all.iter().filter(|p| p.1 == parent).map(|p| p.0));
            i += 1;
        }
        found.retain(|p| all.iter().any(|q| q.0 == *p));
        found
    }

    /// One browser at a time, as the rig's tests.
    static ONE: Mutex<()> = Mutex::new(());

    fn launch() -> Browser {
        Browser::launch(Path::new(crate::CHROMIUM), crate::DESKTOP, &[])
            .unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn chromium_is_killed_with_its_children_on_drop_and_its_profile_removed() {
        let _one = ONE.lock().unwrap_or_else(|e| e.into_inner());
        let b = launch();
        let tab = b.new_tab().unwrap();
        tab.navigate_to("data:text/html,<p>x</p>")
            .and_then(Tab::wait_until_navigated)
            .unwrap();
        let (pid, dir) = (b.pid(), b.dir.clone());
        let before = tree(pid);
        assert!(before.len() > 1, "Chromium and its children: {before:?}");
        assert!(dir.join("profile").exists());
        drop(tab);
        drop(b);
        // SIGKILL has been sent to all of them; each ends as it is next
        // scheduled.
        let running = || {
            let now: Vec<u32> = processes().iter().map(|p| p.0).collect();
            before.iter().filter(|p| now.contains(p)).count()
        };
        let start = Instant::now();
        while running() > 0 {
            assert!(
                start.elapsed() < crate::WAIT,
                "{} of {before:?} still running",
                running()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        assert!(!dir.exists(), "{} left behind", dir.display());
    }

    #[test]
    fn an_error_answer_names_the_method_code_and_message_and_a_dead_chromium_says_so() {
        let _one = ONE.lock().unwrap_or_else(|e| e.into_inner());
        let b = launch();
        let tab = b.new_tab().unwrap();
        let e = tab.call("Page.noSuchMethod", json!({})).unwrap_err();
        assert!(
            matches!(&e, Error::Answer { method, code: -32601, message }
                if method == "Page.noSuchMethod" && message.contains("wasn't found")),
            "{e:?}"
        );
        let e = tab.evaluate("throw new Error('boom')", false).unwrap_err();
        assert!(e.to_string().contains("Error: boom"), "{e}");
        // SAFETY: kill(2) of the process group our Browser started.
        unsafe {
            libc::kill(-(b.pid() as i32), libc::SIGKILL);
        }
        let e = tab.evaluate("1", false).unwrap_err();
        assert!(
            matches!(&e, Error::Ended { method, status, .. }
                if method == "Runtime.evaluate" && status.contains("signal: 9")),
            "{e:?}"
        );
        assert!(
            e.to_string().starts_with(
                "Chromium ended (signal: 9 (SIGKILL)) while waiting for Runtime.evaluate"
            ),
            "{e}"
        );
    }

    #[test]
    fn events_are_kept_up_to_the_bound_dropping_the_oldest() {
        let mut q = VecDeque::new();
        for i in 0..EVENT_BOUND + 3 {
            keep_event(&mut q, json!(i));
        }
        assert_eq!(q.len(), EVENT_BOUND);
        assert_eq!(q.front(), Some(&json!(3)));
    }

    #[test]
    fn the_reader_splits_at_nul_drops_other_events_and_stops_at_a_bad_message() {
        let (r, mut w) = std::io::pipe().unwrap();
        let (tx, rx) = mpsc::sync_channel(QUEUE);
        let reader = std::thread::spawn(move || read_messages(r, tx));
        w.write_all(b"{\"id\":1,\"result\":{}}\0{\"method\":\"Network.dataReceived\"}\0")
            .unwrap();
        w.write_all(b"{\"method\":\"Page.lifecycleEvent\",\"params\":{\"name\":\"load\"}}\0not json\0{\"id\":2}\0")
            .unwrap();
        drop(w);
        reader.join().unwrap();
        let got: Vec<Value> = rx.try_iter().collect();
        assert_eq!(got.len(), 2, "{got:?}");
        assert_eq!(got[0]["id"], 1);
        assert_eq!(got[1]["params"]["name"], "load");
    }
}
