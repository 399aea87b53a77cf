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
use crate::access::accounts::{Account, AccountError, Role, UserName, ACCOUNTS, NAME_MAX};
use crate::access::limit::Guess;
use crate::access::password::{self, PasswordHash, SALT_LEN};
use crate::access::session::Who;
use crate::access::setup::SetupCode;
use crate::audit::{AccountChange, Event, Who as AuditWho};
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

/// An account's name for the audit log, or none.
struct Actor(Option<UserName>);

impl Actor {
    fn as_bytes(&self) -> &[u8] {
        self.0.as_ref().map_or(&[][..], UserName::as_bytes)
    }
}

/// What a name must be.
const NAME_RULE: &str = "a name is 1 to 16 of a-z 0-9 . _ - beginning with a letter";

/// `{"ok":true}`.
pub(crate) fn ok_json() -> Json {
    // Always fits.
    Json::value(|v| v.object(|j| j.key("ok").bool(true))).unwrap_or_else(|_| Json::new())
}

fn saved_json(outcome: SaveOutcome, restart_pending: bool) -> Json {
    let saved = match outcome {
        SaveOutcome::Saved => "saved",
        SaveOutcome::NotPersistent => "not-saved",
        SaveOutcome::Failed(_) => "failed",
    };
    // A few dozen bytes: always fits.
    Json::value(|v| {
        v.object(|j| {
            j.key("ok").bool(true);
            j.key("saved").str(saved.as_bytes());
            j.key("restart_pending").bool(restart_pending);
        })
    })
    .unwrap_or_else(|_| Json::new())
}

/// The settings of an import: name and text, in the order given.
struct Settings<'a>(heapless::Vec<(&'a str, &'a str), { SETTINGS.len() }>);

/// The trigger entries of an import as written, escapes and all (a PLC
/// may have stored quotes or backslashes, which the export escapes):
/// [`unescape`] reads each into its entry. Borrowed, not copied: an owned
/// copy of 16 texts was moved through the reader's layers and took 26 KiB
/// of the field device's stack.
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
                    v.push(t)
                        .map_err(|_| de::Error::custom("more than 16 trigger entries"))?;
                }
                Ok(Triggers(v))
            }
        }
        d.deserialize_seq(V(core::marker::PhantomData))
    }
}

/// A JSON string's content as written (`raw`, between its quotes) into
/// `out`, its escapes read (`\"`, `\\`, `\/`, `\b`, `\f`, `\n`, `\r`,
/// `\t`, `\u00XX` for ASCII); a text longer than `out` or another escape
/// is refused with the reason.
fn unescape<const N: usize>(raw: &str, out: &mut heapless::Vec<u8, N>) -> Result<(), &'static str> {
    const LONG: &str = "longer than 192 characters";
    let mut b = raw.bytes();
    while let Some(c) = b.next() {
        let c = match c {
            b'\\' => match b.next() {
                Some(b'"') => b'"',
                Some(b'\\') => b'\\',
                Some(b'/') => b'/',
                Some(b'b') => 8,
                Some(b'f') => 12,
                Some(b'n') => b'\n',
                Some(b'r') => b'\r',
                Some(b't') => b'\t',
                Some(b'u') => {
                    let mut v: u32 = 0;
                    for _ in 0..4 {
                        let d = b.next().and_then(crate::hex::value);
                        v = v * 16 + u32::from(d.ok_or("a broken \\u escape")?);
                    }
                    u8::try_from(v)
                        .ok()
                        .filter(u8::is_ascii)
                        .ok_or("not a protocol message")?
                }
                _ => return Err("a broken escape"),
            },
            c => c,
        };
        out.push(c).map_err(|_| LONG)?;
    }
    Ok(())
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
/// {"NAME":"reason",...}}`; at most [`MAX_ERRORS`] are named (the first).
struct Errors<'a> {
    list: heapless::Vec<(Key<'a>, &'static str), MAX_ERRORS>,
}

/// What a problem is about.
enum Key<'a> {
    /// A member of the document (`format`, a setting's key as posted).
    Name(&'a str),
    /// Trigger entry n (named `TRIGn`).
    Trigger(usize),
}

/// Errors named in one answer.
const MAX_ERRORS: usize = 8;

impl<'a> Errors<'a> {
    fn new() -> Self {
        Errors {
            list: heapless::Vec::new(),
        }
    }

