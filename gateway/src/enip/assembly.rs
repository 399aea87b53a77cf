//! The I/O assemblies: one more view of the typed state, like the
//! registers. The input assembly ([`INPUT`], the PLC reads it) is encoded
//! from the [`Model`]; the output assembly ([`OUTPUT`], the PLC writes it)
//! is decoded into the PLC's inputs, and its edges are found by the same
//! code as a register write's (`registers::view::changes`), so that the
//! PLC rules (`crate::plc`) see the same typed events.
//!
//! The layout is declared once, as data ([`INPUT_FIELDS`], [`OUTPUT_FIELDS`]:
//! name, offset, type, count); the encoder and decoder take their offsets
//! from it, ENIP.md's tables are checked against it (`enip::tests`)
//! and the EDS file is written from the assemblies' sizes.
//!
//! CIP's own types, little-endian: `UINT` (u16), `DINT` (i32), `REAL`
//! (IEEE-754 f32, zero as +0.0, unknown as NaN), `STRING` (ASCII, NUL
//! padded). The register map's word order and number format do not apply:
//! a Logix PLC reads these types natively.

use embassy_time::Instant;

use crate::error::Outcome;
use crate::registers::{self as r, view, PlcEvents};
use crate::state::handshake::Handshake;
use crate::state::{Io, Model};

/// The input assembly's instance (T->O: the robot to the PLC).
pub const INPUT: u16 = 100;
/// The output assembly's instance (O->T: the PLC to the robot).
pub const OUTPUT: u16 = 150;
/// The heartbeat connection point of an input-only connection.
pub const INPUT_ONLY: u16 = 198;
/// The heartbeat connection point of a listen-only connection.
pub const LISTEN_ONLY: u16 = 199;
/// The configuration instance named in the connection path (no data).
pub const CONFIG: u16 = 1;
/// The size of each assembly: what a Forward_Open (not Large) carries,
/// 500 bytes of I/O data with its headers, rounded to whole DINTs.
pub const SIZE: usize = 496;

/// A field's CIP type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ty {
    /// 16-bit unsigned.
    Uint,
    /// 32-bit signed.
    Dint,
    /// IEEE-754 single.
    Real,
    /// ASCII characters, NUL padded (the count is the characters).
    Text,
}

impl Ty {
    /// Bytes of one element.
    pub const fn size(self) -> usize {
        match self {
            Ty::Uint => 2,
            Ty::Dint | Ty::Real => 4,
            Ty::Text => 1,
        }
    }

    /// Its name in ENIP.md.
    pub const fn name(self) -> &'static str {
        match self {
            Ty::Uint => "UINT",
            Ty::Dint => "DINT",
            Ty::Real => "REAL",
            Ty::Text => "STRING",
        }
    }
}

/// One field of an assembly.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Field {
    /// Its name (the register's, where there is one).
    pub name: &'static str,
    /// Byte offset in the assembly.
    pub offset: usize,
    /// Its type.
    pub ty: Ty,
    /// Elements (characters for a text).
    pub count: usize,
}

impl Field {
    /// Bytes it takes.
    pub const fn bytes(&self) -> usize {
        self.ty.size() * self.count
    }
}

const fn f(name: &'static str, offset: usize, ty: Ty, count: usize) -> Field {
    Field {
        name,
        offset,
        ty,
        count,
    }
}

