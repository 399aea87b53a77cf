//! The JSON documents of the API: the typed state, viewed as JSON (as the
//! registers view it as Modbus words). Each document is written in parts
//! ([`Doc::part`]): part `i` is rendered from the state under its lock
//! into one [`Json`] buffer and sent as one HTTP chunk, so a document of
//! any length needs one buffer of [`super::json::PART`] bytes.
//!
//! The documents and their fields are described in `gateway/WEB.md`.

use embassy_time::Instant;
use hans_codec::{ErrorCode, FsmState, ProtocolLevel};

use super::json::{Full, Json};
use crate::config::{Kind, Setting, SETTINGS};
use crate::error::{ErrorSource, Outcome};
use crate::job::{Source, QUEUE_DEPTH};
use crate::registers::config::register_of;
use crate::registers::map as r;
use crate::state::history::{LogEvent, LOG_LEN};
use crate::state::{Handshake, Io, LinkState, Model, Phase, TextSource};

/// A JSON document of the API.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Doc {
    /// `/api/status`: the live state.
    Status,
    /// `/api/config`: the settings (as text) and the trigger entries.
    Config,
    /// `/api/fields`: the table of settings (names, units, ranges, help).
    Fields,
    /// `/api/log`: the command log.
    Log,
}

/// What [`Doc::part`] wrote.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// A part; more follow.
    More,
    /// The last part.
    Last,
}

/// The gateway's version, for the status.
const VERSION: &str = env!("CARGO_PKG_VERSION");

impl Doc {
    /// Writes part `i` of the document from `m` (the state at `now`).
    pub fn part(self, m: &Model, now: Instant, i: usize, j: &mut Json) -> Result<Part, Full> {
        match self {
            Doc::Status => status(m, now, i, j),
            Doc::Config => config(m, i, j),
            Doc::Fields => fields(i, j),
            Doc::Log => log(m, now, i, j),
        }
    }
}

fn more(last: bool) -> Part {
    if last {
        Part::Last
    } else {
        Part::More
    }
}

/// The name of a phase.
pub fn phase_name(p: Phase) -> &'static str {
    match p {
        Phase::Idle => "idle",
        Phase::Queued => "queued",
        Phase::Running => "running",
        Phase::Moving => "moving",
        Phase::Ended(Outcome::Done) => "done",
        Phase::Ended(Outcome::Error(..)) => "error",
        Phase::Ended(Outcome::Aborted) => "aborted",
    }
}

fn source_name(s: Source) -> &'static str {
    match s {
        Source::Channel(_) => "channel",
        Source::Raw => "raw",
        Source::Trigger(_) => "trigger",
    }
}

fn outcome(j: &mut Json, o: Option<Outcome>) -> Result<(), Full> {
    match o {
        None => {
            j.null()?;
        }
        Some(Outcome::Done) => {
            j.raw("{\"result\":\"done\"}")?;
        }
        Some(Outcome::Aborted) => {
            j.raw("{\"result\":\"aborted\"}")?;
        }
        Some(Outcome::Error(src, id)) => {
            j.raw("{\"result\":\"error\",")?
                .key("error_id")?
                .int(id.into())?;
            j.raw(",")?.key("error_source")?.uint(src as u64)?;
            j.raw(",")?.key("error_text")?;
            error_text(j, src, id)?;
            j.raw("}")?;
        }
    }
    Ok(())
}

/// The text of an ErrorID: the gateway's own, or the protocol's.
fn error_text(j: &mut Json, src: ErrorSource, id: i32) -> Result<(), Full> {
    let text = match src {
        ErrorSource::Gateway => crate::error::GatewayError::from_code(id).map(|e| e.as_str()),
        _ => ErrorCode::from(id).text().or(ErrorCode::from(id).name()),
    };
    match text {
        Some(t) => j.str(t.as_bytes())?,
        None => j.null()?,
    };
    Ok(())
}

fn handshake(j: &mut Json, h: &Handshake) -> Result<(), Full> {
    j.key("phase")?.str(phase_name(h.phase).as_bytes())?;
    j.raw(",")?.key("seq")?.uint(h.seq_echo.into())?;
    j.raw(",")?.key("outcome")?;
    outcome(j, h.outcome())
}

