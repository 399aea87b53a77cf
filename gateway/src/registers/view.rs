//! The registers as a view of the [`Model`]: [`read()`] encodes, [`write()`]
//! decodes.
//!
//! Encodings (REGISTERS.md, "Value types"): `f32` and `i32` in two
//! registers in the configured word order (applied here, once: the model
//! holds numbers, not words); zero as +0.0; unknown values NaN
//! (`0x7FC0 0x0000`); with the number format "thousandths" (map 1.4) every
//! `f32` is an `i32` of thousandths instead, unknown `i32::MIN`; texts two
//! characters per register, the first in the high byte.

use embassy_time::Instant;

use super::config;
use super::map::{self as r, AccessError};
use crate::config::{NumberFormat, WordOrder};
use crate::error::Outcome;
use crate::job::Source;
use crate::state::handshake::{source_code, Handshake};
use crate::state::inputs::{PARAMS, RESULTS};
use crate::state::{Io, Model, RobotFlags};

/// Why a write was refused (maps to a Modbus exception).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WriteError {
    /// An address is unmapped or read-only: exception 02, nothing written.
    Address,
    /// A value is refused: exception 03.
    Value,
    /// The device failed (a save): exception 04.
    Device,
    /// The configuration registers are write-protected
    /// (`CFG_WRITE_PROTECT`): exception 01, nothing written.
    Protected,
}

impl From<AccessError> for WriteError {
    fn from(_: AccessError) -> Self {
        WriteError::Address
    }
}

/// An edge of an Execute bit or a trigger bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Edge {
    /// From 0 to 1: fire.
    Rose(Source),
    /// From 1 to 0: let go of the outputs.
    Fell(Source),
}

/// What a write asked for, besides storing values: applied in this order.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PlcEvents {
    /// `PLC_HEARTBEAT` changed.
    pub heartbeat: bool,
    /// Execute and trigger edges: channels, RAW, then trigger bits in order.
    pub edges: heapless::Vec<Edge, { r::CHANNELS + 1 + r::TRIGGERS }>,
    /// `CONFIG_COMMAND` 1-3 was written (0 does nothing).
    pub config_command: Option<u16>,
    /// A trigger entry's text was written (in use at once: the audit log
    /// records it at once).
    pub triggers_changed: bool,
}

fn halves(v: u32, order: WordOrder) -> [u16; 2] {
    let (hi, lo) = ((v >> 16) as u16, v as u16);
    match order {
        WordOrder::HighFirst => [hi, lo],
        WordOrder::LowFirst => [lo, hi],
    }
}

fn join(w: [u16; 2], order: WordOrder) -> u32 {
    let [a, b] = w;
    let (hi, lo) = match order {
        WordOrder::HighFirst => (a, b),
        WordOrder::LowFirst => (b, a),
    };
    (u32::from(hi) << 16) | u32::from(lo)
}

/// Register `half` (0, 1) of a 32-bit value.
fn half(v: u32, half: u16, order: WordOrder) -> u16 {
    let [first, second] = halves(v, order);
    if half & 1 == 0 {
        first
    } else {
        second
    }
}

/// The "unknown" value of the thousandths format (`0x8000 0x0000`).
pub const UNKNOWN_THOUSANDTHS: i32 = i32::MIN;

/// `x` in thousandths, rounded half away from zero and kept inside
/// `i32::MIN + 1 ..= i32::MAX` (`i32::MIN` means unknown); NaN is unknown.
pub fn to_thousandths(x: f32) -> i32 {
    if x.is_nan() {
        return UNKNOWN_THOUSANDTHS;
    }
    let y = x * 1000.0;
    // `as` saturates (no `round` in core): add the half first.
    let v = if y >= 0.0 { y + 0.5 } else { y - 0.5 } as i32;
    v.max(i32::MIN + 1)
}

/// A number written in thousandths (the PLC's parameters).
pub fn from_thousandths(v: i32) -> f32 {
    v as f32 / 1000.0
}

/// A value the gateway reports: zero as +0.0 (the controller sends
/// `-0.000`), unknown as NaN (thousandths: `i32::MIN`).
fn status_f32(v: Option<f32>, format: NumberFormat) -> u32 {
    match (v, format) {
        // -0.0 too.
        (Some(x), NumberFormat::F32) => {
            if x == 0.0 {
                0
            } else {
                x.to_bits()
            }
        }
        (None, NumberFormat::F32) => f32::NAN.to_bits(),
        (Some(x), NumberFormat::Thousandths) => to_thousandths(x) as u32,
        (None, NumberFormat::Thousandths) => UNKNOWN_THOUSANDTHS as u32,
    }
}

