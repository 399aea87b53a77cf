//! What an MQTT broker can send to the gateway: the real `mqtt::run`
//! future (the Sparkplug B edge node's client) in virtual time, against a
//! broker whose every byte and every move comes from the input. The broker
//! accepts each connection the gateway opens and then sends what the input
//! says: CONNACK (any code), SUBACK, PUBLISH of QoS 0-3 on the node's NCMD
//! and DCMD topics, the primary host's STATE topic and others (raw
//! payloads, or Sparkplug payloads and STATE messages built from the
//! input), PINGRESP, other packet types, oversized and malformed remaining
//! lengths, raw garbage; it closes, resets, stops listening or stops
//! answering. Virtual time moves between the chunks, past the keep-alive,
//! the CONNACK timeout and the backoffs, so the client reconnects; the
//! robot's state changes under the client's eyes.
//!
//! Checked at every step (the broker's side, framing and payloads written
//! independently of the gateway's, is `mqtt_check.rs`):
//! * never a panic, and the client's future always comes to wait;
//! * the gateway's bytes are MQTT: on each connection a CONNECT (clean
//!   session, the NDEATH as a QoS 1 Will, the next `bdSeq`), then, only
//!   once a CONNACK 0 was read, a SUBSCRIBE to NCMD and DCMD (and the
//!   primary host's STATE), the NBIRTH (`seq` 0, the Will's `bdSeq`; with
//!   a primary host only once its STATE said online), then PUBLISH QoS 0 of
//!   the node's own topics in Sparkplug order (`seq` counting, the device
//!   born before its data and its death), PINGREQ, and a PUBACK only for a
//!   QoS 1 PUBLISH, in order; every payload well-formed (each metric: a
//!   name, a timestamp, a datatype, one value);
//! * the client's counters agree with a model of its reader ([`Mirror`]:
//!   the bytes the broker delivered, framed as the client must frame them):
//!   `connects` and `skipped` exactly; `connected` exactly when the newest
//!   connection is open and its CONNACK was 0; `waiting_for_host` exactly
//!   when connected and the primary host's STATE has not said online on it
//!   (an offline STATE ends the connection); at most one connection
//!   attempt more than failures; a last error once something failed; no
//!   more publishes seen than counted sent;
//! * the gateway's state is, field by field, what a second gateway that
//!   never had an MQTT client holds after the same robot changes (no job
//!   queued, no handshake, configuration or log changed; the status
//!   registers as the PLC reads them): MQTT sees the robot, never moves it.
//!
//! Each input builds its own client, hub and network (cheap: no engine, no
//! sockets besides the broker's). `GATEWAY_MQTT_TRACE=1` prints what an
//! input does (replay one with `cargo +nightly fuzz run gateway_mqtt FILE`).
//!
//! Input: a setup byte (bits 0-1 the keep-alive: 1, 4, 10, 30 s; bits 2-3
//! the node's period: 1 s, 100 ms, 10 s, 60 s; bit 4 the robot link up;
//! bits 5-6 the size of the pieces each write is cut into; bit 7 a primary
//! host, `H`), then operations: a byte whose low nibble is the operation
//! ([`Op`]) and whose high nibble a time to let pass after it
//! ([`DELAYS_MS`]), and the operation's arguments. A write while no
//! connection is open first waits (up to 40 s) for the gateway to connect
//! again. Virtual time per input is bounded ([`BUDGET`]).
//!
//! [`Mirror`]: check::Mirror
#![no_main]

#[path = "mqtt_check.rs"]
mod check;

use core::convert::Infallible;
use core::future::Future;
use core::net::{Ipv4Addr, SocketAddrV4};
use core::pin::Pin;
use core::task::{Context, Poll, Waker};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::task::Wake;

use embassy_time::{Duration, Instant};
use hans_gateway::error::Outcome;
use hans_gateway::job::Source;
use hans_gateway::mqtt::{self, Error, Settings, Stats, Status, RX_BUF};
use hans_gateway::mqtt::sparkplug::{Id, NodeConfig};
use hans_gateway::state::history::LogEntry;
use hans_gateway::state::{
    AccessState, ChannelState, ConfigState, ErrorText, LinkState, LinkStatus, Model, PlcState,
    RawState, RobotStatus, Triggers,
};
use hans_gateway::testkit::clock::VirtualClock;
use hans_gateway::testkit::net::{SimNet, SimStream};
use hans_gateway::testkit::world::GATEWAY_IP;
use hans_gateway::{Clock, Gateway, Options};
use libfuzzer_sys::fuzz_target;