fn six(j: &mut Json, v: Option<[f32; 6]>) -> Result<(), Full> {
    match v {
        None => {
            j.null()?;
        }
        Some(a) => {
            j.raw("[")?;
            for (k, x) in a.iter().enumerate() {
                if k > 0 {
                    j.raw(",")?;
                }
                j.fixed3(*x)?;
            }
            j.raw("]")?;
        }
    }
    Ok(())
}

fn status(m: &Model, now: Instant, i: usize, j: &mut Json) -> Result<Part, Full> {
    let robot = &m.robot;
    match i {
        0 => {
            j.raw("{")?.key("version")?.str(VERSION.as_bytes())?;
            let [major, minor] = r::MAP_VERSION.to_be_bytes();
            j.raw(",")?.key("map")?.raw("\"")?.uint(major.into())?;
            j.raw(".")?.uint(minor.into())?.raw("\"")?;
            j.raw(",")?.key("uptime_ms")?.uint(now.as_millis())?;
            j.raw(",")?.key("heartbeat")?.uint(m.ticks.into())?;
            let l = &m.link;
            j.raw(",")?.key("link")?.raw("{")?;
            j.key("state")?.str(l.state.as_str().as_bytes())?;
            j.raw(",")?
                .key("up")?
                .bool(l.state == LinkState::Connected)?;
            j.raw(",")?.key("connects")?.uint(l.connects.into())?;
            j.raw(",")?.key("losses")?.uint(l.losses.into())?;
            j.raw(",")?.key("last_error")?;
            match l.last_error {
                Some(e) => {
                    j.raw("{")?.key("code")?.int(e.code().into())?;
                    j.raw(",")?
                        .key("text")?
                        .str(e.as_str().as_bytes())?
                        .raw("}")?;
                }
                None => {
                    j.null()?;
                }
            }
            j.raw(",")?.key("peer")?;
            match l.peer {
                Some(p) => j.ip(p)?,
                None => j.null()?,
            };
            j.raw(",")?.key("protocol")?;
            match l.level {
                Some(level) if level == ProtocolLevel::V5 => {
                    j.str(b"V5")?;
                }
                Some(level) => {
                    let (major, minor, patch) = level.parts();
                    j.raw("\"HR")?.uint(major.into())?.raw(".")?;
                    j.uint(minor.into())?
                        .raw(".")?
                        .uint(patch.into())?
                        .raw("\"")?;
                }
                None => {
                    j.null()?;
                }
            }
            let c = &m.config.active;
            j.raw(",")?.key("robot")?.ip(c.robot_ip)?;
            j.raw(",")?.key("robot_port")?.uint(c.robot_port.into())?;
            j.raw("}")?;
            Ok(Part::More)
        }
        1 => {
            j.raw(",")?.key("robot")?.raw("{")?;
            j.key("age_ms")?;
            match m.status_age_ms(now) {
                Some(a) => j.uint(a)?,
                None => j.null()?,
            };
            j.raw(",")?.key("fsm")?;
            match robot.fsm {
                Some(s) => {
                    j.raw("{")?.key("code")?.int(i32::from(s).into())?;
                    j.raw(",")?.key("name")?;
                    match FsmState::name(&s) {
                        Some(n) => j.str(n.as_bytes())?,
                        None => j.null()?,
                    };
                    j.raw("}")?;
                }
                None => {
                    j.null()?;
                }
            }
            j.raw(",")?.key("flags")?;
            match robot.flags {
                None => {
                    j.null()?;
                }
                Some(f) => {
                    let all = [
                        ("moving", f.moving),
                        ("enabled", f.enabled),
                        ("error", f.error),
                        ("paused", f.paused),
                        ("emergency_stop", f.emergency_stop),
                        ("safety_guard", f.safety_guard),
                        ("powered", f.powered),
                        ("box_connected", f.box_connected),
                        ("blending_done", f.blending_done),
                        ("in_position", f.in_position),
                        ("brake_released", f.brake_released),
                    ];
                    j.raw("{")?;
                    for (k, (name, on)) in all.iter().enumerate() {
                        if k > 0 {
                            j.raw(",")?;
                        }
                        j.key(name)?.bool(*on)?;
                    }
                    j.raw("}")?;
                }
            }
            let code = ErrorCode::from(robot.error_code);
            j.raw(",")?.key("error")?.raw("{")?;
            j.key("code")?.int(robot.error_code.into())?;
            j.raw(",")?.key("axis")?.uint(robot.error_axis.into())?;
            j.raw(",")?.key("name")?;
            match code.name().filter(|_| robot.error_code != 0) {
                Some(n) => j.str(n.as_bytes())?,
                None => j.null()?,
            };
            // The text the gateway fetched for this code (the controller's
            // own at V6: ERROR_TEXT_*), else the protocol documents'.
            let fetched = &m.error_text;
            let own = (robot.error_code != 0
                && fetched.code == robot.error_code
                && fetched.source == TextSource::Controller)
                .then_some(fetched.text.bytes());
            let text = own.or_else(|| {
                code.text()
                    .filter(|_| robot.error_code != 0)
                    .map(str::as_bytes)
            });
            j.raw(",")?.key("text")?;
            match text {
                Some(t) => j.str(t)?,
                None => j.null()?,
            };
            j.raw(",")?.key("text_source")?;
            match (own, text) {
                (Some(_), _) => j.str(b"controller")?,
                (None, Some(_)) => j.str(b"table")?,
                (None, None) => j.null()?,
            };
            j.raw("}")?;
            j.raw(",")?.key("override")?;
            match robot.override_ratio {
                Some(v) => j.fixed3(v)?,
                None => j.null()?,
            };
            j.raw(",")?.key("joints")?;
            six(j, robot.joints)?;
            j.raw(",")?.key("pose")?;
            six(j, robot.pose)?;
            j.raw(",")?.key("io")?.raw("{")?;
            let names = ["box_di", "box_do", "box_ci", "box_co", "end_di", "end_do"];
            for (k, (g, name)) in Io::ALL.iter().zip(names).enumerate() {
                if k > 0 {
                    j.raw(",")?;
                }
                j.key(name)?;
                match robot.io(*g) {
                    Some(v) => j.uint(v.into())?,
                    None => j.null()?,
                };
            }
            j.raw("}}")?;
            Ok(Part::More)
        }
        2 => {
            j.raw(",")?.key("queue")?.raw("{")?;
            j.key("used")?.uint(m.queue.len() as u64)?;
            j.raw(",")?.key("depth")?.uint(QUEUE_DEPTH as u64)?;
            j.raw(",")?.key("active_motion")?;
            match m.active_motion {
                Some(s) => {
                    j.raw("{")?.key("source")?.str(source_name(s).as_bytes())?;
                    j.raw(",")?.key("index")?.uint(s.index().into())?.raw("}")?;
                }
                None => {
                    j.null()?;
                }
            }
            j.raw("}")?;
            j.raw(",")?.key("watchdog")?.raw("{")?;
            j.key("period_ms")?
                .uint(m.config.active.watchdog_ms.into())?;
            j.raw(",")?.key("armed")?.bool(m.watchdog_armed())?;
            j.raw(",")?.key("tripped")?.bool(m.plc.watchdog_tripped)?;
            j.raw(",")?
                .key("trips")?
                .uint(m.plc.watchdog_trips.into())?;
            j.raw(",")?
                .key("plc_heartbeat")?
                .uint(m.plc.heartbeat.into())?;
            j.raw("}")?;
            j.raw(",")?.key("modbus")?.raw("{")?;
            j.key("sessions")?.uint(m.sessions.into())?;
            j.raw(",")?.key("clients")?.raw("[")?;
            for (k, p) in m.modbus_peers.iter().enumerate() {
                if k > 0 {
                    j.raw(",")?;
                }
                j.endpoint(*p)?;
            }
            j.raw("]")?;
            j.raw(",")?
                .key("refused")?
                .uint(m.access.modbus_refused.into())?;
            j.raw(",")?
                .key("writes_refused")?
                .uint(m.access.writes_refused.into())?;
            j.raw("}")?;
            let a = &m.access;
            let c = &m.config.active;
            j.raw(",")?.key("access")?.raw("{")?;
            j.key("write_protect")?.bool(c.write_protect)?;
            j.raw(",")?
                .key("password_set")?
                .bool(a.password.is_some())?;
            j.raw(",")?
                .key("restart_pending")?
                .bool(a.restart_pending(&c.net))?;
            j.raw(",")?.key("recovery")?.bool(a.recovery)?;
            j.raw(",")?
                .key("network_managed")?
                .bool(a.network_managed)?;
            j.raw(",")?.key("web_refused")?.uint(a.web_refused.into())?;
            j.raw("}")?;
            j.raw(",")?.key("config")?.raw("{")?;
            j.key("result")?.uint(m.config.result as u64)?;
            j.raw(",")?.key("saves")?.uint(m.config.saves.into())?;
            j.raw(",")?
                .key("applied")?
                .uint(m.config.generation.into())?;
            j.raw("}")?;
            Ok(Part::More)
        }
        3 => {
            j.raw(",")?.key("channels")?.raw("[")?;
            for (k, ch) in m.channels.iter().enumerate() {
                if k > 0 {
                    j.raw(",")?;
                }
                j.raw("{")?.key("index")?.uint(k as u64)?;
                j.raw(",")?
                    .key("code")?
                    .uint(ch.handshake.command_echo.into())?;
                j.raw(",")?.key("execute")?.bool(ch.inputs.execute())?;
                j.raw(",")?;
                handshake(j, &ch.handshake)?;
                j.raw("}")?;
            }
            j.raw("]")?.raw(",")?.key("raw")?.raw("{")?;
            j.key("execute")?.bool(m.raw.execute())?.raw(",")?;
            handshake(j, &m.raw.handshake)?;
            j.raw("}")?.raw(",")?.key("triggers")?.raw("[")?;
            Ok(Part::More)
        }
        i => {
            let n = i - 4;
            let (Some(h), Some(text)) = (m.triggers.handshakes.get(n), m.triggers.entries.get(n))
            else {
                j.raw("]}")?;
                return Ok(Part::Last);
            };
            if n > 0 {
                j.raw(",")?;
            }
            j.raw("{")?.key("index")?.uint(n as u64)?;
            j.raw(",")?
                .key("bit")?
                .bool(m.triggers.bits & (1 << n) != 0)?;
            j.raw(",")?.key("text")?.str(text.bytes())?.raw(",")?;
            handshake(j, h)?;
            j.raw("}")?;
            Ok(Part::More)
        }
    }
}