/// The 32 bits of a parameter as the PLC wrote it.
fn param_bits(p: f32, format: NumberFormat) -> u32 {
    match format {
        NumberFormat::F32 => p.to_bits(),
        NumberFormat::Thousandths => to_thousandths(p) as u32,
    }
}

/// A parameter from its 32 bits.
fn param_from_bits(b: u32, format: NumberFormat) -> f32 {
    match format {
        NumberFormat::F32 => f32::from_bits(b),
        NumberFormat::Thousandths => from_thousandths(b as i32),
    }
}

/// Element `i` of six status values.
fn six(v: Option<[f32; 6]>, i: u16, format: NumberFormat) -> u32 {
    status_f32(v.and_then(|a| a.get(usize::from(i)).copied()), format)
}

fn flag_bits(f: Option<RobotFlags>) -> u16 {
    let Some(f) = f else { return 0 };
    let b = |on: bool, bit: u16| if on { bit } else { 0 };
    b(f.moving, r::FLAG_MOVING)
        | b(f.enabled, r::FLAG_ENABLED)
        | b(f.error, r::FLAG_ERROR)
        | b(f.paused, r::FLAG_PAUSED)
        | b(f.emergency_stop, r::FLAG_EMERGENCY_STOP)
        | b(f.safety_guard, r::FLAG_SAFETY_GUARD)
        | b(f.powered, r::FLAG_POWERED)
        | b(f.box_connected, r::FLAG_BOX_CONNECTED)
        | b(f.blending_done, r::FLAG_BLENDING_DONE)
        | b(f.in_position, r::FLAG_IN_POSITION)
        | b(f.brake_released, r::FLAG_BRAKE_RELEASED)
        | r::FLAG_VALID
}

/// The outputs of a handshake from `base` (status, sequence echo, ErrorID,
/// error source, command echo), for channels and RAW.
fn handshake_word(h: &Handshake, off: u16, order: WordOrder) -> u16 {
    let (id, src) = h.error();
    match off {
        0 => status_bits(h),
        1 => h.seq_echo,
        2 | 3 => half(id as u32, off - 2, order),
        4 => src,
        5 => h.command_echo,
        _ => 0,
    }
}

/// The status bits of a handshake (`CHn_STATUS`, `RAW_STATUS`).
pub fn status_bits(h: &Handshake) -> u16 {
    use crate::state::Phase;
    use r::{ST_ABORTED, ST_ACTIVE, ST_BUSY, ST_DONE, ST_ERROR, ST_QUEUED};
    match h.phase {
        Phase::Idle => 0,
        Phase::Queued => ST_BUSY | ST_QUEUED,
        Phase::Running => ST_BUSY,
        Phase::Moving => ST_BUSY | ST_ACTIVE,
        Phase::Ended(Outcome::Done) => ST_DONE,
        Phase::Ended(Outcome::Error(..)) => ST_ERROR,
        Phase::Ended(Outcome::Aborted) => ST_ABORTED,
    }
}

/// The `ACCESS` register.
fn access_bits(m: &Model) -> u16 {
    let a = &m.access;
    let c = &m.config.active;
    let b = |on: bool, bit: u16| if on { bit } else { 0 };
    b(c.write_protect, r::ACCESS_WRITE_PROTECTED)
        | b(a.accounts.admin_exists(), r::ACCESS_ADMIN)
        | b(a.restart_pending(&c.net), r::ACCESS_RESTART_PENDING)
        | b(a.recovery, r::ACCESS_RECOVERY)
        | b(a.web_on, r::ACCESS_WEB_ON)
        | b(a.modbus_may_change_protected(c), r::ACCESS_MODBUS_CONFIG)
}

// The map has room for every channel and trigger entry of the state: the
// channels' blocks end before RAW's, the trigger bits fit one register.
const _: () = assert!(r::TRIGGERS <= 16);
const _: () = assert!(
    r::CHANNEL_BASE as usize + r::CHANNEL_STRIDE as usize * r::CHANNELS <= r::RAW_CONTROL as usize
);

