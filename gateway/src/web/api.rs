//! The JSON documents of the API: the typed state, viewed as JSON (as the
//! registers view it as Modbus words).
//!
//! A document is rendered from one [`Snapshot`] of the state, taken under
//! the state's lock once ([`Snapshot::take`]): what the document shows is
//! copied out (the trigger table's texts, the command log), so the
//! document is one moment of the gateway and the lock is held for a copy,
//! not for the formatting nor for the network. The snapshot is then
//! written with the structured writer ([`super::json`]) by
//! [`Snapshot::render`]; the server measures it first (its
//! `Content-Length`) and sends it window by window, each window rendered
//! again from the same, unchanging snapshot ([`Snapshot::window`]). A
//! document of any length thus needs one window buffer, and nothing is
//! cut: should a value fail to render, [`Snapshot::measure`] says so
//! before the first byte is sent and the server answers 500.
//!
//! The documents and their fields are described in `gateway/WEB.md`.

use core::net::{Ipv4Addr, SocketAddrV4};

use embassy_time::Instant;
use hans_codec::{ErrorCode, FsmState, ProtocolLevel};

use super::json::{Full, Object, Out, Value};
use crate::config::{Config, Kind, Setting, SETTINGS};
use crate::error::{ErrorSource, Outcome};
use crate::job::{Source, QUEUE_DEPTH};
use crate::registers::config::register_of;
use crate::registers::map as r;
use crate::state::history::{LogEntry, LogEvent, LOG_LEN};
use crate::state::inputs::{Text, TRIGGERS, TRIGGER_TEXT};
use crate::state::{
    ErrorText, Handshake, Io, LinkState, LinkStatus, Model, PlcState, RobotStatus, TextSource,
    Triggers,
};

/// A JSON document of the API.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Doc {
    /// `/api/status`: the live state.
    Status,
    /// `/api/config`: the settings (as text) and the trigger entries.
    Config,
    /// `/api/fields`: the table of settings (names, units, ranges, help).
    Fields,
    /// `/api/log`: the command log.
    Log,
}

/// The gateway's version, for the status.
const VERSION: &str = env!("CARGO_PKG_VERSION");

/// What a document shows, copied from the state at one moment.
///
/// Its variants differ in size (the log's entries, the trigger table's
/// texts, nothing for the fields): it is built once in place in the
/// connection's future and read there, never moved around, and the
/// largest is what the connection must hold anyway.
#[derive(Clone, Debug)]
#[allow(clippy::large_enum_variant)]
pub(crate) enum Snapshot {
    /// For `/api/status`.
    Status(StatusSnapshot),
    /// For `/api/config`.
    Config(ConfigSnapshot),
    /// For `/api/fields` (constant: nothing to copy).
    Fields,
    /// For `/api/log`.
    Log(LogSnapshot),
    /// A document with a value that cannot be written (tests).
    #[cfg(test)]
    Failing,
}

/// What `/api/status` shows.
#[derive(Clone, Debug)]
pub(crate) struct StatusSnapshot {
    now: Instant,
    ticks: u16,
    link: LinkStatus,
    robot_ip: Ipv4Addr,
    robot_port: u16,
    watchdog_ms: u16,
    write_protect: bool,
    modbus_config: bool,
    age_ms: Option<u64>,
    robot: RobotStatus,
    error_text: ErrorText,
    queue_used: usize,
    active_motion: Option<Source>,
    watchdog_armed: bool,
    plc: PlcState,
    sessions: u16,
    modbus_peers: heapless::Vec<SocketAddrV4, { crate::limits::MAX_SESSIONS }>,
    admin_exists: bool,
    restart_pending: bool,
    recovery: bool,
    network_managed: bool,
    modbus_refused: u16,
    writes_refused: u16,
    web_refused: u16,
    config_result: u64,
    config_saves: u16,
    config_applied: u32,
    /// The MQTT client's, set after `take` (it lives in the hub).
    #[cfg(feature = "mqtt")]
    mqtt: crate::state::telemetry::Stats,
    mqtt_broker: (crate::config::HostName, u16),
    /// The firmware.
    firmware: crate::state::firmware::Firmware,
    /// What survives a restart.
    keeps: crate::state::Keeps,
    /// Each channel's handshake and Execute.
    channels: [(Handshake, bool); r::CHANNELS],
    /// RAW's.
    raw: (Handshake, bool),
    triggers: Triggers,
}

/// What `/api/config` shows.
#[derive(Clone, Debug)]
pub(crate) struct ConfigSnapshot {
    config: Config,
    triggers: [Text<TRIGGER_TEXT>; TRIGGERS],
}

/// What `/api/log` shows.
#[derive(Clone, Debug)]
pub(crate) struct LogSnapshot {
    now: Instant,
    total: u32,
    entries: heapless::Vec<LogEntry, LOG_LEN>,
}