fn config(m: &Model, i: usize, j: &mut Json) -> Result<Part, Full> {
    match i {
        0 => {
            j.raw("{")?
                .key("format")?
                .str(super::post::FORMAT.as_bytes())?;
            j.raw(",")?.key("settings")?.raw("{")?;
            for (k, s) in SETTINGS.iter().enumerate() {
                if k > 0 {
                    j.raw(",")?;
                }
                j.key(s.key)?;
                let mut v: heapless::String<96> = heapless::String::new();
                s.format(&m.config.active, &mut v).map_err(|_| Full)?;
                j.str(v.as_bytes())?;
            }
            j.raw("},")?.key("triggers")?.raw("[")?;
            Ok(Part::More)
        }
        i => {
            let n = i - 1;
            let Some(text) = m.triggers.entries.get(n) else {
                return Err(Full);
            };
            if n > 0 {
                j.raw(",")?;
            }
            j.str(text.bytes())?;
            let last = n + 1 == m.triggers.entries.len();
            if last {
                j.raw("]}")?;
            }
            Ok(more(last))
        }
    }
}

fn range(j: &mut Json, s: &Setting) -> Result<(), Full> {
    match s.kind {
        Kind::Number { min, max, off } => {
            j.raw("{")?;
            if off {
                j.key("off")?.uint(0)?.raw(",")?;
            }
            j.key("min")?.uint(min.into())?;
            j.raw(",")?.key("max")?.uint(max.into())?.raw("}")?;
        }
        _ => {
            j.null()?;
        }
    }
    Ok(())
}

