//! The requests that change something: log in and out, the password, the
//! settings and trigger entries, a restart. Each is checked whole before
//! anything changes, and saved as `CONFIG_COMMAND` 1 saves.

use core::fmt::Write as _;

use picoserve::io::Read;
use picoserve::request::Request;
use picoserve::response::StatusCode;
use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};
use serde::Deserialize;

use super::json::Json;
use super::{error, error_json, App, Reply};
use crate::access::password::{self, PasswordHash, SALT_LEN};
use crate::clock::Clock;
use crate::config::{schema, Config, Value, SETTINGS};
use crate::registers::config::{Layout, REGISTERS};
use crate::state::inputs::{Text, TRIGGERS, TRIGGER_TEXT};
use crate::storage::SaveOutcome;

/// The format name of an exported configuration: settings by their stable
/// key (`link.poll_ms`).
pub(crate) const FORMAT: &str = "hans-gateway-config-2";
/// The format of the previous version's exports: settings by register
/// name (`CFG_POLL_MS`), still imported.
pub(crate) const FORMAT_1: &str = "hans-gateway-config-1";

/// `{"ok":true}`.
pub(crate) fn ok_json() -> Json {
    let mut j = Json::new();
    let _ = j.raw("{\"ok\":true}");
    j
}

fn saved_json(outcome: SaveOutcome, restart_pending: bool) -> Json {
    let mut j = Json::new();
    let saved = match outcome {
        SaveOutcome::Saved => "saved",
        SaveOutcome::NotPersistent => "not-saved",
        SaveOutcome::Failed(_) => "failed",
    };
    let _ = j
        .raw("{\"ok\":true,")
        .and_then(|j| j.key("saved"))
        .and_then(|j| j.str(saved.as_bytes()))
        .and_then(|j| j.raw(","))
        .and_then(|j| j.key("restart_pending"))
        .and_then(|j| j.bool(restart_pending))
        .and_then(|j| j.raw("}"));
    j
}

/// The settings of an import: name and text, in the order given.
struct Settings<'a>(heapless::Vec<(&'a str, &'a str), { SETTINGS.len() }>);

/// The trigger entries of an import.
struct Triggers<'a>(heapless::Vec<&'a str, TRIGGERS>);

fn plain<E: de::Error>(s: &str) -> Result<&str, E> {
    // Without an unescape buffer the reader hands strings over as written:
    // refuse escapes rather than store a backslash the user did not mean.
    if s.contains('\\') {
        return Err(E::custom("escaped characters are not supported"));
    }
    Ok(s)
}

impl<'de: 'a, 'a> Deserialize<'de> for Settings<'a> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<'a>(core::marker::PhantomData<&'a ()>);
        impl<'de: 'a, 'a> Visitor<'de> for V<'a> {
            type Value = Settings<'a>;
            fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                f.write_str("an object of settings")
            }
            fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
                let mut v = heapless::Vec::new();
                while let Some((k, val)) = map.next_entry::<&'a str, &'a str>()? {
                    v.push((plain(k)?, plain(val)?))
                        .map_err(|_| de::Error::custom("too many settings"))?;
                }
                Ok(Settings(v))
            }
        }
        d.deserialize_map(V(core::marker::PhantomData))
    }
}

impl<'de: 'a, 'a> Deserialize<'de> for Triggers<'a> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<'a>(core::marker::PhantomData<&'a ()>);
        impl<'de: 'a, 'a> Visitor<'de> for V<'a> {
            type Value = Triggers<'a>;
            fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                f.write_str("an array of 16 trigger texts")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let mut v = heapless::Vec::new();
                while let Some(t) = seq.next_element::<&'a str>()? {
                    v.push(plain(t)?)
                        .map_err(|_| de::Error::custom("more than 16 trigger entries"))?;
                }
                Ok(Triggers(v))
            }
        }
        d.deserialize_seq(V(core::marker::PhantomData))
    }
}

/// A configuration as posted (and as exported by `/api/config`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ConfigDoc<'a> {
    #[serde(borrow, default)]
    format: Option<&'a str>,
    #[serde(borrow, default)]
    settings: Option<Settings<'a>>,
    #[serde(borrow, default)]
    triggers: Option<Triggers<'a>>,
}

/// Problems found in a posted configuration, as `{"ok":false,"errors":
/// {"NAME":"reason",...}}`; at most [`MAX_ERRORS`] are named.
struct Errors {
    j: Json,
    n: usize,
}

/// Errors named in one answer.
const MAX_ERRORS: usize = 8;
/// The start of an [`Errors`] answer.
const OPENING: &str = "{\"ok\":false,\"errors\":{";
/// Its end.
const CLOSING: &str = "}}";

impl Errors {
    fn new() -> Self {
        let mut j = Json::new();
        let _ = j.raw(OPENING);
        Errors { j, n: 0 }
    }

