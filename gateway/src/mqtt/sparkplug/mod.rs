//! Sparkplug B 3.0: the gateway as an edge node (part of the MQTT client,
//! feature `mqtt`).
//!
//! This module makes the messages and keeps the publishing rules; it does
//! no networking. The MQTT client drives an [`EdgeNode`]:
//!
//! 1. At each MQTT CONNECT, [`EdgeNode::connect`] starts a session (a new
//!    `bdSeq`) and writes the NDEATH payload to register as the Will (QoS 1,
//!    not retained, topic [`EdgeNode::topic`]`(NDeath)`).
//! 2. Then, whenever the state may have changed and at least every
//!    [`NodeConfig::period`], it calls [`EdgeNode::poll`] with the time and
//!    the state until it returns `None`, publishing each message (QoS 0, not
//!    retained): NBIRTH first, DBIRTH while the robot link is up, DDEATH
//!    when it goes down, NDATA/DDATA with what changed.
//! 3. An NCMD or DCMD it receives goes to [`EdgeNode::command`] (its topic
//!    recognised by [`EdgeNode::inbound`]): a rebirth request makes the next
//!    `poll` return the births again; every other write is refused.
//! 4. When the session ends, [`EdgeNode::disconnect`] (the broker publishes
//!    the Will); before an intentional disconnect, it may publish
//!    [`EdgeNode::ndeath`] itself.
//!
//! ## What is published
//! The metrics are the rows of [`metrics::TABLE`] (names, datatypes, units:
//! `gateway/SPARKPLUG.md`). Node metrics (the gateway, the robot link, the
//! command sources, the command events) are born in the NBIRTH and updated
//! in NDATA; the robot's status is the device `robot` (DBIRTH/DDATA), alive
//! while the robot link is up. Every metric carries its name (no aliases),
//! datatype and timestamp; an unknown value is a null metric.
//!
//! Report by exception: a data round publishes each metric whose value
//! changed since it was last published (floats and the uptime only when
//! they moved by their deadband since the value last published), and the
//! command events. A round that published something is followed by the
//! next one at least [`NodeConfig::period`] later; after a quiet round the
//! next change goes at once.
//!
//! ## Sequence numbers
//! `seq` is 0 in the NBIRTH and counts every later message of the node
//! (DBIRTH, DDEATH, NDATA, DDATA) by one, 255 followed by 0. `bdSeq` is
//! the same in a session's NDEATH and NBIRTH, and one more (wrapping at
//! 255) in the next session. A rebirth keeps the session's `bdSeq`.
//!
//! ## Bounds
//! Everything is fixed size: the record of what was published is one
//! `Option<u64>` per metric ([`metrics::COUNT`]), the command events are
//! read from the command log (`state::history`, [`LOG_LEN`] entries).
//! * A birth must fit the caller's buffer whole (a birth cut in two would
//!   be two births): if it does not, `poll` returns
//!   [`Error::TooSmall`] with the size needed and publishes nothing; a
//!   buffer of [`PAYLOAD_BUF`] bytes always holds one.
//! * Data is split: what does not fit one NDATA/DDATA goes in the next
//!   message of the same round (each with its own `seq`). A single metric
//!   that fits no empty payload is dropped and counted
//!   ([`Stats::dropped`]); with [`PAYLOAD_BUF`] none is.
//! * Command events are published in the order of the log, all the fields
//!   of one event in one message; more events than fit one message go in
//!   the next messages of the round. An event that left the log before it
//!   could be published is counted ([`Stats::events_lost`]; an upper
//!   bound: link events that left the log count too). With the web page's
//!   32-entry log this takes 32 events within one period.
//!
//! [`LOG_LEN`]: crate::state::history::LOG_LEN

pub mod command;
pub mod metrics;
mod payload;
mod proto;
pub mod topic;

#[cfg(test)]
mod tests;

use embassy_time::{Duration, Instant};

use crate::error::Outcome;
use crate::state::history::{CommandEntry, LogEvent};
use crate::state::{Model, Phase};

pub use command::{CommandSummary, Malformed};
pub use metrics::{DataType, Def, Family, Report, Scope, ValueField, BD_SEQ, TABLE};
pub use topic::{Id, IdError, MessageType, Topic};

