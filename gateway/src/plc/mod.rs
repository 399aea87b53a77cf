//! What the PLC's writes do: the rules of REGISTERS.md's handshake on the
//! typed events the register view decodes, and the port that binds them to
//! the Modbus server ([`PlcPort`], in `port.rs`).
//!
//! * A rising edge of Execute (or of a trigger bit) fires the source: its
//!   inputs are read at that moment into a typed job; Busy and Queued are
//!   set before the write is answered, so the first read after it shows
//!   them. A rising edge while Busy is ignored (PLCopen).
//! * A job that cannot be built (a bad parameter, an empty trigger entry)
//!   ends in Error at once; so does one fired while the link is not up
//!   (39500: also while connecting) and one that finds the queue full
//!   (39600). Nothing is dropped without an outcome.
//! * A falling edge clears the outputs of a command that is no longer Busy.
//! * A changed `PLC_HEARTBEAT` feeds the watchdog and clears its trip bit.
//! * `CONFIG_COMMAND` 1 checks and applies the edit (the save is the
//!   storage task's), 2 discards it, 3 loads the factory settings into it.
//! * Who owns the command inputs (`crate::state::owner`): an EtherNet/IP
//!   exclusive owner while its connection is open, else Modbus
//!   ([`modbus_may_write`], [`enip_may_own`]).

mod port;

pub(crate) use port::{warden, PlcPort};

use embassy_time::Instant;

use crate::config::{ConfigResult, Setting};
use crate::error::{GatewayError, Outcome};
use crate::job::{command, text, Job, JobKind, Source};
use crate::registers::config::{self as reg_config, InvalidValue};
use crate::registers::{Edge, PlcEvents};
use crate::state::owner::Commander;
use crate::state::Model;

/// Acts on the events of one write by `by`; `true` if a job was queued
/// (the engine has work).
pub(crate) fn apply(m: &mut Model, ev: &PlcEvents, now: Instant, by: Commander) -> bool {
    if ev.edges.iter().any(|e| matches!(e, Edge::Rose(_))) {
        m.owner.commander = by;
    }
    if ev.heartbeat {
        m.plc.last_beat = now;
        m.plc.watchdog_tripped = false;
        m.plc.lost = false;
    }
    let mut queued = false;
    for edge in &ev.edges {
        match *edge {
            Edge::Rose(source) => queued |= fire(m, source, now),
            Edge::Fell(source) => m.release(source),
        }
    }
    queued
}

/// May a Modbus write of `count` registers from `start` be stored, by the
/// ownership rule? Not when it touches the command inputs while an
/// EtherNet/IP PLC owns them (then it is refused whole: exception 01).
pub(crate) fn modbus_may_write(m: &Model, start: u16, count: usize) -> bool {
    !m.owner.enip_owns()
        || !(start..)
            .take(count)
            .any(crate::registers::view::is_command_input)
}

/// May an EtherNet/IP exclusive owner at `ip` take the command inputs
/// now? Not while a command another master fired (Modbus, or an owner at
/// another address) is Busy: the PLC that fired it keeps the inputs until
/// it has ended, then the Forward_Open (which a Logix PLC repeats on its
/// own) succeeds.
#[cfg(feature = "enip")]
pub(crate) fn enip_may_own(m: &Model, ip: core::net::Ipv4Addr) -> bool {
    let busy = m.channels.iter().any(|c| c.handshake.is_busy())
        || m.raw.handshake.is_busy()
        || m.triggers.handshakes.iter().any(|h| h.is_busy());
    !busy || m.owner.commander == Commander::Enip(ip)
}