/// Offsets of the input assembly.
pub mod input {
    /// The gateway's heartbeat (`HEARTBEAT`).
    pub const HEARTBEAT: usize = 0;
    /// `LINK_STATE`.
    pub const LINK_STATE: usize = 2;
    /// `FSM_STATE`.
    pub const FSM_STATE: usize = 4;
    /// `ROBOT_FLAGS`.
    pub const ROBOT_FLAGS: usize = 6;
    /// `ROBOT_ERROR_CODE`.
    pub const ROBOT_ERROR_CODE: usize = 8;
    /// `ROBOT_ERROR_AXIS`.
    pub const ROBOT_ERROR_AXIS: usize = 12;
    /// `STATUS_AGE_MS`.
    pub const STATUS_AGE_MS: usize = 14;
    /// `WATCHDOG`.
    pub const WATCHDOG: usize = 16;
    /// `WATCHDOG_TRIPS`.
    pub const WATCHDOG_TRIPS: usize = 18;
    /// `ACTIVE_MOTION`.
    pub const ACTIVE_MOTION: usize = 20;
    /// `QUEUE_USED`.
    pub const QUEUE_USED: usize = 22;
    /// `COMMAND_OWNER`.
    pub const COMMAND_OWNER: usize = 24;
    /// The `PLC_HEARTBEAT` in use, echoed.
    pub const HEARTBEAT_ECHO: usize = 26;
    /// `OVERRIDE`.
    pub const OVERRIDE: usize = 28;
    /// `ACT_JOINTS`.
    pub const ACT_JOINTS: usize = 32;
    /// `ACT_POSE`.
    pub const ACT_POSE: usize = 56;
    /// `BOX_DI` .. `END_DO`, `IO_VALID` (7 UINTs).
    pub const IO: usize = 80;
    /// `PROTOCOL_LEVEL`.
    pub const PROTOCOL_LEVEL: usize = 94;
    /// Channel 0's outputs: status, sequence echo, ErrorID, error source,
    /// command echo (12 bytes); channel 1's follow.
    pub const CH0: usize = 96;
    /// Channel 1's outputs.
    pub const CH1: usize = 108;
    /// RAW's outputs, then `RAW_REPLY_LEN` and `RAW_REPLY_TRUNCATED`.
    pub const RAW: usize = 120;
    /// `TRIG_BUSY`, `TRIG_DONE`, `TRIG_ERROR`, `TRIG_ABORTED`.
    pub const TRIG: usize = 134;
    /// Channel 0's results (24 REALs); channel 1's follow.
    pub const CH0_RESULTS: usize = 144;
    /// Channel 1's results.
    pub const CH1_RESULTS: usize = 240;
    /// The RAW reply's first characters.
    pub const RAW_REPLY: usize = 336;
    /// Characters of the RAW reply in the assembly.
    pub const RAW_REPLY_LEN: usize = 160;
}

/// Offsets of the output assembly.
pub mod output {
    /// `PLC_HEARTBEAT`.
    pub const HEARTBEAT: usize = 0;
    /// `TRIG_BITS`.
    pub const TRIG_BITS: usize = 2;
    /// Channel 0's inputs: control, command, sequence, reserved (UINTs),
    /// P0-P11 (REALs), TEXT1 and TEXT2 (32 characters each): 120 bytes.
    pub const CH0: usize = 4;
    /// Channel 1's inputs.
    pub const CH1: usize = 124;
    /// A channel's inputs' size.
    pub const CH_LEN: usize = 120;
    /// `RAW_CONTROL`, `RAW_SEQUENCE`.
    pub const RAW: usize = 244;
    /// `RAW_REQUEST`.
    pub const RAW_REQUEST: usize = 248;
    /// Characters of the RAW request in the assembly (the registers have
    /// 256).
    pub const RAW_REQUEST_LEN: usize = 248;
}