impl Snapshot {
    /// Sets the MQTT client's counters of a status snapshot (they live in
    /// the hub, beside the state).
    #[cfg(feature = "mqtt")]
    pub(crate) fn set_mqtt(&mut self, stats: crate::state::telemetry::Stats) {
        if let Snapshot::Status(s) = self {
            s.mqtt = stats;
        }
    }

    /// Copies what `doc` shows from `m` (the state at `now`) into this
    /// snapshot: the one moment, under the state's lock. Written in place,
    /// field by field, so that no copy of a snapshot passes through the
    /// stack.
    pub(crate) fn take(&mut self, doc: Doc, m: &Model, now: Instant) {
        match doc {
            Doc::Status => {
                if !matches!(self, Snapshot::Status(_)) {
                    *self = Snapshot::Status(StatusSnapshot::new());
                }
                if let Snapshot::Status(s) = self {
                    s.take(m, now);
                }
            }
            Doc::Config => {
                if !matches!(self, Snapshot::Config(_)) {
                    *self = Snapshot::Config(ConfigSnapshot {
                        config: m.config.active,
                        triggers: [Text::EMPTY; TRIGGERS],
                    });
                }
                if let Snapshot::Config(c) = self {
                    c.config = m.config.active;
                    c.triggers = m.triggers.entries;
                }
            }
            Doc::Fields => *self = Snapshot::Fields,
            Doc::Log => {
                if !matches!(self, Snapshot::Log(_)) {
                    *self = Snapshot::Log(LogSnapshot {
                        now,
                        total: 0,
                        entries: heapless::Vec::new(),
                    });
                }
                if let Snapshot::Log(l) = self {
                    l.now = now;
                    l.total = m.log.total;
                    l.entries.clear();
                    for e in m.log.iter() {
                        // Cannot fail: the log holds at most LOG_LEN.
                        let _ = l.entries.push(e.clone());
                    }
                }
            }
        }
    }

    /// Writes the document.
    pub(crate) fn render(&self, v: Value<'_, '_>) {
        match self {
            Snapshot::Status(s) => s.render(v),
            Snapshot::Config(c) => c.render(v),
            Snapshot::Fields => fields(v),
            Snapshot::Log(l) => l.render(v),
            #[cfg(test)]
            Snapshot::Failing => v.object(|j| j.key("value").fail()),
        }
    }

    /// The document's length in bytes, or `Err` if a value in it could
    /// not be written (then it must not be sent).
    pub(crate) fn measure(&self) -> Result<usize, Full> {
        let mut out = Out::new(&mut []);
        self.render(out.value());
        if out.failed() {
            return Err(Full);
        }
        Ok(out.total())
    }

    /// Writes the document's bytes from byte `at` on into `buf`, as many
    /// as fit: the number written (0 at the end).
    pub(crate) fn window(&self, at: usize, buf: &mut [u8]) -> usize {
        let mut out = Out::window(buf, at);
        self.render(out.value());
        out.written().len()
    }
}

impl StatusSnapshot {
    fn new() -> Self {
        StatusSnapshot {
            now: Instant::from_ticks(0),
            ticks: 0,
            link: LinkStatus::default(),
            robot_ip: Ipv4Addr::UNSPECIFIED,
            robot_port: 0,
            watchdog_ms: 0,
            write_protect: false,
            modbus_config: false,
            age_ms: None,
            robot: RobotStatus::UNKNOWN,
            error_text: ErrorText::default(),
            queue_used: 0,
            active_motion: None,
            watchdog_armed: false,
            plc: PlcState {
                heartbeat: 0,
                last_beat: Instant::from_ticks(0),
                watchdog_tripped: false,
                watchdog_trips: 0,
                lost: false,
            },
            sessions: 0,
            modbus_peers: heapless::Vec::new(),
            admin_exists: false,
            restart_pending: false,
            recovery: false,
            network_managed: false,
            modbus_refused: 0,
            writes_refused: 0,
            web_refused: 0,
            config_result: 0,
            config_saves: 0,
            config_applied: 0,
            #[cfg(feature = "mqtt")]
            mqtt: crate::state::telemetry::Status::new().get(),
            mqtt_broker: (crate::config::HostName::EMPTY, 0),
            firmware: crate::state::firmware::Firmware::NONE,
            keeps: crate::state::Keeps::default(),
            channels: [(Handshake::default(), false); r::CHANNELS],
            raw: (Handshake::default(), false),
            triggers: Triggers::default(),
        }
    }

