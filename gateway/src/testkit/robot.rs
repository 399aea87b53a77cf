//! A robot controller for virtual-time tests: a small model of what the
//! gateway can tell about a controller (the FSM, the flags of
//! `ReadRobotState`, a motion that takes time, pause, stop, bring-up steps
//! that take time, faults), answering on the simulated network.
//!
//! It is deliberately much simpler than `hans-sim` (no kinematics, no
//! DataSheet): it exists to be fast and deterministic, and to misbehave on
//! demand. Faults come from a script ([`SimRobot::script`], applied to the
//! next requests in order) or at random ([`RandomFaults`], from a seeded
//! generator). Everything the gateway sends is logged ([`SimRobot::log`])
//! with the time, for the invariants of the tests.

use core::net::SocketAddrV4;
use std::collections::VecDeque;
use std::format;
use std::string::{String, ToString};
use std::vec::Vec;

use embassy_time::{Duration, Instant};
use hans_codec::{CommandId, Framer, Request};

use super::net::{SimNet, SimStream};
use super::rng::Rng;

/// Something a request gets instead of its proper reply.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Fault {
    /// No reply at all.
    NoReply,
    /// The reply, but this late.
    Late(Duration),
    /// Bytes that are no protocol message.
    Garbage,
    /// A reply naming another command.
    WrongName,
    /// `Name,Fail,code,;`.
    Fail(i32),
    /// `errorcmd` (the controller could not parse the request).
    ErrorCmd,
    /// The connection is reset instead of an answer.
    Drop,
    /// These bytes instead of the proper reply.
    Reply(Vec<u8>),
}

/// Probabilities (per mille) of random faults, per request or per motion.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RandomFaults {
    /// A request gets no reply.
    pub no_reply: u32,
    /// A reply comes later than any timeout.
    pub late: u32,
    /// A reply is garbage.
    pub garbage: u32,
    /// A reply names another command.
    pub wrong_name: u32,
    /// A command (not a status read) is refused with `Fail`.
    pub fail: u32,
    /// The connection drops instead of a reply.
    pub drop: u32,
    /// A motion ends in a robot error.
    pub motion_error: u32,
    /// A motion ends in an emergency stop.
    pub estop: u32,
    /// A motion ends in the safety guard.
    pub guard: u32,
}

/// A controller stops a long jog when no `LongMoveEvent` came for this
/// long (V6 document 4.10.18).
pub const JOG_TIMEOUT: Duration = Duration::from_millis(200);

/// A long jog under way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JogState {
    /// `LongJogL` rather than `LongJogJ`.
    pub cartesian: bool,
    /// Axis 0-5.
    pub axis: i32,
    /// Direction 0/1.
    pub direction: i32,
    /// When it started.
    pub since: Instant,
    /// The last keep-alive (or the start).
    pub last_event: Instant,
}

/// What a motion is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Motion {
    /// When the FSM went to Moving.
    start: Instant,
    /// When it will end if not paused.
    end: Instant,
    /// Paused since.
    paused: Option<Instant>,
    /// A fault that ends it early: at, and which.
    fault: Option<(Instant, MotionFault)>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum MotionFault {
    Error(i32),
    Estop,
    Guard,
}