    /// Names a problem; past [`MAX_ERRORS`] it is dropped.
    fn add(&mut self, key: Key<'a>, reason: &'static str) {
        let _ = self.list.push((key, reason));
    }

    /// The answer, `None` without problems. Entries go in whole, the last
    /// ones left out where the names are too long for the answer: it stays
    /// valid JSON however long the posted names are.
    fn finish(self) -> Option<Json> {
        if self.list.is_empty() {
            return None;
        }
        (1..=self.list.len()).rev().find_map(|n| {
            Json::value(|v| {
                v.object(|j| {
                    j.key("ok").bool(false);
                    j.key("errors").object(|e| {
                        for (key, reason) in self.list.iter().take(n) {
                            let mut trig: heapless::String<8> = heapless::String::new();
                            let name = match key {
                                Key::Name(n) => n,
                                Key::Trigger(i) => {
                                    let _ = write!(trig, "TRIG{i}");
                                    trig.as_str()
                                }
                            };
                            e.key(name).str(reason.as_bytes());
                        }
                    });
                })
            })
            .ok()
        })
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
        errors.add(Key::Name("format"), FORMAT);
    }
    let mut config = *base;
    for (name, text) in doc.settings.as_ref().map_or(&[][..], |s| &s.0) {
        if let Err(e) = set_named(name, text, &mut config) {
            errors.add(Key::Name(name), e);
        }
    }
    let mut triggers = None;
    if let Some(t) = &doc.triggers {
        let mut all = [Text::EMPTY; TRIGGERS];
        for (i, (slot, raw)) in all.iter_mut().zip(&t.0).enumerate() {
            let mut text = heapless::Vec::<u8, TRIGGER_TEXT>::new();
            let text = unescape(raw, &mut text)
                .and_then(|()| core::str::from_utf8(&text).map_err(|_| "not UTF-8"));
            match text.and_then(check_trigger) {
                Ok(v) => *slot = v,
                Err(e) => errors.add(Key::Trigger(i), e),
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
    // A few dozen bytes: always fits.
    let j = Json::value(|v| {
        v.object(|j| {
            j.key("error").str(b"too many wrong attempts");
            j.key("retry_after_s").uint(wait.as_secs() + 1);
        })
    })
    .unwrap_or_else(|_| Json::new());
    Reply::Json(StatusCode::TOO_MANY_REQUESTS, j)
}

/// A string member of a posted object, unescaped (a password may hold
/// `"` or `\\`), at most `N` bytes.
struct Field<const N: usize>(heapless::Vec<u8, N>);

impl<'de, const N: usize> Deserialize<'de> for Field<N> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V<const N: usize>;
        impl<const N: usize> Visitor<'_> for V<N> {
            type Value = Field<N>;
            fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                write!(f, "a string of at most {N} bytes")
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<Self::Value, E> {
                heapless::Vec::from_slice(s.as_bytes())
                    .map(Field)
                    .map_err(|_| E::custom("too long"))
            }
        }
        d.deserialize_str(V::<N>)
    }
}

/// Longest password read (longer ones are refused by the policy).
const PW: usize = password::MAX_LEN + 1;

/// The body of the requests on accounts: `{"name":…,"password":…}` and
/// the like; members a request does not use are refused by it.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct AccountDoc {
    #[serde(default)]
    op: Option<Field<12>>,
    #[serde(default)]
    name: Option<Field<{ NAME_MAX + 1 }>>,
    #[serde(default)]
    role: Option<Field<12>>,
    #[serde(default)]
    password: Option<Field<PW>>,
    #[serde(default)]
    current: Option<Field<PW>>,
    #[serde(default)]
    code: Option<Field<32>>,
}

fn bytes<const N: usize>(f: &Option<Field<N>>) -> &[u8] {
    f.as_ref().map_or(&[][..], |f| &f.0[..])
}

/// Reads an [`AccountDoc`] (strings unescaped in `buf`).
// The error is the answer (built once, written by the caller).
#[allow(clippy::result_large_err)]
fn account_doc(body: &[u8]) -> Result<AccountDoc, Reply> {
    let mut buf = [0u8; 96];
    serde_json_core::from_slice_escaped::<AccountDoc>(body, &mut buf)
        .map(|(d, _)| d)
        .map_err(|_| error(StatusCode::BAD_REQUEST, "not the expected JSON object"))
}