/// One register as the PLC reads it (0 for unmapped addresses; the caller
/// checks the access first).
pub fn read(m: &Model, addr: u16, now: Instant) -> u16 {
    let order = m.config.active.word_order;
    let format = m.config.active.number_format;
    let robot = &m.robot;
    let in_area = |start: u16, len: u16| addr.checked_sub(start).filter(|&o| o < len);
    if let Some(o) = in_area(r::STATUS_JOINTS, 12) {
        return half(six(robot.joints, o / 2, format), o, order);
    }
    if let Some(o) = in_area(r::STATUS_POSE, 12) {
        return half(six(robot.pose, o / 2, format), o, order);
    }
    if let Some(o) = in_area(r::STATUS_BOX_DI, 6) {
        let io = Io::ALL.get(usize::from(o)).and_then(|&g| robot.io(g));
        return io.unwrap_or(0);
    }
    if let Some(s) = config::slot_of(addr) {
        return config_words(m).get(s).copied().unwrap_or(0);
    }
    if let Some(o) = in_area(r::ERROR_TEXT, r::ERROR_TEXT_REGS) {
        return m.error_text.text.word(usize::from(o));
    }
    for (i, ch) in m.channels.iter().enumerate() {
        let Some(o) = in_area(r::channel_base(i), r::CH_RESULTS + 2 * RESULTS as u16) else {
            continue;
        };
        let inp = &ch.inputs;
        return match o {
            r::CH_CONTROL => inp.control,
            r::CH_COMMAND => inp.code,
            r::CH_SEQUENCE => inp.seq,
            r::CH_RESERVED => inp.reserved,
            o if o < r::CH_TEXT1 => {
                let k = usize::from((o - r::CH_PARAMS) / 2);
                let v = inp.params.get(k).copied().unwrap_or(0.0);
                half(param_bits(v, format), o - r::CH_PARAMS, order)
            }
            o if o < r::CH_TEXT2 => inp.text1.word(usize::from(o - r::CH_TEXT1)),
            o if o < r::CH_STATUS => inp.text2.word(usize::from(o - r::CH_TEXT2)),
            o if o < r::CH_RESULTS => handshake_word(&ch.handshake, o - r::CH_STATUS, order),
            o => {
                let k = usize::from((o - r::CH_RESULTS) / 2);
                let v = ch.results.and_then(|res| res.get(k).copied());
                half(status_f32(v, format), o - r::CH_RESULTS, order)
            }
        };
    }
    if let Some(o) = in_area(r::RAW_REQUEST, r::RAW_REQUEST_REGS) {
        return m.raw.request.word(usize::from(o));
    }
    if let Some(o) = in_area(r::RAW_STATUS, r::RAW_REPLY_LEN - r::RAW_STATUS) {
        return handshake_word(&m.raw.handshake, o, order);
    }
    if let Some(o) = in_area(r::RAW_REPLY, r::RAW_REPLY_REGS) {
        return m.raw.reply.word(usize::from(o));
    }
    if let Some(o) = in_area(r::TRIG_ERROR_ID, 2 * r::TRIGGERS as u16) {
        let h = m.triggers.handshakes.get(usize::from(o / 2));
        let id = h.map_or(0, |h| h.error().0);
        return half(id as u32, o, order);
    }
    if let Some(o) = in_area(r::TRIG_ERROR_SOURCE, r::TRIGGERS as u16) {
        let h = m.triggers.handshakes.get(usize::from(o));
        return h.map_or(0, |h| source_code(h.outcome()));
    }
    if addr >= r::TRIG_TEXT_BASE {
        let i = usize::from((addr - r::TRIG_TEXT_BASE) / r::TRIG_TEXT_STRIDE);
        let o = usize::from((addr - r::TRIG_TEXT_BASE) % r::TRIG_TEXT_STRIDE);
        return m.triggers.entries.get(i).map_or(0, |e| e.word(o));
    }
    match addr {
        r::STATUS_VERSION => r::MAP_VERSION,
        r::STATUS_HEARTBEAT => m.ticks,
        r::STATUS_AGE_MS => m
            .status_age_ms(now)
            .and_then(|ms| u16::try_from(ms).ok())
            .unwrap_or(u16::MAX),
        r::STATUS_LINK_STATE => m.link.state as u16,
        r::STATUS_LINK_CONNECTS => m.link.connects,
        r::STATUS_LINK_LAST_ERROR => m.link.last_error.map_or(0, |e| e.code() as u16),
        r::STATUS_FSM => robot
            .fsm
            .and_then(|s| u16::try_from(i32::from(s)).ok())
            .unwrap_or(u16::MAX),
        r::STATUS_FLAGS => flag_bits(robot.flags),
        a if a == r::STATUS_ERROR_CODE || a == r::STATUS_ERROR_CODE + 1 => {
            half(robot.error_code as u32, a - r::STATUS_ERROR_CODE, order)
        }
        r::STATUS_ERROR_AXIS => robot.error_axis,
        r::STATUS_SOURCE => m.config.active.status_source as u16,
        a if a == r::STATUS_OVERRIDE || a == r::STATUS_OVERRIDE + 1 => half(
            status_f32(robot.override_ratio, format),
            a - r::STATUS_OVERRIDE,
            order,
        ),
        r::STATUS_IO_VALID => Io::ALL
            .iter()
            .enumerate()
            .filter(|(_, &g)| robot.io(g).is_some())
            .fold(0, |acc, (i, _)| acc | (1 << i)),
        r::STATUS_QUEUE_USED => m.queue.len() as u16,
        r::STATUS_SESSIONS => m.sessions,
        r::STATUS_WATCHDOG => {
            u16::from(m.watchdog_armed()) | (u16::from(m.plc.watchdog_tripped) << 1)
        }
        r::STATUS_WATCHDOG_TRIPS => m.plc.watchdog_trips,
        r::STATUS_ACTIVE_MOTION => m.active_motion.map_or(0, Source::code),
        r::STATUS_ACCESS => access_bits(m),
        r::STATUS_MODBUS_REFUSED => m.access.modbus_refused,
        r::STATUS_WEB_REFUSED => m.access.web_refused,
        r::STATUS_WRITES_REFUSED => m.access.writes_refused,
        r::STATUS_FW_VERSION..=58 if addr < r::STATUS_FW_STATE => {
            let v = m.firmware.running;
            v.map_or(0, |v| match addr - r::STATUS_FW_VERSION {
                0 => v.major,
                1 => v.minor,
                _ => v.patch,
            })
        }
        r::STATUS_FW_STATE => m.firmware.boot.map_or(0, |b| b.code()),
        r::STATUS_COMMAND_OWNER => m.owner.code(),
        r::STATUS_ENIP_CONNECTIONS => m.owner.enip_connections,
        r::STATUS_ENIP_REFUSED => m.owner.enip_refused,
        r::STATUS_ENIP_MISSED => m.owner.enip_missed,
        r::STATUS_ENIP_IO_DROPPED => m.owner.enip_io_dropped,
        r::STATUS_PROTOCOL => m.link.level.map_or(0, |l| {
            let (major, minor, _) = l.parts();
            u16::from(major) * 100 + u16::from(minor)
        }),
        a if a == r::ERROR_TEXT_CODE || a == r::ERROR_TEXT_CODE + 1 => {
            half(m.error_text.code as u32, a - r::ERROR_TEXT_CODE, order)
        }
        r::ERROR_TEXT_SOURCE => m.error_text.source as u16,
        r::ERROR_TEXT_COUNT => m.error_text.count,
        r::CONTROL_HEARTBEAT => m.plc.heartbeat,
        r::CONTROL_CONFIG_COMMAND => 0,
        r::CONTROL_CONFIG_RESULT => m.config.result as u16,
        r::CONTROL_CONFIG_BAD_ADDR => m.config.bad_addr,
        r::CONTROL_SAVES => m.config.saves,
        r::RAW_CONTROL => m.raw.control,
        r::RAW_SEQUENCE => m.raw.seq,
        r::RAW_REPLY_LEN => m.raw.reply_len,
        r::RAW_REPLY_TRUNCATED => u16::from(m.raw.reply_truncated()),
        r::TRIG_BITS => m.triggers.bits,
        r::TRIG_BUSY | r::TRIG_DONE | r::TRIG_ERROR | r::TRIG_ABORTED => {
            trigger_bits(m, |h| match addr {
                r::TRIG_BUSY => h.is_busy(),
                r::TRIG_DONE => h.outcome() == Some(Outcome::Done),
                r::TRIG_ERROR => matches!(h.outcome(), Some(Outcome::Error(..))),
                _ => h.outcome() == Some(Outcome::Aborted),
            })
        }
        _ => 0,
    }
}