    fn take(&mut self, m: &Model, now: Instant) {
        let c = &m.config.active;
        let a = &m.access;
        self.now = now;
        self.ticks = m.ticks;
        self.link = m.link;
        self.robot_ip = c.robot_ip;
        self.robot_port = c.robot_port;
        self.watchdog_ms = c.watchdog_ms;
        self.write_protect = c.write_protect;
        self.modbus_config = a.modbus_may_change_protected(c);
        self.age_ms = m.status_age_ms(now);
        self.robot.clone_from(&m.robot);
        self.error_text.clone_from(&m.error_text);
        self.queue_used = m.queue.len();
        self.active_motion = m.active_motion;
        self.watchdog_armed = m.watchdog_armed();
        self.plc = m.plc;
        self.sessions = m.sessions;
        self.modbus_peers.clone_from(&m.modbus_peers);
        self.admin_exists = a.accounts.admin_exists();
        self.restart_pending = a.restart_pending(&c.net);
        self.recovery = a.recovery;
        self.network_managed = a.network_managed;
        self.modbus_refused = a.modbus_refused;
        self.writes_refused = a.writes_refused;
        self.web_refused = a.web_refused;
        self.config_result = m.config.result as u64;
        self.config_saves = m.config.saves;
        self.config_applied = m.config.generation;
        self.mqtt_broker = (c.mqtt.broker, c.mqtt.port);
        self.firmware = m.firmware;
        self.keeps = m.keeps;
        for (dst, ch) in self.channels.iter_mut().zip(m.channels.iter()) {
            *dst = (ch.handshake, ch.inputs.execute());
        }
        self.raw = (m.raw.handshake, m.raw.execute());
        self.triggers.bits = m.triggers.bits;
        self.triggers.entries = m.triggers.entries;
        self.triggers.handshakes = m.triggers.handshakes;
    }
}

fn source_name(s: Source) -> &'static str {
    match s {
        Source::Channel(_) => "channel",
        Source::Raw => "raw",
        Source::Trigger(_) => "trigger",
    }
}

fn outcome(v: Value<'_, '_>, o: Option<Outcome>) {
    v.opt(o, |v, o| {
        v.object(|j| match o {
            Outcome::Done => j.key("result").str(b"done"),
            Outcome::Aborted => j.key("result").str(b"aborted"),
            Outcome::Error(src, id) => {
                j.key("result").str(b"error");
                j.key("error_id").int(id.into());
                j.key("error_source").uint(src as u64);
                j.key("error_text").opt(error_text(src, id), Value::str);
            }
        })
    })
}

/// The text of an ErrorID: the gateway's own, or the protocol's.
fn error_text(src: ErrorSource, id: i32) -> Option<&'static [u8]> {
    let text = match src {
        ErrorSource::Gateway => crate::error::GatewayError::from_code(id).map(|e| e.as_str()),
        _ => ErrorCode::from(id).text().or(ErrorCode::from(id).name()),
    };
    text.map(str::as_bytes)
}

/// The members of a handshake (in the object of its source).
fn handshake(j: &mut Object<'_, '_>, h: &Handshake) {
    j.key("phase").str(h.phase.as_str().as_bytes());
    j.key("seq").uint(h.seq_echo.into());
    outcome(j.key("outcome"), h.outcome());
}

fn six(v: Value<'_, '_>, a: Option<[f32; 6]>) {
    v.opt(a, |v, a| {
        v.array(|j| {
            for x in a {
                j.item().fixed3(x);
            }
        })
    })
}

/// `"HR5.50.3"`, or `"V5"`.
fn level(v: Value<'_, '_>, level: ProtocolLevel) {
    if level == ProtocolLevel::V5 {
        return v.str(b"V5");
    }
    let (major, minor, patch) = level.parts();
    v.text(|t| {
        t.str(b"HR").uint(major.into()).str(b".");
        t.uint(minor.into()).str(b".").uint(patch.into());
    });
}