/// The controller's state, as far as the gateway can see it.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// The FSM state (`ReadCurFSM`).
    pub fsm: i32,
    /// An error is active, with this code.
    pub error: Option<i32>,
    /// Emergency stop pressed.
    pub estop: bool,
    /// Safety guard open.
    pub guard: bool,
    /// The moving flag lags the FSM by this much (start and end).
    pub flag_lag: Duration,
    /// How long a bring-up step takes.
    pub step_time: Duration,
    /// How long the next motion takes.
    pub motion_time: Duration,
    /// Box I/O and tool I/O, `ReadBoxDI` ... `ReadEO` order.
    pub io: [u16; 6],
    /// The joints `ReadActPos` reports.
    pub joints: [i32; 6],
    /// The controller's version (`PackageVersion`); `None`: a V5
    /// controller, which refuses the V6 commands with `Fail,20005`.
    pub version: Option<&'static str>,
    /// A long jog under way.
    pub jog: Option<JogState>,
    /// Long jogs the controller stopped itself because `LongMoveEvent`
    /// stopped coming for [`JOG_TIMEOUT`].
    pub jog_timeouts: u32,
    /// The longest gap between two keep-alives of a jog (or from its
    /// start to the first one).
    pub max_event_gap: Duration,
    motion: Option<Motion>,
    /// The last motion ended (for the lagging flag).
    last_end: Option<Instant>,
    /// A bring-up step under way: the state it reaches, and when.
    step: Option<(Instant, i32)>,
}

impl Default for Model {
    fn default() -> Self {
        Model {
            fsm: 33,
            error: None,
            estop: false,
            guard: false,
            flag_lag: Duration::from_millis(30),
            step_time: Duration::from_millis(200),
            motion_time: Duration::from_millis(300),
            io: [0; 6],
            joints: [0, 0, 90, 0, 90, 0],
            version: Some("6.3.6.20240305"),
            jog: None,
            jog_timeouts: 0,
            max_event_gap: Duration::from_ticks(0),
            motion: None,
            last_end: None,
            step: None,
        }
    }
}

impl Model {
    /// A controller with 48 V off and the box disconnected (`Power on`
    /// brings it up).
    pub fn powered_off() -> Self {
        Model {
            fsm: 2,
            ..Model::default()
        }
    }

    /// A motion is under way (moving or paused).
    pub fn in_motion(&self) -> bool {
        self.motion.is_some()
    }

    /// When the motion under way was accepted (or last continued).
    pub fn motion_start(&self) -> Option<Instant> {
        self.motion.map(|m| m.start)
    }

    /// A motion is paused (held until `GrpContinue`).
    pub fn paused(&self) -> bool {
        self.motion.is_some_and(|m| m.paused.is_some())
    }

    /// The emergency stop is pressed now: the motion under way stops.
    pub fn emergency_stop(&mut self, now: Instant) {
        if self.motion.take().is_some() || self.jog.take().is_some() {
            self.last_end = Some(now);
        }
        self.estop = true;
        self.set_fsm(5);
    }

    /// The operator cleared every fault (released the emergency stop,
    /// closed the guard, reset the error): an idle robot is enabled and
    /// stands by; a bring-up step under way is forgotten.
    pub fn clear_faults(&mut self) {
        self.estop = false;
        self.guard = false;
        self.error = None;
        self.step = None;
        if self.motion.is_none() {
            self.fsm = if self.jog.is_some() { 26 } else { 33 };
        }
    }

    /// Moves the model to `now`: motions and bring-up steps end, faults
    /// strike.
    pub fn advance(&mut self, now: Instant) {
        if let Some(j) = self.jog {
            let end = j.last_event + JOG_TIMEOUT;
            if now >= end {
                self.jog = None;
                self.jog_timeouts += 1;
                self.last_end = Some(end);
                if self.fsm == 26 {
                    self.fsm = 33;
                }
            }
        }
        if let Some((at, to)) = self.step {
            if now >= at {
                self.fsm = to;
                self.step = None;
            }
        }
        let Some(m) = self.motion else { return };
        if let Some((at, f)) = m.fault {
            if now >= at {
                self.motion = None;
                self.last_end = Some(at);
                match f {
                    MotionFault::Error(code) => {
                        self.error = Some(code);
                        self.fsm = 22;
                    }
                    MotionFault::Estop => {
                        self.estop = true;
                        self.fsm = 5;
                    }
                    MotionFault::Guard => {
                        self.guard = true;
                        self.fsm = 12;
                    }
                }
                return;
            }
        }
        if m.paused.is_none() && now >= m.end {
            self.motion = None;
            self.last_end = Some(m.end);
            self.fsm = 33;
        }
    }