use check::{
    bytes_field, hex, key, mqtt_str, packet, varint, Conn, Phase, DCMD, EDGE, GROUP, NCMD,
};

const BROKER: SocketAddrV4 = SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, 50), 1883);
const REBIRTH: &str = "Node Control/Rebirth";
/// The primary host (when the setup byte asks for one) and its STATE topic.
const HOST: &str = "H";
const STATE: &str = "spBv1.0/STATE/H";

/// Virtual time one input may use, at most.
const BUDGET: Duration = Duration::from_secs(120);
/// How long a write waits for the gateway to connect again.
const RECONNECT_WAIT: Duration = Duration::from_secs(40);
/// Polls of the client's future within one instant before it counts as
/// never waiting.
const POLL_LIMIT: u32 = 100_000;

const KEEP_ALIVES_S: [u64; 4] = [1, 4, 10, 30];
/// The node's period: the client wakes at each to run a data round
/// (reading every metric), the cost of virtual time; 100 ms (the default)
/// costs ten times 1 s.
const PERIODS_MS: [u64; 4] = [1000, 100, 10_000, 60_000];
/// Writes are cut into pieces of this size, the client running between
/// them (`usize::MAX`: whole).
const PIECES: [usize; 4] = [usize::MAX, 1, 3, 64];
/// Time let pass after an operation (the high nibble of its byte).
/// Most operations let no time pass (virtual time costs: see
/// [`PERIODS_MS`]); `Op::Time` says more.
const DELAYS_MS: [u64; 16] = [
    0, 0, 0, 0, 0, 0, 1, 10, 100, 500, 1000, 2000, 5000, 15_000, 31_000, 60_000,
];

/// The operations (the low nibble of an operation's byte).
#[derive(Clone, Copy, Debug)]
enum Op {
    /// 0: a length byte, then that many bytes, sent as they are.
    Raw,
    /// 1: CONNACK with the return code of the next byte.
    ConnAck,
    /// 2: SUBACK: a byte (its low 2 bits: 0-3 return codes, each the next
    /// byte's; bit 2: packet id 1, else the next two bytes).
    SubAck,
    /// 3: PUBLISH: see [`publish`].
    Publish,
    /// 4: PINGRESP.
    PingResp,
    /// 5: a packet longer than the client's buffer, or a malformed length:
    /// see [`oversized`].
    Oversized,
    /// 6: time: a byte, ((b & 63) + 1) × 10 ms, 100 ms, 1 s or 10 s (b >> 6).
    Time,
    /// 7: the broker closes the connection.
    Close,
    /// 8: the broker resets the connection.
    Reset,
    /// 9: the broker stops (or starts again) listening: refused connects.
    Listen,
    /// 10: the broker's host stops (or starts again) answering: connects
    /// that never complete.
    Blackhole,
    /// 11: the robot's state changes (both gateways): see [`robot_change`].
    Robot,
    /// 12: a packet of any type: its first byte, then two body bytes.
    Other,
    /// 13-15: as `Raw`.
    Spare,
}

impl Op {
    fn of(b: u8) -> Op {
        match b & 0x0F {
            0 => Op::Raw,
            1 => Op::ConnAck,
            2 => Op::SubAck,
            3 => Op::Publish,
            4 => Op::PingResp,
            5 => Op::Oversized,
            6 => Op::Time,
            7 => Op::Close,
            8 => Op::Reset,
            9 => Op::Listen,
            10 => Op::Blackhole,
            11 => Op::Robot,
            12 => Op::Other,
            _ => Op::Spare,
        }
    }
}

/// The input, read from the front; past its end every byte is 0.
struct Input<'a>(&'a [u8]);

impl<'a> Input<'a> {
    fn byte(&mut self) -> u8 {
        match self.0.split_first() {
            Some((&b, rest)) => {
                self.0 = rest;
                b
            }
            None => 0,
        }
    }
    fn u16(&mut self) -> u16 {
        u16::from_be_bytes([self.byte(), self.byte()])
    }
    /// Up to `n` bytes.
    fn take(&mut self, n: usize) -> &'a [u8] {
        let (a, b) = self.0.split_at(n.min(self.0.len()));
        self.0 = b;
        a
    }
    fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

// ---------------------------------------------------------------------------
// The state MQTT must not change.