impl StatusSnapshot {
    fn render(&self, v: Value<'_, '_>) {
        v.object(|j| {
            j.key("version").str(VERSION.as_bytes());
            // The running image's version beside the software's: a board
            // runs an image signed with its own version (`null`: no image,
            // as on Linux, whose package's version is the software's).
            version(j.key("image"), self.firmware.running);
            let [major, minor] = r::MAP_VERSION.to_be_bytes();
            j.key("map").text(|t| {
                t.uint(major.into()).str(b".").uint(minor.into());
            });
            j.key("uptime_ms").uint(self.now.as_millis());
            j.key("heartbeat").uint(self.ticks.into());
            j.key("link").object(|j| self.link(j));
            j.key("robot").object(|j| self.robot(j));
            j.key("queue").object(|j| {
                j.key("used").uint(self.queue_used as u64);
                j.key("depth").uint(QUEUE_DEPTH as u64);
                j.key("active_motion").opt(self.active_motion, |v, s| {
                    v.object(|j| {
                        j.key("source").str(source_name(s).as_bytes());
                        j.key("index").uint(s.index().into());
                    })
                });
            });
            j.key("watchdog").object(|j| {
                j.key("period_ms").uint(self.watchdog_ms.into());
                j.key("armed").bool(self.watchdog_armed);
                j.key("tripped").bool(self.plc.watchdog_tripped);
                j.key("trips").uint(self.plc.watchdog_trips.into());
                j.key("plc_heartbeat").uint(self.plc.heartbeat.into());
            });
            j.key("modbus").object(|j| {
                j.key("sessions").uint(self.sessions.into());
                j.key("clients").array(|j| {
                    for p in &self.modbus_peers {
                        j.item().endpoint(*p);
                    }
                });
                j.key("refused").uint(self.modbus_refused.into());
                j.key("writes_refused").uint(self.writes_refused.into());
            });
            j.key("access").object(|j| {
                j.key("write_protect").bool(self.write_protect);
                j.key("modbus_config").bool(self.modbus_config);
                j.key("admin_exists").bool(self.admin_exists);
                j.key("restart_pending").bool(self.restart_pending);
                j.key("recovery").bool(self.recovery);
                j.key("network_managed").bool(self.network_managed);
                j.key("web_refused").uint(self.web_refused.into());
            });
            j.key("keeps").object(|j| {
                j.key("config").bool(self.keeps.config);
                j.key("audit").bool(self.keeps.audit);
            });
            j.key("config").object(|j| {
                j.key("result").uint(self.config_result);
                j.key("saves").uint(self.config_saves.into());
                j.key("applied").uint(self.config_applied.into());
            });
            j.key("mqtt").object(|j| self.mqtt(j));
            j.key("firmware").object(|j| firmware(j, &self.firmware));
            j.key("channels").array(|j| {
                for (k, (h, execute)) in self.channels.iter().enumerate() {
                    j.item().object(|j| {
                        j.key("index").uint(k as u64);
                        j.key("code").uint(h.command_echo.into());
                        j.key("execute").bool(*execute);
                        handshake(j, h);
                    });
                }
            });
            j.key("raw").object(|j| {
                j.key("execute").bool(self.raw.1);
                handshake(j, &self.raw.0);
            });
            j.key("triggers").array(|j| {
                let t = &self.triggers;
                for (n, (h, text)) in t.handshakes.iter().zip(&t.entries).enumerate() {
                    j.item().object(|j| {
                        j.key("index").uint(n as u64);
                        j.key("bit").bool(t.bits & (1 << n) != 0);
                        j.key("text").str(text.bytes());
                        handshake(j, h);
                    });
                }
            });
        });
    }

    /// The broker connection (`on` false: telemetry off, or a build
    /// without MQTT).
    fn mqtt(&self, j: &mut Object<'_, '_>) {
        let (broker, port) = &self.mqtt_broker;
        j.key("broker").str(broker.as_str().as_bytes());
        j.key("port").uint((*port).into());
        #[cfg(feature = "mqtt")]
        {
            let s = &self.mqtt;
            let state = match (s.on, s.connected, s.waiting_for_host) {
                (false, _, _) => "off",
                (true, false, _) => "connecting",
                (true, true, true) => "waiting for the primary host",
                (true, true, false) => "connected",
            };
            j.key("on").bool(s.on);
            j.key("state").str(state.as_bytes());
            j.key("connects").uint(s.connects.into());
            j.key("failures").uint(s.failures.into());
            j.key("last_error")
                .opt(s.last_error, |v, e| v.str(e.as_str().as_bytes()));
            j.key("sent").uint(s.sent.into());
            j.key("dropped")
                .uint(u64::from(s.dropped) + u64::from(s.node.dropped));
            j.key("commands_refused").uint(s.node.refused.into());
            j.key("rebirths").uint(s.node.rebirths.into());
        }
        #[cfg(not(feature = "mqtt"))]
        {
            j.key("on").bool(false);
            j.key("state").str(b"off");
        }
    }

    fn link(&self, j: &mut Object<'_, '_>) {
        let l = &self.link;
        j.key("state").str(l.state.as_str().as_bytes());
        j.key("up").bool(l.state == LinkState::Connected);
        j.key("connects").uint(l.connects.into());
        j.key("losses").uint(l.losses.into());
        j.key("last_error").opt(l.last_error, |v, e| {
            v.object(|j| {
                j.key("code").int(e.code().into());
                j.key("text").str(e.as_str().as_bytes());
            })
        });
        j.key("peer").opt(l.peer, Value::ip);
        j.key("protocol").opt(l.level, level);
        j.key("robot").ip(self.robot_ip);
        j.key("robot_port").uint(self.robot_port.into());
    }