/// The input assembly, field by field.
pub const INPUT_FIELDS: &[Field] = &[
    f("HEARTBEAT", input::HEARTBEAT, Ty::Uint, 1),
    f("LINK_STATE", input::LINK_STATE, Ty::Uint, 1),
    f("FSM_STATE", input::FSM_STATE, Ty::Uint, 1),
    f("ROBOT_FLAGS", input::ROBOT_FLAGS, Ty::Uint, 1),
    f("ROBOT_ERROR_CODE", input::ROBOT_ERROR_CODE, Ty::Dint, 1),
    f("ROBOT_ERROR_AXIS", input::ROBOT_ERROR_AXIS, Ty::Uint, 1),
    f("STATUS_AGE_MS", input::STATUS_AGE_MS, Ty::Uint, 1),
    f("WATCHDOG", input::WATCHDOG, Ty::Uint, 1),
    f("WATCHDOG_TRIPS", input::WATCHDOG_TRIPS, Ty::Uint, 1),
    f("ACTIVE_MOTION", input::ACTIVE_MOTION, Ty::Uint, 1),
    f("QUEUE_USED", input::QUEUE_USED, Ty::Uint, 1),
    f("COMMAND_OWNER", input::COMMAND_OWNER, Ty::Uint, 1),
    f("HEARTBEAT_ECHO", input::HEARTBEAT_ECHO, Ty::Uint, 1),
    f("OVERRIDE", input::OVERRIDE, Ty::Real, 1),
    f("ACT_JOINTS", input::ACT_JOINTS, Ty::Real, 6),
    f("ACT_POSE", input::ACT_POSE, Ty::Real, 6),
    f("BOX_DI", input::IO, Ty::Uint, 1),
    f("BOX_DO", input::IO + 2, Ty::Uint, 1),
    f("BOX_CI", input::IO + 4, Ty::Uint, 1),
    f("BOX_CO", input::IO + 6, Ty::Uint, 1),
    f("END_DI", input::IO + 8, Ty::Uint, 1),
    f("END_DO", input::IO + 10, Ty::Uint, 1),
    f("IO_VALID", input::IO + 12, Ty::Uint, 1),
    f("PROTOCOL_LEVEL", input::PROTOCOL_LEVEL, Ty::Uint, 1),
    f("CH0_STATUS", input::CH0, Ty::Uint, 1),
    f("CH0_SEQ_ECHO", input::CH0 + 2, Ty::Uint, 1),
    f("CH0_ERROR_ID", input::CH0 + 4, Ty::Dint, 1),
    f("CH0_ERROR_SOURCE", input::CH0 + 8, Ty::Uint, 1),
    f("CH0_COMMAND_ECHO", input::CH0 + 10, Ty::Uint, 1),
    f("CH1_STATUS", input::CH1, Ty::Uint, 1),
    f("CH1_SEQ_ECHO", input::CH1 + 2, Ty::Uint, 1),
    f("CH1_ERROR_ID", input::CH1 + 4, Ty::Dint, 1),
    f("CH1_ERROR_SOURCE", input::CH1 + 8, Ty::Uint, 1),
    f("CH1_COMMAND_ECHO", input::CH1 + 10, Ty::Uint, 1),
    f("RAW_STATUS", input::RAW, Ty::Uint, 1),
    f("RAW_SEQ_ECHO", input::RAW + 2, Ty::Uint, 1),
    f("RAW_ERROR_ID", input::RAW + 4, Ty::Dint, 1),
    f("RAW_ERROR_SOURCE", input::RAW + 8, Ty::Uint, 1),
    f("RAW_REPLY_LEN", input::RAW + 10, Ty::Uint, 1),
    f("RAW_REPLY_TRUNCATED", input::RAW + 12, Ty::Uint, 1),
    f("TRIG_BUSY", input::TRIG, Ty::Uint, 1),
    f("TRIG_DONE", input::TRIG + 2, Ty::Uint, 1),
    f("TRIG_ERROR", input::TRIG + 4, Ty::Uint, 1),
    f("TRIG_ABORTED", input::TRIG + 6, Ty::Uint, 1),
    f("RESERVED", input::TRIG + 8, Ty::Uint, 1),
    f("CH0_RESULTS", input::CH0_RESULTS, Ty::Real, 24),
    f("CH1_RESULTS", input::CH1_RESULTS, Ty::Real, 24),
    f(
        "RAW_REPLY",
        input::RAW_REPLY,
        Ty::Text,
        input::RAW_REPLY_LEN,
    ),
];

/// A channel's inputs in the output assembly, from `base`.
const fn ch(base: usize, names: [&'static str; 7]) -> [Field; 7] {
    [
        f(names[0], base, Ty::Uint, 1),
        f(names[1], base + 2, Ty::Uint, 1),
        f(names[2], base + 4, Ty::Uint, 1),
        f(names[3], base + 6, Ty::Uint, 1),
        f(names[4], base + 8, Ty::Real, 12),
        f(names[5], base + 56, Ty::Text, 32),
        f(names[6], base + 88, Ty::Text, 32),
    ]
}

const CH0_IN: [Field; 7] = ch(
    output::CH0,
    [
        "CH0_CONTROL",
        "CH0_COMMAND",
        "CH0_SEQUENCE",
        "CH0_RESERVED",
        "CH0_PARAMS",
        "CH0_TEXT1",
        "CH0_TEXT2",
    ],
);
const CH1_IN: [Field; 7] = ch(
    output::CH1,
    [
        "CH1_CONTROL",
        "CH1_COMMAND",
        "CH1_SEQUENCE",
        "CH1_RESERVED",
        "CH1_PARAMS",
        "CH1_TEXT1",
        "CH1_TEXT2",
    ],
);

/// The output assembly, field by field.
// Indexing in a constant: checked by the compiler.
#[allow(clippy::indexing_slicing)]
pub const OUTPUT_FIELDS: &[Field] = &[
    f("PLC_HEARTBEAT", output::HEARTBEAT, Ty::Uint, 1),
    f("TRIG_BITS", output::TRIG_BITS, Ty::Uint, 1),
    CH0_IN[0],
    CH0_IN[1],
    CH0_IN[2],
    CH0_IN[3],
    CH0_IN[4],
    CH0_IN[5],
    CH0_IN[6],
    CH1_IN[0],
    CH1_IN[1],
    CH1_IN[2],
    CH1_IN[3],
    CH1_IN[4],
    CH1_IN[5],
    CH1_IN[6],
    f("RAW_CONTROL", output::RAW, Ty::Uint, 1),
    f("RAW_SEQUENCE", output::RAW + 2, Ty::Uint, 1),
    f(
        "RAW_REQUEST",
        output::RAW_REQUEST,
        Ty::Text,
        output::RAW_REQUEST_LEN,
    ),
];

/// An assembly's bytes, written and read by offset; out of range is a
/// no-op (the layout's test proves every offset is inside).
struct Bytes<'a>(&'a mut [u8]);