/// What the PLC and the page see of a gateway: every field of its model
/// (destructured, so that a field added to the model is a field added
/// here; the queue by the sources waiting) and, as the PLC reads them, the
/// status registers (the whole map is a view of these fields: reading it
/// all would cost a quarter of each input).
#[derive(Debug, PartialEq)]
struct Snapshot {
    status_registers: Vec<u16>,
    robot: RobotStatus,
    link: LinkStatus,
    channels: Vec<ChannelState>,
    raw: RawState,
    triggers: Triggers,
    config: ConfigState,
    plc: PlcState,
    queue: Vec<Source>,
    active_motion: Option<Source>,
    ticks: u16,
    sessions: u16,
    modbus_peers: Vec<SocketAddrV4>,
    access: AccessState,
    log_total: u32,
    log: Vec<LogEntry>,
    error_text: ErrorText,
    firmware: hans_gateway::state::firmware::Firmware,
    owner: hans_gateway::state::owner::Ownership,
    keeps: hans_gateway::state::Keeps,
}

fn snapshot(g: &Gateway, now: Instant) -> Snapshot {
    let mut status_registers =
        vec![0u16; usize::from(hans_gateway::registers::STATUS_FW_STATE) + 1];
    g.hub()
        .with(|m| hans_gateway::registers::view::read_into(m, 0, &mut status_registers, now))
        .expect("the status block");
    g.hub().with(|m| {
        let Model {
            robot,
            link,
            channels,
            raw,
            triggers,
            config,
            plc,
            queue,
            active_motion,
            ticks,
            sessions,
            modbus_peers,
            access,
            log,
            error_text,
            firmware,
            owner,
            keeps,
        } = m;
        Snapshot {
            status_registers,
            robot: robot.clone(),
            link: *link,
            channels: channels.to_vec(),
            raw: raw.clone(),
            triggers: triggers.clone(),
            config: config.clone(),
            plc: *plc,
            queue: queue.sources().collect(),
            active_motion: *active_motion,
            ticks: *ticks,
            sessions: *sessions,
            modbus_peers: modbus_peers.to_vec(),
            access: *access,
            log_total: log.total,
            log: log.iter().cloned().collect(),
            error_text: error_text.clone(),
            firmware: *firmware,
            owner: *owner,
            keeps: *keeps,
        }
    })
}

/// A change of the robot, made to both gateways: a byte (bits 0-1: the
/// link toggles up/down; joint 1 moves to the next byte's degrees; a
/// channel command ends done; one ends aborted).
fn robot_change(inp: &mut Input<'_>, now: Instant, gateways: [&Gateway; 2]) {
    let b = inp.byte();
    let arg = inp.byte();
    for g in gateways {
        g.hub().with(|m| match b & 3 {
            0 => {
                m.link.state = if m.link.is_up() {
                    LinkState::Down
                } else {
                    LinkState::Connected
                };
            }
            1 => {
                let mut j = m.robot.joints.unwrap_or_default();
                j[0] = f32::from(arg);
                m.robot.joints = Some(j);
            }
            k => {
                let source = Source::Channel(arg & 1);
                m.start(source, u16::from(arg), 13, now);
                let outcome = if k == 2 {
                    Outcome::Done
                } else {
                    Outcome::Aborted
                };
                m.finish(source, outcome, now + Duration::from_millis(u64::from(arg)));
            }
        });
    }
}

// ---------------------------------------------------------------------------
// The world: a client, a broker, virtual time.

/// The waker of the client's future: raised, it is polled again.
struct Flag(AtomicBool);

impl Wake for Flag {
    fn wake(self: Arc<Self>) {
        self.0.store(true, Ordering::Relaxed);
    }
    fn wake_by_ref(self: &Arc<Self>) {
        self.0.store(true, Ordering::Relaxed);
    }
}

/// The client, the broker and virtual time of one input.
struct Sim<'a> {
    clock: &'a VirtualClock,
    status: &'a Status,
    net: SimNet,
    fut: Pin<Box<dyn Future<Output = Infallible> + 'a>>,
    flag: Arc<Flag>,
    waker: Waker,
    keep_alive_s: u16,
    piece: usize,
    /// The primary host's STATE topic, if the node has one.
    state: Option<&'static str>,
    /// The broker's side of the newest connection.
    stream: Option<SimStream>,
    conns: Vec<Conn>,
    listening: bool,
    blackholed: bool,
    end: Instant,
}