    fn robot(&self, j: &mut Object<'_, '_>) {
        let robot = &self.robot;
        j.key("age_ms").opt(self.age_ms, Value::uint);
        j.key("fsm").opt(robot.fsm, |v, s| {
            v.object(|j| {
                j.key("code").int(i32::from(s).into());
                j.key("name")
                    .opt(FsmState::name(&s), |v, n| v.str(n.as_bytes()));
            })
        });
        j.key("flags").opt(robot.flags, |v, f| {
            v.object(|j| {
                j.key("moving").bool(f.moving);
                j.key("enabled").bool(f.enabled);
                j.key("error").bool(f.error);
                j.key("paused").bool(f.paused);
                j.key("emergency_stop").bool(f.emergency_stop);
                j.key("safety_guard").bool(f.safety_guard);
                j.key("powered").bool(f.powered);
                j.key("box_connected").bool(f.box_connected);
                j.key("blending_done").bool(f.blending_done);
                j.key("in_position").bool(f.in_position);
                j.key("brake_released").bool(f.brake_released);
            })
        });
        j.key("error").object(|j| {
            let code = ErrorCode::from(robot.error_code);
            let any = robot.error_code != 0;
            j.key("code").int(robot.error_code.into());
            j.key("axis").uint(robot.error_axis.into());
            j.key("name")
                .opt(code.name().filter(|_| any), |v, n| v.str(n.as_bytes()));
            // The text the gateway fetched for this code (the controller's
            // own at V6: ERROR_TEXT_*), else the protocol documents'.
            let fetched = &self.error_text;
            let own = (any
                && fetched.code == robot.error_code
                && fetched.source == TextSource::Controller)
                .then_some(fetched.text.bytes());
            let text = own.or_else(|| code.text().filter(|_| any).map(str::as_bytes));
            j.key("text").opt(text, Value::str);
            let source: Option<&[u8]> = match (own, text) {
                (Some(_), _) => Some(b"controller"),
                (None, Some(_)) => Some(b"table"),
                (None, None) => None,
            };
            j.key("text_source").opt(source, Value::str);
        });
        j.key("override").opt(robot.override_ratio, Value::fixed3);
        six(j.key("joints"), robot.joints);
        six(j.key("pose"), robot.pose);
        j.key("io").object(|j| {
            let names = ["box_di", "box_do", "box_ci", "box_co", "end_di", "end_do"];
            for (g, name) in Io::ALL.iter().zip(names) {
                j.key(name).opt(robot.io(*g).map(u64::from), Value::uint);
            }
        });
    }
}

impl ConfigSnapshot {
    fn render(&self, v: Value<'_, '_>) {
        v.object(|j| {
            j.key("format").str(super::post::FORMAT.as_bytes());
            j.key("settings").object(|j| {
                for s in SETTINGS {
                    let mut text: heapless::String<96> = heapless::String::new();
                    match s.format(&self.config, &mut text) {
                        Ok(()) => j.key(s.key).str(text.as_bytes()),
                        Err(_) => j.key(s.key).fail(),
                    }
                }
            });
            j.key("triggers").array(|j| {
                for text in &self.triggers {
                    j.item().str(text.bytes());
                }
            });
        });
    }
}

fn range(v: Value<'_, '_>, s: &Setting) {
    match s.kind {
        Kind::Number { min, max, off } => v.object(|j| {
            if off {
                j.key("off").uint(0);
            }
            j.key("min").uint(min.into());
            j.key("max").uint(max.into());
        }),
        _ => v.null(),
    }
}

fn fields(v: Value<'_, '_>) {
    v.array(|j| {
        for s in SETTINGS {
            j.item().object(|j| {
                j.key("key").str(s.key.as_bytes());
                j.key("kind").str(s.kind.name().as_bytes());
                j.key("unit").str(s.unit.as_bytes());
                range(j.key("range"), s);
                match s.kind {
                    Kind::Choice(words) => j.key("choices").array(|j| {
                        for w in words {
                            j.item().str(w.as_bytes());
                        }
                    }),
                    Kind::Flag => j.key("choices").array(|j| {
                        j.item().str(b"false");
                        j.item().str(b"true");
                    }),
                    _ => j.key("choices").null(),
                }
                let mut d: heapless::String<96> = heapless::String::new();
                match s.kind.format(&s.default_value(), &mut d) {
                    Ok(()) => j.key("default").str(d.as_bytes()),
                    Err(_) => j.key("default").fail(),
                }
                j.key("restart").bool(s.restart);
                match register_of(s) {
                    Some((g, bit)) => j.key("register").object(|j| {
                        j.key("name").str(g.name.as_bytes());
                        j.key("address").uint(g.addr.into());
                        j.key("count").uint(g.count().into());
                        if let Some(b) = bit {
                            j.key("bit").uint(b.into());
                        }
                    }),
                    None => j.key("register").null(),
                }
                j.key("help").str(s.help.as_bytes());
                j.key("label").str(s.label().as_bytes());
            });
        }
    });
}