use metrics::{Ctx, Metric, Val, COUNT, SOURCES};
use payload::Writer;

/// A payload buffer that always holds a birth (the largest message), with
/// every text at its longest: the largest NBIRTH measured 3620 bytes, the
/// largest DBIRTH 1217 (`the_largest_births_fit_the_payload_buffer`).
pub const PAYLOAD_BUF: usize = 4096;

/// Bytes of a payload besides its metrics, at most: the timestamp (key and
/// a 10-byte varint) and `seq` (key and 2 bytes).
const HEAD_MAX: usize = 1 + 10 + 3;

/// The edge node's settings.
#[derive(Clone, Debug, PartialEq)]
pub struct NodeConfig {
    /// The Sparkplug group id.
    pub group: Id,
    /// The edge node id (this gateway).
    pub edge: Id,
    /// The device id of the robot (default `robot`).
    pub device: Id,
    /// The shortest time between two data rounds that publish (default
    /// 100 ms).
    pub period: Duration,
    /// Joints deadband in degrees (default 0.1).
    pub joint_deadband: f32,
    /// Pose deadband in mm and degrees (default 0.1).
    pub pose_deadband: f32,
    /// The software's version `Gateway/Version` shows where no firmware
    /// image names one (Linux, the core firmwares): the platform's program
    /// (on Linux `hans-gateway`'s, which is its package's). Default: this
    /// crate's. A board with updates shows its running image's instead.
    pub version: &'static str,
}

impl NodeConfig {
    /// Node `edge` of `group`, with the defaults.
    pub fn new(group: &str, edge: &str) -> Result<NodeConfig, IdError> {
        Ok(NodeConfig {
            group: Id::new(group)?,
            edge: Id::new(edge)?,
            device: Id::new("robot")?,
            period: Duration::from_millis(100),
            joint_deadband: 0.1,
            pose_deadband: 0.1,
            version: env!("CARGO_PKG_VERSION"),
        })
    }
}

/// Why nothing could be written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Error {
    /// The buffer cannot hold this message (a birth, the NDEATH), which
    /// needs `needed` bytes. Nothing changed: the same call with a larger
    /// buffer writes it.
    TooSmall {
        /// Bytes needed.
        needed: usize,
    },
}

/// A message to publish.
#[derive(Debug, PartialEq)]
pub struct Publish<'b> {
    /// Its type (QoS: [`MessageType::qos`]; never retained).
    pub ty: MessageType,
    /// Its topic.
    pub topic: Topic,
    /// The protobuf payload, in the caller's buffer.
    pub payload: &'b [u8],
}

pub use crate::state::telemetry::NodeStats as Stats;

/// Where the node's session is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Session {
    /// Not connected: nothing to publish.
    Offline,
    /// Connected (or a rebirth asked): the NBIRTH is next.
    Birth,
    /// Born: data, and the device's births and deaths.
    Online,
}

/// A data round in progress.
#[derive(Clone, Copy, Debug)]
struct Round {
    /// When it began.
    start: Instant,
    /// Every new command event has been published.
    events_done: bool,
    /// The next metric to look at (index in [`metrics::all`]).
    cursor: usize,
    /// Something was published in it.
    sent: bool,
}

/// A Sparkplug B edge node: a pure state machine of the publishing rules,
/// driven by time and the gateway's state.
pub struct EdgeNode {
    cfg: NodeConfig,
    /// Milliseconds since 1970 UTC at `Instant` 0.
    utc_at_zero: u64,
    /// The session's `bdSeq`.
    bd_seq: u8,
    /// The next session's.
    next_bd_seq: u8,
    /// The next message's `seq`.
    seq: u8,
    session: Session,
    /// The device `robot` was born (and not dead since).
    device_born: bool,
    /// What each metric was last published as (its fingerprint; `None`:
    /// null).
    last: [Option<u64>; COUNT],
    /// Each source's last finished outcome.
    outcomes: [Option<Outcome>; SOURCES],
    /// Each source's last command event published (its serial in the log).
    reported: [Option<u32>; SOURCES],
    /// The log's total when it was last read through.
    scanned: u32,
    round: Option<Round>,
    /// A round may begin from then on.
    next_round: Instant,
    /// When the last NBIRTH was published.
    born_at: Option<Instant>,
    /// A rebirth was asked within [`REBIRTH_MIN`] of the last births: they
    /// go again once that has passed.
    rebirth_due: bool,
    stats: Stats,
}