/// What a source's inputs say now: its job (or why there is none), the
/// sequence number and the command code to echo.
fn build(m: &Model, source: Source) -> (u16, u16, Result<Job, GatewayError>) {
    let robot = m.config.active.robot_id;
    let job = |seq, built: Result<(JobKind, Option<u8>), GatewayError>| {
        built.map(|(kind, rbt)| Job {
            source,
            seq,
            robot: rbt.unwrap_or(robot),
            kind,
        })
    };
    match source {
        Source::Channel(i) => {
            let Some(ch) = m.channels.get(usize::from(i)) else {
                return (0, 0, Err(GatewayError::BadParameter));
            };
            let inp = &ch.inputs;
            let built = match (inp.text1.trimmed(), inp.text2.trimmed()) {
                (Some(text1), Some(text2)) => command::build(
                    &command::Inputs {
                        code: inp.code,
                        params: &inp.params,
                        text1,
                        text2,
                        seq: inp.seq,
                        joints: m.robot.joints,
                    },
                    robot,
                )
                .map(|k| (k, None)),
                _ => Err(GatewayError::BadParameter),
            };
            (inp.seq, inp.code, job(inp.seq, built))
        }
        Source::Raw => {
            let seq = m.raw.seq;
            (seq, 0, job(seq, text::build(m.raw.request.bytes())))
        }
        Source::Trigger(i) => {
            let entry = m.triggers.entries.get(usize::from(i));
            let built = match entry {
                Some(e) if !e.is_empty() => text::build(e.bytes()),
                _ => Err(GatewayError::TriggerEmpty),
            };
            (0, 0, job(0, built))
        }
    }
}

/// A rising edge at `now`: fires the source unless it is Busy. `true` if
/// queued.
pub(crate) fn fire(m: &mut Model, source: Source, now: Instant) -> bool {
    if m.is_busy(source) {
        // PLCopen: a new edge while Busy is ignored.
        return false;
    }
    let (seq, code, job) = build(m, source);
    m.start(source, seq, code, now);
    let job = match job {
        Ok(j) => j,
        Err(e) => {
            m.finish(source, Outcome::gateway(e), now);
            return false;
        }
    };
    if !m.link.is_up() {
        m.finish(source, Outcome::gateway(GatewayError::NotConnected), now);
        return false;
    }
    info!("{} {}: queued", source.name(), source.index());
    if let Err(job) = m.queue.push(job) {
        m.finish(job.source, Outcome::gateway(GatewayError::QueueFull), now);
        return false;
    }
    true
}

/// What a configuration command asks of the caller next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(crate) enum ConfigStep {
    /// Done (discard, defaults): nothing more.
    Done,
    /// The edit holds an invalid value: nothing applied (exception 03).
    Invalid(InvalidValue),
    /// Applied: now save it (the storage task), then report.
    Save,
    /// The edit changes this protected setting (the first), which Modbus
    /// may not while configuration over Modbus is off: nothing applied
    /// (exception 01, `CONFIG_RESULT` 4).
    Locked(&'static Setting),
}