    fn moving_flag(&self, now: Instant) -> bool {
        if self.jog.is_some_and(|j| now >= j.since + self.flag_lag) {
            return true;
        }
        match self.motion {
            Some(m) => m.paused.is_none() && now >= m.start + self.flag_lag,
            None => self.last_end.is_some_and(|e| now < e + self.flag_lag),
        }
    }

    fn enabled(&self) -> bool {
        matches!(self.fsm, 25..=27 | 29..=38 | 41 | 44..=46)
    }

    /// The `ReadRobotState` values.
    fn state_values(&self, now: Instant) -> [i32; 13] {
        let b = |v: bool| i32::from(v);
        let idle = self.motion.is_none() && self.jog.is_none() && !self.moving_flag(now);
        [
            b(self.moving_flag(now)),
            b(self.enabled()),
            b(self.error.is_some()),
            self.error.unwrap_or(0),
            0,
            b(self.enabled()),
            b(self.motion.is_some_and(|m| m.paused.is_some())),
            b(self.estop),
            b(self.guard),
            b(self.fsm >= 9),
            b(self.fsm >= 4),
            b(idle),
            b(idle),
        ]
    }

    /// Goes to state `v` now: a bring-up step under way is overtaken (a
    /// controller does one thing at a time).
    fn set_fsm(&mut self, v: i32) {
        self.fsm = v;
        self.step = None;
    }

    fn begin_step(&mut self, now: Instant, via: i32, to: i32) {
        self.fsm = via;
        self.step = Some((now + self.step_time, to));
    }
}

struct Conn {
    stream: SimStream,
    framer: Framer<1024>,
    /// A request was answered not yet (one may be in flight).
    awaiting: bool,
}

/// A request as the robot received it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Received {
    /// When.
    pub at: Instant,
    /// The message, terminator included.
    pub text: String,
    /// On which connection (counted from 0).
    pub conn: u32,
}

/// The simulated controller.
pub struct SimRobot {
    net: SimNet,
    /// Its command endpoint (connect mode: it listens here).
    pub addr: SocketAddrV4,
    /// Listen mode: the gateway's port it connects to (it reconnects when
    /// the connection is gone).
    pub gateway_port: Option<u16>,
    conns: Vec<(u32, Conn)>,
    next_conn: u32,
    /// The controller's state.
    pub model: Model,
    /// Faults for the next requests, in order (status reads included).
    pub script: VecDeque<Fault>,
    /// Random faults.
    pub faults: RandomFaults,
    rng: Rng,
    /// Every request received.
    pub log: Vec<Received>,
    /// Broken rules of the protocol seen (a second request while one was
    /// in flight on a connection).
    pub violations: Vec<String>,
    /// Time from a request to its reply.
    pub latency: Duration,
    outbox: Vec<(Instant, u32, Vec<u8>)>,
    /// In listen mode: when to connect again.
    reconnect_at: Option<Instant>,
    /// Connections are refused (listen mode: not made).
    offline: bool,
}

impl SimRobot {
    /// A controller at `addr` on `net` (connect mode: it listens there).
    pub fn new(net: &SimNet, addr: SocketAddrV4, seed: u64) -> Self {
        net.listen(addr);
        SimRobot {
            net: net.clone(),
            addr,
            gateway_port: None,
            conns: Vec::new(),
            next_conn: 0,
            model: Model::default(),
            script: VecDeque::new(),
            faults: RandomFaults::default(),
            rng: Rng::new(seed),
            log: Vec::new(),
            violations: Vec::new(),
            latency: Duration::from_micros(500),
            outbox: Vec::new(),
            reconnect_at: None,
            offline: false,
        }
    }

    /// Listen mode: the controller connects to the gateway's `port`.
    pub fn connect_to_gateway(&mut self, port: u16) {
        self.net.unlisten(self.addr);
        self.gateway_port = Some(port);
        self.reconnect_at = Some(Instant::from_ticks(0));
    }