impl Bytes<'_> {
    fn put(&mut self, at: usize, b: &[u8]) {
        if let Some(dst) = self.0.get_mut(at..at + b.len()) {
            dst.copy_from_slice(b);
        }
    }
    fn u16(&mut self, at: usize, v: u16) {
        self.put(at, &v.to_le_bytes());
    }
    fn i32(&mut self, at: usize, v: i32) {
        self.put(at, &v.to_le_bytes());
    }
    /// A REAL the gateway reports: zero as +0.0, unknown as NaN.
    fn real(&mut self, at: usize, v: Option<f32>) {
        let bits = match v {
            // -0.0 too: a float pattern compares by value.
            Some(0.0) => 0,
            Some(x) => x.to_bits(),
            None => f32::NAN.to_bits(),
        };
        self.put(at, &bits.to_le_bytes());
    }
    fn reals(&mut self, at: usize, v: Option<&[f32]>, n: usize) {
        for i in 0..n {
            self.real(at + 4 * i, v.and_then(|a| a.get(i).copied()));
        }
    }
    fn handshake(&mut self, at: usize, h: &Handshake) {
        let (id, src) = h.error();
        self.u16(at, view::status_bits(h));
        self.u16(at + 2, h.seq_echo);
        self.i32(at + 4, id);
        self.u16(at + 8, src);
    }
}

fn u16_at(d: &[u8], at: usize) -> u16 {
    match d.get(at..at + 2) {
        Some(&[a, b]) => u16::from_le_bytes([a, b]),
        _ => 0,
    }
}

fn real_at(d: &[u8], at: usize) -> f32 {
    match d.get(at..at + 4) {
        Some(&[a, b, c, e]) => f32::from_le_bytes([a, b, c, e]),
        _ => f32::NAN,
    }
}