impl Sim<'_> {
    fn now(&self) -> Instant {
        self.clock.now()
    }

    /// Runs the client until it waits, the broker accepting what connects
    /// and reading what the gateway sent; then checks the counters.
    fn settle(&mut self) {
        let mut polls = 0u32;
        loop {
            while self.flag.0.swap(false, Ordering::Relaxed) {
                let mut cx = Context::from_waker(&self.waker);
                if let Poll::Ready(never) = self.fut.as_mut().poll(&mut cx) {
                    match never {}
                }
                polls += 1;
                assert!(
                    polls < POLL_LIMIT,
                    "the client never waits at {:?}",
                    self.now()
                );
            }
            self.drain();
            match self.net.accept(BROKER) {
                Some(s) => {
                    self.stream = Some(s);
                    self.conns.push(Conn::new(self.conns.len(), self.state));
                    self.drain();
                }
                None => break,
            }
        }
        self.check();
    }

    /// Reads and checks what the gateway sent on the newest connection.
    fn drain(&mut self) {
        if let (Some(s), Some(c)) = (self.stream.as_mut(), self.conns.last_mut()) {
            let bytes = s.read();
            c.take(&bytes, self.keep_alive_s);
        }
    }

    fn is_open(&self) -> bool {
        self.stream.as_ref().is_some_and(SimStream::is_open)
    }

    fn check(&self) {
        let s: Stats = self.status.get();
        let accepted = self.conns.iter().filter(|c| c.mirror.accepted).count();
        assert_eq!(
            s.connects as usize, accepted,
            "connects, CONNACK 0s read: {s:?}"
        );
        let skipped: u32 = self.conns.iter().map(|c| c.mirror.skipped).sum();
        assert_eq!(s.skipped, skipped, "packets skipped: {s:?}");
        let newest = self.conns.last().map(|c| c.mirror.phase);
        let open = self.is_open();
        assert_eq!(
            s.connected,
            open && newest == Some(Phase::Session),
            "connected: open {open}, {newest:?}, {s:?}"
        );
        if open {
            assert_ne!(
                newest,
                Some(Phase::Ended),
                "the client reads on after an error"
            );
        }
        let host = self.conns.last().is_some_and(|c| c.mirror.host_online);
        assert_eq!(
            s.waiting_for_host,
            s.connected && !host,
            "waiting for the primary host: {s:?}"
        );
        assert!(s.on, "{s:?}");
        let attempts = self.net.attempts(BROKER) as u64;
        let failures = u64::from(s.failures);
        assert!(
            attempts == failures || attempts == failures + 1,
            "attempts {attempts}, {s:?}"
        );
        if s.connected {
            assert_eq!(attempts, failures + 1, "{s:?}");
        }
        assert_eq!(s.last_error.is_some(), s.failures > 0, "{s:?}");
        let seen: u64 = self.conns.iter().map(|c| u64::from(c.publishes)).sum();
        assert!(seen <= u64::from(s.sent), "{seen} publishes seen, {s:?}");
        assert!(
            u64::from(s.node.messages) >= u64::from(s.sent) + u64::from(s.dropped),
            "{s:?}"
        );
        if let Some(Error::TooLong) = s.last_error {
            panic!("a packet of the client did not fit its buffer: {s:?}");
        }
    }

    /// Lets `d` of virtual time pass (within the budget), step by step.
    fn run_for(&mut self, d: Duration) {
        let end = (self.now() + d).min(self.end);
        self.run_until(end, |_| false);
    }

    /// Runs until `cond` holds or `end`; `true` if it held.
    fn run_until(&mut self, end: Instant, mut cond: impl FnMut(&Self) -> bool) -> bool {
        loop {
            self.settle();
            if cond(self) {
                return true;
            }
            let now = self.now();
            if now >= end {
                return false;
            }
            let next = self
                .clock
                .next_deadline()
                .filter(|t| *t > now)
                .unwrap_or(end)
                .min(end);
            self.clock.advance_to(next);
        }
    }

    /// Sends `bytes` on the open connection (after waiting for one), in
    /// pieces, the client reading between them.
    fn send(&mut self, bytes: &[u8]) {
        if !self.is_open() {
            let end = (self.now() + RECONNECT_WAIT).min(self.end);
            if !self.run_until(end, Self::is_open) {
                return;
            }
        }
        for piece in bytes.chunks(self.piece.max(1)) {
            if !self.is_open() {
                return;
            }
            if let (Some(s), Some(c)) = (self.stream.as_mut(), self.conns.last_mut()) {
                s.write(piece);
                c.mirror.feed(piece);
            }
            self.settle();
        }
    }
}