    /// Listen mode: a new connection from the controller now (the old one
    /// stays open until the gateway closes it).
    pub fn reconnect_now(&mut self, now: Instant) {
        self.reconnect_at = Some(now);
        if let Some(port) = self.gateway_port {
            if let Some(s) = self.net.connect(self.addr, port) {
                self.add(s);
            }
        }
    }

    /// The controller is off the network (`true`: connects to it are
    /// refused; listen mode: it does not connect) or back.
    pub fn set_offline(&mut self, off: bool) {
        self.offline = off;
        if self.gateway_port.is_none() {
            if off {
                self.net.unlisten(self.addr);
            } else {
                self.net.listen(self.addr);
            }
        }
    }

    /// Drops every connection (a reset).
    pub fn drop_connections(&mut self) {
        for (_, c) in self.conns.iter_mut() {
            c.stream.reset();
        }
        self.conns.clear();
        self.outbox.clear();
    }

    /// Connections open now.
    pub fn open_connections(&self) -> usize {
        self.conns
            .iter()
            .filter(|(_, c)| c.stream.is_open())
            .count()
    }

    fn add(&mut self, stream: SimStream) {
        let id = self.next_conn;
        self.next_conn += 1;
        self.conns.push((
            id,
            Conn {
                stream,
                framer: Framer::new(),
                awaiting: false,
            },
        ));
    }

    /// The next instant the robot has something to do: a reply to deliver,
    /// a connection to make. (The model changes lazily: it is brought up to
    /// date whenever a request comes.)
    pub fn next_wakeup(&self) -> Option<Instant> {
        let mut t = None;
        for (at, _, _) in &self.outbox {
            t = Some(t.map_or(*at, |x: Instant| x.min(*at)));
        }
        if let Some(r) = self.reconnect_at {
            if self.gateway_port.is_some() && self.open_connections() == 0 && !self.offline {
                t = Some(t.map_or(r, |x| x.min(r)));
            }
        }
        t
    }

    /// Does what is due at `now`: accepts connections, answers requests,
    /// delivers replies. `true` if anything happened.
    pub fn step(&mut self, now: Instant) -> bool {
        self.model.advance(now);
        let mut acted = false;
        if self.offline {
            // Nothing to accept, nothing to connect.
        } else if self.gateway_port.is_none() {
            while let Some(s) = self.net.accept(self.addr) {
                self.add(s);
                acted = true;
            }
        } else if self.open_connections() == 0 && self.reconnect_at.is_some_and(|r| now >= r) {
            match self
                .gateway_port
                .and_then(|p| self.net.connect(self.addr, p))
            {
                Some(s) => {
                    self.add(s);
                    self.reconnect_at = Some(now + Duration::from_millis(100));
                }
                None => self.reconnect_at = Some(now + Duration::from_millis(100)),
            }
            acted = true;
        }
        self.conns.retain(|(_, c)| c.stream.is_open());
        let mut requests = Vec::new();
        for (id, c) in self.conns.iter_mut() {
            let bytes = c.stream.read();
            if bytes.is_empty() {
                continue;
            }
            acted = true;
            let mut msgs = Vec::new();
            c.framer.feed(&bytes, |m| {
                msgs.push(match m {
                    Ok(t) => t.to_string(),
                    Err(_) => String::new(),
                })
            });
            for m in msgs {
                if c.awaiting {
                    self.violations
                        .push(format!("{now:?}: a request while one was in flight: {m}"));
                }
                c.awaiting = true;
                requests.push((*id, m));
            }
        }
        for (conn, text) in requests {
            self.log.push(Received {
                at: now,
                text: text.clone(),
                conn,
            });
            self.answer(now, conn, &text);
        }
        let due: Vec<(Instant, u32, Vec<u8>)>;
        (due, self.outbox) = core::mem::take(&mut self.outbox)
            .into_iter()
            .partition(|(at, _, _)| *at <= now);
        for (_, conn, bytes) in due {
            if let Some((_, c)) = self.conns.iter_mut().find(|(id, _)| *id == conn) {
                c.awaiting = false;
                c.stream.write(&bytes);
                acted = true;
            }
        }
        acted
    }