/// The shortest time between two births of a session: rebirth requests
/// that come faster are answered together, one birth a second at most (a
/// host, or anyone who may publish NCMD, asking 25 times a second had the
/// gateway publish 25 birth pairs a second, issue 25).
pub const REBIRTH_MIN: Duration = Duration::from_secs(1);

/// The entries of the command log, each with its serial number (the
/// count of entries logged before it, wrapping).
fn log_entries(m: &Model) -> impl Iterator<Item = (u32, &crate::state::history::LogEntry)> {
    let len = m.log.iter().count() as u32;
    let first = m.log.total.wrapping_sub(len);
    m.log
        .iter()
        .enumerate()
        .map(move |(i, e)| (first.wrapping_add(i as u32), e))
}

/// `a` comes after `b` (serials wrap).
fn after(a: u32, b: u32) -> bool {
    (a.wrapping_sub(b) as i32) > 0
}

/// The last published value's number, for deadbands.
fn number_of(datatype: DataType, fp: u64) -> f64 {
    match datatype {
        DataType::Float => f64::from(f32::from_bits(fp as u32)),
        DataType::Int8 | DataType::Int16 | DataType::Int32 => f64::from(fp as u32 as i32),
        DataType::Int64 => fp as i64 as f64,
        _ => fp as f64,
    }
}

impl EdgeNode {
    /// A node with settings `cfg`, offline; its first session will have
    /// `bdSeq` 0.
    pub fn new(cfg: NodeConfig) -> EdgeNode {
        EdgeNode {
            cfg,
            utc_at_zero: 0,
            bd_seq: 0,
            next_bd_seq: 0,
            seq: 0,
            session: Session::Offline,
            device_born: false,
            last: [None; COUNT],
            outcomes: [None; SOURCES],
            reported: [None; SOURCES],
            scanned: 0,
            round: None,
            next_round: Instant::from_ticks(0),
            born_at: None,
            rebirth_due: false,
            stats: Stats::default(),
        }
    }

    /// Sets the wall time: `utc_ms` is the time in ms since 1970 UTC at
    /// `now`. Until it is set, timestamps count from the gateway's start.
    pub fn set_wall_time(&mut self, now: Instant, utc_ms: u64) {
        self.utc_at_zero = utc_ms.saturating_sub(now.as_millis());
    }

    /// The settings.
    pub fn config(&self) -> &NodeConfig {
        &self.cfg
    }

    /// The counters.
    pub fn stats(&self) -> Stats {
        self.stats
    }

    /// The current session's `bdSeq`.
    pub fn bd_seq(&self) -> u8 {
        self.bd_seq
    }

    /// The topic of `ty` for this node (and its device).
    pub fn topic(&self, ty: MessageType) -> Topic {
        topic::topic(&self.cfg.group, &self.cfg.edge, &self.cfg.device, ty)
    }

    /// What a received topic is: this node's NCMD, its device's DCMD, or
    /// `None` (to ignore).
    pub fn inbound(&self, topic: &str) -> Option<MessageType> {
        topic::inbound(&self.cfg.group, &self.cfg.edge, &self.cfg.device, topic)
    }

    fn stamp(&self, t: Instant) -> u64 {
        self.utc_at_zero.saturating_add(t.as_millis())
    }

    fn next_seq(&mut self) -> u8 {
        let s = self.seq;
        self.seq = self.seq.wrapping_add(1);
        s
    }