    fn add(&mut self, key: &str, reason: &str) {
        self.n += 1;
        if self.n > MAX_ERRORS {
            return;
        }
        // An entry goes in whole, with room left for the closing `}}`,
        // or not at all: the answer stays valid JSON however long the
        // names are.
        let mark = self.j.len();
        let sep = if mark > OPENING.len() { "," } else { "" };
        let whole = self
            .j
            .raw(sep)
            .and_then(|j| j.str(key.as_bytes()))
            .and_then(|j| j.raw(":"))
            .and_then(|j| j.str(reason.as_bytes()))
            .is_ok();
        if !whole || self.j.len() + CLOSING.len() > super::json::ANSWER {
            self.j.truncate(mark);
        }
    }

    fn finish(mut self) -> Option<Json> {
        if self.n == 0 {
            return None;
        }
        let _ = self.j.raw(CLOSING);
        Some(self.j)
    }
}

/// Checks a trigger text as the PLC's are checked when fired: empty
/// (unused), or one protocol message of printable ASCII that the grammar
/// reads, at most [`TRIGGER_TEXT`] characters.
pub(crate) fn check_trigger(t: &str) -> Result<Text<TRIGGER_TEXT>, &'static str> {
    let t = t.trim();
    let mut text = Text::EMPTY;
    if t.is_empty() {
        return Ok(text);
    }
    if t.len() > TRIGGER_TEXT {
        return Err("longer than 192 characters");
    }
    crate::job::text::build(t.as_bytes()).map_err(|_| "not a protocol message")?;
    text.set(t.as_bytes());
    Ok(text)
}

/// Sets the setting named `name` (its key, or in a format-1 export its
/// register name) in `c` from its text.
fn set_named(name: &str, text: &str, c: &mut Config) -> Result<(), &'static str> {
    if let Some(s) = schema::by_key(name) {
        return s.parse_into(text, c).map_err(|e| e.as_str());
    }
    let Some(g) = REGISTERS.iter().find(|g| g.name == name) else {
        return Err("unknown setting");
    };
    match g.layout {
        Layout::Value(s) => s.parse_into(text, c).map_err(|e| e.as_str()),
        Layout::Bits(flags) => {
            let bits: u16 = text.trim().parse().map_err(|_| "not a whole number")?;
            if u32::from(bits) >> flags.len() != 0 {
                return Err("out of range");
            }
            for (b, s) in flags.iter().enumerate() {
                s.set(c, Value::Flag(bits >> b & 1 == 1))
                    .map_err(|e| e.as_str())?;
            }
            Ok(())
        }
    }
}

/// Reads a posted configuration over `base`, and the trigger texts; every
/// problem is named.
// The error is the answer to send (1 KiB of JSON; no heap to box it in),
// smaller than the success value (the trigger texts, 3 KiB).
#[allow(clippy::type_complexity, clippy::result_large_err)]
pub(crate) fn read_config(
    body: &[u8],
    base: &Config,
) -> Result<(Config, Option<[Text<TRIGGER_TEXT>; TRIGGERS]>), Json> {
    let doc = match serde_json_core::from_slice::<ConfigDoc<'_>>(body) {
        Ok((d, _)) => d,
        Err(e) => {
            let mut reason: heapless::String<96> = heapless::String::new();
            let _ = write!(reason, "not a configuration document: {e:?}");
            return Err(error_json(&reason));
        }
    };
    let mut errors = Errors::new();
    if doc.format.is_some_and(|f| f != FORMAT && f != FORMAT_1) {
        errors.add("format", FORMAT);
    }
    let mut config = *base;
    for (name, text) in doc.settings.as_ref().map_or(&[][..], |s| &s.0) {
        if let Err(e) = set_named(name, text, &mut config) {
            errors.add(name, e);
        }
    }
    let mut triggers = None;
    if let Some(t) = &doc.triggers {
        let mut all = [Text::EMPTY; TRIGGERS];
        for (i, (slot, text)) in all.iter_mut().zip(&t.0).enumerate() {
            match check_trigger(text) {
                Ok(v) => *slot = v,
                Err(e) => {
                    let mut key: heapless::String<8> = heapless::String::new();
                    let _ = write!(key, "TRIG{i}");
                    errors.add(&key, e);
                }
            }
        }
        triggers = Some(all);
    }
    if let Some(j) = errors.finish() {
        return Err(j);
    }
    Ok((config, triggers))
}

/// 429 with the wait: `{"error":…,"retry_after_s":n}`.
fn too_many(wait: embassy_time::Duration) -> Reply {
    let mut j = Json::new();
    let _ = j
        .raw("{\"error\":\"too many wrong passwords\",")
        .and_then(|j| j.key("retry_after_s"))
        .and_then(|j| j.uint(wait.as_secs() + 1))
        .and_then(|j| j.raw("}"));
    Reply::Json(StatusCode::TOO_MANY_REQUESTS, j)
}

