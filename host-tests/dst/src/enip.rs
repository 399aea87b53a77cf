//! The EtherNet/IP PLC of a scenario (a third of the seeds): a Logix PLC
//! at its own address, with the testkit's scanner, that opens an
//! exclusive-owner class 1 connection at a random RPI and timeout
//! multiplier, writes the output assembly (heartbeat, both channels'
//! commands, parameters and Execute) in its datagrams, closes it with
//! Forward_Close, or falls silent (cable pulled) and lets it time out.
//!
//! While it owns the command inputs the Modbus PLCs' actions on them are
//! probes of the ownership rule (each must be refused whole, exception 01);
//! the channels' commands are fired through the assemblies instead and the
//! checker judges them as any command (the same outcomes as over Modbus).

use std::net::Ipv4Addr;

use embassy_time::Instant;
use hans_enip::wire::cip::GeneralStatus;
use hans_enip::wire::conn_mgr::ExtendedStatus;
use hans_gateway::config::Config;
use hans_gateway::enip::assembly::output;
use hans_gateway::job::Source;
use hans_gateway::registers as r;
use hans_gateway::state::owner::Commander;
use hans_gateway::state::Phase;
use hans_gateway::testkit::enip::Scanner;
use hans_gateway::testkit::plc::Answer;
use hans_gateway::testkit::rng::Rng;

use super::{ms, Failure, Kind, Scenario};

/// The Logix PLC's address.
pub(crate) const LOGIX: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 50);

/// Whether the scenario of `seed` has an EtherNet/IP PLC: drawn from a
/// stream of its own, so that the scenarios without one are what they
/// were before it existed.
pub(crate) fn enabled(seed: u64) -> bool {
    Rng::new(seed ^ 0x454E_4950).chance(333)
}

/// The configuration of a scenario with an EtherNet/IP PLC: the watchdog
/// on in most (a lost connection during a motion is what it acts on),
/// from the same stream of its own.
pub(crate) fn watched(seed: u64, mut config: Config) -> Config {
    let mut rng = Rng::new(seed ^ 0x454E_4950 ^ 1);
    if config.enip_enabled && config.watchdog_ms == 0 && rng.chance(600) {
        config.watchdog_ms = 100 + rng.below(900) as u16;
    }
    config
}

/// The EtherNet/IP PLC's state.
#[derive(Default)]
pub(crate) struct EnipPlc {
    scanner: Option<Scanner>,
    /// The connection's RPI (µs).
    rpi_us: u32,
    /// When the next datagram is due, while the connection is open and the
    /// PLC talks.
    next: Option<Instant>,
    /// The cable is pulled: nothing is sent until the connection timed out.
    silent: bool,
    serial: u16,
    beat: u16,
    /// Finished (the drain): no more actions or datagrams.
    done: bool,
}

impl EnipPlc {
    /// The connection is open on the PLC's side.
    fn open(&self) -> bool {
        self.scanner.as_ref().is_some_and(|s| s.conn.is_some())
    }

    /// It talks: the connection is open and its datagrams flow.
    pub(crate) fn talking(&self) -> bool {
        self.open() && !self.silent && !self.done
    }
}

impl Scenario {
    /// The EtherNet/IP PLC talks and owns the command inputs: the
    /// channels' commands go through its assemblies.
    pub(crate) fn enip_drives(&self) -> bool {
        self.enip.as_ref().is_some_and(EnipPlc::talking)
            && self.world.model(|m| m.owner.enip_owns())
    }

    /// Someone owns the command inputs over EtherNet/IP.
    pub(crate) fn enip_owns(&self) -> bool {
        self.world.model(|m| m.owner.enip_owns())
    }

    /// Sends the output image now and lets the gateway take it.
    fn enip_send(&mut self) {
        let Some(e) = self.enip.as_mut() else { return };
        if !e.talking() {
            return;
        }
        if let Some(s) = e.scanner.as_mut() {
            s.produce(&mut self.world);
            // The T->O datagrams are the gateway's view; the checker reads
            // the same view from the model (assembly::encode_input).
            let _ = s.consume(&mut self.world);
        }
        self.world.catch_up();
    }