fn fields(i: usize, j: &mut Json) -> Result<Part, Full> {
    let Some(s) = SETTINGS.get(i) else {
        return Err(Full);
    };
    j.raw(if i == 0 { "[" } else { "," })?;
    j.raw("{")?.key("key")?.str(s.key.as_bytes())?;
    j.raw(",")?.key("kind")?.str(s.kind.name().as_bytes())?;
    j.raw(",")?.key("unit")?.str(s.unit.as_bytes())?;
    j.raw(",")?.key("range")?;
    range(j, s)?;
    j.raw(",")?.key("choices")?;
    match s.kind {
        Kind::Choice(words) => {
            j.raw("[")?;
            for (k, w) in words.iter().enumerate() {
                if k > 0 {
                    j.raw(",")?;
                }
                j.str(w.as_bytes())?;
            }
            j.raw("]")?;
        }
        Kind::Flag => {
            j.raw("[\"false\",\"true\"]")?;
        }
        _ => {
            j.null()?;
        }
    }
    let mut d: heapless::String<96> = heapless::String::new();
    s.kind
        .format(&s.default_value(), &mut d)
        .map_err(|_| Full)?;
    j.raw(",")?.key("default")?.str(d.as_bytes())?;
    j.raw(",")?.key("restart")?.bool(s.restart)?;
    j.raw(",")?.key("register")?;
    match register_of(s) {
        Some((g, bit)) => {
            j.raw("{")?.key("name")?.str(g.name.as_bytes())?;
            j.raw(",")?.key("address")?.uint(g.addr.into())?;
            j.raw(",")?.key("count")?.uint(g.count().into())?;
            if let Some(b) = bit {
                j.raw(",")?.key("bit")?.uint(b.into())?;
            }
            j.raw("}")?;
        }
        None => {
            j.null()?;
        }
    }
    j.raw(",")?.key("help")?.str(s.help.as_bytes())?.raw("}")?;
    let last = i + 1 == SETTINGS.len();
    if last {
        j.raw("]")?;
    }
    Ok(more(last))
}