    fn fault(&mut self, is_status: bool) -> Option<Fault> {
        if let Some(f) = self.script.pop_front() {
            return Some(f);
        }
        let f = self.faults;
        let r = self.rng.below(1000) as u32;
        let mut acc = 0;
        let mut pick = |p: u32, fault: Fault| {
            acc += p;
            (r < acc).then_some(fault)
        };
        pick(f.no_reply, Fault::NoReply)
            .or_else(|| pick(f.late, Fault::Late(Duration::from_secs(120))))
            .or_else(|| pick(f.garbage, Fault::Garbage))
            .or_else(|| pick(f.wrong_name, Fault::WrongName))
            .or_else(|| pick(f.drop, Fault::Drop))
            .or_else(|| {
                if is_status {
                    None
                } else {
                    pick(f.fail, Fault::Fail(20018))
                }
            })
    }

    fn answer(&mut self, now: Instant, conn: u32, text: &str) {
        let name = text
            .split(',')
            .next()
            .unwrap_or("")
            .trim()
            .trim_end_matches(';');
        let id = CommandId::from_name(name);
        let is_status = matches!(
            id,
            Some(
                CommandId::ReadRobotState
                    | CommandId::ReadCurFSM
                    | CommandId::ReadActPos
                    | CommandId::ReadBoxDI
                    | CommandId::ReadBoxDO
                    | CommandId::ReadBoxCI
                    | CommandId::ReadBoxCO
                    | CommandId::ReadEI
                    | CommandId::ReadEO
            )
        );
        let reply = match self.fault(is_status) {
            None => Some((self.reply(now, name, id, text), self.latency)),
            Some(Fault::NoReply) => None,
            Some(Fault::Late(d)) => Some((self.reply(now, name, id, text), d)),
            Some(Fault::Garbage) => Some((b"\x01\x02garbage\xff;".to_vec(), self.latency)),
            Some(Fault::WrongName) => Some((b"SomethingElse,OK,;".to_vec(), self.latency)),
            Some(Fault::Fail(code)) => {
                Some((format!("{name},Fail,{code},;").into_bytes(), self.latency))
            }
            Some(Fault::ErrorCmd) => Some((b"errorcmd,;".to_vec(), self.latency)),
            Some(Fault::Reply(bytes)) => Some((bytes, self.latency)),
            Some(Fault::Drop) => {
                if let Some((_, c)) = self.conns.iter_mut().find(|(i, _)| *i == conn) {
                    c.stream.reset();
                }
                self.reconnect_at = Some(now + Duration::from_millis(100));
                None
            }
        };
        if let Some((bytes, delay)) = reply {
            self.outbox.push((now + delay, conn, bytes));
        }
    }