// ---------------------------------------------------------------------------
// What the input has the broker send.

/// A command payload from the input: a byte (bits 0-2 the number of
/// metrics, bit 3 a payload timestamp, bit 4 a `seq`, bit 5 trailing input
/// bytes), then per metric a selector byte (bits 0-2 the name: the rebirth
/// request thrice, `Node Control/Reboot`, `bdSeq`, none (an alias), one
/// from the input, a robot metric; bits 3-5 the value: true, false, int,
/// long, float, string, null, a bool varint from the input; bit 6 the
/// datatype; bit 7 a timestamp) and the value's bytes.
fn sparkplug(inp: &mut Input<'_>) -> Vec<u8> {
    let shape = inp.byte();
    let mut out = Vec::new();
    if shape & 0x08 != 0 {
        key(1, 0, &mut out);
        varint(1_700_000_000_000, &mut out);
    }
    for _ in 0..shape & 7 {
        let sel = inp.byte();
        let mut m = Vec::new();
        let name: Option<&[u8]> = match sel & 7 {
            0..=2 => Some(REBIRTH.as_bytes()),
            3 => Some(b"Node Control/Reboot"),
            4 => Some(b"bdSeq"),
            5 => None,
            6 => {
                let n = usize::from(inp.byte() & 0x3F);
                Some(inp.take(n))
            }
            _ => Some(b"robot/J1"),
        };
        match name {
            Some(n) => bytes_field(1, n, &mut m),
            None => {
                key(2, 0, &mut m);
                varint(u64::from(inp.byte()), &mut m);
            }
        }
        if sel & 0x80 != 0 {
            key(3, 0, &mut m);
            varint(1_700_000_000_000, &mut m);
        }
        let datatype = match (sel >> 3) & 7 {
            0 | 1 | 7 => 11,
            2 => 7,
            3 => 4,
            4 => 9,
            5 => 12,
            _ => 11,
        };
        if sel & 0x40 != 0 {
            key(4, 0, &mut m);
            varint(datatype, &mut m);
        }
        match (sel >> 3) & 7 {
            0 | 1 => {
                key(14, 0, &mut m);
                varint(u64::from(sel & 0x08 == 0), &mut m);
            }
            2 => {
                key(10, 0, &mut m);
                varint(u64::from(inp.byte()), &mut m);
            }
            3 => {
                key(11, 0, &mut m);
                varint(u64::from(inp.u16()) << 20, &mut m);
            }
            4 => {
                key(12, 5, &mut m);
                m.extend_from_slice(&f32::from(inp.byte()).to_le_bytes());
            }
            5 => {
                let n = usize::from(inp.byte() & 0x1F);
                bytes_field(15, inp.take(n), &mut m);
            }
            6 => {
                key(7, 0, &mut m);
                varint(1, &mut m);
            }
            _ => {
                key(14, 0, &mut m);
                varint(u64::from(inp.byte()), &mut m);
            }
        }
        bytes_field(2, &m, &mut out);
    }
    if shape & 0x10 != 0 {
        key(3, 0, &mut out);
        varint(u64::from(inp.byte()), &mut out);
    }
    if shape & 0x20 != 0 {
        let n = usize::from(inp.byte() & 0x0F);
        out.extend_from_slice(inp.take(n));
    }
    out
}