/// Encodes the input assembly (`out`: [`SIZE`] bytes) from the state.
pub fn encode_input(m: &Model, now: Instant, out: &mut [u8]) {
    out.fill(0);
    let mut b = Bytes(out);
    let robot = &m.robot;
    b.u16(input::HEARTBEAT, m.ticks);
    b.u16(input::LINK_STATE, m.link.state as u16);
    let fsm = robot
        .fsm
        .and_then(|s| u16::try_from(i32::from(s)).ok())
        .unwrap_or(u16::MAX);
    b.u16(input::FSM_STATE, fsm);
    b.u16(input::ROBOT_FLAGS, view::read(m, r::STATUS_FLAGS, now));
    b.i32(input::ROBOT_ERROR_CODE, robot.error_code);
    b.u16(input::ROBOT_ERROR_AXIS, robot.error_axis);
    b.u16(input::STATUS_AGE_MS, view::read(m, r::STATUS_AGE_MS, now));
    b.u16(input::WATCHDOG, view::read(m, r::STATUS_WATCHDOG, now));
    b.u16(input::WATCHDOG_TRIPS, m.plc.watchdog_trips);
    b.u16(
        input::ACTIVE_MOTION,
        view::read(m, r::STATUS_ACTIVE_MOTION, now),
    );
    b.u16(input::QUEUE_USED, m.queue.len() as u16);
    b.u16(input::COMMAND_OWNER, m.owner.code());
    b.u16(input::HEARTBEAT_ECHO, m.plc.heartbeat);
    b.real(input::OVERRIDE, robot.override_ratio);
    b.reals(input::ACT_JOINTS, robot.joints.as_ref().map(|a| &a[..]), 6);
    b.reals(input::ACT_POSE, robot.pose.as_ref().map(|a| &a[..]), 6);
    for (i, g) in Io::ALL.iter().enumerate() {
        b.u16(input::IO + 2 * i, robot.io(*g).unwrap_or(0));
    }
    b.u16(input::IO + 12, view::read(m, r::STATUS_IO_VALID, now));
    b.u16(
        input::PROTOCOL_LEVEL,
        view::read(m, r::STATUS_PROTOCOL, now),
    );
    for (ch, at) in m.channels.iter().zip([input::CH0, input::CH1]) {
        b.handshake(at, &ch.handshake);
        b.u16(at + 10, ch.handshake.command_echo);
    }
    b.handshake(input::RAW, &m.raw.handshake);
    b.u16(input::RAW + 10, m.raw.reply_len);
    b.u16(input::RAW + 12, u16::from(m.raw.reply_truncated()));
    let trig = |f: fn(&Handshake) -> bool| {
        m.triggers
            .handshakes
            .iter()
            .enumerate()
            .filter(|(_, h)| f(h))
            .fold(0u16, |acc, (i, _)| acc | (1 << i))
    };
    b.u16(input::TRIG, trig(Handshake::is_busy));
    b.u16(
        input::TRIG + 2,
        trig(|h| h.outcome() == Some(Outcome::Done)),
    );
    b.u16(
        input::TRIG + 4,
        trig(|h| matches!(h.outcome(), Some(Outcome::Error(..)))),
    );
    b.u16(
        input::TRIG + 6,
        trig(|h| h.outcome() == Some(Outcome::Aborted)),
    );
    for (ch, at) in m
        .channels
        .iter()
        .zip([input::CH0_RESULTS, input::CH1_RESULTS])
    {
        b.reals(at, ch.results.as_ref().map(|a| &a[..]), 24);
    }
    let reply = m.raw.reply.bytes();
    let n = reply.len().min(input::RAW_REPLY_LEN);
    b.put(input::RAW_REPLY, reply.get(..n).unwrap_or(&[]));
}

/// Encodes the output assembly (`out`: [`SIZE`] bytes) from the PLC's
/// inputs as they are (an explicit read of instance 150).
pub fn encode_output(m: &Model, out: &mut [u8]) {
    out.fill(0);
    let mut b = Bytes(out);
    b.u16(output::HEARTBEAT, m.plc.heartbeat);
    b.u16(output::TRIG_BITS, m.triggers.bits);
    for (ch, at) in m.channels.iter().zip([output::CH0, output::CH1]) {
        let i = &ch.inputs;
        b.u16(at, i.control);
        b.u16(at + 2, i.code);
        b.u16(at + 4, i.seq);
        b.u16(at + 6, i.reserved);
        for (k, p) in i.params.iter().enumerate() {
            b.put(at + 8 + 4 * k, &p.to_le_bytes());
        }
        b.put(at + 56, &i.text1.0);
        b.put(at + 88, &i.text2.0);
    }
    b.u16(output::RAW, m.raw.control);
    b.u16(output::RAW + 2, m.raw.seq);
    let req = &m.raw.request.0;
    b.put(
        output::RAW_REQUEST,
        req.get(..output::RAW_REQUEST_LEN).unwrap_or(&[]),
    );
}

/// Stores the output assembly's `data` ([`SIZE`] bytes) in the PLC's
/// inputs.
fn store(m: &mut Model, data: &[u8]) {
    m.plc.heartbeat = u16_at(data, output::HEARTBEAT);
    m.triggers.bits = u16_at(data, output::TRIG_BITS);
    for (ch, at) in m.channels.iter_mut().zip([output::CH0, output::CH1]) {
        let i = &mut ch.inputs;
        i.control = u16_at(data, at);
        i.code = u16_at(data, at + 2);
        i.seq = u16_at(data, at + 4);
        i.reserved = u16_at(data, at + 6);
        for (k, p) in i.params.iter_mut().enumerate() {
            *p = real_at(data, at + 8 + 4 * k);
        }
        i.text1.set(data.get(at + 56..at + 88).unwrap_or(&[]));
        i.text2.set(data.get(at + 88..at + 120).unwrap_or(&[]));
    }
    m.raw.control = u16_at(data, output::RAW);
    m.raw.seq = u16_at(data, output::RAW + 2);
    let end = output::RAW_REQUEST + output::RAW_REQUEST_LEN;
    m.raw
        .request
        .set(data.get(output::RAW_REQUEST..end).unwrap_or(&[]));
}