fn trigger_bits(m: &Model, f: impl Fn(&Handshake) -> bool) -> u16 {
    m.triggers
        .handshakes
        .iter()
        .enumerate()
        .filter(|(_, h)| f(h))
        .fold(0, |acc, (i, _)| acc | (1 << i))
}

/// Reads `out.len()` registers from `start` (exception 02 if any of them is
/// unmapped).
pub fn read_into(m: &Model, start: u16, out: &mut [u16], now: Instant) -> Result<(), AccessError> {
    let count = u16::try_from(out.len()).map_err(|_| AccessError::IllegalAddress)?;
    r::check(start, count, false)?;
    // The settings' registers are encoded once for the whole read, not once
    // per register.
    let mut settings: Option<config::Words> = None;
    for (a, o) in (start..).zip(out.iter_mut()) {
        *o = match config::slot_of(a) {
            Some(s) => settings
                .get_or_insert_with(|| config_words(m))
                .get(s)
                .copied()
                .unwrap_or(0),
            None => read(m, a, now),
        };
    }
    Ok(())
}

/// The settings' registers as the PLC reads them: its unapplied edit, or
/// the configuration in use.
fn config_words(m: &Model) -> config::Words {
    m.config
        .edit
        .unwrap_or_else(|| config::encode(&m.config.active))
}