/// PUBLISH from the input: a flags byte (bits 0-1 the QoS, 3 included;
/// bit 2 DUP; bit 3 RETAIN; bits 4-6 the topic: NCMD, DCMD, the primary
/// host's STATE, another node's NCMD, another device's DCMD, one from the
/// input, NCMD with a `/` more, another host's STATE; bit 7 a payload
/// built from the input: a STATE message on STATE topics ([`state`]), a
/// Sparkplug payload on the others ([`sparkplug`]); else raw bytes), a
/// packet id (2 bytes) if QoS > 0, then the payload (raw: a length byte and
/// the bytes).
fn publish(inp: &mut Input<'_>) -> Vec<u8> {
    let flags = inp.byte();
    let qos = flags & 3;
    let topic: Vec<u8> = match (flags >> 4) & 7 {
        0 => NCMD.into(),
        1 => DCMD.into(),
        2 => STATE.into(),
        3 => b"spBv1.0/G/NCMD/F".to_vec(),
        4 => b"spBv1.0/G/DCMD/E/arm".to_vec(),
        5 => {
            let n = usize::from(inp.byte() & 0x3F);
            inp.take(n).to_vec()
        }
        6 => format!("{NCMD}/").into_bytes(),
        _ => b"spBv1.0/STATE/I".to_vec(),
    };
    let mut body = mqtt_str(&topic);
    if qos > 0 {
        body.extend(inp.u16().to_be_bytes());
    }
    if flags & 0x80 != 0 && topic.starts_with(b"spBv1.0/STATE/") {
        body.extend(state(inp));
    } else if flags & 0x80 != 0 {
        body.extend(sparkplug(inp));
    } else {
        let n = usize::from(inp.byte());
        body.extend_from_slice(inp.take(n));
    }
    packet(0x30 | (flags & 0x0F), &body)
}

/// A primary host's STATE message from the input (Sparkplug 3.0: JSON,
/// `online` and `timestamp`): a byte (bits 0-1 the value: `true`, `false`,
/// `"true"`, `tru`; bit 2 blanks around the colon; bit 3 the timestamp
/// first; bit 4 the key `Online`; bit 5 cut after the colon).
fn state(inp: &mut Input<'_>) -> Vec<u8> {
    let b = inp.byte();
    let value = ["true", "false", "\"true\"", "tru"][usize::from(b & 3)];
    let colon = if b & 4 != 0 { " :\t" } else { ":" };
    let name = if b & 0x10 != 0 { "Online" } else { "online" };
    let mut member = format!("\"{name}\"{colon}");
    if b & 0x20 == 0 {
        member.push_str(value);
    }
    let json = if b & 8 != 0 {
        format!("{{\"timestamp\":1700000000000,{member}}}")
    } else {
        format!("{{{member},\"timestamp\":1700000000000}}")
    };
    json.into_bytes()
}

/// A packet the client cannot keep, or just can: a byte, its bits 0-1
/// choosing a PUBLISH to NCMD longer than [`RX_BUF`] by the next two bytes
/// (mod 4096), sent whole, a PINGRESP behind it; a remaining length of the
/// next 4 bytes as they are (up to 256 MiB) and a few bytes; a remaining
/// length of 5 bytes; a PUBLISH to NCMD of exactly [`RX_BUF`] bytes (one
/// more if bit 7 is set).
fn oversized(inp: &mut Input<'_>) -> Vec<u8> {
    let b = inp.byte();
    match b & 3 {
        0 => {
            let extra = usize::from(inp.u16() % 4096);
            let mut body = mqtt_str(NCMD.as_bytes());
            body.resize(RX_BUF + extra, b);
            let mut p = packet(0x30, &body);
            p.extend_from_slice(&[0xD0, 0]);
            p
        }
        1 => {
            let mut p = vec![0x30 | (b >> 4)];
            p.extend_from_slice(inp.take(4));
            p.extend_from_slice(&[0, 1, b'x', 0xD0, 0]);
            p
        }
        2 => vec![0x30, 0xFF, 0xFF, 0xFF, 0xFF, 0x01, 0, 0],
        _ => {
            // Header (3 bytes) + body = RX_BUF, or one more.
            let mut body = mqtt_str(NCMD.as_bytes());
            body.resize(RX_BUF - 3 + usize::from(b >> 7), 0);
            packet(0x30, &body)
        }
    }
}