impl LogSnapshot {
    fn render(&self, v: Value<'_, '_>) {
        v.object(|j| {
            j.key("capacity").uint(LOG_LEN as u64);
            j.key("total").uint(self.total.into());
            j.key("now_ms").uint(self.now.as_millis());
            j.key("entries").array(|j| {
                for e in &self.entries {
                    j.item().object(|j| entry(j, e));
                }
            });
        });
    }
}

fn entry(j: &mut Object<'_, '_>, e: &LogEntry) {
    j.key("at_ms").uint(e.at.as_millis());
    match &e.event {
        LogEvent::Command(c) => {
            j.key("kind").str(b"command");
            j.key("source").str(source_name(c.source).as_bytes());
            j.key("index").uint(c.source.index().into());
            j.key("code").uint(c.code.into());
            j.key("sent").str(&c.sent);
            j.key("reply").str(&c.reply);
            outcome(j.key("outcome"), c.outcome);
            j.key("took_ms")
                .opt(c.outcome.map(|_| u64::from(c.took_ms)), Value::uint);
        }
        LogEvent::LinkUp(peer) => {
            j.key("kind").str(b"link-up");
            j.key("peer").opt(*peer, Value::ip);
        }
        LogEvent::LinkDown(e) => {
            j.key("kind").str(b"link-down");
            j.key("error").int(e.code().into());
            j.key("text").str(e.as_str().as_bytes());
        }
    }
}

/// A firmware image's version, `"1.2.3"` (`null`: none).
fn version(val: Value<'_, '_>, v: Option<crate::state::firmware::Version>) {
    val.opt(v, |val, v| {
        val.text(|t| {
            t.uint(v.major.into()).str(b".").uint(v.minor.into());
            t.str(b".").uint(v.patch.into());
        })
    })
}