/// Decodes the output assembly's `data` into the PLC's inputs and returns
/// what the write asks for: the heartbeat and the edges, exactly as a
/// register write of the same values would (`registers::view::changes`).
pub fn write_output(m: &mut Model, data: &[u8]) -> PlcEvents {
    view::changes(m, |m| store(m, data))
}

/// Takes the output assembly's `data` as the inputs' levels, without
/// edges: the first data of a new owner (an Execute already high fires
/// nothing, so that a PLC reconnecting with Execute still high does not
/// repeat a command). Only the heartbeat counts (the owner is there).
pub fn baseline_output(m: &mut Model, data: &[u8]) -> PlcEvents {
    store(m, data);
    PlcEvents {
        heartbeat: true,
        ..PlcEvents::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;
    use crate::job::Source;
    use crate::registers::Edge;

    #[test]
    fn fields_tile_each_assembly_without_gaps_or_overlap() {
        for fields in [INPUT_FIELDS, OUTPUT_FIELDS] {
            let mut at = 0;
            for fl in fields {
                assert_eq!(fl.offset, at, "{} starts where the last ended", fl.name);
                at += fl.bytes();
            }
            assert_eq!(at, SIZE);
        }
        assert_eq!(SIZE % 4, 0, "whole DINTs");
        // A Forward_Open (not Large) carries up to 511 bytes: the data, the
        // sequence count and (O->T) the run/idle header.
        const { assert!(SIZE + 6 <= 511) };
    }

    #[test]
    fn a_write_stores_the_inputs_and_its_edges_are_the_registers_edges() {
        let mut m = Model::new(Config::default(), Config::default());
        let mut d = [0u8; SIZE];
        d[output::HEARTBEAT] = 7;
        d[output::CH0] = 1; // Execute
        d[output::CH0 + 2] = 12; // code
        d[output::CH0 + 4] = 9; // sequence
        d[output::CH0 + 8..output::CH0 + 12].copy_from_slice(&420.5f32.to_le_bytes());
        d[output::CH0 + 56..output::CH0 + 59].copy_from_slice(b"TCP");
        d[output::TRIG_BITS] = 0b101;
        let ev = write_output(&mut m, &d);
        assert!(ev.heartbeat);
        assert_eq!(
            ev.edges.as_slice(),
            [
                Edge::Rose(Source::Channel(0)),
                Edge::Rose(Source::Trigger(0)),
                Edge::Rose(Source::Trigger(2))
            ]
        );
        let i = &m.channels[0].inputs;
        assert_eq!((i.code, i.seq, i.params[0]), (12, 9, 420.5));
        assert_eq!(i.text1.bytes(), b"TCP");
        // Read back as an explicit read of instance 150 sees it.
        let mut back = [0u8; SIZE];
        encode_output(&m, &mut back);
        assert_eq!(&back[..], &d[..]);
        // The same data again: no edge, no heartbeat.
        let ev = write_output(&mut m, &d);
        assert!(!ev.heartbeat && ev.edges.is_empty());
        // A baseline takes levels without edges.
        let mut m = Model::new(Config::default(), Config::default());
        let ev = baseline_output(&mut m, &d);
        assert!(ev.heartbeat && ev.edges.is_empty());
        assert!(m.channels[0].inputs.execute());
    }

    #[test]
    fn the_input_reads_unknown_as_nan_and_the_handshakes_as_the_registers() {
        let mut m = Model::new(Config::default(), Config::default());
        let now = Instant::from_millis(5);
        let mut out = [0u8; SIZE];
        encode_input(&m, now, &mut out);
        assert_eq!(u16_at(&out, input::FSM_STATE), u16::MAX);
        assert!(real_at(&out, input::ACT_JOINTS).is_nan());
        m.robot.joints = Some([-0.0, 1.5, 0.0, 0.0, 0.0, 0.0]);
        m.start(Source::Channel(1), 4, 12, now);
        encode_input(&m, now, &mut out);
        assert_eq!(out[input::ACT_JOINTS..input::ACT_JOINTS + 4], [0; 4]);
        assert_eq!(real_at(&out, input::ACT_JOINTS + 4), 1.5);
        assert_eq!(
            u16_at(&out, input::CH1),
            view::read(&m, r::channel_base(1) + r::CH_STATUS, now)
        );
        assert_eq!(u16_at(&out, input::CH1 + 2), 4);
        assert_eq!(u16_at(&out, input::CH1 + 10), 12);
    }
}