fuzz_target!(|data: &[u8]| {
    let mut inp = Input(data);
    let setup = inp.byte();
    let keep_alive_s = KEEP_ALIVES_S[usize::from(setup & 3)];
    let period = PERIODS_MS[usize::from((setup >> 2) & 3)];
    let link_up = setup & 0x10 != 0;
    let piece = PIECES[usize::from((setup >> 5) & 3)];
    let host = setup & 0x80 != 0;

    let clock = VirtualClock::new();
    let net = SimNet::new(GATEWAY_IP);
    net.listen(BROKER);
    let gateway = Gateway::new(Options::default());
    // The same gateway without an MQTT client: what the state must stay.
    let reference = Gateway::new(Options::default());
    for g in [&gateway, &reference] {
        g.hub().with(|m| {
            if link_up {
                m.link.state = LinkState::Connected;
            }
            m.robot.joints = Some([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
        });
    }
    let mut node = NodeConfig::new(GROUP, EDGE).expect("the node's ids");
    node.period = Duration::from_millis(period);
    let mut settings = Settings::new(BROKER, node);
    settings.keep_alive = Duration::from_secs(keep_alive_s);
    if host {
        settings.primary_host = Some(Id::new(HOST).expect("the host's id"));
    }
    let status = Status::new();
    let flag = Arc::new(Flag(AtomicBool::new(true)));
    let waker = Waker::from(flag.clone());
    let (hub, c, n, st) = (gateway.hub(), &clock, net.clone(), &status);
    let settings = &settings;
    let mut sim = Sim {
        clock: &clock,
        status: &status,
        net: net.clone(),
        fut: Box::pin(async move { mqtt::run(hub, c, &n, settings, st).await }),
        flag,
        waker,
        keep_alive_s: keep_alive_s as u16,
        piece,
        state: host.then_some(STATE),
        stream: None,
        conns: Vec::new(),
        listening: true,
        blackholed: false,
        end: Instant::from_ticks(0) + BUDGET,
    };
    sim.settle();

    let trace = std::env::var_os("GATEWAY_MQTT_TRACE").is_some();
    while !inp.is_empty() {
        let b = inp.byte();
        if trace {
            eprintln!(
                "at {} ms, {} connections: {:?}, then {} ms",
                sim.now().as_millis(),
                sim.conns.len(),
                Op::of(b),
                DELAYS_MS[usize::from(b >> 4)]
            );
        }
        match Op::of(b) {
            Op::Raw | Op::Spare => {
                let n = usize::from(inp.byte());
                let bytes = inp.take(n);
                sim.send(bytes);
            }
            Op::ConnAck => {
                let code = inp.byte();
                sim.send(&[0x20, 2, 0, code]);
            }
            Op::SubAck => {
                let shape = inp.byte();
                let mut body = if shape & 4 != 0 {
                    vec![0, 1]
                } else {
                    inp.u16().to_be_bytes().to_vec()
                };
                for _ in 0..shape & 3 {
                    body.push(inp.byte());
                }
                sim.send(&packet(0x90, &body));
            }
            Op::Publish => {
                let p = publish(&mut inp);
                sim.send(&p);
            }
            Op::PingResp => sim.send(&[0xD0, 0]),
            Op::Oversized => {
                let p = oversized(&mut inp);
                sim.send(&p);
            }
            Op::Time => {
                let t = inp.byte();
                let unit = [10, 100, 1000, 10_000][usize::from(t >> 6)];
                sim.run_for(Duration::from_millis(u64::from(t & 0x3F) * unit + unit));
            }
            Op::Close => {
                if let Some(s) = sim.stream.as_mut() {
                    s.close();
                }
                sim.settle();
            }
            Op::Reset => {
                if let Some(s) = sim.stream.as_mut() {
                    s.reset();
                }
                sim.settle();
            }
            Op::Listen => {
                sim.listening = !sim.listening;
                if sim.listening {
                    sim.net.listen(BROKER);
                } else {
                    sim.net.unlisten(BROKER);
                }
            }
            Op::Blackhole => {
                sim.blackholed = !sim.blackholed;
                sim.net.blackhole(*BROKER.ip(), sim.blackholed);
            }
            Op::Robot => {
                let now = sim.now();
                robot_change(&mut inp, now, [&gateway, &reference]);
                sim.settle();
            }
            Op::Other => {
                let first = inp.byte();
                let body = [inp.byte(), inp.byte()];
                sim.send(&packet(first, &body));
            }
        }
        let delay = DELAYS_MS[usize::from(b >> 4)];
        if delay > 0 {
            sim.run_for(Duration::from_millis(delay));
        }
    }
    sim.settle();
    if trace {
        eprintln!("at {:?}: {:?}", sim.now(), status.get());
        for c in &sim.conns {
            eprintln!(
                "connection {}: {:?}, {:?}, {} publishes, {} PUBACKs, {} skipped",
                c.index, c.mirror.phase, c.stage, c.publishes, c.acks, c.mirror.skipped
            );
        }
    }
    for c in &sim.conns {
        assert!(
            c.out.is_empty(),
            "connection {}: the gateway left a packet half written: {}",
            c.index,
            hex(&c.out)
        );
    }
    let now = sim.now();
    assert_eq!(
        snapshot(&gateway, now),
        snapshot(&reference, now),
        "MQTT changed the gateway's state"
    );
});
