//! Firmware updates under seeded random events, in virtual time: the real
//! gateway (its web upload, storage task, trial check) on the testkit's
//! board flash (the QEMU board's layout), whose bootloader step runs at
//! every restart. Each seed draws a sequence of events: good uploads,
//! refused ones (another key, truncated, corrupted, older), restarts,
//! waits (the trial confirms itself after 8 s), trial images that fail
//! their self-check, and power cuts at a random write or erase: during an
//! upload, during the bootloader's swap or revert, during the
//! confirmation.
//!
//! After every boot, the invariants:
//! * the active slot holds a whole image that passes the checks (never
//!   neither image, never a torn one), and the gateway reports its version
//!   (the page's status and FW_VERSION alike);
//! * the version running is the one the rules allow: an update answered
//!   200 runs after the next restart, on trial; a trial image restarted
//!   before its confirmation gives way to the previous one; a confirmed
//!   image stays; a refused upload changes nothing; a cut leaves one of
//!   the outcomes on either side of the cut operation;
//! * the PLC was served across each upload (HEARTBEAT advanced).

use std::collections::HashMap;
use std::net::Ipv4Addr;

use embassy_time::Duration;
use hans_fw_image::layout::MPS2_AN386;
use hans_fw_image::{check, Expect, Version};
use hans_gateway::registers as r;
use hans_gateway::testkit::flash::{sign, test_key, version, SimFlash, TEST_KEY_SEED};
use hans_gateway::testkit::rng::Rng;
use hans_gateway::testkit::world::{MemStorage, World, WorldConfig, SETUP_CODE};

const PC: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 50);
const BOARD: &str = "mps2-an386";

fn request(path: &str, token: Option<&str>, ty: &str, body: &[u8]) -> Vec<u8> {
    let mut r = format!(
        "POST {path} HTTP/1.1\r\nHost: 192.168.1.50\r\nOrigin: http://192.168.1.50\r\nConnection: close\r\nContent-Type: {ty}\r\nContent-Length: {}\r\n",
        body.len()
    );
    if let Some(t) = token {
        r.push_str(&format!("Cookie: hgw_session={t}\r\n"));
    }
    r.push_str("\r\n");
    let mut r = r.into_bytes();
    r.extend_from_slice(body);
    r
}

fn status_of(answer: &[u8]) -> u16 {
    let text = String::from_utf8_lossy(answer);
    text.split(' ')
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0)
}

fn body(seed: u64, v: Version, len: usize) -> Vec<u8> {
    let tag = (seed as u8) ^ (v.minor as u8).wrapping_mul(17) ^ v.patch as u8;
    (0..len).map(|i| (i as u8).wrapping_mul(29) ^ tag).collect()
}

struct Sim {
    w: World,
    flash: SimFlash,
    rng: Rng,
    seed: u64,
    token: Option<String>,
    /// Bodies of every image ever made (by version), to check the slot.
    bodies: HashMap<Version, usize>,
    /// The version confirmed (what a restart keeps when nothing else is
    /// pending or on trial).
    confirmed: Version,
    /// An update answered 200 and not superseded: runs after the restart.
    pending: Option<Version>,
    /// A possible pending update (a cut made it uncertain).
    maybe_pending: Option<Version>,
    /// The image on trial since the last boot, and its predecessor.
    trial: Option<(Version, Version)>,
    /// The trial's confirmation may have happened (a cut hit it).
    maybe_confirmed: bool,
    next_minor: u16,
    stats: Stats,
}

#[derive(Debug, Default)]
struct Stats {
    uploads: u32,
    refused: u32,
    restarts: u32,
    cuts: u32,
    trials_confirmed: u32,
    rollbacks: u32,
}

