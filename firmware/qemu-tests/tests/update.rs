//! Signed A/B firmware updates of the field device under QEMU (issue 18).
//! The firmware boots through the bootloader from a flash file, signed as
//! 0.1.0 (image A) by `scripts/qemu-run.sh`; hans-sim is the robot, and a
//! PLC polls HEARTBEAT over Modbus ten times a second through the uploads.
//!
//! * An update: bad images first (signed by another key, truncated, for
//!   another board), each refused with its reason in the answer and in
//!   `firmware.upload.reason` while every poll of the PLC is answered; then
//!   image B (the same firmware signed as 0.2.0) through
//!   `POST /api/firmware` ("pending"), the restart (`POST /api/restart`:
//!   QEMU's machine resets in place, the flash file stays, the bootloader
//!   swaps B in), B on trial, and confirmed by its self-check.
//! * A rollback: B's self-check fails (`selfcheck=fail` on the command
//!   line), it restarts, and the bootloader puts A back ("rolled back").
//!
//! Figures, printed and not asserted: the upload's time and rate, the swap
//! and restart until the page answers again, and during the upload the
//! PLC's poll latency and the longest gap between two advances of
//! HEARTBEAT (+1 every poll period of the engine: the longest engine stall
//! the PLC could see, to the polls' resolution of 100 ms). Asserted: no
//! poll failed, HEARTBEAT kept advancing.
//!
//! The images are made by `scripts/fw-image.sh`, as `qemu-run.sh` makes A.
//! Register addresses are the gateway's (`gateway/REGISTERS.md`), repeated
//! on purpose as in `gateway.rs`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::{Duration, Instant};

use qemu_tests::{
    firmware_elf, hans_fw, http_get, log_dir, must, repo_root, HttpClient, HttpResponse,
};
use serde_json::Value;

mod common;
use common::{modbus_at, wait_for, Rig, STEP};

/// HEARTBEAT: +1 every poll period of the engine.
const HEARTBEAT: u16 = 1;
/// FW_VERSION: the running firmware's major, minor, patch (55-57).
const FW_VERSION: u16 = 55;
/// FW_STATE (58): 1 confirmed, 2 on trial, 3 an update waits for the
/// restart, 4 rolled back.
const FW_CONFIRMED: u16 = 1;
const FW_TRIAL: u16 = 2;
const FW_PENDING: u16 = 3;
const FW_ROLLED_BACK: u16 = 4;
/// CFG_POLL_MS: the engine's poll period.
const CFG_POLL_MS: u16 = 105;

/// The setup code the host hands the firmware (`SETUP_CODE`).
const SETUP_CODE: &str = "ABCD-EFGH-JKMN";
const ADMIN: &str = "admin";
const PASSWORD: &str = "commission-2026";

/// The PLC's poll period.
const POLL_EVERY: Duration = Duration::from_millis(100);
/// How long image B is uploaded again and again while the PLC polls.
const UPLOADING: Duration = Duration::from_secs(3);
/// How long the bad images are sent again and again while the PLC polls.
const REFUSING: Duration = Duration::from_secs(1);
/// The longest an upload or a request of the test may take.
const UPLOAD_LIMIT: Duration = Duration::from_secs(60);
/// The longest a restart (swap, boot, network) may take until the page
/// answers again, and the trial until its confirmation or rollback.
const BACK_LIMIT: Duration = Duration::from_secs(90);

/// The images a test uploads, made in a directory of its own (removed at
/// the end).
struct Images {
    dir: PathBuf,
}