    /// Opens, closes, or pulls the cable.
    pub(crate) fn enip_connection(&mut self) -> Result<(), String> {
        let Some(e) = self.enip.as_mut() else {
            return Ok(());
        };
        if e.done {
            return Ok(());
        }
        if e.open() && e.silent {
            // The cable is back once the gateway has timed the connection
            // out (it has, when no connection is counted).
            if self.world.model(|m| m.owner.enip_connections) == 0 {
                e.silent = false;
                if let Some(s) = e.scanner.as_mut() {
                    s.conn = None;
                }
                self.note("enip: cable back".into());
            }
            return Ok(());
        }
        if e.open() {
            // The cable is pulled more often while a motion runs: that is
            // when the watchdog must act.
            let moving = self.world.model(|m| m.active_motion.is_some());
            if self.rng.chance(if moving { 700 } else { 300 }) {
                let e = self.enip.as_mut().expect("checked");
                e.silent = true;
                e.next = None;
                self.note("enip: cable pulled (the connection will time out)".into());
                return Ok(());
            }
            let e = self.enip.as_mut().expect("checked");
            let s = e.scanner.as_mut().expect("open");
            s.ensure_session(&mut self.world);
            let h = s.close(&mut self.world);
            e.next = None;
            self.note(format!("enip: Forward_Close: {:?}", h.status));
            if h.status != GeneralStatus::Success {
                return Err(format!("Forward_Close refused: {h:?}"));
            }
            return Ok(());
        }
        // Closed: a Forward_Open at 20-100 ms RPI, multiplier 0-3.
        let rpi_us = 20_000 + 1_000 * self.rng.below(81) as u32;
        let mult = self.rng.below(4) as u8;
        let e = self.enip.as_mut().expect("checked");
        e.serial = e.serial.wrapping_add(1);
        let serial = e.serial;
        if e.scanner.is_none() {
            e.scanner = Some(Scanner::connect(&mut self.world, LOGIX));
        }
        let s = e.scanner.as_mut().expect("connected");
        s.ensure_session(&mut self.world);
        // The ownership rule: refused while a command another master
        // fired is Busy, admitted otherwise.
        let (others_busy, busy_now) = self.world.model(|m| {
            let busy: Vec<Source> = Source::all().filter(|src| m.is_busy(*src)).collect();
            let others = !busy.is_empty() && m.owner.commander != Commander::Enip(LOGIX);
            (others, format!("{busy:?} fired by {:?}", m.owner.commander))
        });
        let h = s.open_at(&mut self.world, serial, rpi_us, mult);
        let ok = h.status == GeneralStatus::Success;
        let conflict =
            h.additional.first().copied() == Some(ExtendedStatus::OwnershipConflict.into());
        self.note(format!(
            "enip: Forward_Open rpi {} ms x{} (Busy: {busy_now}): {:?} {:?}",
            rpi_us / 1000,
            4u32 << mult,
            h.status,
            h.additional
        ));
        // (Judged on the state when the gateway answered too: a command
        // may have ended in between.)
        let still_busy = self
            .world
            .model(|m| Source::all().any(|src| m.is_busy(src)));
        if ok && others_busy && still_busy {
            return Err(format!(
                "an owner Forward_Open admitted while another master's command was Busy ({busy_now})"
            ));
        }
        if !(ok || conflict && others_busy) {
            return Err(format!("an owner Forward_Open refused: {h:?}"));
        }
        if ok {
            let e = self.enip.as_mut().expect("checked");
            e.rpi_us = rpi_us;
            e.silent = false;
            e.next = Some(self.world.now());
            // The image as the inputs are: the first datagram is the
            // baseline (no edges), as a PLC going online.
            let image = self.world.model(|m| {
                let mut out = vec![0u8; hans_gateway::enip::assembly::SIZE];
                hans_gateway::enip::assembly::encode_output(m, &mut out);
                out
            });
            let s = e.scanner.as_mut().expect("connected");
            s.out = image;
            e.beat = u16::from_le_bytes([s.out[output::HEARTBEAT], s.out[output::HEARTBEAT + 1]]);
            self.enip_send();
            self.enip_tick();
        }
        Ok(())
    }

    /// A Modbus write to a command input while EtherNet/IP owns them: it
    /// must be refused whole (exception 01), and change nothing.
    pub(crate) fn enip_probe(&mut self) -> Result<(), String> {
        let (addr, words): (u16, Vec<u16>) = match self.rng.below(5) {
            0 => (r::channel_base(self.rng.below(2) as usize), vec![1, 13, 7]),
            1 => (r::RAW_CONTROL, vec![1]),
            2 => (r::TRIG_BITS, vec![0xFFFF]),
            3 => (r::CONTROL_HEARTBEAT, vec![self.heartbeat.wrapping_add(77)]),
            _ => (r::channel_base(1) + 8, vec![1, 2, 3, 4]),
        };
        let before = self.world.model(|m| m.owner.enip_owns());
        let i = self.plc();
        let a = self.write(i, addr, &words);
        self.note(format!("modbus write {addr} while EtherNet/IP owns: {a:?}"));
        if before && !matches!(a, Answer::Exception(1)) {
            return Err(format!(
                "ownership: a Modbus write to command input {addr} while EtherNet/IP owns them: {a:?}"
            ));
        }
        Ok(())
    }