    /// A new MQTT session begins (call before CONNECT): a new `bdSeq`, the
    /// births are next. Returns the NDEATH to register as the Will.
    pub fn connect<'b>(&mut self, now: Instant, buf: &'b mut [u8]) -> Result<Publish<'b>, Error> {
        let bd = self.next_bd_seq;
        // Written with the new bdSeq before anything changes, so that a
        // buffer too small leaves the node as it was.
        let saved = self.bd_seq;
        self.bd_seq = bd;
        let will = match self.write_ndeath(now, buf) {
            Ok(len) => len,
            Err(e) => {
                self.bd_seq = saved;
                return Err(e);
            }
        };
        self.next_bd_seq = bd.wrapping_add(1);
        self.session = Session::Birth;
        self.device_born = false;
        self.round = None;
        self.rebirth_due = false;
        Ok(Publish {
            ty: MessageType::NDeath,
            topic: self.topic(MessageType::NDeath),
            payload: buf.get(..will).unwrap_or(&[]),
        })
    }

    /// The session ended (connection lost or closed): nothing more is
    /// published until the next [`EdgeNode::connect`].
    pub fn disconnect(&mut self) {
        self.session = Session::Offline;
        self.device_born = false;
        self.round = None;
        self.rebirth_due = false;
    }

    /// The current session's NDEATH, to publish before an intentional
    /// disconnect.
    pub fn ndeath<'b>(&mut self, now: Instant, buf: &'b mut [u8]) -> Result<Publish<'b>, Error> {
        let len = self.write_ndeath(now, buf)?;
        Ok(Publish {
            ty: MessageType::NDeath,
            topic: self.topic(MessageType::NDeath),
            payload: buf.get(..len).unwrap_or(&[]),
        })
    }

    /// NDEATH: a timestamp and the `bdSeq` metric, no `seq`. Returns its
    /// length in `buf`.
    fn write_ndeath(&mut self, now: Instant, buf: &mut [u8]) -> Result<usize, Error> {
        let ts = self.stamp(now);
        let bd = Val::I64(self.bd_seq.into());
        let m = payload::metric("bdSeq", BD_SEQ, ts, &bd);
        let needed = HEAD_MAX + Writer::len_of(&m);
        let mut w = Writer::new(buf, ts).ok_or(Error::TooSmall { needed })?;
        if !w.push(&m) {
            return Err(Error::TooSmall { needed });
        }
        self.stats.messages = self.stats.messages.wrapping_add(1);
        Ok(w.finish(None).len())
    }

    /// Applies a received command of type `ty` (see [`command::decode`]):
    /// a rebirth request makes the births next (at most one birth each
    /// [`REBIRTH_MIN`]: requests within it are answered together, when it
    /// has passed); refusals and malformed payloads are counted. Returns
    /// what it asked.
    pub fn command(
        &mut self,
        ty: MessageType,
        payload: &[u8],
    ) -> Result<CommandSummary, Malformed> {
        let summary = match command::decode(ty, payload) {
            Ok(s) => s,
            Err(e) => {
                self.stats.malformed = self.stats.malformed.wrapping_add(1);
                return Err(e);
            }
        };
        self.stats.refused = self.stats.refused.wrapping_add(summary.refused.into());
        if summary.refused > 0 {
            warn!("sparkplug: {} metric writes refused", summary.refused);
        }
        if summary.rebirth && self.session == Session::Online {
            self.rebirth_due = true;
        }
        Ok(summary)
    }

    /// A rebirth asked, once [`REBIRTH_MIN`] has passed since the last
    /// births: the births are next.
    fn rebirth(&mut self, now: Instant) {
        let due = self.born_at.is_none_or(|t| now >= t + REBIRTH_MIN);
        if self.rebirth_due && self.session == Session::Online && due {
            self.rebirth_due = false;
            self.session = Session::Birth;
            self.device_born = false;
            self.round = None;
            self.stats.rebirths = self.stats.rebirths.wrapping_add(1);
        }
    }

    /// When a data round may next publish, or a rebirth asked is due (the
    /// caller polls at this time at the latest after a change; polling
    /// earlier does no harm).
    pub fn next_round(&self) -> Instant {
        match (self.rebirth_due, self.born_at) {
            (true, Some(t)) => self.next_round.min(t + REBIRTH_MIN),
            _ => self.next_round,
        }
    }

    /// The next message to publish at `now` for state `m`, written in
    /// `buf`; `None` when there is nothing (offline, nothing changed, or
    /// the period has not passed). Call again until `None`.
    pub fn poll<'b>(
        &mut self,
        now: Instant,
        m: &Model,
        buf: &'b mut [u8],
    ) -> Result<Option<Publish<'b>>, Error> {
        self.rebirth(now);
        match self.session {
            Session::Offline => return Ok(None),
            Session::Birth => return self.nbirth(now, m, buf).map(Some),
            Session::Online => {}
        }
        self.follow_outcomes(m);
        let alive = metrics::device_alive(m);
        if alive && !self.device_born {
            return self.dbirth(now, m, buf).map(Some);
        }
        if !alive && self.device_born {
            return Ok(Some(self.ddeath(now, buf)));
        }
        let mut round = match self.round {
            Some(r) => r,
            None if now >= self.next_round => Round {
                start: now,
                events_done: false,
                cursor: 0,
                sent: false,
            },
            None => return Ok(None),
        };
        let out = self.data(now, m, buf, &mut round);
        if out.is_some() {
            round.sent = true;
            self.round = Some(round);
        } else {
            if round.sent {
                self.next_round = round.start + self.cfg.period;
            }
            self.round = None;
        }
        Ok(out)
    }

    /// Keeps each source's last outcome from its handshake.
    fn follow_outcomes(&mut self, m: &Model) {
        for (i, slot) in self.outcomes.iter_mut().enumerate() {
            let phase = metrics::source_at(i)
                .and_then(|s| m.handshake(s))
                .map(|h| h.phase);
            if let Some(Phase::Ended(o)) = phase {
                *slot = Some(o);
            }
        }
    }

    /// A birth of `scope`'s metrics, whole or not at all: its length.
    fn birth(
        &mut self,
        now: Instant,
        m: &Model,
        buf: &mut [u8],
        scope: Scope,
        seq: u8,
    ) -> Result<usize, Error> {
        let ts = self.stamp(now);
        let ctx = Ctx {
            m,
            now,
            bd_seq: self.bd_seq,
            mqtt_refused: self.stats.refused,
            version: self.cfg.version,
            outcomes: &self.outcomes,
            event: last_finished(m),
        };
        let in_scope = || {
            metrics::all()
                .enumerate()
                .filter(move |(_, x)| x.def.scope == scope)
        };
        let len_of = |x: &Metric| {
            let v = metrics::read(x, &ctx);
            Writer::len_of(&payload::metric(&x.name(), x.def.datatype, ts, &v))
        };
        let needed = HEAD_MAX + in_scope().map(|(_, x)| len_of(&x)).sum::<usize>();
        if needed > buf.len() {
            return Err(Error::TooSmall { needed });
        }
        let mut w = Writer::new(buf, ts).ok_or(Error::TooSmall { needed })?;
        for (i, x) in in_scope() {
            let v = metrics::read(&x, &ctx);
            if !w.push(&payload::metric(&x.name(), x.def.datatype, ts, &v)) {
                return Err(Error::TooSmall { needed });
            }
            if let Some(slot) = self.last.get_mut(i) {
                *slot = v.fingerprint();
            }
        }
        self.stats.messages = self.stats.messages.wrapping_add(1);
        Ok(w.finish(Some(seq)).len())
    }

    fn nbirth<'b>(
        &mut self,
        now: Instant,
        m: &Model,
        buf: &'b mut [u8],
    ) -> Result<Publish<'b>, Error> {
        // What happened before the birth is in the birth (the last
        // command's values), not replayed as events.
        self.outcomes = [None; SOURCES];
        self.reported = [None; SOURCES];
        for (serial, e) in log_entries(m) {
            if let LogEvent::Command(c) = &e.event {
                if let Some(o) = c.outcome {
                    let i = metrics::source_index(c.source);
                    if let Some(slot) = self.reported.get_mut(i) {
                        *slot = Some(serial);
                    }
                    if let Some(slot) = self.outcomes.get_mut(i) {
                        *slot = Some(o);
                    }
                }
            }
        }
        self.follow_outcomes(m);
        let len = self.birth(now, m, buf, Scope::Node, 0)?;
        self.born_at = Some(now);
        self.scanned = m.log.total;
        self.seq = 1;
        self.session = Session::Online;
        self.device_born = false;
        self.round = None;
        self.next_round = now;
        info!("sparkplug: NBIRTH, bdSeq {}", self.bd_seq);
        Ok(Publish {
            ty: MessageType::NBirth,
            topic: self.topic(MessageType::NBirth),
            payload: buf.get(..len).unwrap_or(&[]),
        })
    }

    fn dbirth<'b>(
        &mut self,
        now: Instant,
        m: &Model,
        buf: &'b mut [u8],
    ) -> Result<Publish<'b>, Error> {
        let len = self.birth(now, m, buf, Scope::Device, self.seq)?;
        self.seq = self.seq.wrapping_add(1);
        self.device_born = true;
        Ok(Publish {
            ty: MessageType::DBirth,
            topic: self.topic(MessageType::DBirth),
            payload: buf.get(..len).unwrap_or(&[]),
        })
    }

    fn ddeath<'b>(&mut self, now: Instant, buf: &'b mut [u8]) -> Publish<'b> {
        let ts = self.stamp(now);
        let seq = self.next_seq();
        self.device_born = false;
        self.stats.messages = self.stats.messages.wrapping_add(1);
        let payload = match Writer::new(buf, ts) {
            Some(w) => w.finish(Some(seq)),
            // A buffer of a few bytes: an empty payload still says dead.
            None => &[],
        };
        Publish {
            ty: MessageType::DDeath,
            topic: self.topic(MessageType::DDeath),
            payload,
        }
    }

    /// The next data message of `round`, or `None` when it is over.
    fn data<'b>(
        &mut self,
        now: Instant,
        m: &Model,
        buf: &'b mut [u8],
        round: &mut Round,
    ) -> Option<Publish<'b>> {
        let node_end = metrics::all()
            .position(|x| x.def.scope == Scope::Device)
            .unwrap_or(COUNT);
        // NDATA: the command events, then the node's changed metrics.
        let mut ty = None;
        if !round.events_done || round.cursor < node_end {
            ty = self
                .fill(now, m, buf, round, node_end)
                .map(|len| (MessageType::NData, len));
        }
        // DDATA: the robot's changed metrics, while it is alive.
        if ty.is_none() && self.device_born && round.cursor < COUNT {
            round.cursor = round.cursor.max(node_end);
            ty = self
                .fill(now, m, buf, round, COUNT)
                .map(|len| (MessageType::DData, len));
        }
        let (ty, len) = ty?;
        Some(Publish {
            ty,
            topic: self.topic(ty),
            payload: buf.get(..len).unwrap_or(&[]),
        })
    }

    /// Writes a data payload: the pending events (NDATA only, while
    /// `round.events_done` is false), then the changed metrics up to index
    /// `to`. Its length, or `None` if it would be empty.
    fn fill(
        &mut self,
        now: Instant,
        m: &Model,
        buf: &mut [u8],
        round: &mut Round,
        to: usize,
    ) -> Option<usize> {
        let ts = self.stamp(now);
        let mut w = Writer::new(buf, ts)?;
        if !round.events_done {
            round.events_done = self.events(m, now, &mut w);
        }
        if round.events_done {
            round.cursor = self.changed(m, now, ts, &mut w, round.cursor, to);
        }
        if w.metrics() == 0 {
            return None;
        }
        let seq = self.next_seq();
        self.stats.messages = self.stats.messages.wrapping_add(1);
        Some(w.finish(Some(seq)).len())
    }

    /// Writes the command events not yet published, each whole, in log
    /// order: `true` once all are written, `false` if the payload is full.
    fn events(&mut self, m: &Model, now: Instant, w: &mut Writer<'_>) -> bool {
        let len = m.log.iter().count() as u32;
        let oldest = m.log.total.wrapping_sub(len);
        if after(oldest, self.scanned) {
            let lost = oldest.wrapping_sub(self.scanned);
            self.stats.events_lost = self.stats.events_lost.wrapping_add(lost);
            self.scanned = oldest;
            warn!("sparkplug: {} log entries left the log unpublished", lost);
        }
        let rows = || metrics::all().filter(|x| x.def.report == Report::Event);
        for (serial, e) in log_entries(m) {
            let LogEvent::Command(c) = &e.event else {
                continue;
            };
            let Some(o) = c.outcome else {
                continue;
            };
            let i = metrics::source_index(c.source);
            let seen = self.reported.get(i).copied().flatten();
            if seen.is_some_and(|s| !after(serial, s)) {
                continue;
            }
            let ended = e.at + Duration::from_millis(c.took_ms.into());
            let ts = self.stamp(ended);
            let ctx = Ctx {
                m,
                now,
                bd_seq: self.bd_seq,
                mqtt_refused: self.stats.refused,
                version: self.cfg.version,
                outcomes: &self.outcomes,
                event: Some(c),
            };
            let size: usize = rows()
                .map(|x| {
                    let v = metrics::read(&x, &ctx);
                    Writer::len_of(&payload::metric(&x.name(), x.def.datatype, ts, &v))
                })
                .sum();
            if size > w.room() {
                if w.metrics() > 0 {
                    return false;
                }
                // One event alone does not fit an empty payload: dropped.
                self.stats.dropped = self.stats.dropped.wrapping_add(1);
            } else {
                for x in rows() {
                    let v = metrics::read(&x, &ctx);
                    w.push(&payload::metric(&x.name(), x.def.datatype, ts, &v));
                }
            }
            if let Some(slot) = self.reported.get_mut(i) {
                *slot = Some(serial);
            }
            if let Some(slot) = self.outcomes.get_mut(i) {
                *slot = Some(o);
            }
        }
        self.scanned = m.log.total;
        true
    }

    /// Writes the metrics of `from..to` (indices in [`metrics::all`]) that
    /// changed, until the payload is full: the index to go on from.
    fn changed(
        &mut self,
        m: &Model,
        now: Instant,
        ts: u64,
        w: &mut Writer<'_>,
        from: usize,
        to: usize,
    ) -> usize {
        let ctx = Ctx {
            m,
            now,
            bd_seq: self.bd_seq,
            mqtt_refused: self.stats.refused,
            version: self.cfg.version,
            outcomes: &self.outcomes,
            event: None,
        };
        let mut dropped = 0u32;
        let mut next = to;
        for (i, x) in metrics::all().enumerate().take(to).skip(from) {
            if matches!(x.def.report, Report::Birth | Report::Event) {
                continue;
            }
            let v = metrics::read(&x, &ctx);
            let Some(slot) = self.last.get_mut(i) else {
                continue;
            };
            if !moved(&self.cfg, x.def, *slot, &v) {
                continue;
            }
            if !w.push(&payload::metric(&x.name(), x.def.datatype, ts, &v)) {
                if w.metrics() > 0 {
                    next = i;
                    break;
                }
                // Alone in an empty payload and still too large: dropped.
                dropped += 1;
            }
            *slot = v.fingerprint();
        }
        self.stats.dropped = self.stats.dropped.wrapping_add(dropped);
        next
    }
}

/// `v` differs from the value last published (`old`) by enough to be
/// published: any change, or the row's deadband for numbers.
fn moved(cfg: &NodeConfig, def: &Def, old: Option<u64>, v: &Val<'_>) -> bool {
    let new = v.fingerprint();
    if new == old {
        return false;
    }
    let band = match def.report {
        Report::JointBand => cfg.joint_deadband,
        Report::PoseBand => cfg.pose_deadband,
        Report::Band(b) => b,
        _ => 0.0,
    };
    match (old, v.number()) {
        (Some(old), Some(new)) if band > 0.0 => {
            // NaN on either side publishes.
            let moved = (new - number_of(def.datatype, old)).abs();
            moved.is_nan() || moved >= f64::from(band)
        }
        _ => true,
    }
}

/// The newest finished command in the log.
fn last_finished(m: &Model) -> Option<&CommandEntry> {
    m.log
        .iter()
        .filter_map(|e| match &e.event {
            LogEvent::Command(c) if c.outcome.is_some() => Some(c),
            _ => None,
        })
        .last()
}
