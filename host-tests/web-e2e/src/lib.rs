//! Helpers of the browser tests: a rig of hans-sim + the host gateway (with
//! its web page) + a Modbus PLC + headless Chromium showing the page, and
//! the page driven through the DevTools protocol by our own small client
//! ([`cdp`], over Chromium's `--remote-debugging-pipe`).
//!
//! * The browser is Debian's `/usr/bin/chromium` ([`CHROMIUM`]), never a
//!   downloaded one; a machine without it fails with a message that says
//!   how to install it (`scripts/setup.sh`).
//! * Everything listens on 127.0.0.1 on ports the system picks.
//! * Every wait is bounded by [`WAIT`]; a wait that runs out takes a
//!   screenshot (`…-timeout.png`) and fails with what it waited for.
//! * Screenshots are PNG files in `screenshots/` under the cargo target
//!   directory (`target/screenshots/<test>-<step>.png`); each path is
//!   printed.
//! * One browser at a time: the tests of a binary take turns
//!   ([`WebRig::start`] holds a lock), so that two cores are not shared by
//!   several Chromiums at once.
//! * The gateway is the host library in the test's process
//!   ([`WebRig::start`]) or the QEMU board's field-device firmware
//!   ([`WebRig::start_qemu`], [`Qemu`]).

use std::future::Future;
use std::io::{Read, Write};
use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

use base64::Engine as _;
use serde_json::{json, Value};

use hans_gateway_linux::{HostOptions, RunningGateway};
use hans_sim::Sim;

pub use hans_e2e::{Plc, WAIT};

pub mod cdp;
use cdp::{Browser, Tab};

/// The browser: Debian's Chromium (`apt-get install chromium`, done by
/// `scripts/setup.sh`).
pub const CHROMIUM: &str = "/usr/bin/chromium";

/// How often a wait looks at the page again.
pub const PAGE_POLL: Duration = Duration::from_millis(50);

/// The desktop window the page is shown in.
pub const DESKTOP: (u32, u32) = (1280, 900);

/// The phone-sized viewport ([`WebRig::phone`]): CSS pixels of a common
/// phone.
pub const PHONE: (u32, u32) = (390, 844);

/// Held by the rig that has the browser (one at a time).
static ONE_BROWSER: Mutex<()> = Mutex::new(());

/// Starts headless Chromium. Panics, saying how to install it, when
/// [`CHROMIUM`] is not there.
pub fn launch_chromium() -> Browser {
    let path = Path::new(CHROMIUM);
    assert!(
        path.exists(),
        "{CHROMIUM} not found: the browser tests need Debian's chromium \
         (`bash scripts/setup.sh` installs it, or `apt-get install chromium`)"
    );
    // Headless, no sandbox (it refuses to run as root, as CI does; the
    // browser only ever shows our own page on 127.0.0.1): cdp::SWITCHES.
    Browser::launch(path, DESKTOP, &[]).unwrap_or_else(|e| panic!("starting {CHROMIUM}: {e:#}"))
}

/// Where screenshots go: `screenshots/` in the cargo target directory
/// (the test binary lives in `<target>/<profile>/deps/`).
pub fn screenshot_dir() -> PathBuf {
    let exe = std::env::current_exe().expect("the test binary's path");
    let target = exe
        .ancestors()
        .nth(3)
        .map(Path::to_path_buf)
        .unwrap_or_else(std::env::temp_dir);
    target.join("screenshots")
}