impl Sim {
    fn new(seed: u64) -> Sim {
        let flash = SimFlash::new();
        let first = version(1, 0, 0);
        let len = 3000;
        flash.install(&sign(&TEST_KEY_SEED, BOARD, first, &body(seed, first, len)));
        let mut storage = MemStorage::default();
        storage.flash = Some(flash.clone());
        let mut w = World::new(WorldConfig {
            seed,
            web: true,
            storage,
            ..WorldConfig::default()
        });
        w.run_for(Duration::from_millis(300));
        let mut sim = Sim {
            w,
            flash,
            rng: Rng::new(seed),
            seed,
            token: None,
            bodies: HashMap::from([(first, len)]),
            confirmed: first,
            pending: None,
            maybe_pending: None,
            trial: None,
            maybe_confirmed: false,
            next_minor: 1,
            stats: Stats::default(),
        };
        let setup =
            format!(r#"{{"code":"{SETUP_CODE}","name":"admin","password":"correct horse"}}"#);
        let got = sim.w.http(
            PC,
            &request("/api/setup", None, "application/json", setup.as_bytes()),
            Duration::from_secs(10),
        );
        assert_eq!(status_of(&got), 200, "{}", String::from_utf8_lossy(&got));
        sim.token = session(&got);
        sim
    }

    fn login(&mut self) {
        let got = self.w.http(
            PC,
            &request(
                "/api/login",
                None,
                "application/json",
                br#"{"name":"admin","password":"correct horse"}"#,
            ),
            Duration::from_secs(10),
        );
        assert_eq!(status_of(&got), 200, "login");
        self.token = session(&got);
    }

    fn upload(&mut self, image: &[u8]) -> u16 {
        let beat = self.w.reg(r::STATUS_HEARTBEAT);
        let raw = request(
            "/api/firmware",
            self.token.as_deref(),
            "application/octet-stream",
            image,
        );
        let got = self.w.http(PC, &raw, Duration::from_secs(60));
        let code = status_of(&got);
        if code == 401 {
            self.login();
            return self.upload(image);
        }
        self.w.run_for(Duration::from_millis(300));
        assert_ne!(
            self.w.reg(r::STATUS_HEARTBEAT),
            beat,
            "the gateway kept its heartbeat across the upload"
        );
        code
    }

    /// A good image of the next version, perhaps with a power cut during
    /// its upload.
    fn good_upload(&mut self) {
        let v = version(1, self.next_minor, 0);
        self.next_minor += 1;
        let len = 1000 + self.rng.below(20_000) as usize;
        self.bodies.insert(v, len);
        let image = sign(&TEST_KEY_SEED, BOARD, v, &body(self.seed, v, len));
        // A cut only when nothing is pending or on trial (the outcome is
        // then one of two), in one upload of three.
        let on_trial = self.trial.is_some();
        let cut = self.pending.is_none()
            && self.maybe_pending.is_none()
            && !on_trial
            && self.rng.chance(333);
        if cut {
            let writes = 2 + (len / 512) as u64 + 4;
            self.flash.cut_after(self.rng.below(writes) as u32);
        }
        let code = self.upload(&image);
        self.stats.uploads += 1;
        if cut && self.flash.is_off() {
            self.stats.cuts += 1;
            // The upload failed somewhere, or was marked just before the
            // cut (the mark's last write the cut one): either way a
            // restart follows (the power is gone).
            assert_ne!(code, 200, "an upload whose flash died answered 200");
            self.maybe_pending = Some(v);
            self.restart();
            return;
        }
        self.flash.power_on();
        if on_trial {
            // A trial image takes no update until it is confirmed.
            assert_eq!(code, 409, "an upload during a trial");
            return;
        }
        assert_eq!(
            code,
            200,
            "a good image refused (seed {}, FW_STATE {}, {self:?})",
            self.seed,
            self.w.reg(r::STATUS_FW_STATE)
        );
        self.pending = Some(v);
        self.maybe_pending = None;
    }

    /// A bad image: refused, nothing changes.
    fn bad_upload(&mut self) {
        let v = version(1, self.next_minor, 0);
        let good = body(self.seed, v, 2000);
        let kind = self.rng.below(4);
        let image = match kind {
            0 => sign(&[9; 32], BOARD, v, &good),
            1 => {
                let full = sign(&TEST_KEY_SEED, BOARD, v, &good);
                full[..full.len() - 1 - self.rng.below(1500) as usize].to_vec()
            }
            2 => {
                let mut full = sign(&TEST_KEY_SEED, BOARD, v, &good);
                let n = full.len();
                let at = 136 + self.rng.below((n - 136) as u64) as usize;
                full[at] ^= 0x40;
                full
            }
            _ => sign(&TEST_KEY_SEED, BOARD, version(0, 1, 0), &good),
        };
        let code = self.upload(&image);
        self.stats.refused += 1;
        assert!((400..500).contains(&code), "a bad image answered {code}");
        if self.trial.is_some() {
            return;
        }
        let state = self.w.reg(r::STATUS_FW_STATE);
        if kind == 2 {
            // Its header passed: its body went into the download slot,
            // over a pending update, which is no longer marked (and the
            // state says so).
            self.pending = None;
            self.maybe_pending = None;
            assert_ne!(state, 3, "a pending update overwritten still shown");
        } else if self.pending.is_some() {
            // Refused at its header: nothing written, the pending update
            // stays.
            assert_eq!(state, 3, "a header refusal unmarked the pending update");
        }
    }

    /// What may run after the next power-up.
    fn expected(&self) -> Vec<Version> {
        if let Some((new, old)) = self.trial {
            // Restarted before (or during) its confirmation: rolled back,
            // unless the confirmation was made (or half made).
            return if self.maybe_confirmed {
                vec![new, old]
            } else {
                vec![old]
            };
        }
        if let Some(v) = self.pending {
            return vec![v];
        }
        let mut allowed = vec![self.confirmed];
        if let Some(v) = self.maybe_pending {
            allowed.push(v);
        }
        allowed
    }

    /// A power cycle, perhaps with a cut during the bootloader's swap or
    /// revert; then the invariants.
    fn restart(&mut self) {
        let allowed = self.expected();
        let before = self.running();
        let swapping =
            self.pending.is_some() || self.maybe_pending.is_some() || self.trial.is_some();
        if swapping && self.rng.chance(400) {
            // Somewhere in the swap (thousands of writes and erases for
            // its pages and progress words).
            self.flash.cut_after(self.rng.below(3000) as u32);
            self.stats.cuts += 1;
        }
        self.w.config.self_check_fails = self.rng.chance(300);
        self.w.restart();
        self.stats.restarts += 1;
        self.w.run_for(Duration::from_millis(200));
        self.token = None;
        let running = self.check_active();
        assert!(
            allowed.contains(&running),
            "running {running:?} after the restart; allowed {allowed:?} (before: {before:?}, {self:?})"
        );
        let state = self.w.reg(r::STATUS_FW_STATE);
        let was_trial = self.trial.take();
        self.maybe_confirmed = false;
        if Some(running) == self.pending
            || (Some(running) == self.maybe_pending && running != before)
        {
            assert_eq!(state, 2, "a new image runs on trial");
            self.trial = Some((running, before));
        } else if let Some((new, old)) = was_trial {
            if running == old && new != old {
                assert_eq!(state, 4, "a rolled-back image says so");
                self.stats.rollbacks += 1;
            }
            self.confirmed = running;
        } else {
            assert!(
                state == 1 || state == 4,
                "state {state} of a confirmed image"
            );
            self.confirmed = running;
        }
        self.pending = None;
        self.maybe_pending = None;
    }

    /// The active slot's image passes every check; the gateway reports its
    /// version. Returns it.
    fn check_active(&mut self) -> Version {
        let h = self
            .flash
            .header(false)
            .expect("a header in the active slot");
        let len = self.bodies[&h.version];
        let image = self.flash.active_image(len);
        let key = test_key();
        let expect = Expect {
            key: &key,
            board: BOARD,
            running: version(0, 0, 0),
            allow_downgrade: true,
            max_body: MPS2_AN386.max_body(),
        };
        let checked = check(&image, &expect).expect("the active image is whole and signed");
        let v = checked.version;
        let regs = [55, 56, 57].map(|a| self.w.reg(a));
        assert_eq!(regs, [v.major, v.minor, v.patch], "FW_VERSION");
        v
    }

    fn running(&mut self) -> Version {
        let [a, b, c] = [55, 56, 57].map(|a| self.w.reg(a));
        version(a, b, c)
    }

    /// Time passes: a trial image confirms itself after its check, or
    /// (its check failing) restarts; perhaps a cut hits the confirmation.
    fn wait(&mut self) {
        let ms = self.rng.below(12_000);
        let cut_confirm = self.trial.is_some() && self.rng.chance(200);
        if cut_confirm {
            self.flash.cut_after(self.rng.below(3) as u32);
        }
        self.w.run_for(Duration::from_millis(ms));
        if self.flash.is_off() {
            // The cut hit the confirmation: a restart follows.
            self.stats.cuts += 1;
            self.maybe_confirmed = true;
            self.restart();
            return;
        }
        self.flash.power_on();
        if self.w.restart_asked() {
            // The self-check failed: the device restarts itself.
            assert_eq!(
                self.w.reg(r::STATUS_FW_STATE),
                2,
                "only a trial image restarts"
            );
            self.restart();
            return;
        }
        if let Some((new, _)) = self.trial {
            if self.w.reg(r::STATUS_FW_STATE) == 1 {
                self.trial = None;
                self.confirmed = new;
                self.stats.trials_confirmed += 1;
            }
        }
    }
}

impl std::fmt::Debug for Sim {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "confirmed {:?}, pending {:?}, maybe {:?}, trial {:?}",
            self.confirmed, self.pending, self.maybe_pending, self.trial
        )
    }
}