    /// The V6 commands the gateway uses (matched by name, whatever the
    /// codec's features): the protocol level, error texts, long jogs. A V5
    /// controller ([`Model::version`] `None`) refuses them with 20005.
    fn reply_v6(&mut self, now: Instant, name: &str, text: &str) -> Option<Vec<u8>> {
        const V6: [&str; 5] = [
            "PackageVersion",
            "GetErrorCodeStr",
            "LongJogJ",
            "LongJogL",
            "LongMoveEvent",
        ];
        if !V6.contains(&name) {
            return None;
        }
        let m = &mut self.model;
        let Some(version) = m.version else {
            return Some(format!("{name},Fail,20005,;").into_bytes());
        };
        let ints: Vec<i32> = text
            .trim_end_matches(';')
            .split(',')
            .skip(1)
            .filter_map(|x| x.trim().parse().ok())
            .collect();
        let ok = format!("{name},OK,;").into_bytes();
        Some(match (name, ints.as_slice()) {
            ("PackageVersion", _) => format!("{name},OK,{version},;").into_bytes(),
            ("GetErrorCodeStr", [code]) => {
                let t = hans_codec::ErrorCode::from(*code)
                    .text()
                    .unwrap_or("unkown error");
                format!("{name},OK,{t},;").into_bytes()
            }
            ("LongJogJ" | "LongJogL", [_, axis, direction, state]) => {
                if *state == 0 {
                    if m.jog.take().is_some() {
                        m.last_end = Some(now);
                        m.set_fsm(33);
                    }
                    ok
                } else if m.fsm != 33 || m.motion.is_some() || m.jog.is_some() || m.error.is_some()
                {
                    format!("{name},Fail,20018,;").into_bytes()
                } else {
                    m.jog = Some(JogState {
                        cartesian: name == "LongJogL",
                        axis: *axis,
                        direction: *direction,
                        since: now,
                        last_event: now,
                    });
                    m.set_fsm(26);
                    ok
                }
            }
            ("LongMoveEvent", _) => match &mut m.jog {
                Some(j) => {
                    let gap = now.saturating_duration_since(j.last_event);
                    m.max_event_gap = m.max_event_gap.max(gap);
                    j.last_event = now;
                    ok
                }
                None => format!("{name},Fail,20018,;").into_bytes(),
            },
            _ => format!("{name},Fail,20006,;").into_bytes(),
        })
    }