impl Images {
    fn new(name: &str) -> Images {
        let dir = log_dir().join(format!("{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).expect("the images' directory");
        Images { dir }
    }

    /// The field-device firmware signed as `version` for `board`, with
    /// `key` (the development key if `None`), by `scripts/fw-image.sh`.
    fn signed(&self, file: &str, version: &str, board: &str, key: Option<&Path>) -> PathBuf {
        let out = self.dir.join(file);
        let mut cmd = Command::new("bash");
        cmd.arg(repo_root().join("scripts/fw-image.sh"))
            .arg(firmware_elf("field-device"))
            .arg(&out)
            .env("FW_VERSION", version)
            .env("FW_BOARD", board)
            .env("HANS_FW", hans_fw());
        match key {
            Some(k) => cmd.env("FW_KEY", k),
            None => cmd.env_remove("FW_KEY"),
        };
        run(&mut cmd);
        out
    }

    /// A signing key the device does not trust (`hans-fw keygen`).
    fn untrusted_key(&self) -> PathBuf {
        run(Command::new(hans_fw())
            .args(["keygen", "--name", "untrusted", "--out"])
            .arg(&self.dir));
        self.dir.join("untrusted.key")
    }
}

impl Drop for Images {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

fn run(cmd: &mut Command) {
    let out = cmd.output().expect("run a tool");
    assert!(out.status.success(), "{cmd:?}: {out:?}");
}

fn read(path: &Path) -> Vec<u8> {
    std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The field device under QEMU with its administrator's session.
struct Device {
    rig: Rig,
    /// `hgw_session=TOKEN`, once logged in.
    cookie: String,
}

impl Device {
    /// Starts the field device (`args`: its command line) and creates the
    /// administrator with the setup code.
    fn start(name: &'static str, args: &str) -> Device {
        Device::start_kept(name, args, None)
    }

    /// As [`Device::start`], on the flash file `flash` if given (made if
    /// absent, kept after QEMU ends): the administrator is created, and
    /// the setup's answer says it was saved.
    fn start_kept(name: &'static str, args: &str, flash: Option<&Path>) -> Device {
        let mut dev = Device::boot(name, args, flash);
        let body = format!(r#"{{"code":"{SETUP_CODE}","name":"{ADMIN}","password":"{PASSWORD}"}}"#);
        let r = HttpClient::connect(dev.web(), STEP)
            .and_then(|mut c| c.post_json("/api/setup", &body))
            .unwrap_or_else(|e| panic!("POST /api/setup: {e}"));
        assert_eq!(r.status, 200, "POST /api/setup: {}", r.text());
        assert!(
            r.text().contains(r#""saved":"saved""#),
            "kept in flash: {}",
            r.text()
        );
        dev.take_cookie(&r);
        dev
    }

    /// Starts the field device and waits for its page, without a session.
    fn boot(name: &'static str, args: &str, flash: Option<&Path>) -> Device {
        let mut env = vec![("SETUP_CODE", SETUP_CODE.to_string())];
        if let Some(f) = flash {
            env.push(("FLASH_FILE", f.display().to_string()));
        }
        let rig = Rig::start_with_env("field-device", name, args, &env);
        let dev = Device {
            rig,
            cookie: String::new(),
        };
        // The page is up before anything is posted (a POST to a guest not
        // listening yet is closed unanswered).
        let fw = dev.firmware();
        assert_eq!(fw["supported"], true, "{fw}");
        dev
    }

    /// The session cookie of a login's or setup's answer.
    fn take_cookie(&mut self, r: &HttpResponse) {
        self.cookie = r
            .header("Set-Cookie")
            .and_then(|c| c.split(';').next())
            .filter(|c| c.starts_with("hgw_session="))
            .unwrap_or_else(|| panic!("a session cookie: {:?}", r.headers))
            .to_string();
    }

    /// `POST /api/login` as `name`: the answer (the session is taken when
    /// it is 200).
    fn login(&mut self, name: &str, password: &str) -> HttpResponse {
        let body = format!(r#"{{"name":"{name}","password":"{password}"}}"#);
        let r = HttpClient::connect(self.web(), STEP)
            .and_then(|mut c| c.post_json("/api/login", &body))
            .unwrap_or_else(|e| panic!("POST /api/login: {e}"));
        if r.status == 200 {
            self.take_cookie(&r);
        }
        r
    }

    /// `GET path` with the session: the answer as JSON (200 expected).
    fn get_json(&self, path: &str) -> Value {
        let cookie = [("Cookie", self.cookie.as_str())];
        let headers: &[(&str, &str)] = if self.cookie.is_empty() { &[] } else { &cookie };
        let (r, _) = HttpClient::connect(self.web(), STEP)
            .and_then(|mut c| c.send("GET", path, headers, b"", STEP))
            .unwrap_or_else(|e| panic!("GET {path}: {e}"));
        assert_eq!(r.status, 200, "GET {path}: {}", r.text());
        serde_json::from_slice(&r.body)
            .unwrap_or_else(|e| panic!("GET {path} is not JSON ({e}): {}", r.text()))
    }

    /// The audit log's records (`GET /api/audit`).
    fn audit(&self) -> Vec<Value> {
        // Page by page (32 records a page), back to the first kept.
        let mut all = Vec::new();
        let mut path = String::from("/api/audit");
        for _ in 0..256 {
            let page = self.get_json(&path);
            let mut records = page["records"].as_array().cloned().unwrap_or_default();
            records.append(&mut all);
            all = records;
            match page["next_before"].as_u64() {
                Some(n) => path = format!("/api/audit?before={n}"),
                None => break,
            }
        }
        all
    }

    fn web(&self) -> u16 {
        self.rig.qemu.ports.web
    }

    /// `/api/status`'s `firmware` object (reading needs no login).
    fn firmware(&self) -> Value {
        let r = http_get(self.web(), "/api/status", STEP)
            .unwrap_or_else(|e| panic!("GET /api/status: {e}"));
        assert_eq!(r.status, 200, "GET /api/status: {}", r.text());
        let status: Value = serde_json::from_slice(&r.body)
            .unwrap_or_else(|e| panic!("/api/status is not JSON ({e}): {}", r.text()));
        status["firmware"].clone()
    }

    /// A `POST` as the administrator, on a connection of its own; the
    /// answer and how long it took.
    fn post(&self, path: &str, content_type: &str, body: &[u8]) -> (HttpResponse, Duration) {
        let origin = format!("http://127.0.0.1:{}", self.web());
        let headers = [
            ("Origin", origin.as_str()),
            ("Content-Type", content_type),
            ("Cookie", self.cookie.as_str()),
        ];
        HttpClient::connect(self.web(), STEP)
            .and_then(|mut c| c.send("POST", path, &headers, body, UPLOAD_LIMIT))
            .unwrap_or_else(|e| panic!("POST {path}: {e}"))
    }

    /// `POST /api/firmware` with `image`.
    fn upload(&self, image: &[u8]) -> (HttpResponse, Duration) {
        self.post("/api/firmware", "application/octet-stream", image)
    }

    /// `POST /api/restart` (no motion runs): 202, then the machine resets.
    fn restart(&self) -> Restart {
        let lines = self.boot_log().lines().count();
        let (r, _) = self.post("/api/restart", "application/json", b"{}");
        assert_eq!(r.status, 202, "POST /api/restart: {}", r.text());
        Restart {
            at: Instant::now(),
            lines,
        }
    }

    /// Waits (at most [`BACK_LIMIT`]) until `/api/status` answers with a
    /// `firmware` object that `want` accepts. While the device restarts,
    /// nothing answers (QEMU's forward closes the connection, or holds it
    /// while it retries its SYN to the guest with a growing back-off) or
    /// the old firmware still does: each attempt is a new connection given
    /// half a second, so that the time the page is back is seen to about
    /// that.
    fn wait_firmware(&self, what: &str, want: impl Fn(&Value) -> bool) -> Value {
        wait_for(what, BACK_LIMIT, || {
            let fw = self.firmware_now()?;
            want(&fw).then_some(fw)
        })
    }

    /// `/api/status`'s `firmware` object if it answers within half a
    /// second (it takes milliseconds when the page is up).
    fn firmware_now(&self) -> Option<Value> {
        let limit = Duration::from_millis(500);
        let mut c = HttpClient::connect(self.web(), limit).ok()?;
        c.set_timeout(limit).ok()?;
        let r = c.get("/api/status").ok()?;
        let status: Value = serde_json::from_slice(&r.body).ok()?;
        Some(status["firmware"].clone())
    }

    /// After `restart`, waits for `version` to run: the time (from the
    /// restart's answer) the bootloader said it boots it (its log watched
    /// every 10 ms on a thread of its own, as a status request may wait a
    /// second for a guest that is not up) and the time the page answered
    /// with it running; the `firmware` object then.
    fn wait_back(&self, restart: &Restart, version: &str) -> (Duration, Duration, Value) {
        let line = format!("hans-boot: booting {version}");
        let found = AtomicBool::new(false);
        std::thread::scope(|s| {
            let watcher = s.spawn(|| {
                while !found.load(Ordering::Relaxed) && restart.at.elapsed() < BACK_LIMIT {
                    let log = self.boot_log();
                    if log
                        .lines()
                        .skip(restart.lines)
                        .any(|l| l.starts_with(&line))
                    {
                        return Some(restart.at.elapsed());
                    }
                    std::thread::sleep(Duration::from_millis(10));
                }
                None
            });
            let what = format!("{version} running after the restart");
            let fw = wait_for(&what, BACK_LIMIT, || {
                let fw = self.firmware_now()?;
                (fw["running"] == version).then_some(fw)
            });
            let page = restart.at.elapsed();
            found.store(true, Ordering::Relaxed);
            let booted = watcher.join().expect("the log's watcher");
            (booted.unwrap_or(page), page, fw)
        })
    }

    /// FW_VERSION (major, minor, patch) and FW_STATE over Modbus.
    fn fw_registers(&self) -> ([u16; 3], u16) {
        let mut plc = self.rig.modbus();
        let r = must(
            plc.read_holding_registers(FW_VERSION, 4),
            "FW_VERSION, FW_STATE",
        );
        ([r[0], r[1], r[2]], r[3])
    }

    /// The bootloader's lines so far (QEMU's stderr).
    fn boot_log(&self) -> String {
        let log = log_dir().join(format!("{}.qemu.log", self.rig.name));
        std::fs::read_to_string(log)
            .unwrap_or_default()
            .lines()
            .filter(|l| l.starts_with("hans-boot:"))
            .collect::<Vec<_>>()
            .join("\n")
    }
}

/// A restart asked for: when it was answered, and how many lines the
/// bootloader had written by then.
struct Restart {
    at: Instant,
    lines: usize,
}

/// One poll of the PLC: when (since the poller started), how long it
/// took, and HEARTBEAT or why the poll failed.
struct Poll {
    at: Duration,
    took: Duration,
    heartbeat: Result<u16, String>,
}

/// A PLC reading HEARTBEAT every [`POLL_EVERY`] on a thread of its own,
/// over one Modbus session, until stopped.
struct Poller {
    stop: Arc<AtomicBool>,
    thread: std::thread::JoinHandle<Vec<Poll>>,
}

impl Poller {
    /// Starts polling; returns once the session has answered.
    fn start(port: u16) -> Poller {
        let stop = Arc::new(AtomicBool::new(false));
        let (ready, up) = mpsc::channel();
        let stopped = stop.clone();
        let thread = std::thread::spawn(move || {
            let mut plc = modbus_at(port, "update poller");
            let _ = ready.send(());
            let start = Instant::now();
            let mut polls = Vec::new();
            let mut next = start;
            while !stopped.load(Ordering::Relaxed) {
                let t = Instant::now();
                let r = plc.read_holding_registers(HEARTBEAT, 1);
                let took = t.elapsed();
                let heartbeat = match r {
                    Ok(Ok(v)) => Ok(v[0]),
                    Ok(Err(exception)) => Err(format!("exception {exception:?}")),
                    Err(e) => Err(e.to_string()),
                };
                polls.push(Poll {
                    at: t - start,
                    took,
                    heartbeat,
                });
                next += POLL_EVERY;
                std::thread::sleep(next.saturating_duration_since(Instant::now()));
            }
            polls
        });
        up.recv_timeout(STEP + STEP)
            .expect("the poller's Modbus session");
        Poller { stop, thread }
    }

    fn stop(self) -> Polls {
        self.stop.store(true, Ordering::Relaxed);
        Polls(self.thread.join().expect("the poller"))
    }
}

/// What the PLC saw over one stretch.
struct Polls(Vec<Poll>);

impl Polls {
    /// Asserts that every poll was answered and that HEARTBEAT advanced.
    fn assert_served(&self, during: &str) {
        let failed: Vec<_> = self
            .0
            .iter()
            .filter_map(|p| p.heartbeat.as_ref().err().map(|e| (p.at, e)))
            .collect();
        assert!(
            failed.is_empty(),
            "{during}: {} of {} polls failed: {failed:?}",
            failed.len(),
            self.0.len()
        );
        assert!(self.0.len() >= 2, "{during}: only {} polls", self.0.len());
        assert!(
            self.advances() > 0,
            "{during}: HEARTBEAT did not advance over {} polls",
            self.0.len()
        );
    }

    /// HEARTBEAT's advance from the first poll to the last.
    fn advances(&self) -> u32 {
        let beats: Vec<u16> = self
            .0
            .iter()
            .filter_map(|p| p.heartbeat.clone().ok())
            .collect();
        beats
            .windows(2)
            .map(|w| u32::from(w[1].wrapping_sub(w[0])))
            .sum()
    }

    /// The longest time between two polls that saw HEARTBEAT advance (the
    /// first poll counts as one, and the stretch after the last advance
    /// up to the last poll too).
    fn longest_gap(&self) -> Duration {
        let mut longest = Duration::ZERO;
        let mut last: Option<(Duration, u16)> = None;
        for p in &self.0 {
            let Ok(hb) = p.heartbeat else { continue };
            match last {
                None => last = Some((p.at, hb)),
                Some((since, prev)) => {
                    longest = longest.max(p.at - since);
                    if hb != prev {
                        last = Some((p.at, hb));
                    }
                }
            }
        }
        longest
    }

    /// Poll latency: p50, p99, max.
    fn latency(&self) -> (Duration, Duration, Duration) {
        let mut t: Vec<Duration> = self.0.iter().map(|p| p.took).collect();
        t.sort();
        let at = |q: f64| t[((t.len() - 1) as f64 * q).round() as usize];
        (at(0.5), at(0.99), t[t.len() - 1])
    }

    fn span(&self) -> Duration {
        self.0.last().map_or(Duration::ZERO, |p| p.at)
    }

    /// One line of figures.
    fn report(&self, poll_ms: u16) -> String {
        let (p50, p99, max) = self.latency();
        let span = self.span().as_secs_f64();
        let expected = span * 1000.0 / f64::from(poll_ms.max(1));
        format!(
            "{} polls over {span:.1} s: latency p50 {:.1} ms, p99 {:.1} ms, max {:.1} ms; \
             HEARTBEAT +{} (+{expected:.0} expected at CFG_POLL_MS {poll_ms}), \
             longest gap between its advances {:.0} ms",
            self.0.len(),
            ms(p50),
            ms(p99),
            ms(max),
            self.advances(),
            ms(self.longest_gap())
        )
    }
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1000.0
}

/// A refusal's answer: 422 and `{"error": reason}`.
fn refused(r: &HttpResponse) -> String {
    let j: Value = serde_json::from_slice(&r.body)
        .unwrap_or_else(|e| panic!("the answer is not JSON ({e}): {}", r.text()));
    assert_eq!(r.status, 422, "{}", r.text());
    j["error"].as_str().unwrap_or_default().to_string()
}

#[test]
fn bad_images_are_refused_and_a_signed_update_is_installed_and_confirms_itself() {
    let images = Images::new("update");
    let dev = Device::start("update", "");
    let fw = dev.firmware();
    assert_eq!(
        (&fw["running"], &fw["state"]),
        (&Value::from("0.1.0"), &Value::from("confirmed")),
        "image A, confirmed: {fw}"
    );
    assert_eq!(
        dev.fw_registers(),
        ([0, 1, 0], FW_CONFIRMED),
        "FW_VERSION, FW_STATE"
    );
    let poll_ms = {
        let mut plc = dev.rig.modbus();
        must(plc.read_holding_registers(CFG_POLL_MS, 1), "CFG_POLL_MS")[0]
    };
    let port = dev.rig.qemu.ports.modbus;

    let b_path = images.signed("b-0.2.0.img", "0.2.0", "mps2-an386", None);
    let b = read(&b_path);
    let key = images.untrusted_key();
    let untrusted = read(&images.signed("untrusted.img", "0.2.0", "mps2-an386", Some(&key)));
    let other_board = read(&images.signed("nucleo.img", "0.2.0", "nucleo-f767zi", None));
    let truncated = b[..b.len() - 4096].to_vec();

    // The PLC's polls before any upload, for comparison.
    let idle = Poller::start(port);
    std::thread::sleep(Duration::from_secs(2));
    let idle = idle.stop();
    idle.assert_served("idle");
    println!("update: the PLC, idle: {}", idle.report(poll_ms));

    // Bad images: each refused with its reason, nothing marked, the PLC
    // served throughout. A refusal takes some 50 ms: the three are sent
    // again for a second or so, for the PLC's polls to span them.
    let bad = [
        (
            "signed by another key",
            &untrusted,
            "not signed by the trusted key",
        ),
        ("truncated", &truncated, "image truncated or too long"),
        (
            "for the NUCLEO-F767ZI",
            &other_board,
            "image for another board",
        ),
    ];
    let poller = Poller::start(port);
    let start = Instant::now();
    let mut rounds = 0;
    while rounds == 0 || start.elapsed() < REFUSING {
        for (what, image, reason) in bad {
            let (r, took) = dev.upload(image);
            assert_eq!(refused(&r), reason, "an image {what}");
            let fw = dev.firmware();
            assert_eq!(fw["upload"]["state"], "refused", "{what}: {fw}");
            assert_eq!(fw["upload"]["reason"], reason, "{what}: {fw}");
            assert_eq!(fw["state"], "confirmed", "{what}: nothing marked: {fw}");
            if rounds == 0 {
                println!(
                    "update: an image {what} ({} bytes) refused in {:.0} ms: {reason}",
                    image.len(),
                    ms(took)
                );
            }
        }
        rounds += 1;
    }
    let polls = poller.stop();
    polls.assert_served("the refused uploads");
    assert_eq!(
        dev.fw_registers(),
        ([0, 1, 0], FW_CONFIRMED),
        "nothing marked"
    );
    println!(
        "update: the PLC during {} refused uploads: {}",
        rounds * bad.len(),
        polls.report(poll_ms)
    );

    // Image B: written and marked, the PLC served throughout. Under QEMU
    // one upload takes less than a tenth of a second, too short for the
    // PLC's polls to say much: B is uploaded again and again for
    // UPLOADING (each upload replaces the marked one), the device
    // receiving and writing flash all that time, and the PLC's polls over
    // it are the figures of "during an upload".
    let poller = Poller::start(port);
    let start = Instant::now();
    let mut took = Vec::new();
    while took.is_empty() || start.elapsed() < UPLOADING {
        let (r, t) = dev.upload(&b);
        assert_eq!(
            r.status,
            200,
            "upload {} of B: {}",
            took.len() + 1,
            r.text()
        );
        let answer: Value = serde_json::from_slice(&r.body).expect("JSON");
        assert_eq!(answer["ok"], true, "{answer}");
        assert_eq!(answer["version"], "0.2.0", "{answer}");
        assert_eq!(answer["restart_needed"], true, "{answer}");
        took.push(t);
    }
    let polls = poller.stop();
    let fw = dev.firmware();
    assert_eq!(fw["state"], "pending", "{fw}");
    assert_eq!(fw["upload"]["state"], "installed", "{fw}");
    assert_eq!(fw["upload"]["version"], "0.2.0", "{fw}");
    assert_eq!(dev.fw_registers(), ([0, 1, 0], FW_PENDING), "B marked");
    polls.assert_served("the uploads of B");
    let first = took[0];
    took.sort();
    let median = took[took.len() / 2];
    let rate = |t: Duration| b.len() as f64 / 1024.0 / t.as_secs_f64();
    println!(
        "update: full image uploaded: {} bytes in {:.3} s, {:.0} KiB/s (the first); \
         {} uploads back to back: median {:.3} s ({:.0} KiB/s), slowest {:.3} s",
        b.len(),
        first.as_secs_f64(),
        rate(first),
        took.len(),
        median.as_secs_f64(),
        rate(median),
        took[took.len() - 1].as_secs_f64()
    );
    println!(
        "update: the PLC during the uploads: {}",
        polls.report(poll_ms)
    );
    println!(
        "update: longest engine stall during an upload (HEARTBEAT not advancing, to the polls' 100 ms): {:.0} ms",
        ms(polls.longest_gap())
    );

    // The restart: swapped in, on trial, then confirmed.
    let restart = dev.restart();
    let (booted, back, fw) = dev.wait_back(&restart, "0.2.0");
    assert_eq!(fw["previous"], "0.1.0", "{fw}");
    assert_eq!(fw["state"], "trial", "{fw}");
    assert_eq!(dev.fw_registers(), ([0, 2, 0], FW_TRIAL), "B on trial");
    println!(
        "update: swap and restart: the bootloader boots B {:.2} s after the restart's answer \
         (the device waits 0.5 s for the answer to leave), the page answers with B running \
         {:.2} s after it",
        booted.as_secs_f64(),
        back.as_secs_f64()
    );
    println!("update: the bootloader:\n{}", dev.boot_log());
    let fw = dev.wait_firmware("B confirmed by its self-check", |fw| fw["state"] != "trial");
    let confirmed = restart.at.elapsed();
    assert_eq!(
        (&fw["running"], &fw["previous"], &fw["state"]),
        (
            &Value::from("0.2.0"),
            &Value::from("0.1.0"),
            &Value::from("confirmed")
        ),
        "{fw}"
    );
    assert_eq!(dev.fw_registers(), ([0, 2, 0], FW_CONFIRMED), "B confirmed");
    println!(
        "update: B confirmed itself {:.1} s after the restart's answer (its self-check runs \
         TRIAL_CHECK after its start)",
        confirmed.as_secs_f64()
    );
    // The update kept the device's store: the administrator logs in to B
    // (no setup code needed again), and the audit log still holds A's
    // records (the account's creation, boot 1).
    let mut dev = dev;
    let r = dev.login(ADMIN, PASSWORD);
    assert_eq!(
        r.status,
        200,
        "the administrator kept across the update: {}",
        r.text()
    );
    let audit = dev.audit();
    assert!(
        audit
            .iter()
            .any(|r| r["kind"] == "account-created" && r["boot"] == 1),
        "the audit records of 0.1.0 kept across the update: {audit:?}"
    );
    let _ = dev.rig.exit();
}

/// The configuration, the accounts and the audit log are kept in the flash
/// file across a restart of QEMU (as on the NUCLEO in its flash): an
/// account and a setting made on one run are there on the next, which
/// needs no setup code, and the first run's audit records are still read.
#[test]
fn settings_accounts_and_the_audit_log_are_kept_across_restarts() {
    let images = Images::new("kept");
    let flash = images.dir.join("flash.bin");
    let dev = Device::start_kept("kept", "", Some(&flash));
    let (r, _) = dev.post(
        "/api/accounts",
        "application/json",
        br#"{"op":"add","name":"shift-2","role":"operator","password":"evening-crew-26"}"#,
    );
    assert_eq!(r.status, 200, "add an account: {}", r.text());
    assert!(r.text().contains(r#""saved":"saved""#), "{}", r.text());
    let poll_ms = {
        let mut plc = dev.rig.modbus();
        must(plc.read_holding_registers(CFG_POLL_MS, 1), "CFG_POLL_MS")[0]
    };
    let new_poll = if poll_ms == 80 { 90 } else { 80 };
    let body = format!(r#"{{"settings":{{"link.poll_ms":"{new_poll}"}}}}"#);
    let (r, _) = dev.post("/api/config", "application/json", body.as_bytes());
    assert_eq!(r.status, 200, "change a setting: {}", r.text());
    assert!(r.text().contains(r#""saved":"saved""#), "{}", r.text());
    let change = format!("link.poll_ms: {poll_ms} -> {new_poll}");
    assert!(
        dev.audit().iter().any(|r| r["detail"] == change.as_str()),
        "the change is audited"
    );
    // QEMU ends (the firmware exits); the flash file stays.
    let _ = dev.rig.exit();
    assert!(flash.exists(), "the flash file is kept");

    let mut dev = Device::boot("kept-again", "", Some(&flash));
    let session = dev.get_json("/api/session");
    assert_eq!(session["admin_exists"], true, "{session}");
    assert_eq!(session["setup"], false, "no setup again: {session}");
    let body = format!(r#"{{"code":"{SETUP_CODE}","name":"other","password":"{PASSWORD}"}}"#);
    let r = HttpClient::connect(dev.web(), STEP)
        .and_then(|mut c| c.post_json("/api/setup", &body))
        .unwrap_or_else(|e| panic!("POST /api/setup: {e}"));
    assert_eq!(r.status, 409, "an administrator exists: {}", r.text());
    let r = dev.login("shift-2", "evening-crew-26");
    assert_eq!(
        r.status,
        200,
        "the account made before the restart: {}",
        r.text()
    );
    let r = dev.login(ADMIN, PASSWORD);
    assert_eq!(r.status, 200, "the administrator: {}", r.text());
    let accounts = dev.get_json("/api/accounts");
    assert!(
        accounts
            .to_string()
            .contains(r#""name":"shift-2","role":"operator""#),
        "{accounts}"
    );
    {
        let mut plc = dev.rig.modbus();
        let now = must(plc.read_holding_registers(CFG_POLL_MS, 1), "CFG_POLL_MS")[0];
        assert_eq!(now, new_poll, "the setting kept");
    }
    let config = dev.get_json("/api/config");
    assert_eq!(
        config["settings"]["link.poll_ms"],
        new_poll.to_string(),
        "{config}"
    );
    let audit = dev.audit();
    let first = |kind: &str| audit.iter().any(|r| r["kind"] == kind && r["boot"] == 1);
    assert!(
        first("account-created") && audit.iter().any(|r| r["detail"] == change.as_str()),
        "the first run's records kept: {audit:?}"
    );
    assert!(
        audit.iter().any(|r| r["kind"] == "start" && r["boot"] == 2),
        "the second start recorded as boot 2: {audit:?}"
    );
    println!(
        "kept: after a restart of QEMU on the same flash file: 2 accounts, link.poll_ms {new_poll}, \
         {} audit records ({} from boot 1)",
        audit.len(),
        audit.iter().filter(|r| r["boot"] == 1).count()
    );
    let _ = dev.rig.exit();
}

#[test]
fn an_update_whose_self_check_fails_is_rolled_back() {
    let images = Images::new("update-rollback");
    // Every image run by this QEMU fails its self-check if it is on trial.
    let dev = Device::start("update-rollback", "selfcheck=fail");
    let b = read(&images.signed("b-0.2.0.img", "0.2.0", "mps2-an386", None));
    let (r, _) = dev.upload(&b);
    assert_eq!(r.status, 200, "upload of B: {}", r.text());
    assert_eq!(dev.firmware()["state"], "pending");

    assert_eq!(dev.fw_registers(), ([0, 1, 0], FW_PENDING), "B marked");

    let restart = dev.restart();
    let (_, on_trial, fw) = dev.wait_back(&restart, "0.2.0");
    assert_eq!(fw["state"], "trial", "{fw}");
    let (_, back, fw) = dev.wait_back(&restart, "0.1.0");
    assert_eq!(fw["state"], "rolled back", "{fw}");
    assert_eq!(fw["previous"], "0.2.0", "the image rolled back: {fw}");
    assert_eq!(dev.fw_registers(), ([0, 1, 0], FW_ROLLED_BACK), "A back");
    println!(
        "update-rollback: B on trial {:.1} s after the restart's answer, A back and rolled back after {:.1} s: {fw}",
        on_trial.as_secs_f64(),
        back.as_secs_f64()
    );
    let log = dev.boot_log();
    println!("update-rollback: the bootloader:\n{log}");
    assert!(
        log.contains("hans-boot: reverted: the image on trial did not confirm itself"),
        "{log}"
    );
    let _ = dev.rig.exit();
}