/// Removes the screenshots an earlier run of `test` left.
fn remove_screenshots(test: &str) {
    let prefix = format!("{test}-");
    let Ok(dir) = std::fs::read_dir(screenshot_dir()) else {
        return;
    };
    for e in dir.flatten() {
        let name = e.file_name();
        let name = name.to_string_lossy();
        if name.starts_with(&prefix) && name.ends_with(".png") {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// One HTTP answer read by [`http`].
#[derive(Clone, Debug)]
pub struct HttpAnswer {
    /// Status code.
    pub status: u16,
    /// The body (chunks joined).
    pub body: String,
}

/// One HTTP/1.1 request from the test itself (a client beside the
/// browser), read to its end: for reading the API back independently of
/// the page.
pub fn http(addr: SocketAddrV4, method: &str, path: &str, body: &str) -> HttpAnswer {
    try_http(addr, method, path, body, WAIT)
        .unwrap_or_else(|e| panic!("{method} http://{addr}{path}: {e}"))
}

/// [`http`] that says why it failed instead of panicking; the whole
/// exchange takes at most `limit`.
pub fn try_http(
    addr: SocketAddrV4,
    method: &str,
    path: &str,
    body: &str,
    limit: Duration,
) -> std::io::Result<HttpAnswer> {
    let start = Instant::now();
    let mut s = TcpStream::connect_timeout(&SocketAddr::V4(addr), limit)?;
    s.set_read_timeout(Some(limit))?;
    // A change needs the page's own Origin and a JSON content type
    // (gateway/WEB.md), as the page sends them.
    let change = if method == "POST" {
        format!("Origin: http://{addr}\r\nContent-Type: application/json\r\n")
    } else {
        String::new()
    };
    let req = format!(
        "{method} {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n{change}Content-Length: {}\r\n\r\n{body}",
        body.len()
    );
    s.write_all(req.as_bytes())?;
    let mut buf = Vec::new();
    let mut chunk = [0u8; 4096];
    loop {
        if let Some(a) = parse_http(&buf) {
            return Ok(a);
        }
        if start.elapsed() > limit {
            return Err(std::io::Error::new(
                std::io::ErrorKind::TimedOut,
                format!("no complete answer in {limit:?}"),
            ));
        }
        match s.read(&mut chunk)? {
            0 => {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::UnexpectedEof,
                    format!(
                        "closed before the answer ended: {:?}",
                        String::from_utf8_lossy(&buf)
                    ),
                ))
            }
            n => buf.extend_from_slice(&chunk[..n]),
        }
    }
}

/// A complete answer in `buf` (by `Content-Length` or chunked), or `None`
/// while more is to come.
fn parse_http(buf: &[u8]) -> Option<HttpAnswer> {
    let end = buf.windows(4).position(|w| w == b"\r\n\r\n")?;
    let head = String::from_utf8_lossy(&buf[..end]).to_ascii_lowercase();
    let status = head.split(' ').nth(1)?.parse().ok()?;
    let rest = &buf[end + 4..];
    let header = |name: &str| {
        head.lines()
            .find_map(|l| l.strip_prefix(name).map(|v| v.trim().to_string()))
    };
    let body = if header("transfer-encoding:").is_some_and(|v| v == "chunked") {
        let mut out = Vec::new();
        let mut at = 0;
        loop {
            let line_end = rest[at..].windows(2).position(|w| w == b"\r\n")? + at;
            let size_text = String::from_utf8_lossy(&rest[at..line_end]);
            let size = usize::from_str_radix(size_text.trim(), 16).ok()?;
            let data = line_end + 2;
            if size == 0 {
                break;
            }
            out.extend_from_slice(rest.get(data..data + size)?);
            rest.get(data + size..data + size + 2)?;
            at = data + size + 2;
        }
        out
    } else {
        let len: usize = header("content-length:")?.parse().ok()?;
        rest.get(..len)?.to_vec()
    };
    Some(HttpAnswer {
        status,
        body: String::from_utf8_lossy(&body).into_owned(),
    })
}

/// A JSON text as a string for a script (`"…"`, escaped).
pub fn js_str(s: &str) -> String {
    Value::String(s.to_string()).to_string()
}

/// The field-device firmware of the QEMU board (`mps2-an386`):
/// `$FIRMWARE_BIN_DIR/field-device`, else the firmware workspace's release
/// build. Panics, saying how to build it, when it is not there.
pub fn field_device_elf() -> PathBuf {
    let elf = match std::env::var_os("FIRMWARE_BIN_DIR") {
        Some(dir) => PathBuf::from(dir).join("field-device"),
        None => Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../firmware/target/thumbv7em-none-eabihf/release/field-device"),
    };
    assert!(
        elf.exists(),
        "{} not found: build the QEMU field-device firmware first \
         (cd firmware && cargo build --release -p board-mps2-an386 --features field-device \
         --bin field-device), or set FIRMWARE_BIN_DIR to the directory that has it",
        elf.display()
    );
    elf
}

/// The hans-fw program (keys, signed images): `$HANS_FW`, else the cargo
/// target directory's (`cargo build -p hans-fw`, debug or release).
pub fn hans_fw() -> PathBuf {
    if let Some(p) = std::env::var_os("HANS_FW") {
        return PathBuf::from(p);
    }
    let target = screenshot_dir()
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_default();
    ["debug", "release"]
        .iter()
        .map(|p| target.join(p).join("hans-fw"))
        .find(|p| p.exists())
        .unwrap_or_else(|| {
            panic!(
                "hans-fw not found in {}: cargo build -p hans-fw (scripts/firmware-tests.sh does), \
                 or set HANS_FW",
                target.display()
            )
        })
}

/// `elf` (the QEMU field device) as a signed update image at `out`, with
/// `version` and `key` (the development key if `None`), made by
/// `scripts/fw-image.sh` as `scripts/qemu-run.sh` makes the device's own.
pub fn signed_image(elf: &Path, out: &Path, version: &str, key: Option<&Path>) {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts/fw-image.sh");
    let mut cmd = Command::new("bash");
    cmd.arg(script)
        .arg(elf)
        .arg(out)
        .env("FW_VERSION", version)
        .env("HANS_FW", hans_fw())
        .env_remove("FW_BOARD");
    match key {
        Some(k) => cmd.env("FW_KEY", k),
        None => cmd.env_remove("FW_KEY"),
    };
    let done = cmd.output().expect("running scripts/fw-image.sh");
    assert!(done.status.success(), "{cmd:?}: {done:?}");
}

/// A signing key the device does not trust, made by `hans-fw keygen` in
/// `dir` (`untrusted.key`).
pub fn untrusted_key(dir: &Path) -> PathBuf {
    let done = Command::new(hans_fw())
        .args(["keygen", "--name", "untrusted", "--out"])
        .arg(dir)
        .output()
        .expect("running hans-fw keygen");
    assert!(done.status.success(), "hans-fw keygen: {done:?}");
    dir.join("untrusted.key")
}

/// A port on 127.0.0.1 that was free a moment ago.
pub fn free_port() -> u16 {
    TcpListener::bind((Ipv4Addr::LOCALHOST, 0))
        .and_then(|l| l.local_addr())
        .expect("a free port on 127.0.0.1")
        .port()
}

/// Longest life of a QEMU run ([`Qemu`]): `timeout(1)` ends it even if the
/// test process dies without stopping it.
pub const QEMU_LIFE: Duration = Duration::from_secs(300);

/// A QEMU running a firmware ELF on the `mps2-an386` board, run by
/// `scripts/qemu-run.sh` (user networking, `restrict=on`: the only
/// ways in and out are the forwards), with the web page forwarded too:
/// host `127.0.0.1:modbus` → guest port 502, `127.0.0.1:web` → guest port
/// 80, and the guest's robot address 10.0.2.100:10003 → the simulator on
/// `127.0.0.1:sim_port`. Stopped on drop.
pub struct Qemu {
    child: Child,
    /// Where the firmware's Modbus server is reached.
    pub modbus: SocketAddrV4,
    /// Where the firmware's web page is reached.
    pub web: SocketAddrV4,
    /// The firmware's raw defmt log (QEMU's stderr beside it, with the
    /// extension `qemu.log`).
    pub log: PathBuf,
}

impl Qemu {
    /// Starts `elf`, its robot being the simulator on `sim_port`.
    pub fn start(elf: &Path, sim_port: u16, log: PathBuf) -> Qemu {
        for tool in ["qemu-system-arm", "socat", "timeout"] {
            let found = Command::new("sh")
                .args(["-c", &format!("command -v {tool}")])
                .stdout(Stdio::null())
                .status()
                .is_ok_and(|s| s.success());
            assert!(
                found,
                "{tool} not found (bash scripts/setup.sh installs it)"
            );
        }
        let lo = Ipv4Addr::LOCALHOST;
        let modbus = SocketAddrV4::new(lo, free_port());
        let web = SocketAddrV4::new(lo, free_port());
        if let Some(dir) = log.parent() {
            std::fs::create_dir_all(dir).expect("the log directory");
        }
        // QEMU's stderr: its own messages and, for a firmware started by
        // the bootloader (the field device), the bootloader's lines.
        let err = std::fs::File::create(log.with_extension("qemu.log")).expect("the QEMU log file");
        // The script starts the field device through the bootloader from a
        // flash file it makes (and execs QEMU: stopping `timeout` stops it).
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scripts/qemu-run.sh");
        let child = Command::new("timeout")
            .arg("--kill-after=5")
            .arg(QEMU_LIFE.as_secs().to_string())
            .arg("bash")
            .arg(script)
            .arg(elf)
            .env("MODBUS_PORT", modbus.port().to_string())
            .env("WEB_PORT", web.port().to_string())
            .env("SIM_PORT", sim_port.to_string())
            // The host hands in the setup code, as it does the seed.
            .env("SETUP_CODE", SETUP_CODE)
            .env("DEFMT_OUT", &log)
            .env_remove("FIRMWARE_ARGS")
            .env_remove("ADMIN_PORT")
            .env_remove("MQTT_PORT")
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(err)
            .spawn()
            .expect("start QEMU");
        Qemu {
            child,
            modbus,
            web,
            log,
        }
    }

    /// Waits until the firmware's page answers `/api/status` (bounded by
    /// [`WAIT`]).
    pub fn wait_web(&mut self) {
        let start = Instant::now();
        loop {
            let a = try_http(self.web, "GET", "/api/status", "", Duration::from_secs(2));
            if a.as_ref().is_ok_and(|a| a.status == 200) {
                return;
            }
            if let Ok(Some(status)) = self.child.try_wait() {
                panic!(
                    "QEMU ended ({status}) before its page answered; log {}",
                    self.log.display()
                );
            }
            assert!(
                start.elapsed() < WAIT,
                "the firmware's page did not answer in {WAIT:?} ({a:?}); log {}",
                self.log.display()
            );
            std::thread::sleep(Duration::from_millis(200));
        }
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        // SIGTERM to `timeout`, which passes it on to QEMU; SIGKILL if that
        // was not enough within 5 s.
        let _ = Command::new("kill")
            .args(["-TERM", &self.child.id().to_string()])
            .status();
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(5) {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// A PLC connected to `addr` once the server there answers a read (a
/// firmware under QEMU may take its connection before its Modbus server
/// is up: QEMU's forward accepts at once). Retries for at most [`WAIT`].
pub async fn connect_plc(addr: SocketAddrV4) -> Plc {
    use tokio_modbus::client::Reader;
    let start = Instant::now();
    loop {
        let attempt = tokio::time::timeout(Duration::from_secs(2), async {
            let mut ctx = tokio_modbus::client::tcp::connect(SocketAddr::V4(addr))
                .await
                .map_err(|e| e.to_string())?;
            match ctx.read_holding_registers(0, 1).await {
                Ok(Ok(_)) => Ok(ctx),
                Ok(Err(e)) => Err(format!("exception {e:?}")),
                Err(e) => Err(e.to_string()),
            }
        })
        .await
        .unwrap_or_else(|_| Err("no answer in 2 s".to_string()));
        match attempt {
            Ok(ctx) => return Plc { ctx },
            Err(e) => assert!(
                start.elapsed() < WAIT,
                "the Modbus server at {addr} did not answer in {WAIT:?}: {e}"
            ),
        }
        tokio::time::sleep(Duration::from_millis(200)).await;
    }
}

/// hans-sim, the host gateway with its page, a PLC and the page in
/// headless Chromium.
/// The setup code the rig hands the gateway (as its platform would print
/// it) for the first administrator.
pub const SETUP_CODE: &str = "ABCD-EFGH-JKMN";

pub struct WebRig {
    /// The tab showing the page.
    pub tab: Tab,
    /// A Modbus client (connected before the page is opened).
    pub plc: Plc,
    /// The simulated robot.
    pub sim: Sim,
    /// The host gateway (`None` once [`WebRig::stop_gateway`] stopped it,
    /// or when the gateway is the QEMU firmware).
    pub gw: Option<RunningGateway>,
    /// The QEMU running the firmware ([`WebRig::start_qemu`]).
    pub qemu: Option<Qemu>,
    /// Where the page is served.
    pub web: SocketAddrV4,
    /// The runtime of the simulator and the PLC: `rig.rt.block_on(rig.plc.…)`.
    pub rt: tokio::runtime::Runtime,
    test: &'static str,
    shots: Vec<PathBuf>,
    _browser: Browser,
    _one: MutexGuard<'static, ()>,
}

impl WebRig {
    /// Starts everything for the test named `test` (the screenshots'
    /// prefix) and opens the page; returns once the robot link is up and
    /// the page is loaded.
    pub fn start(test: &'static str) -> WebRig {
        Self::start_with(test, None, None)
    }

    /// As [`WebRig::start`], the gateway keeping its configuration in a
    /// file (`--config`, in a fresh directory under the screenshot
    /// directory's `files/`): what a restart keeps.
    pub fn start_kept(test: &'static str) -> WebRig {
        let dir = screenshot_dir().join("files").join(test);
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("a directory for the configuration file");
        Self::start_with(test, None, Some(dir.join("gateway.toml")))
    }

    /// As [`WebRig::start`], the gateway being the firmware `elf` on the
    /// QEMU board ([`Qemu`]; its log in the screenshot directory as
    /// `<test>.defmt`).
    pub fn start_qemu(test: &'static str, elf: &Path) -> WebRig {
        Self::start_with(test, Some(elf), None)
    }

    fn start_with(test: &'static str, elf: Option<&Path>, config: Option<PathBuf>) -> WebRig {
        // A test that failed while holding the lock poisons it; the next
        // one may still run.
        let one = ONE_BROWSER.lock().unwrap_or_else(|e| e.into_inner());
        remove_screenshots(test);
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()
            .expect("tokio runtime");
        let sim = rt
            .block_on(Sim::start(hans_sim::Config {
                datasheet_ports: Vec::new(),
                fast_port: None,
                ..hans_sim::Config::ready()
            }))
            .expect("start the simulator");
        let robot = match sim.command_addr() {
            SocketAddr::V4(a) => a,
            SocketAddr::V6(_) => panic!("simulator not on IPv4"),
        };
        let (gw, qemu, web, modbus) = match elf {
            None => {
                let mut opts = HostOptions::new(SocketAddrV4::new(Ipv4Addr::LOCALHOST, 0), robot);
                opts.web_listen = Some(SocketAddrV4::new(Ipv4Addr::LOCALHOST, 0));
                opts.setup_code = hans_gateway::SetupCode::parse(SETUP_CODE.as_bytes());
                opts.config_file = config;
                let gw = RunningGateway::start(opts).expect("start the gateway");
                let web = gw.web_addr().expect("the page is served");
                let modbus = gw.modbus_addr();
                (Some(gw), None, web, modbus)
            }
            Some(elf) => {
                let log = screenshot_dir().join(format!("{test}.defmt"));
                let mut q = Qemu::start(elf, robot.port(), log);
                q.wait_web();
                let (web, modbus) = (q.web, q.modbus);
                (None, Some(q), web, modbus)
            }
        };
        let mut plc = rt.block_on(connect_plc(modbus));
        rt.block_on(plc.wait_link());
        let browser = launch_chromium();
        let tab = browser
            .new_tab()
            .unwrap_or_else(|e| panic!("a browser tab: {e:#}"));
        let rig = WebRig {
            tab,
            plc,
            sim,
            gw,
            qemu,
            web,
            rt,
            test,
            shots: Vec::new(),
            _browser: browser,
            _one: one,
        };
        rig.tab
            .navigate_to(&rig.url())
            .and_then(|t| t.wait_until_navigated())
            .unwrap_or_else(|e| panic!("opening {}: {e:#}", rig.url()));
        rig
    }

    /// How long the page took to load, from the browser's navigation
    /// timing (ms from the start of the navigation): `ttfb` (first byte of
    /// the page), `response` (last byte), `dom` (DOMContentLoaded), `load`
    /// (load event), `live` (the first status shown, the page's
    /// `data-first-live-ms`; waits for it), and the page's `bytes` on the
    /// wire and `decoded`.
    pub fn load_times(&mut self) -> Value {
        self.wait_js(
            "the first status shown",
            "document.body.dataset.firstLiveMs !== undefined && \
             performance.getEntriesByType('navigation')[0].loadEventEnd > 0",
        );
        self.js(
            "(() => { const n = performance.getEntriesByType('navigation')[0]; \
             const r = x => Math.round(x * 10) / 10; \
             return {ttfb: r(n.responseStart - n.startTime), response: r(n.responseEnd - n.startTime), \
             dom: r(n.domContentLoadedEventEnd - n.startTime), load: r(n.loadEventEnd - n.startTime), \
             live: r(+document.body.dataset.firstLiveMs - n.startTime), \
             bytes: n.encodedBodySize, decoded: n.decodedBodySize}; })()",
        )
    }

    /// The page's address.
    pub fn url(&self) -> String {
        format!("http://{}/", self.web)
    }

    /// Runs a future (of the simulator, say) to its end.
    pub fn block_on<F: Future>(&self, f: F) -> F::Output {
        self.rt.block_on(f)
    }

    /// Runs what the PLC does: `rig.modbus(async |plc| plc.read1(A).await)`.
    pub fn modbus<T>(&mut self, f: impl AsyncFnOnce(&mut Plc) -> T) -> T {
        self.rt.block_on(f(&mut self.plc))
    }

    /// Evaluates a script expression in the page (awaited if a promise)
    /// and returns its value as JSON (`undefined` is `null`). Panics if it
    /// throws.
    pub fn js(&self, expr: &str) -> Value {
        let wrapped = format!(
            "(async () => {{ const v = await ({expr}); return v === undefined ? 'null' : JSON.stringify(v); }})()"
        );
        let r = self
            .tab
            .evaluate(&wrapped, true)
            .unwrap_or_else(|e| panic!("evaluating `{expr}`: {e:#}"));
        match r {
            Value::String(s) => serde_json::from_str(&s).unwrap_or(Value::String(s)),
            other => panic!("`{expr}` gave no value: {other}"),
        }
    }

    /// The text of the element with id `id` (empty if it has none;
    /// panics if there is no such element).
    pub fn text(&self, id: &str) -> String {
        let v = self.js(&format!(
            "(() => {{ const e = document.getElementById({}); return e ? e.textContent : null; }})()",
            js_str(id)
        ));
        match v {
            Value::String(s) => s,
            _ => panic!("no element #{id} on the page"),
        }
    }

    /// Attribute `name` of element `id` (`None` if absent).
    pub fn attr(&self, id: &str, name: &str) -> Option<String> {
        let v = self.js(&format!(
            "document.getElementById({}).getAttribute({})",
            js_str(id),
            js_str(name)
        ));
        v.as_str().map(str::to_string)
    }

    /// `data-NAME` of element `id` (empty if absent).
    pub fn data(&self, id: &str, name: &str) -> String {
        self.attr(id, &format!("data-{name}")).unwrap_or_default()
    }

    /// The computed CSS property `prop` of element `id` (colours as
    /// `rgb(r, g, b)`).
    pub fn style(&self, id: &str, prop: &str) -> String {
        let v = self.js(&format!(
            "getComputedStyle(document.getElementById({})).getPropertyValue({})",
            js_str(id),
            js_str(prop)
        ));
        v.as_str().unwrap_or_default().to_string()
    }

    /// Is element `id` shown (not hidden by itself or a parent)?
    pub fn visible(&self, id: &str) -> bool {
        self.js(&format!(
            "(() => {{ const e = document.getElementById({}); return !!e && e.getClientRects().length > 0; }})()",
            js_str(id)
        )) == Value::Bool(true)
    }

    /// Is the control `id` disabled (itself or by a disabled fieldset)?
    pub fn disabled(&self, id: &str) -> bool {
        self.js(&format!(
            "document.getElementById({}).matches(':disabled')",
            js_str(id)
        )) == Value::Bool(true)
    }

    /// Waits until `f` gives `Some`, looking every [`PAGE_POLL`]; after
    /// [`WAIT`] takes a screenshot and fails naming `what`.
    pub fn wait_for<T>(&mut self, what: &str, f: impl FnMut(&WebRig) -> Option<T>) -> T {
        self.wait_for_in(what, WAIT, f)
    }

    /// [`WebRig::wait_for`] with its own bound `limit` (for what must
    /// happen sooner than something else would make it happen anyway).
    pub fn wait_for_in<T>(
        &mut self,
        what: &str,
        limit: Duration,
        mut f: impl FnMut(&WebRig) -> Option<T>,
    ) -> T {
        let start = Instant::now();
        loop {
            if let Some(v) = f(self) {
                return v;
            }
            if start.elapsed() > limit {
                let shot = self.shot("timeout");
                panic!(
                    "timed out after {limit:?} waiting for {what} (screenshot {})",
                    shot.display()
                );
            }
            std::thread::sleep(PAGE_POLL);
        }
    }

    /// Waits until the script expression `cond` is true in the page.
    pub fn wait_js(&mut self, what: &str, cond: &str) {
        self.wait_for(what, |r| (r.js(cond) == Value::Bool(true)).then_some(()));
    }

    /// Waits until the text of element `id` satisfies `ok`; returns it.
    pub fn wait_text(&mut self, id: &str, what: &str, ok: impl Fn(&str) -> bool) -> String {
        self.wait_for(what, |r| {
            let t = r.text(id);
            ok(&t).then_some(t)
        })
    }

    /// Waits until `data-NAME` of element `id` is `value`.
    pub fn wait_data(&mut self, id: &str, name: &str, value: &str) {
        let what = format!("#{id} data-{name} = {value:?}");
        self.wait_for(&what, |r| (r.data(id, name) == value).then_some(()));
    }

    /// Clicks element `id` with the mouse (scrolled into view first).
    ///
    /// The mouse goes to where the element was a moment before; when the
    /// page moved in between (a table above it grew, as the audit log does
    /// after a change), the click lands on something else. A listener
    /// placed for this one click keeps such a click from reaching the other
    /// element (stopped, its default prevented) and the click is tried
    /// again, within [`WAIT`]. A click the page never sees (a disabled
    /// button) is left as a user's would be.
    pub fn click(&self, id: &str) {
        let guard = format!(
            "(() => {{ const want = document.getElementById({id}); \
             if (window.__rigClick) document.removeEventListener('click', window.__rigClick, true); \
             window.__rigClickSeen = 'none'; \
             window.__rigClick = (e) => {{ \
               document.removeEventListener('click', window.__rigClick, true); \
               if (want && want.contains(e.target)) {{ window.__rigClickSeen = 'hit'; return; }} \
               window.__rigClickSeen = 'miss'; e.stopPropagation(); e.preventDefault(); }}; \
             document.addEventListener('click', window.__rigClick, true); }})()",
            id = js_str(id)
        );
        let start = Instant::now();
        loop {
            self.js(&guard);
            self.tab
                .click_id(id)
                .unwrap_or_else(|e| panic!("clicking #{id}: {e:#}"));
            let seen = self.js("(() => { const s = window.__rigClickSeen; \
                 document.removeEventListener('click', window.__rigClick, true); return s; })()");
            if seen.as_str() != Some("miss") {
                return;
            }
            assert!(
                start.elapsed() < WAIT,
                "clicking #{id}: the click landed elsewhere for {WAIT:?}, the page kept moving"
            );
        }
    }

    /// Replaces the text of input `id` as typed text does (focus, select
    /// all, insert).
    pub fn type_in(&self, id: &str, text: &str) {
        self.js(&format!(
            "(() => {{ const e = document.getElementById({}); e.focus(); e.select(); }})()",
            js_str(id)
        ));
        if text.is_empty() {
            self.tab
                .press_key("Delete")
                .unwrap_or_else(|e| panic!("clearing #{id}: {e:#}"));
        } else {
            self.tab
                .send_character(text)
                .unwrap_or_else(|e| panic!("typing into #{id}: {e:#}"));
        }
    }

    /// Chooses `value` in the select `id` (as a user's choice does:
    /// `input` and `change` fire).
    pub fn choose(&self, id: &str, value: &str) {
        self.js(&format!(
            "(() => {{ const e = document.getElementById({}); e.value = {}; \
             e.dispatchEvent(new Event('input', {{bubbles: true}})); \
             e.dispatchEvent(new Event('change', {{bubbles: true}})); }})()",
            js_str(id),
            js_str(value)
        ));
    }

    /// Limits what the page sends to `bytes_per_s` (DevTools' network
    /// throttling: an upload then takes long enough to be seen); `None`
    /// lifts the limit.
    pub fn throttle_upload(&self, bytes_per_s: Option<f64>) {
        self.tab
            .call("Network.enable", json!({}))
            .unwrap_or_else(|e| panic!("{e:#}"));
        self.tab
            .call(
                "Network.emulateNetworkConditions",
                json!({
                    "offline": false,
                    "latency": 0,
                    // -1: not limited.
                    "downloadThroughput": -1,
                    "uploadThroughput": bytes_per_s.unwrap_or(-1.0),
                }),
            )
            .unwrap_or_else(|e| panic!("{e:#}"));
    }

    /// Sets the files of the file input `id` (as the file chooser does).
    pub fn set_file(&mut self, id: &str, file: &Path) {
        let path = file.to_str().expect("a UTF-8 path");
        self.tab
            .set_input_files(id, &[path])
            .unwrap_or_else(|e| panic!("setting the file of #{id}: {e:#}"));
        self.js(&format!(
            "document.getElementById({}).dispatchEvent(new Event('change', {{bubbles: true}}))",
            js_str(id)
        ));
        // The input holds the new file before anything reads it.
        let name = file
            .file_name()
            .and_then(|n| n.to_str())
            .expect("a file name");
        self.wait_js(
            &format!("#{id} to hold {name}"),
            &format!(
                "document.getElementById({}).files[0]?.name === {}",
                js_str(id),
                js_str(name)
            ),
        );
    }

    /// The session state the page shows: `fresh` (no password),
    /// `login`, `open`.
    pub fn session(&self) -> String {
        self.js("document.body.dataset.session")
            .as_str()
            .unwrap_or_default()
            .to_string()
    }

    /// Sets the first password through the page (its "set a password
    /// first" form) and waits for the session it opens.
    pub fn set_first_password(&mut self, pw: &str) {
        self.wait_for("the page to ask for a first password", |r| {
            (r.session() == "fresh").then_some(())
        });
        self.type_in("setup-code", SETUP_CODE);
        self.type_in("setup-name", "admin");
        self.type_in("pw-new", pw);
        self.type_in("pw-new2", pw);
        self.click("pw-set");
        self.wait_for("a session opened by the first administrator", |r| {
            (r.session() == "open").then_some(())
        });
    }

    /// Waits for the page's live status (`#conn` says `live`).
    pub fn wait_live(&mut self) {
        self.wait_data("conn", "state", "live");
    }

    /// Shows the page in a phone-sized viewport ([`PHONE`]); `false` goes
    /// back to the desktop window.
    pub fn phone(&self, on: bool) {
        if on {
            self.tab
                .call(
                    "Emulation.setDeviceMetricsOverride",
                    json!({"width": PHONE.0, "height": PHONE.1, "deviceScaleFactor": 2, "mobile": true}),
                )
                .unwrap_or_else(|e| panic!("phone viewport: {e:#}"));
        } else {
            self.tab
                .call("Emulation.clearDeviceMetricsOverride", json!({}))
                .unwrap_or_else(|e| panic!("desktop viewport: {e:#}"));
        }
    }

    /// A screenshot of the whole page as
    /// `<target>/screenshots/<test>-<step>.png`; prints and returns its
    /// path.
    pub fn shot(&mut self, step: &str) -> PathBuf {
        // From the top, so that the sticky header is where it belongs.
        self.js("window.scrollTo(0, 0)");
        let m = self
            .tab
            .call("Page.getLayoutMetrics", json!({}))
            .unwrap_or_else(|e| panic!("the page's size: {e:#}"));
        let size = &m["cssContentSize"];
        self.capture(
            step,
            Some(json!({
                "x": 0, "y": 0, "width": size["width"], "height": size["height"], "scale": 1,
            })),
        )
    }

    /// A screenshot of what the window shows of the page, after
    /// scrolling element `id` to the top (as [`WebRig::shot`] names it).
    pub fn shot_at(&mut self, id: &str, step: &str) -> PathBuf {
        self.js(&format!(
            "document.getElementById({}).scrollIntoView()",
            js_str(id)
        ));
        self.capture(step, None)
    }

    fn capture(&mut self, step: &str, clip: Option<Value>) -> PathBuf {
        let dir = screenshot_dir();
        std::fs::create_dir_all(&dir).expect("the screenshot directory");
        let path = dir.join(format!("{}-{step}.png", self.test));
        let mut params = json!({
            "format": "png",
            "captureBeyondViewport": clip.is_some(),
            "fromSurface": true,
        });
        if let Some(clip) = clip {
            params["clip"] = clip;
        }
        let shot = self
            .tab
            .call("Page.captureScreenshot", params)
            .unwrap_or_else(|e| panic!("a screenshot: {e:#}"));
        let png = base64::engine::general_purpose::STANDARD
            .decode(shot["data"].as_str().unwrap_or_default())
            .expect("the screenshot's base64");
        std::fs::write(&path, png).expect("writing the screenshot");
        println!("screenshot: {}", path.display());
        self.shots.push(path.clone());
        path
    }

    /// One request to the page's server from the test (not the browser).
    pub fn http(&self, method: &str, path: &str, body: &str) -> HttpAnswer {
        http(self.web, method, path, body)
    }

    /// `GET /api/config` from the test: the configuration document.
    pub fn config_doc(&self) -> String {
        let a = self.http("GET", "/api/config", "");
        assert_eq!(a.status, 200, "GET /api/config: {}", a.body);
        a.body
    }

    /// Stops the gateway, host or QEMU (the page then gets no answer).
    pub fn stop_gateway(&mut self) {
        if let Some(gw) = self.gw.take() {
            gw.stop();
        }
        drop(self.qemu.take());
    }

    /// Stops everything; returns the screenshots taken.
    pub fn finish(self) -> Vec<PathBuf> {
        let WebRig {
            tab,
            plc,
            sim,
            gw,
            qemu,
            rt,
            shots,
            _browser,
            _one,
            ..
        } = self;
        drop(tab);
        drop(_browser);
        drop(plc);
        drop(gw);
        drop(qemu);
        rt.block_on(sim.shutdown());
        drop(rt);
        drop(_one);
        shots
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn answers_are_read_whole_by_length_or_in_chunks() {
        let a = parse_http(b"HTTP/1.1 200 OK\r\nContent-Length: 2\r\n\r\nok").unwrap();
        assert_eq!((a.status, a.body.as_str()), (200, "ok"));
        assert!(parse_http(b"HTTP/1.1 200 OK\r\nContent-Length: 3\r\n\r\nok").is_none());
        let c = b"HTTP/1.1 200 OK\r\nTransfer-Encoding: chunked\r\n\r\n3\r\n{\"a\r\n2\r\n\":\r\n0\r\n\r\n";
        assert_eq!(parse_http(c).unwrap().body, "{\"a\":");
        assert!(parse_http(&c[..c.len() - 7]).is_none());
    }

    #[test]
    fn script_strings_are_escaped() {
        assert_eq!(js_str("a'b\"c\n"), r#""a'b\"c\n""#);
    }
}