fn session(answer: &[u8]) -> Option<String> {
    let text = String::from_utf8_lossy(answer);
    text.split("hgw_session=")
        .nth(1)
        .and_then(|t| t.split(';').next())
        .map(str::to_string)
}

#[test]
fn seeded_updates_restarts_and_power_cuts_keep_a_whole_signed_image_running() {
    let start = std::time::Instant::now();
    let mut total = Stats::default();
    for seed in 0..40u64 {
        let mut sim = Sim::new(seed);
        for _ in 0..14 {
            let e = sim.rng.below(10);
            if std::env::var("DST_TRACE").is_ok() {
                eprintln!("seed {seed}: event {e}: {sim:?}");
            }
            match e {
                0..=2 => sim.good_upload(),
                3 => sim.bad_upload(),
                4..=6 => sim.restart(),
                _ => sim.wait(),
            }
        }
        sim.restart();
        let s = &sim.stats;
        total.uploads += s.uploads;
        total.refused += s.refused;
        total.restarts += s.restarts;
        total.cuts += s.cuts;
        total.trials_confirmed += s.trials_confirmed;
        total.rollbacks += s.rollbacks;
    }
    println!(
        "updates: 40 seeds in {:.1} s: {total:?}",
        start.elapsed().as_secs_f64()
    );
    assert!(total.uploads > 40 && total.cuts > 10, "{total:?}");
    assert!(
        total.trials_confirmed > 5 && total.rollbacks > 5,
        "{total:?}"
    );
}