/// Stores a write of `values` from `start` in the model (all or nothing:
/// unmapped or read-only addresses refuse the whole write, and so does a
/// `CONFIG_COMMAND` above 3) and returns what it asks for. The events are
/// for `crate::plc` to act on.
pub fn write(m: &mut Model, start: u16, values: &[u16]) -> Result<PlcEvents, WriteError> {
    let count = u16::try_from(values.len()).map_err(|_| WriteError::Value)?;
    r::check(start, count, true)?;
    if m.config.active.write_protect && (start..start.saturating_add(count)).any(is_protected) {
        m.access.writes_refused = m.access.writes_refused.wrapping_add(1);
        warn!(
            "modbus: write to {} refused: configuration write-protected",
            start
        );
        return Err(WriteError::Protected);
    }
    let mut ev = PlcEvents {
        triggers_changed: usize::from(start) + values.len() > usize::from(r::TRIG_TEXT_BASE),
        ..PlcEvents::default()
    };
    if let Some(o) = r::CONTROL_CONFIG_COMMAND.checked_sub(start) {
        if let Some(&cmd) = values.get(usize::from(o)) {
            if cmd > 3 {
                return Err(WriteError::Value);
            }
            ev.config_command = (cmd != 0).then_some(cmd);
        }
    }
    let order = m.config.active.word_order;
    let format = m.config.active.number_format;
    let changes = changes(m, |m| {
        for (addr, &v) in (start..).zip(values) {
            store(m, addr, v, order, format);
        }
    });
    ev.heartbeat = changes.heartbeat;
    ev.edges = changes.edges;
    Ok(ev)
}

/// What storing new PLC inputs with `store` asks for: the heartbeat
/// changed, and the Execute and trigger edges (channels, RAW, then trigger
/// bits in order). The one place edges are found, for every view a PLC
/// writes through (the registers, the EtherNet/IP output assembly).
pub fn changes(m: &mut Model, store: impl FnOnce(&mut Model)) -> PlcEvents {
    // Execute of every channel, then RAW's.
    let execute = |m: &Model| -> [bool; r::CHANNELS + 1] {
        core::array::from_fn(|i| match m.channels.get(i) {
            Some(ch) => ch.inputs.execute(),
            None => m.raw.execute(),
        })
    };
    let old_exec = execute(m);
    let old_bits = m.triggers.bits;
    let old_beat = m.plc.heartbeat;
    store(m);
    let mut ev = PlcEvents {
        heartbeat: m.plc.heartbeat != old_beat,
        ..PlcEvents::default()
    };
    let new_exec = execute(m);
    let sources = (0..r::CHANNELS as u8)
        .map(Source::Channel)
        .chain(core::iter::once(Source::Raw));
    for ((old, new), source) in old_exec.into_iter().zip(new_exec).zip(sources) {
        edge(&mut ev, source, old, new);
    }
    for i in 0..r::TRIGGERS as u8 {
        let bit = |b: u16| b & (1 << i) != 0;
        edge(
            &mut ev,
            Source::Trigger(i),
            bit(old_bits),
            bit(m.triggers.bits),
        );
    }
    ev
}