/// A new password of the account named `name`, checked against the
/// policy, hashed with a fresh salt.
// The error is the answer (built once, written by the caller).
#[allow(clippy::result_large_err)]
async fn new_hash<C: Clock>(
    app: &App<'_, C>,
    pw: &[u8],
    name: &[u8],
) -> Result<PasswordHash, Reply> {
    password::check_new(pw, name).map_err(|e| error(StatusCode::BAD_REQUEST, e.as_str()))?;
    let salt: [u8; SALT_LEN] = app.web.sessions.borrow_mut().random();
    Ok(PasswordHash::new(pw, salt).await)
}

/// A hash that matches no password, checked for unknown names so that an
/// unknown name takes as long as a wrong password.
const NOBODY: PasswordHash = PasswordHash {
    iterations: password::ITERATIONS,
    salt: [0; SALT_LEN],
    hash: [0; password::HASH_LEN],
};

impl<C: Clock> App<'_, C> {
    fn ip(&self) -> Option<core::net::Ipv4Addr> {
        self.peer.map(|p| *p.ip())
    }

    /// Account `account` (named `name`) logged in from this client: its
    /// address is one of the account's own from now on, kept with the
    /// accounts (saved if it is new: a restart forgets nothing).
    async fn trust(&self, account: usize, name: &[u8]) {
        let Some(ip) = self.ip() else {
            return;
        };
        let who = AuditWho::web(name, Some(ip));
        let new = self
            .hub
            .change_by(who, |m| match m.access.accounts.trust(account, ip) {
                true => Ok(false),
                false => Err(()),
            })
            .await;
        if new.is_ok() {
            self.web.limiter.borrow_mut().own_changed(account);
        }
    }

    /// A login for the audit log.
    fn audit_login(&self, name: &[u8]) {
        let from = self.ip();
        self.hub.audit(Event::Login {
            name,
            ok: true,
            from,
        });
    }

    /// A guess refused unchecked (its address or account must wait):
    /// counted in the audit log, answered 429 with the wait.
    fn unchecked(&self, wait: embassy_time::Duration) -> Reply {
        self.hub.audit.login_limited(self.ip());
        too_many(wait)
    }

    /// A failed login (or a wrong current password) for `name` (`known`:
    /// an account of that name exists), for the audit log: the first of a
    /// period is recorded, the rest counted (`crate::audit::log`: a flood
    /// of guesses from rotating addresses writes two records a period).
    fn audit_login_failed(&self, name: &[u8], known: bool) {
        self.hub.audit.login_failed(name, known, self.ip());
    }

    /// A change of account `name` by account `by`, for the audit log.
    fn audit_account(&self, name: &[u8], change: AccountChange<'_>, by: &[u8]) {
        let from = self.ip();
        self.hub.audit(Event::Account {
            name,
            change,
            by,
            from,
        });
    }

    /// The name of session `who`'s account, for the audit log's records
    /// (`None`: removed meanwhile, recorded as `-`).
    fn actor(&self, who: Who) -> Actor {
        Actor(self.name_of(who))
    }

    /// `{"name":…,"password":…}`: opens a session of that account.
    pub(super) async fn login<R: Read>(&self, request: &mut Request<'_, R>) -> Reply {
        let Ok(body) = request.body_connection.body().read_all().await else {
            return error(StatusCode::PAYLOAD_TOO_LARGE, "request too long");
        };
        let doc = match account_doc(body) {
            Ok(d) => d,
            Err(r) => return r,
        };
        let (name, pw) = (bytes(&doc.name), bytes(&doc.password));
        let ip = self.ip();
        let found = self.hub.with(|m| {
            let a = &m.access.accounts;
            let i = a.index_of(name)?;
            let acc = a.at(i)?;
            Some((i, (acc.hash, acc.role), a.own_address(i, ip)))
        });
        if !self.admin_exists() {
            return error(
                StatusCode::CONFLICT,
                "no account exists yet: create the administrator with the setup code",
            );
        }
        let guess = match found {
            Some((account, _, Some(own))) => Guess::Own { account, own },
            Some((account, _, None)) => Guess::Account(account),
            None => Guess::Nobody,
        };
        // Counted before the hash is computed: parallel guesses see each other.
        let ticket = match self
            .web
            .limiter
            .borrow_mut()
            .reserve(ip, guess, self.clock.now())
        {
            Ok(t) => t,
            Err(wait) => return self.unchecked(wait),
        };
        let hash = found.map_or(NOBODY, |f| f.1 .0);
        let right = hash.verify(pw).await && found.is_some();
        match found.filter(|_| right) {
            Some((account, (_, role), _)) => {
                self.web.limiter.borrow_mut().succeeded(ticket);
                self.trust(account, name).await;
                let t = self
                    .web
                    .sessions
                    .borrow_mut()
                    .open(Who { account, role }, self.clock.now());
                info!(
                    "web: {} logged in",
                    core::str::from_utf8(name).unwrap_or("?")
                );
                self.audit_login(name);
                Reply::Session(StatusCode::OK, ok_json(), t)
            }
            None => {
                warn!("web: wrong name or password");
                self.audit_login_failed(name, found.is_some());
                error(StatusCode::UNAUTHORIZED, "wrong name or password")
            }
        }
    }

    /// `{"code":…,"name":…,"password":…}`: the first administrator, with
    /// the setup code (proof of presence, see `access::setup`). After a
    /// recovery start also the way back from a forgotten password: the
    /// account named gets the password and the administrator role.
    pub(super) async fn setup<R: Read>(&self, request: &mut Request<'_, R>) -> Reply {
        let Ok(body) = request.body_connection.body().read_all().await else {
            return error(StatusCode::PAYLOAD_TOO_LARGE, "request too long");
        };
        let doc = match account_doc(body) {
            Ok(d) => d,
            Err(r) => return r,
        };
        let recovery = self.hub.with(|m| m.access.recovery);
        if self.admin_exists() && !recovery {
            return error(StatusCode::CONFLICT, "an administrator exists: log in");
        }
        let ticket =
            match self
                .web
                .limiter
                .borrow_mut()
                .reserve(self.ip(), Guess::Nobody, self.clock.now())
            {
                Ok(t) => t,
                Err(wait) => return self.unchecked(wait),
            };
        match (&self.web.setup_code, SetupCode::parse(bytes(&doc.code))) {
            (Some(code), Some(given)) if code.matches(&given) => {}
            // Without a code (a board that has none), a recovery start is
            // the proof of presence.
            (None, _) if recovery => {}
            (None, _) => {
                return error(StatusCode::SERVICE_UNAVAILABLE, "this device has no setup code: start it in recovery (hold its button at power-up)");
            }
            _ => {
                warn!("web: wrong setup code");
                self.hub.audit.setup_failed(self.ip());
                return error(StatusCode::FORBIDDEN, "wrong setup code");
            }
        }
        let Some(name) = UserName::new(bytes(&doc.name)) else {
            return error(StatusCode::BAD_REQUEST, NAME_RULE);
        };
        let hash = match new_hash(self, bytes(&doc.password), name.as_bytes()).await {
            Ok(h) => h,
            Err(r) => return r,
        };
        self.web.limiter.borrow_mut().succeeded(ticket);
        let existed = self
            .hub
            .with(|m| m.access.accounts.get(name.as_bytes()).is_some());
        let ip = self.ip();
        let saved = self
            .hub
            .change_by(AuditWho::web(name.as_bytes(), ip), |m| {
                let a = &mut m.access.accounts;
                let i = if a.get(name.as_bytes()).is_some() {
                    a.set_hash(name.as_bytes(), hash)?;
                    a.set_role(name.as_bytes(), Role::Admin)?;
                    a.index_of(name.as_bytes()).ok_or(AccountError::Unknown)?
                } else {
                    a.add(Account {
                        name,
                        role: Role::Admin,
                        hash,
                    })?
                };
                // Created from here: the administrator's own address.
                if let Some(ip) = ip {
                    a.trust(i, ip);
                }
                Ok::<_, AccountError>(false)
            })
            .await;
        let account = self
            .hub
            .with(|m| m.access.accounts.index_of(name.as_bytes()));
        match (saved, account) {
            (Ok(saved), Some(account)) => {
                let t = {
                    let mut s = self.web.sessions.borrow_mut();
                    s.close_account(account);
                    s.open(
                        Who {
                            account,
                            role: Role::Admin,
                        },
                        self.clock.now(),
                    )
                };
                warn!(
                    "web: administrator {} created with the setup code",
                    name.as_str()
                );
                let change = if existed {
                    AccountChange::Password
                } else {
                    AccountChange::Created { role: "admin" }
                };
                self.audit_account(name.as_bytes(), change, name.as_bytes());
                Reply::Session(StatusCode::OK, saved_json(saved, false), t)
            }
            (Err(e), _) => error(StatusCode::CONFLICT, e.as_str()),
            (Ok(_), None) => error(StatusCode::INTERNAL_SERVER_ERROR, "the account vanished"),
        }
    }

    /// `{"current":…,"password":…}`: the caller's own password. Ends the
    /// account's other sessions and opens one for the caller.
    pub(super) async fn set_password<R: Read>(
        &self,
        who: Who,
        request: &mut Request<'_, R>,
    ) -> Reply {
        let Ok(body) = request.body_connection.body().read_all().await else {
            return error(StatusCode::PAYLOAD_TOO_LARGE, "request too long");
        };
        let doc = match account_doc(body) {
            Ok(d) => d,
            Err(r) => return r,
        };
        let ip = self.ip();
        let Some((acc, own)) = self.hub.with(|m| {
            let a = &m.access.accounts;
            Some((*a.at(who.account)?, a.own_address(who.account, ip)))
        }) else {
            return error(StatusCode::UNAUTHORIZED, "log in first");
        };
        let guess = match own {
            Some(own) => Guess::Own {
                account: who.account,
                own,
            },
            None => Guess::Account(who.account),
        };
        let ticket = match self
            .web
            .limiter
            .borrow_mut()
            .reserve(ip, guess, self.clock.now())
        {
            Ok(t) => t,
            Err(wait) => return self.unchecked(wait),
        };
        if !acc.hash.verify(bytes(&doc.current)).await {
            warn!("web: wrong password");
            self.audit_login_failed(acc.name.as_bytes(), true);
            return error(StatusCode::UNAUTHORIZED, "wrong password");
        }
        self.web.limiter.borrow_mut().succeeded(ticket);
        let hash = match new_hash(self, bytes(&doc.password), acc.name.as_bytes()).await {
            Ok(h) => h,
            Err(r) => return r,
        };
        let saved = self
            .hub
            .change_by(AuditWho::web(acc.name.as_bytes(), ip), |m| {
                let a = &mut m.access.accounts;
                a.set_hash(acc.name.as_bytes(), hash)?;
                // Its own addresses are forgotten with the old password,
                // but for this one: the owner changed it from here.
                if let Some(ip) = ip {
                    a.trust(who.account, ip);
                }
                Ok::<_, AccountError>(false)
            })
            .await;
        self.web.limiter.borrow_mut().own_changed(who.account);
        let t = {
            let mut s = self.web.sessions.borrow_mut();
            s.close_account(who.account);
            s.open(who, self.clock.now())
        };
        info!("web: password of {} changed", acc.name.as_str());
        self.audit_account(
            acc.name.as_bytes(),
            AccountChange::Password,
            acc.name.as_bytes(),
        );
        match saved {
            Ok(saved) => Reply::Session(StatusCode::OK, saved_json(saved, false), t),
            Err(e) => error(StatusCode::CONFLICT, e.as_str()),
        }
    }

    /// `GET /api/accounts`: names and roles (never the hashes).
    pub(super) fn accounts_json(&self) -> Json {
        let accounts = self.hub.with(|m| m.access.accounts);
        Json::value(|v| {
            v.object(|j| {
                j.key("accounts").array(|a| {
                    for acc in accounts.iter() {
                        a.item().object(|o| {
                            o.key("name").str(acc.name.as_bytes());
                            o.key("role").str(acc.role.as_str().as_bytes());
                        });
                    }
                });
                j.key("max").uint(ACCOUNTS as u64);
                j.key("min_password").uint(password::MIN_LEN as u64);
            })
        })
        .unwrap_or_else(|_| error_json("accounts"))
    }

    /// `POST /api/accounts`: `{"op":"add","name":…,"role":…,"password":…}`,
    /// `{"op":"remove","name":…}`, `{"op":"role","name":…,"role":…}` or
    /// `{"op":"password","name":…,"password":…}` (an administrator sets
    /// another's). The account's sessions end on every change.
    pub(super) async fn post_accounts<R: Read>(
        &self,
        who: Who,
        request: &mut Request<'_, R>,
    ) -> Reply {
        let admin = self.actor(who);
        let Ok(body) = request.body_connection.body().read_all().await else {
            return error(StatusCode::PAYLOAD_TOO_LARGE, "request too long");
        };
        let doc = match account_doc(body) {
            Ok(d) => d,
            Err(r) => return r,
        };
        let name = bytes(&doc.name);
        let role = core::str::from_utf8(bytes(&doc.role))
            .ok()
            .and_then(Role::parse);
        let op = bytes(&doc.op);
        let hash = match op {
            b"add" | b"password" => match new_hash(self, bytes(&doc.password), name).await {
                Ok(h) => Some(h),
                Err(r) => return r,
            },
            _ => None,
        };
        let before = self.hub.with(|m| m.access.accounts.index_of(name));
        let result = self
            .hub
            .change_by(AuditWho::web(admin.as_bytes(), self.ip()), |m| {
                let a = &mut m.access.accounts;
                match (op, role, hash) {
                    (b"add", Some(role), Some(hash)) => {
                        let name = UserName::new(name).ok_or(NAME_RULE)?;
                        a.add(Account { name, role, hash })
                            .map_err(AccountError::as_str)?;
                    }
                    (b"remove", _, _) => {
                        a.remove(name).map_err(AccountError::as_str)?;
                    }
                    (b"role", Some(role), _) => {
                        a.set_role(name, role).map_err(AccountError::as_str)?
                    }
                    (b"password", _, Some(hash)) => {
                        a.set_hash(name, hash).map_err(AccountError::as_str)?
                    }
                    (b"add" | b"role", None, _) => return Err("role: viewer, operator or admin"),
                    _ => return Err("op: add, remove, role or password"),
                }
                Ok(false)
            })
            .await;
        match result {
            Ok(saved) => {
                let after = self.hub.with(|m| m.access.accounts.index_of(name));
                for i in [before, after].into_iter().flatten() {
                    if i != who.account || op != b"role" {
                        self.web.sessions.borrow_mut().close_account(i);
                    }
                    if op == b"remove" || op == b"add" || op == b"password" {
                        self.web.limiter.borrow_mut().forget_account(i);
                    }
                }
                if op == b"role" && before == Some(who.account) {
                    // The administrator changed their own role: that
                    // session ends too (it holds the old role).
                    self.web.sessions.borrow_mut().close_account(who.account);
                }
                info!(
                    "web: account {} changed",
                    core::str::from_utf8(name).unwrap_or("?")
                );
                let role = role.map_or("", Role::as_str);
                let change = match op {
                    b"add" => AccountChange::Created { role },
                    b"remove" => AccountChange::Removed,
                    b"role" => AccountChange::Role { role },
                    _ => AccountChange::Password,
                };
                self.audit_account(name, change, admin.as_bytes());
                Reply::Json(StatusCode::OK, saved_json(saved, false))
            }
            Err(why) => error(StatusCode::BAD_REQUEST, why),
        }
    }

    // The closure's error is the answer (see `read_config`).
    #[allow(clippy::result_large_err)]
    pub(super) async fn post_config<R: Read>(
        &self,
        who: Who,
        request: &mut Request<'_, R>,
    ) -> Reply {
        let actor = self.actor(who);
        let Ok(body) = request.body_connection.body().read_all().await else {
            return error(StatusCode::PAYLOAD_TOO_LARGE, "request too long");
        };
        let body: &[u8] = body;
        // Read, checked and applied under the state's lock, in one go: the
        // trigger texts (3 KiB) stay off the connection's future.
        let saved = self
            .hub
            .change_by(AuditWho::web(actor.as_bytes(), self.ip()), |m| {
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
        who: Who,
        n: Option<usize>,
        request: &mut Request<'_, R>,
    ) -> Reply {
        let actor = self.actor(who);
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
            .change_by(AuditWho::web(actor.as_bytes(), self.ip()), |m| {
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

    #[test]
    fn json_escapes_are_read_and_bad_ones_refused() {
        let read = |raw: &str| {
            let mut out = heapless::Vec::<u8, 8>::new();
            unescape(raw, &mut out).map(|()| out.to_vec())
        };
        assert_eq!(read(r#"a\"b\\c"#), Ok(b"a\"b\\c".to_vec()));
        assert_eq!(read(r"\/\t\u0041"), Ok(b"/\tA".to_vec()));
        assert_eq!(read(r"\u00e9"), Err("not a protocol message"));
        assert_eq!(read(r"\u12"), Err("a broken \\u escape"));
        assert_eq!(read(r"\x"), Err("a broken escape"));
        assert_eq!(read(r"\"), Err("a broken escape"));
        assert_eq!(read("123456789"), Err("longer than 192 characters"));
    }

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
        assert_eq!(c.mqtt.broker.as_str(), "broker.plant");
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
            br#"{"settings":{"robot.address":"10.0.0.\u0031"}}"#,
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