fn log(m: &Model, now: Instant, i: usize, j: &mut Json) -> Result<Part, Full> {
    if i == 0 {
        j.raw("{")?.key("capacity")?.uint(LOG_LEN as u64)?;
        j.raw(",")?.key("total")?.uint(m.log.total.into())?;
        j.raw(",")?.key("now_ms")?.uint(now.as_millis())?;
        j.raw(",")?.key("entries")?.raw("[")?;
        if m.log.iter().next().is_none() {
            j.raw("]}")?;
            return Ok(Part::Last);
        }
        return Ok(Part::More);
    }
    let n = i - 1;
    let Some(e) = m.log.iter().nth(n) else {
        // The log moved on between two parts: close the document.
        j.raw("]}")?;
        return Ok(Part::Last);
    };
    if n > 0 {
        j.raw(",")?;
    }
    j.raw("{")?.key("at_ms")?.uint(e.at.as_millis())?.raw(",")?;
    match &e.event {
        LogEvent::Command(c) => {
            j.key("kind")?.str(b"command")?;
            j.raw(",")?
                .key("source")?
                .str(source_name(c.source).as_bytes())?;
            j.raw(",")?.key("index")?.uint(c.source.index().into())?;
            j.raw(",")?.key("code")?.uint(c.code.into())?;
            j.raw(",")?.key("sent")?.str(&c.sent)?;
            j.raw(",")?.key("reply")?.str(&c.reply)?;
            j.raw(",")?.key("outcome")?;
            outcome(j, c.outcome)?;
            j.raw(",")?.key("took_ms")?;
            match c.outcome {
                Some(_) => j.uint(c.took_ms.into())?,
                None => j.null()?,
            };
        }
        LogEvent::LinkUp(peer) => {
            j.key("kind")?.str(b"link-up")?.raw(",")?.key("peer")?;
            match peer {
                Some(p) => j.ip(*p)?,
                None => j.null()?,
            };
        }
        LogEvent::LinkDown(e) => {
            j.key("kind")?.str(b"link-down")?;
            j.raw(",")?.key("error")?.int(e.code().into())?;
            j.raw(",")?.key("text")?.str(e.as_str().as_bytes())?;
        }
    }
    j.raw("}")?;
    let last = n + 1 >= m.log.iter().count();
    if last {
        j.raw("]}")?;
    }
    Ok(more(last))
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::config::Config;
    use crate::error::GatewayError;
    use crate::state::robot::RobotFlags;
    use crate::state::ERROR_TEXT;
    use std::string::String;

    /// The whole document, parts joined (as the chunks arrive).
    fn render(doc: Doc, m: &Model) -> String {
        let mut out = String::new();
        let mut j = Json::new();
        for i in 0..200 {
            j.clear();
            let p = doc
                .part(m, Instant::from_millis(5000), i, &mut j)
                .expect("fits");
            out.push_str(core::str::from_utf8(j.as_bytes()).unwrap());
            if p == Part::Last {
                return out;
            }
        }
        panic!("no last part");
    }

    /// A state with every text at its longest and worst characters.
    fn worst() -> Model {
        let mut m = Model::new(Config::default(), Config::default());
        for e in m.triggers.entries.iter_mut() {
            e.set(&[b'"'; 192]);
        }
        m.robot.flags = Some(RobotFlags::default());
        m.robot.joints = Some([-1.0e12; 6]);
        m.robot.pose = Some([f32::MAX; 6]);
        m.robot.error_code = 20018;
        m.error_text
            .set(20018, TextSource::Controller, &[b'"'; ERROR_TEXT]);
        m.link.level = Some(ProtocolLevel::new(255, 255, 255));
        for i in 0..LOG_LEN {
            let s = Source::Channel((i % 2) as u8);
            m.log.started(s, 9, Instant::from_millis(i as u64));
            m.log.sent(s, &[b'\\'; 200]);
            m.log.replied(s, &[0xff; 200]);
            m.log.ended(
                s,
                Outcome::Error(ErrorSource::Gateway, GatewayError::StateNotReached.code()),
                Instant::from_millis(i as u64 + 7),
            );
        }
        for p in 0..crate::MAX_SESSIONS {
            let _ = m.modbus_peers.push(core::net::SocketAddrV4::new(
                core::net::Ipv4Addr::new(255, 255, 255, 255),
                65535 - p as u16,
            ));
        }
        m
    }

    #[test]
    fn every_document_fits_its_parts_even_at_its_longest() {
        let m = worst();
        for doc in [Doc::Status, Doc::Config, Doc::Fields, Doc::Log] {
            let s = render(doc, &m);
            assert!(s.starts_with(['{', '[']), "{doc:?}");
        }
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
        let status = render(Doc::Status, &m);
        assert!(status.contains(r#""triggers":[{"index":0,"#), "{status}");
        assert!(status.contains(r#""text":"GrpStop,0,;","phase":"error","seq":0,"outcome":{"result":"error","error_id":39600,"error_source":3,"error_text":"queue full"}"#), "{status}");
        assert!(
            status.contains(r#""joints":[-999999995904.000,"#),
            "{status}"
        );
        assert!(
            status.contains(r#""protocol":"HR255.255.255","#),
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
        assert!(config.contains(r#""access.modbus_allow":"""#), "{config}");
        assert!(config.ends_with("]}"), "{config}");
        let fields = render(Doc::Fields, &m);
        assert!(fields.contains(r#"{"key":"link.poll_ms","kind":"number","unit":"ms","range":{"min":10,"max":100},"choices":null,"default":"100","restart":false,"register":{"name":"CFG_POLL_MS","address":105,"count":1},"#), "{fields}");
        assert!(fields.contains(r#"{"key":"motion.wait_in_position","kind":"flag","unit":"","range":null,"choices":["false","true"],"default":"false","restart":false,"register":{"name":"CFG_MOTION_POLICY","address":110,"count":1,"bit":1},"#), "{fields}");
        assert!(fields.contains(r#"{"key":"mqtt.broker","kind":"host","unit":"","range":null,"choices":null,"default":"","restart":false,"register":null,"#), "{fields}");
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