    /// The proper reply to `text`, and what it does to the model.
    fn reply(&mut self, now: Instant, name: &str, id: Option<CommandId>, text: &str) -> Vec<u8> {
        let fail = |code: i32| format!("{name},Fail,{code},;").into_bytes();
        let ok = || format!("{name},OK,;").into_bytes();
        if let Some(reply) = self.reply_v6(now, name, text) {
            return reply;
        }
        let Some(id) = id else { return ok() };
        let Ok(req) = Request::parse(text) else {
            return fail(20006);
        };
        if req.validate().is_err() {
            return fail(20006);
        }
        let m = &mut self.model;
        if id.is_motion() {
            if m.fsm != 33 || m.motion.is_some() || m.jog.is_some() || m.error.is_some() {
                return fail(20018);
            }
            m.set_fsm(25);
            let r = self.rng.below(1000) as u32;
            let f = self.faults;
            let fault = if r < f.motion_error {
                Some(MotionFault::Error(10005))
            } else if r < f.motion_error + f.estop {
                Some(MotionFault::Estop)
            } else if r < f.motion_error + f.estop + f.guard {
                Some(MotionFault::Guard)
            } else {
                None
            };
            let time = m.motion_time;
            let at = now
                + Duration::from_ticks(
                    time.as_ticks() * u64::from(self.rng.below(90) as u32 + 10) / 100,
                );
            m.motion = Some(Motion {
                start: now,
                end: now + time,
                paused: None,
                fault: fault.map(|f| (at, f)),
            });
            return ok();
        }
        match id {
            CommandId::ReadRobotState => {
                let v = m.state_values(now);
                let list: Vec<String> = v.iter().map(|x| x.to_string()).collect();
                format!("{name},OK,{},;", list.join(",")).into_bytes()
            }
            CommandId::ReadCurFSM => format!("{name},OK,{},;", m.fsm).into_bytes(),
            CommandId::ReadActPos => {
                let j: Vec<String> = m.joints.iter().map(|x| format!("{x}.000")).collect();
                format!(
                    "{name},OK,{},420.000,0.000,445.000,180.000,0.000,180.000,0,0,0,0,0,0,0,0,0,0,0,0,;",
                    j.join(",")
                )
                .into_bytes()
            }
            CommandId::ReadBoxDI
            | CommandId::ReadBoxDO
            | CommandId::ReadBoxCI
            | CommandId::ReadBoxCO
            | CommandId::ReadEI
            | CommandId::ReadEO => {
                let group = match id {
                    CommandId::ReadBoxDI => 0,
                    CommandId::ReadBoxDO => 1,
                    CommandId::ReadBoxCI => 2,
                    CommandId::ReadBoxCO => 3,
                    CommandId::ReadEI => 4,
                    _ => 5,
                };
                let word = m.io[group];
                let skip = usize::from(matches!(id, CommandId::ReadEI | CommandId::ReadEO));
                let bits: Vec<String> = text
                    .trim_end_matches(';')
                    .split(',')
                    .skip(1 + skip)
                    .filter(|f| !f.trim().is_empty())
                    .map(|f| {
                        let b: u32 = f.trim().parse().unwrap_or(0);
                        ((word >> (b & 15)) & 1).to_string()
                    })
                    .collect();
                format!("{name},OK,{},;", bits.join(",")).into_bytes()
            }
            CommandId::SetBoxDO | CommandId::SetBoxCO | CommandId::SetEndDO => {
                let f: Vec<i32> = text
                    .trim_end_matches(';')
                    .split(',')
                    .skip(1)
                    .filter_map(|x| x.trim().parse().ok())
                    .collect();
                let (group, bit, value) = match (id, f.as_slice()) {
                    (CommandId::SetEndDO, [_, b, v, ..]) => (5, *b, *v),
                    (CommandId::SetBoxCO, [b, v, ..]) => (3, *b, *v),
                    (_, [b, v, ..]) => (1, *b, *v),
                    _ => return fail(20006),
                };
                let mask = 1u16 << (bit & 15);
                m.io[group] = if value != 0 {
                    m.io[group] | mask
                } else {
                    m.io[group] & !mask
                };
                ok()
            }
            CommandId::GrpStop => {
                if m.jog.take().is_some() {
                    m.last_end = Some(now);
                    m.set_fsm(33);
                }
                if m.motion.take().is_some() {
                    m.last_end = Some(now);
                    m.set_fsm(33);
                }
                ok()
            }
            CommandId::GrpInterrupt => match &mut m.motion {
                Some(mo) if mo.paused.is_none() => {
                    mo.paused = Some(now);
                    m.set_fsm(32);
                    ok()
                }
                Some(_) => ok(),
                None => fail(20018),
            },
            CommandId::GrpContinue => match &mut m.motion {
                Some(mo) => {
                    if let Some(p) = mo.paused.take() {
                        let held = now.saturating_duration_since(p);
                        mo.end += held;
                        mo.start = now;
                        if let Some((at, _)) = &mut mo.fault {
                            *at += held;
                        }
                        m.set_fsm(25);
                    }
                    ok()
                }
                None => fail(20018),
            },
            CommandId::GrpReset => {
                if m.estop {
                    return fail(20018);
                }
                if m.error.take().is_some() || m.guard {
                    m.guard = false;
                    m.set_fsm(33);
                }
                ok()
            }
            CommandId::ConnectToBox => {
                if m.fsm <= 3 {
                    m.begin_step(now, 3, 7);
                }
                ok()
            }
            CommandId::Electrify => {
                if m.fsm == 7 {
                    m.begin_step(now, 8, 14);
                }
                ok()
            }
            CommandId::StartMaster => {
                if m.fsm == 14 {
                    m.begin_step(now, 15, 24);
                }
                ok()
            }
            CommandId::GrpEnable => {
                if m.fsm == 24 {
                    m.begin_step(now, 23, 33);
                    ok()
                } else if m.fsm == 33 {
                    ok()
                } else {
                    fail(20018)
                }
            }
            CommandId::GrpDisable => {
                if m.motion.is_some() {
                    return fail(20018);
                }
                if m.fsm == 33 {
                    m.set_fsm(24);
                }
                ok()
            }
            CommandId::BlackOut => {
                if m.motion.is_some() {
                    return fail(20018);
                }
                m.set_fsm(7);
                ok()
            }
            _ => ok(),
        }
    }
}