/// `CONFIG_COMMAND` `cmd` (1-3).
///
/// A refused apply leaves the edit as it is (`CONFIG_BAD_ADDR` names the
/// register to fix); every later apply is refused until it is fixed or
/// discarded (2). While configuration over Modbus is off, an apply that
/// changes a protected setting is refused whole, and defaults (3) leave
/// the protected settings as they are.
pub(crate) fn config_command(m: &mut Model, cmd: u16) -> ConfigStep {
    let may_change_protected = m.access.modbus_may_change_protected(&m.config.active);
    let c = &mut m.config;
    match cmd {
        1 => {
            match c
                .edit
                .map_or(Ok(c.active), |w| reg_config::decode(&w, &c.active))
            {
                Err(bad) => {
                    c.result = ConfigResult::Invalid;
                    c.bad_addr = bad.addr;
                    warn!("config: register {} invalid, not applied", bad.addr);
                    ConfigStep::Invalid(bad)
                }
                Ok(new) => match new.protected_change(&c.active) {
                    Some(s) if !may_change_protected => {
                        c.result = ConfigResult::Protected;
                        warn!("config: {} is protected (configuration over Modbus is off), not applied", s.key);
                        ConfigStep::Locked(s)
                    }
                    _ => {
                        c.apply(new);
                        ConfigStep::Save
                    }
                },
            }
        }
        2 => {
            c.edit = None;
            c.result = ConfigResult::Ok;
            ConfigStep::Done
        }
        _ => {
            // Registers only: the settings without registers keep their
            // values when the edit is applied (it is read over the active
            // configuration).
            let defaults = match may_change_protected {
                true => c.factory,
                false => c.factory.with_protected_of(&c.active),
            };
            c.edit = Some(reg_config::encode(&defaults));
            c.result = ConfigResult::Ok;
            ConfigStep::Done
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;
    use crate::registers::{self as r, write};
    use crate::state::{LinkState, Phase};

    fn model() -> Model {
        let mut m = Model::new(Config::default(), Config::default());
        m.link.state = LinkState::Connected;
        m
    }

    fn now() -> Instant {
        Instant::from_millis(10)
    }

    fn plc(m: &mut Model, start: u16, values: &[u16]) -> bool {
        let ev = write(m, start, values).unwrap();
        apply(m, &ev, now(), Commander::Modbus)
    }

    #[test]
    fn a_rising_edge_fires_once_and_an_edge_while_busy_is_ignored() {
        let mut m = model();
        let b = r::channel_base(0);
        assert!(plc(&mut m, b, &[1, 5, 9]));
        assert_eq!(m.channels[0].handshake.phase, Phase::Queued);
        assert_eq!(m.channels[0].handshake.seq_echo, 9);
        assert_eq!(m.queue.len(), 1);
        // Falls and rises again while Busy: ignored, nothing queued.
        plc(&mut m, b, &[0]);
        assert!(!plc(&mut m, b, &[1, 5, 10]));
        assert_eq!((m.queue.len(), m.channels[0].handshake.seq_echo), (1, 9));
    }

    #[test]
    fn what_cannot_go_ends_at_once_with_its_reason() {
        let mut m = model();
        // An unknown code.
        plc(&mut m, r::channel_base(0), &[1, 99]);
        let err = |m: &Model, s| m.handshake(s).unwrap().error();
        assert_eq!(err(&m, Source::Channel(0)), (39501, 3));
        // An empty trigger entry.
        plc(&mut m, r::TRIG_BITS, &[1]);
        assert_eq!(err(&m, Source::Trigger(0)), (39603, 3));
        // The link is not up (connecting counts as not up).
        m.link.state = LinkState::Connecting;
        let t = crate::registers::map::RAW_REQUEST;
        let words: Vec<u16> = b"GrpReset,0,;\0\0\0\0"
            .chunks(2)
            .map(|c| u16::from_be_bytes([c[0], c[1]]))
            .collect();
        write(&mut m, t, &words).unwrap();
        plc(&mut m, r::RAW_CONTROL, &[1]);
        assert_eq!(err(&m, Source::Raw), (39500, 3));
        assert!(m.queue.is_empty());
    }

    #[test]
    fn a_refused_apply_keeps_the_edit_until_fixed_or_discarded() {
        let mut m = model();
        write(&mut m, r::CONFIG_POLL_MS, &[500]).unwrap();
        let bad = ConfigStep::Invalid(InvalidValue {
            addr: r::CONFIG_POLL_MS,
        });
        assert_eq!(config_command(&mut m, 1), bad);
        assert_eq!(config_command(&mut m, 1), bad);
        assert_eq!(m.config.active, Config::default());
        assert_eq!(config_command(&mut m, 2), ConfigStep::Done);
        assert_eq!(config_command(&mut m, 1), ConfigStep::Save);
        write(&mut m, r::CONFIG_POLL_MS, &[50]).unwrap();
        assert_eq!(config_command(&mut m, 1), ConfigStep::Save);
        assert_eq!((m.config.active.poll_ms, m.config.generation), (50, 2));
    }
}