impl<C: Clock> App<'_, C> {
    pub(super) async fn login<R: Read>(&self, request: &mut Request<'_, R>) -> Reply {
        let now = self.clock.now();
        let hash = self.hub.with(|m| m.access.password);
        let tried = self.web.sessions.borrow().may_try(now);
        let body = request.body_connection.body().read_all().await;
        match (hash, tried, body) {
            (_, _, Err(_)) => error(StatusCode::PAYLOAD_TOO_LARGE, "request too long"),
            (None, _, _) => error(StatusCode::CONFLICT, "no password is set"),
            (_, Err(wait), _) => too_many(wait),
            (Some(h), Ok(()), Ok(pw)) => {
                if h.verify(pw).await {
                    let mut s = self.web.sessions.borrow_mut();
                    s.succeeded();
                    let t = s.open(self.clock.now());
                    info!("web: logged in");
                    Reply::Session(StatusCode::OK, ok_json(), t)
                } else {
                    self.web.sessions.borrow_mut().failed(self.clock.now());
                    warn!("web: wrong password");
                    error(StatusCode::UNAUTHORIZED, "wrong password")
                }
            }
        }
    }

    /// `current` newline `new`: `current` must be the password set (empty
    /// on a fresh device). Ends every session and opens one for the
    /// caller.
    pub(super) async fn set_password<R: Read>(&self, request: &mut Request<'_, R>) -> Reply {
        let now = self.clock.now();
        let hash = self.hub.with(|m| m.access.password);
        let tried = self.web.sessions.borrow().may_try(now);
        let Ok(body) = request.body_connection.body().read_all().await else {
            return error(StatusCode::PAYLOAD_TOO_LARGE, "request too long");
        };
        let (current, new) = match body.iter().position(|&b| b == b'\n') {
            Some(i) => (
                body.get(..i).unwrap_or(&[]),
                body.get(i + 1..).unwrap_or(&[]),
            ),
            None => (&[][..], &body[..]),
        };
        let new = new.strip_suffix(b"\n").unwrap_or(new);
        // A recovery start (the board's button held at power-up) is the
        // way back from a forgotten password: whoever can press it may set
        // a new one without the old.
        let recovery = self.hub.with(|m| m.access.recovery);
        match (hash.filter(|_| !recovery), tried) {
            (Some(_), Err(wait)) => {
                return too_many(wait);
            }
            (Some(h), Ok(())) => {
                if !h.verify(current).await {
                    self.web.sessions.borrow_mut().failed(self.clock.now());
                    warn!("web: wrong password");
                    return error(StatusCode::UNAUTHORIZED, "wrong password");
                }
            }
            (None, _) => {}
        }
        if let Err(e) = password::check_new(new) {
            return error(StatusCode::BAD_REQUEST, e.as_str());
        }
        let salt: [u8; SALT_LEN] = self.web.sessions.borrow_mut().random();
        let h = PasswordHash::new(new, salt).await;
        let saved = self
            .hub
            .change(|m| {
                m.access.password = Some(h);
                Ok::<_, ()>(false)
            })
            .await;
        let token = {
            let mut s = self.web.sessions.borrow_mut();
            s.succeeded();
            s.close_all();
            s.open(self.clock.now())
        };
        info!("web: password set");
        let j = saved_json(saved.unwrap_or(SaveOutcome::NotPersistent), false);
        Reply::Session(StatusCode::OK, j, token)
    }

    // The closure's error is the answer (see `read_config`).
    #[allow(clippy::result_large_err)]
    pub(super) async fn post_config<R: Read>(&self, request: &mut Request<'_, R>) -> Reply {
        let Ok(body) = request.body_connection.body().read_all().await else {
            return error(StatusCode::PAYLOAD_TOO_LARGE, "request too long");
        };
        let body: &[u8] = body;
        // Read, checked and applied under the state's lock, in one go: the
        // trigger texts (3 KiB) stay off the connection's future.
        let saved = self
            .hub
            .change(|m| {
                let (new, triggers) = read_config(body, &m.config.active)?;
                m.config.apply(new);
                if let Some(t) = triggers {
                    m.triggers.entries = t;
                }
                Ok(true)
            })
            .await;
        match saved {
            Ok(o) => {
                let pending = self
                    .hub
                    .with(|m| m.access.restart_pending(&m.config.active.net));
                info!("web: configuration applied");
                Reply::Json(StatusCode::OK, saved_json(o, pending))
            }
            Err(j) => Reply::Json(StatusCode::BAD_REQUEST, j),
        }
    }

    pub(super) async fn post_trigger<R: Read>(
        &self,
        n: Option<usize>,
        request: &mut Request<'_, R>,
    ) -> Reply {
        let Some(n) = n.filter(|&n| n < TRIGGERS) else {
            return error(StatusCode::NOT_FOUND, "no such trigger entry");
        };
        let Ok(body) = request.body_connection.body().read_all().await else {
            return error(StatusCode::PAYLOAD_TOO_LARGE, "request too long");
        };
        let text = match core::str::from_utf8(body).map_err(|_| "not a protocol message") {
            Ok(t) => match check_trigger(t) {
                Ok(text) => text,
                Err(e) => return error(StatusCode::BAD_REQUEST, e),
            },
            Err(e) => return error(StatusCode::BAD_REQUEST, e),
        };
        let saved = self
            .hub
            .change(|m| {
                if let Some(e) = m.triggers.entries.get_mut(n) {
                    *e = text;
                }
                Ok::<_, ()>(false)
            })
            .await;
        info!("web: trigger entry {} stored", n);
        Reply::Json(
            StatusCode::OK,
            saved_json(saved.unwrap_or(SaveOutcome::NotPersistent), false),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(j: &Json) -> &str {
        core::str::from_utf8(j.as_bytes()).unwrap()
    }

    #[test]
    fn a_posted_configuration_is_checked_whole() {
        let base = Config::default();
        let (c, t) = read_config(
            br#"{"format":"hans-gateway-config-2","settings":{"link.poll_ms":"50","network.address":"10.0.0.2","access.modbus_allow":"127.0.0.1","link.mode":"listen","mqtt.broker":"broker.plant"},"triggers":["GrpStop,0,;",""]}"#,
            &base,
        )
        .unwrap();
        assert_eq!(c.poll_ms, 50);
        assert_eq!(c.link_mode, crate::config::LinkMode::Listen);
        assert_eq!(c.mqtt_broker.as_str(), "broker.plant");
        assert!(c.modbus_allow.permits(core::net::Ipv4Addr::LOCALHOST));
        assert!(!c
            .modbus_allow
            .permits(core::net::Ipv4Addr::new(127, 0, 0, 2)));
        let t = t.unwrap();
        assert_eq!(t[0].bytes(), b"GrpStop,0,;");
        assert!(t[1].is_empty() && t[15].is_empty());
        let e = read_config(
            br#"{"settings":{"link.poll_ms":"5","link.nope":"1","network.mask":"255.0.255.0"},"triggers":["Not a message"]}"#,
            &base,
        )
        .unwrap_err();
        assert_eq!(
            text(&e),
            r#"{"ok":false,"errors":{"link.poll_ms":"out of range","link.nope":"unknown setting","network.mask":"not a network mask (e.g. 255.255.255.0)","TRIG0":"not a protocol message"}}"#
        );
        for bad in [
            &b"not json"[..],
            br#"{"settings":{"link.poll_ms":50}}"#,
            br#"{"settings":{},"extra":1}"#,
            br#"{"triggers":["a\"b"]}"#,
            br#"{"format":"other"}"#,
        ] {
            assert!(
                read_config(bad, &base).is_err(),
                "{}",
                core::str::from_utf8(bad).unwrap()
            );
        }
    }

    /// What the previous version's page exported (settings by register
    /// name, numbers for choices and flags) still imports.
    #[test]
    fn a_format_1_export_imports() {
        let (c, _) = read_config(
            br#"{"format":"hans-gateway-config-1","settings":{"CFG_POLL_MS":"40","CFG_LINK_MODE":"1","CFG_MOTION_POLICY":"3","CFG_WRITE_PROTECT":"1","WEB_ALLOW":"10.0.0.0/8"}}"#,
            &Config::default(),
        )
        .unwrap();
        assert_eq!(c.poll_ms, 40);
        assert_eq!(c.link_mode, crate::config::LinkMode::Listen);
        assert!(c.wait_blending_done && c.wait_in_position && c.write_protect);
        assert!(!c.web_allow.is_empty());
        let e = read_config(
            br#"{"settings":{"CFG_MOTION_POLICY":"4"}}"#,
            &Config::default(),
        )
        .unwrap_err();
        assert_eq!(
            text(&e),
            r#"{"ok":false,"errors":{"CFG_MOTION_POLICY":"out of range"}}"#
        );
    }

    #[test]
    fn trigger_texts_are_checked_by_the_grammar() {
        assert!(check_trigger("").unwrap().is_empty());
        assert_eq!(
            check_trigger(" SetBoxDO,1,1,; ").unwrap().bytes(),
            b"SetBoxDO,1,1,;"
        );
        assert!(check_trigger("SetBoxDO,1,1,;GrpStop,0,;").is_err());
        assert!(check_trigger(&"x".repeat(193)).is_err());
        assert!(check_trigger("Grp\u{e9}Stop,0,;").is_err());
    }
}