/// A register of the command inputs, which belong to one master at a time
/// (`COMMAND_OWNER`): `PLC_HEARTBEAT`, the channels' and RAW's inputs and
/// `TRIG_BITS`.
pub fn is_command_input(addr: u16) -> bool {
    let channel = (0..r::CHANNELS).any(|i| {
        let base = r::channel_base(i);
        (base..base + r::CH_STATUS).contains(&addr)
    });
    channel
        || addr == r::CONTROL_HEARTBEAT
        || (r::RAW_CONTROL..r::RAW_REQUEST + r::RAW_REQUEST_REGS).contains(&addr)
        || addr == r::TRIG_BITS
}

/// A register the write protection covers: the settings, `CONFIG_COMMAND`
/// and the trigger texts (stored configuration too). The heartbeat, the
/// command channels, RAW and the trigger bits stay writable.
pub fn is_protected(addr: u16) -> bool {
    config::slot_of(addr).is_some()
        || addr == r::CONTROL_CONFIG_COMMAND
        || (r::TRIG_TEXT_BASE..r::MAP_LEN as u16).contains(&addr)
}

fn edge(ev: &mut PlcEvents, source: Source, old: bool, new: bool) {
    let e = match (old, new) {
        (false, true) => Edge::Rose(source),
        (true, false) => Edge::Fell(source),
        _ => return,
    };
    // One per source: always room.
    let _ = ev.edges.push(e);
}

/// Replaces half `h` of the 32-bit value `v`.
fn with_half(v: u32, h: u16, w: u16, order: WordOrder) -> u32 {
    let mut words = halves(v, order);
    if let Some(slot) = words.get_mut(usize::from(h & 1)) {
        *slot = w;
    }
    join(words, order)
}