    /// The heartbeat, in the output image.
    pub(crate) fn enip_heartbeat(&mut self) {
        if let Some(e) = self.enip.as_mut() {
            e.beat = e.beat.wrapping_add(1);
            let b = e.beat;
            if let Some(s) = e.scanner.as_mut() {
                s.put_u16(output::HEARTBEAT, b);
            }
        }
        self.enip_send();
    }

    /// A channel command through the output assembly: code and parameters
    /// with Execute low, then Execute.
    pub(crate) fn enip_channel(
        &mut self,
        ch: u8,
        code: u16,
        params: &[f32],
        kind: Kind,
    ) -> Result<(), String> {
        self.seq = self.seq.wrapping_add(1);
        let seq = self.seq;
        let high = self
            .world
            .model(|m| m.channels[usize::from(ch)].inputs.execute());
        if high {
            // A rising edge needs Execute low first.
            self.checker.released(Source::Channel(ch), &self.world);
        }
        if let Some(s) = self.enip.as_mut().and_then(|e| e.scanner.as_mut()) {
            s.command_on(ch, code, seq, params);
        }
        self.enip_send();
        self.note(format!("enip ch{ch}: code {code} {params:?}"));
        if !self.world.model(|m| m.is_busy(Source::Channel(ch))) {
            self.stats.enip_commands += 1;
        }
        self.fire_via(Source::Channel(ch), kind, true)
    }

    /// Execute of channel `ch` in the output image, sent now.
    pub(crate) fn enip_execute(&mut self, ch: u8, on: bool) {
        if let Some(s) = self.enip.as_mut().and_then(|e| e.scanner.as_mut()) {
            s.execute_on(ch, on);
        }
        self.enip_send();
    }

    /// Execute falls through the assembly; the outputs clear as over Modbus.
    pub(crate) fn enip_release(&mut self, ch: u8) -> Result<(), String> {
        let source = Source::Channel(ch);
        let (busy, high) = self.world.model(|m| {
            (
                m.is_busy(source),
                m.channels[usize::from(ch)].inputs.execute(),
            )
        });
        if high {
            self.checker.released(source, &self.world);
        }
        self.enip_execute(ch, false);
        self.note(format!("enip release {source:?}"));
        let h = self
            .world
            .model(|m| m.handshake(source).copied().unwrap_or_default());
        if high && !busy && h.phase != Phase::Idle {
            return Err(format!(
                "{source:?}: outputs not cleared when Execute fell over EtherNet/IP ({:?})",
                h.phase
            ));
        }
        Ok(())
    }

    /// Sends the datagrams due by now (one per RPI while the PLC talks).
    fn enip_tick(&mut self) {
        let now = self.world.now();
        let Some(e) = self.enip.as_mut() else { return };
        let Some(next) = e.next.filter(|_| e.talking()) else {
            return;
        };
        if next <= now {
            let rpi = embassy_time::Duration::from_micros(u64::from(e.rpi_us));
            e.next = Some(next + rpi).map(|t| if t <= now { now + rpi } else { t });
            self.enip_send();
        }
    }

    /// Runs the world until `end`, the EtherNet/IP PLC producing at its
    /// RPI; the invariants after every turn.
    pub(crate) fn advance(&mut self, end: Instant, n: usize) -> Result<(), Failure> {
        loop {
            let due = self
                .enip
                .as_ref()
                .filter(|e| e.talking())
                .and_then(|e| e.next)
                .map_or(end, |t| t.min(end));
            while self.world.turn(due) {
                self.checker
                    .check(&self.world)
                    .map_err(|e| self.fail(n, e))?;
            }
            self.enip_tick();
            self.checker
                .check(&self.world)
                .map_err(|e| self.fail(n, e))?;
            if self.world.now() >= end {
                return Ok(());
            }
        }
    }

    /// The drain: the EtherNet/IP PLC closes its connection (Modbus owns
    /// the inputs again, as they were last written) and stops.
    pub(crate) fn enip_stop(&mut self) {
        let Some(e) = self.enip.as_mut() else { return };
        e.done = true;
        e.next = None;
        if let Some(s) = e.scanner.as_mut().filter(|s| s.conn.is_some()) {
            s.ensure_session(&mut self.world);
            let h = s.close(&mut self.world);
            // A silent connection may have timed out already.
            let _ = h;
        }
        self.world.run_for(ms(20));
        self.note("enip: closed for the drain".into());
    }
}