/// The firmware: running and previous versions, trial state, the last
/// upload (`supported` false: this platform installs no image).
fn firmware(j: &mut Object<'_, '_>, s: &crate::state::firmware::Firmware) {
    use crate::state::firmware::Upload;
    j.key("supported").bool(s.supported);
    version(j.key("running"), s.running);
    version(j.key("previous"), s.previous);
    j.key("state")
        .opt(s.boot, |v, b| v.str(b.as_str().as_bytes()));
    j.key("upload").object(|j| match s.upload {
        Upload::Idle => j.key("state").str(b"idle"),
        Upload::Receiving {
            version: v,
            received,
            total,
        } => {
            j.key("state").str(b"receiving");
            version(j.key("version"), Some(v));
            j.key("received").uint(received.into());
            j.key("total").uint(total.into());
        }
        Upload::Installed { version: v } => {
            j.key("state").str(b"installed");
            version(j.key("version"), Some(v));
        }
        Upload::Refused { reason } => {
            j.key("state").str(b"refused");
            j.key("reason").str(reason.as_bytes());
        }
    });
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::config::{AllowEntry, AllowList, Config, ALLOW_ENTRIES};
    use crate::error::GatewayError;
    use crate::state::robot::RobotFlags;
    use crate::state::{Phase, ERROR_TEXT};
    use std::string::String;
    use std::vec::Vec;

    const NOW: Instant = Instant::from_millis(5000);
    const DOCS: [Doc; 4] = [Doc::Status, Doc::Config, Doc::Fields, Doc::Log];

    fn snapshot(doc: Doc, m: &Model) -> Snapshot {
        let mut snap = Snapshot::Fields;
        snap.take(doc, m, NOW);
        snap
    }

    /// The document as the server sends it: measured, then window by
    /// window (`window` bytes each), joined.
    fn send(doc: Doc, m: &Model, window: usize) -> String {
        let snap = snapshot(doc, m);
        let len = snap.measure().expect("every value renders");
        let mut body = Vec::new();
        let mut buf = std::vec![0u8; window];
        while body.len() < len {
            let n = snap.window(body.len(), &mut buf);
            assert!(n > 0, "{doc:?} ended early");
            body.extend_from_slice(&buf[..n]);
        }
        assert_eq!(snap.window(body.len(), &mut buf), 0, "{doc:?} goes on");
        String::from_utf8(body).unwrap()
    }

    fn render(doc: Doc, m: &Model) -> String {
        send(doc, m, super::super::WINDOW)
    }

    /// A state with every text and list at its longest, and its worst
    /// characters (escaped: twice as long).
    fn worst() -> Model {
        let mut c = Config::default();
        let widest = AllowEntry {
            ip: Ipv4Addr::new(255, 255, 255, 255),
            prefix: 32,
        };
        c.modbus_allow = AllowList([widest; ALLOW_ENTRIES]);
        c.web_allow = AllowList([widest; ALLOW_ENTRIES]);
        c.robot_ip = Ipv4Addr::new(255, 255, 255, 255);
        c.mqtt.broker =
            crate::config::HostName::new(&"h".repeat(crate::config::HostName::MAX)).unwrap();
        let mut m = Model::new(c, c);
        for e in m.triggers.entries.iter_mut() {
            e.set(&[b'"'; TRIGGER_TEXT]);
        }
        for h in m.triggers.handshakes.iter_mut() {
            h.phase = Phase::Ended(Outcome::gateway(GatewayError::StateNotReached));
            h.seq_echo = u16::MAX;
        }
        m.robot.flags = Some(RobotFlags::default());
        m.robot.joints = Some([-1.0e12; 6]);
        m.robot.pose = Some([f32::MAX; 6]);
        m.robot.error_code = 20018;
        m.error_text
            .set(20018, TextSource::Controller, &[b'"'; ERROR_TEXT]);
        m.link.level = Some(ProtocolLevel::new(255, 255, 255));
        m.link.peer = Some(Ipv4Addr::new(255, 255, 255, 255));
        m.link.last_error = Some(GatewayError::StateNotReached);
        for i in 0..LOG_LEN {
            let s = Source::Channel((i % 2) as u8);
            let end = Instant::MAX;
            m.log
                .started(s, 9, end - embassy_time::Duration::from_millis(7));
            m.log.sent(s, &[b'\\'; 200]);
            m.log.replied(s, &[0xff; 200]);
            m.log.ended(
                s,
                Outcome::Error(ErrorSource::Gateway, GatewayError::StateNotReached.code()),
                end,
            );
        }
        for p in 0..crate::limits::MAX_SESSIONS {
            let _ = m.modbus_peers.push(SocketAddrV4::new(
                Ipv4Addr::new(255, 255, 255, 255),
                65535 - p as u16,
            ));
        }
        m
    }

    /// What the server needs for a document is its snapshot (in the
    /// connection's future) and one window: nothing grows with the
    /// document's length. Every document renders whole at its longest, the
    /// same whatever the window, as JSON.
    #[test]
    fn every_document_renders_whole_even_at_its_longest() {
        let size = core::mem::size_of::<Snapshot>();
        assert!(size <= 6 * 1024, "a snapshot takes {size} bytes");
        for m in [worst(), Model::new(Config::default(), Config::default())] {
            for doc in DOCS {
                let whole = render(doc, &m);
                for window in [97, 4096, 1 << 16] {
                    assert_eq!(send(doc, &m, window), whole, "{doc:?}, window {window}");
                }
                let v: serde_json::Value = serde_json::from_str(&whole)
                    .unwrap_or_else(|e| panic!("{doc:?} is not JSON ({e}): {whole}"));
                assert!(v.is_object() || v.is_array(), "{doc:?}");
            }
        }
        // The longest texts are all there, none cut.
        let m = worst();
        let status = render(Doc::Status, &m);
        let trigger = format!(r#""text":"{}""#, r#"\""#.repeat(TRIGGER_TEXT));
        assert_eq!(status.matches(&trigger).count(), TRIGGERS, "{status}");
        let config = render(Doc::Config, &m);
        let allow = ["255.255.255.255/32"; ALLOW_ENTRIES].join(" ");
        assert!(
            config.contains(&format!(r#""access.modbus_allow":"{allow}""#)),
            "{config}"
        );
        let log = render(Doc::Log, &m);
        assert_eq!(log.matches(r#""kind":"command""#).count(), LOG_LEN);
    }

    /// A snapshot taken again (the connection's, from request to request)
    /// holds the new document only.
    #[test]
    fn a_snapshot_taken_again_is_the_new_document() {
        let (w, d) = (worst(), Model::new(Config::default(), Config::default()));
        let mut snap = Snapshot::Fields;
        for doc in [Doc::Log, Doc::Status, Doc::Status, Doc::Config, Doc::Log] {
            for m in [&w, &d] {
                snap.take(doc, m, NOW);
                let mut body = std::vec![0u8; snap.measure().unwrap()];
                assert_eq!(snap.window(0, &mut body), body.len());
                assert_eq!(String::from_utf8(body).unwrap(), render(doc, m), "{doc:?}");
            }
        }
    }

    /// A value that cannot be written makes the document unsendable (the
    /// server answers 500 before sending anything) rather than sent
    /// without it.
    #[test]
    fn a_value_that_fails_is_reported_before_sending() {
        assert_eq!(Snapshot::Failing.measure(), Err(Full));
        for doc in DOCS {
            assert!(snapshot(doc, &worst()).measure().is_ok());
        }
    }

    /// The document is the state at one moment: changes after the
    /// snapshot do not show, whatever is still to be sent.
    #[test]
    fn a_document_is_one_moment_of_the_state() {
        let mut m = worst();
        let snap = snapshot(Doc::Status, &m);
        let mut first = [0u8; 64];
        let n = snap.window(0, &mut first);
        m.ticks = 4242;
        m.triggers.entries[15].set(b"GrpStop,0,;");
        m.robot.error_code = 0;
        let mut rest = Vec::new();
        let mut buf = [0u8; 64];
        loop {
            let k = snap.window(n + rest.len(), &mut buf);
            if k == 0 {
                break;
            }
            rest.extend_from_slice(&buf[..k]);
        }
        let mut whole = first[..n].to_vec();
        whole.extend_from_slice(&rest);
        let before = snapshot(Doc::Status, &worst());
        let mut expected = std::vec![0u8; before.measure().unwrap()];
        assert_eq!(before.window(0, &mut expected), expected.len());
        assert_eq!(whole, expected);
    }

    #[test]
    fn documents_are_well_formed_json_with_the_state() {
        let mut m = worst();
        m.triggers.entries[2].set(b"GrpStop,0,;");
        m.finish(
            Source::Trigger(2),
            Outcome::gateway(GatewayError::QueueFull),
            Instant::from_millis(1),
        );
        m.link.peer = None;
        m.link.last_error = None;
        let status = render(Doc::Status, &m);
        assert!(status.contains(r#""triggers":[{"index":0,"#), "{status}");
        assert!(status.contains(r#""text":"GrpStop,0,;","phase":"error","seq":65535,"outcome":{"result":"error","error_id":39600,"error_source":3,"error_text":"queue full"}"#), "{status}");
        assert!(
            status.contains(r#""joints":[-999999995904.000,"#),
            "{status}"
        );
        assert!(
            status.contains(r#""protocol":"HR255.255.255","#),
            "{status}"
        );
        assert!(
            status.contains(r#""last_error":null,"peer":null,"#),
            "{status}"
        );
        // The controller's own text for the code shown wins over the table's.
        assert!(
            status
                .contains(r#""error":{"code":20018,"axis":0,"name":"StateRefused","text":"\"\"\""#),
            "{status}"
        );
        assert!(
            status.contains(r#"","text_source":"controller"}"#),
            "{status}"
        );
        m.error_text.set(20005, TextSource::Controller, b"other");
        m.link.level = Some(ProtocolLevel::V5);
        let status = render(Doc::Status, &m);
        assert!(status.contains(r#""protocol":"V5","#), "{status}");
        assert!(status.contains(r#""error":{"code":20018,"axis":0,"name":"StateRefused","text":"command forbidden in this state","text_source":"table"}"#), "{status}");
        assert!(status.ends_with("}]}"), "{status}");
        let config = render(Doc::Config, &m);
        assert!(config.contains(r#""link.poll_ms":"100""#), "{config}");
        assert!(config.contains(r#""access.modbus_allow":""#), "{config}");
        assert!(config.ends_with("]}"), "{config}");
        let config = render(
            Doc::Config,
            &Model::new(Config::default(), Config::default()),
        );
        assert!(config.contains(r#""access.modbus_allow":"""#), "{config}");
        let fields = render(Doc::Fields, &m);
        assert!(fields.contains(r#"{"key":"link.poll_ms","kind":"number","unit":"ms","range":{"min":10,"max":100},"choices":null,"default":"100","restart":false,"register":{"name":"CFG_POLL_MS","address":105,"count":1},"#), "{fields}");
        assert!(fields.contains(r#"{"key":"motion.wait_in_position","kind":"flag","unit":"","range":null,"choices":["false","true"],"default":"false","restart":false,"register":{"name":"CFG_MOTION_POLICY","address":110,"count":1,"bit":1},"#), "{fields}");
        assert!(fields.contains(r#"{"key":"mqtt.broker","kind":"host","unit":"","range":null,"choices":null,"default":"","restart":true,"register":null,"#), "{fields}");
        assert!(
            fields.contains(r#""help":"robot reply timeout","label":"Robot reply timeout"}"#),
            "{fields}"
        );
        let log = render(Doc::Log, &Model::new(Config::default(), Config::default()));
        assert_eq!(
            log,
            r#"{"capacity":32,"total":0,"now_ms":5000,"entries":[]}"#
        );
        let log = render(Doc::Log, &m);
        assert!(log.contains(r#""sent":"\\\\\\"#), "{log}");
        assert!(log.contains(r#""took_ms":7}"#), "{log}");
    }
}