/// Stores one writable register (the access was checked).
fn store(m: &mut Model, addr: u16, v: u16, order: WordOrder, format: NumberFormat) {
    let in_area = |start: u16, len: u16| addr.checked_sub(start).filter(|&o| o < len);
    if let Some(s) = config::slot_of(addr) {
        let active = &m.config.active;
        let words = m.config.edit.get_or_insert_with(|| config::encode(active));
        if let Some(w) = words.get_mut(s) {
            *w = v;
        }
        return;
    }
    for (i, ch) in m.channels.iter_mut().enumerate() {
        let Some(o) = in_area(r::channel_base(i), r::CH_STATUS) else {
            continue;
        };
        let inp = &mut ch.inputs;
        match o {
            r::CH_CONTROL => inp.control = v,
            r::CH_COMMAND => inp.code = v,
            r::CH_SEQUENCE => inp.seq = v,
            r::CH_RESERVED => inp.reserved = v,
            o if o < r::CH_PARAMS + 2 * PARAMS as u16 => {
                let k = usize::from((o - r::CH_PARAMS) / 2);
                if let Some(p) = inp.params.get_mut(k) {
                    let bits = with_half(param_bits(*p, format), o - r::CH_PARAMS, v, order);
                    *p = param_from_bits(bits, format);
                }
            }
            o if o < r::CH_TEXT2 => inp.text1.set_word(usize::from(o - r::CH_TEXT1), v),
            o => inp.text2.set_word(usize::from(o - r::CH_TEXT2), v),
        }
        return;
    }
    if let Some(o) = in_area(r::RAW_REQUEST, r::RAW_REQUEST_REGS) {
        m.raw.request.set_word(usize::from(o), v);
        return;
    }
    if addr >= r::TRIG_TEXT_BASE {
        let i = usize::from((addr - r::TRIG_TEXT_BASE) / r::TRIG_TEXT_STRIDE);
        let o = usize::from((addr - r::TRIG_TEXT_BASE) % r::TRIG_TEXT_STRIDE);
        if let Some(e) = m.triggers.entries.get_mut(i) {
            e.set_word(o, v);
        }
        return;
    }
    match addr {
        r::CONTROL_HEARTBEAT => m.plc.heartbeat = v,
        r::RAW_CONTROL => m.raw.control = v,
        r::RAW_SEQUENCE => m.raw.seq = v,
        r::TRIG_BITS => m.triggers.bits = v,
        // CONFIG_COMMAND is an event, not a value (it reads 0).
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;
    use crate::error::{ErrorSource, GatewayError};
    use crate::state::Phase;

    fn model() -> Model {
        Model::new(Config::default(), Config::default())
    }

    fn now() -> Instant {
        Instant::from_millis(1000)
    }

    #[test]
    fn unknown_values_read_nan_and_zero_is_positive() {
        let mut m = model();
        assert_eq!(read(&m, r::STATUS_JOINTS, now()), 0x7FC0);
        assert_eq!(read(&m, r::STATUS_JOINTS + 1, now()), 0);
        assert_eq!(read(&m, r::STATUS_FSM, now()), 0xFFFF);
        assert_eq!(read(&m, r::STATUS_AGE_MS, now()), 0xFFFF);
        m.robot.joints = Some([-0.0, 1.5, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(read(&m, r::STATUS_JOINTS, now()), 0);
        assert_eq!(read(&m, r::STATUS_JOINTS + 2, now()), 0x3FC0);
        // The word order is applied when reading: nothing is re-encoded.
        m.config.active.word_order = WordOrder::LowFirst;
        assert_eq!(read(&m, r::STATUS_JOINTS + 2, now()), 0);
        assert_eq!(read(&m, r::STATUS_JOINTS + 3, now()), 0x3FC0);
        m.robot.updated = Some(Instant::from_millis(750));
        assert_eq!(read(&m, r::STATUS_AGE_MS, now()), 250);
        assert_eq!(read(&m, r::STATUS_VERSION, now()), r::MAP_VERSION);
    }

    #[test]
    fn thousandths_round_half_away_from_zero_and_keep_the_unknown_value_apart() {
        assert_eq!(to_thousandths(420.5), 420_500);
        assert_eq!(to_thousandths(-0.0), 0);
        assert_eq!(to_thousandths(0.0015), 2);
        assert_eq!(to_thousandths(-0.0015), -2);
        assert_eq!(to_thousandths(-123.4564), -123_456);
        assert_eq!(to_thousandths(f32::NAN), UNKNOWN_THOUSANDTHS);
        // Out of range saturates; the most negative stays "unknown" only.
        assert_eq!(to_thousandths(1e12), i32::MAX);
        assert_eq!(to_thousandths(-1e12), i32::MIN + 1);
        assert_eq!(from_thousandths(-5250), -5.25);
        // Every thousandth up to 4096 units survives the f32 the gateway
        // keeps a parameter in (REGISTERS.md says so).
        for v in (-4_096_000..=4_096_000).step_by(997) {
            assert_eq!(to_thousandths(from_thousandths(v)), v, "{v}");
        }
        let mut m = model();
        m.config.active.number_format = NumberFormat::Thousandths;
        m.robot.joints = Some([-0.0, 12.3456, 0.0, 0.0, 0.0, -1.0]);
        assert_eq!(read(&m, r::STATUS_JOINTS + 2, now()), 0);
        assert_eq!(read(&m, r::STATUS_JOINTS + 3, now()), 12_346);
        assert_eq!(read(&m, r::STATUS_JOINTS + 10, now()), 0xFFFF);
        assert_eq!(read(&m, r::STATUS_JOINTS + 11, now()), 0xFC18);
        m.robot.joints = None;
        assert_eq!(read(&m, r::STATUS_JOINTS, now()), 0x8000);
        assert_eq!(read(&m, r::STATUS_JOINTS + 1, now()), 0);
    }

    #[test]
    fn a_write_is_stored_then_its_edges_reported() {
        let mut m = model();
        let base = r::channel_base(0);
        // One FC 16 over control, code, sequence, reserved and P0 = 420.0.
        let ev = write(&mut m, base, &[1, 12, 7, 0, 0x43D2, 0]).unwrap();
        assert_eq!(ev.edges.as_slice(), [Edge::Rose(Source::Channel(0))]);
        let inp = &m.channels[0].inputs;
        assert_eq!((inp.code, inp.seq, inp.params[0]), (12, 7, 420.0));
        let ev = write(&mut m, base, &[0]).unwrap();
        assert_eq!(ev.edges.as_slice(), [Edge::Fell(Source::Channel(0))]);
        // Half a float: the other half stays.
        write(&mut m, base + r::CH_PARAMS + 1, &[0x8000]).unwrap();
        assert_eq!(m.channels[0].inputs.params[0], f32::from_bits(0x43D2_8000));
        // Trigger bits rise in bit order; the heartbeat is an event.
        let ev = write(&mut m, r::TRIG_BITS, &[0b1010_0000_0000_0001]).unwrap();
        let rose: Vec<Edge> = ev.edges.to_vec();
        assert_eq!(
            rose,
            [
                Edge::Rose(Source::Trigger(0)),
                Edge::Rose(Source::Trigger(13)),
                Edge::Rose(Source::Trigger(15))
            ]
        );
        assert!(write(&mut m, r::CONTROL_HEARTBEAT, &[5]).unwrap().heartbeat);
        assert!(!write(&mut m, r::CONTROL_HEARTBEAT, &[5]).unwrap().heartbeat);
    }

    #[test]
    fn refused_writes_change_nothing() {
        let mut m = model();
        // Read-only status inside the range: exception 02, inputs untouched.
        let base = r::channel_base(1);
        assert_eq!(
            write(&mut m, base + r::CH_TEXT2, &[0x4142; 17]),
            Err(WriteError::Address)
        );
        assert!(m.channels[1].inputs.text2.is_empty());
        // CONFIG_COMMAND 4: exception 03, the heartbeat before it untouched.
        assert_eq!(
            write(&mut m, r::CONTROL_HEARTBEAT, &[9, 4]),
            Err(WriteError::Value)
        );
        assert_eq!(m.plc.heartbeat, 0);
        let ev = write(&mut m, r::CONTROL_HEARTBEAT, &[9, 1]).unwrap();
        assert_eq!(ev.config_command, Some(1));
        assert_eq!(read(&m, r::CONTROL_CONFIG_COMMAND, now()), 0);
    }

    #[test]
    fn the_firmware_reads_as_its_version_and_update_state() {
        use crate::state::firmware::{BootState, Version};
        let mut m = model();
        assert_eq!(
            [55, 56, 57, 58].map(|a| read(&m, a, now())),
            [0; 4],
            "no updates here"
        );
        m.firmware.running = Some(Version {
            major: 2,
            minor: 10,
            patch: 7,
        });
        m.firmware.boot = Some(BootState::Trial);
        assert_eq!(
            [r::STATUS_FW_VERSION, 56, 57, r::STATUS_FW_STATE].map(|a| read(&m, a, now())),
            [2, 10, 7, 2]
        );
        m.firmware.boot = Some(BootState::RolledBack);
        assert_eq!(read(&m, r::STATUS_FW_STATE, now()), 4);
    }

    #[test]
    fn handshakes_read_as_status_words() {
        let mut m = model();
        m.start(Source::Raw, 4, 0, now());
        assert_eq!(read(&m, r::RAW_STATUS, now()), r::ST_BUSY | r::ST_QUEUED);
        assert_eq!(read(&m, r::RAW_SEQ_ECHO, now()), 4);
        m.finish(
            Source::Raw,
            Outcome::Error(ErrorSource::RobotFail, 20018),
            now(),
        );
        assert_eq!(read(&m, r::RAW_ERROR_ID + 1, now()), 20018);
        assert_eq!(read(&m, r::RAW_ERROR_SOURCE, now()), 1);
        m.start(Source::Trigger(2), 0, 0, now());
        m.finish(
            Source::Trigger(5),
            Outcome::gateway(GatewayError::TriggerEmpty),
            now(),
        );
        assert_eq!(read(&m, r::TRIG_BUSY, now()), 1 << 2);
        assert_eq!(read(&m, r::TRIG_ERROR, now()), 1 << 5);
        assert_eq!(
            read(&m, r::TRIG_ERROR_ID + 11, now()),
            (39603u32 & 0xFFFF) as u16
        );
        assert_eq!(read(&m, r::TRIG_ERROR_SOURCE + 5, now()), 3);
        assert_eq!(m.triggers.handshakes[2].phase, Phase::Queued);
        // Results read NaN until a command gives them.
        let res = r::channel_base(0) + r::CH_RESULTS;
        assert_eq!(read(&m, res, now()), 0x7FC0);
        m.channels[0].results = Some([2.0; RESULTS]);
        assert_eq!(read(&m, res, now()), 0x4000);
    }
}
