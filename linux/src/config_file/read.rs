//! Reading the file: toml's spanned parse tree, walked key by key; each
//! value becomes its setting's typed value and is checked by the
//! setting's kind where it is written, so that every problem is reported
//! with its place.

extern crate std;

use std::borrow::{Cow, ToOwned};
use std::format;
use std::string::{String, ToString};
use std::vec::Vec;

use toml::de::{DeTable, DeValue};
use toml::Spanned;

use super::{
    quoted, register_name, setting_of, tables, takes, Contents, Problem, ACCOUNTS, PASSWORD, SCHEME,
};
use hans_gateway::access::accounts::{Account, Role, Trusted, UserName, TRUSTED};
use hans_gateway::access::password::{PasswordHash, HASH_LEN, ITERATIONS, SALT_LEN};
use hans_gateway::config::{
    AllowEntry, AllowList, Config, HostName, Kind, Setting, Value, ALLOW_ENTRIES, SETTINGS,
};
use hans_gateway::state::inputs::{TRIGGERS, TRIGGER_TEXT};

/// The line and column of byte `offset` of `text`, and the reason.
pub(super) fn problem(text: &str, offset: usize, reason: String) -> Problem {
    let before = text.get(..offset).unwrap_or(text);
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    Problem {
        line: before.matches('\n').count() + 1,
        column: before.get(line_start..).unwrap_or("").chars().count() + 1,
        reason,
    }
}

/// Reads a configuration file's text. Settings it leaves out take their
/// value in `defaults`; every problem is returned, in the order of the
/// file.
pub fn parse(text: &str, defaults: &Config) -> Result<Contents, Vec<Problem>> {
    let doc = DeTable::parse(text).map_err(|e| {
        let at = e.span().map_or(0, |s| s.start);
        std::vec![problem(text, at, e.message().to_owned())]
    })?;
    let mut r = Reader {
        text,
        contents: Contents::new(*defaults),
        problems: Vec::new(),
    };
    for (name, value) in doc.get_ref().iter() {
        r.table(name, value);
    }
    if r.problems.is_empty() {
        Ok(r.contents)
    } else {
        r.problems.sort_by_key(|p| (p.line, p.column));
        Err(r.problems)
    }
}

type Span = core::ops::Range<usize>;

/// The tables that have a key named `key`: `[robot] or [network]`.
fn tables_of(key: &str) -> Option<String> {
    let tables: Vec<String> = SETTINGS
        .iter()
        .filter(|s| s.name() == key)
        .map(|s| format!("[{}]", s.group()))
        .collect();
    (!tables.is_empty()).then(|| tables.join(" or "))
}

/// The state of a read: the contents so far, the problems found.
struct Reader<'t> {
    text: &'t str,
    contents: Contents,
    problems: Vec<Problem>,
}

impl Reader<'_> {
    fn refuse(&mut self, span: &Span, reason: String) {
        self.problems.push(problem(self.text, span.start, reason));
    }

    /// The value as written (for messages).
    fn written(&self, span: &Span) -> &str {
        self.text.get(span.clone()).unwrap_or("").trim()
    }

    fn table(&mut self, name: &Spanned<Cow<'_, str>>, value: &Spanned<DeValue<'_>>) {
        let n = name.get_ref().as_ref();
        let all = tables();
        if !all.contains(&n) {
            let reason = match tables_of(n) {
                Some(tables) => {
                    format!("unknown key \"{n}\" outside the tables (it goes in {tables})")
                }
                None => format!(
                    "unknown table [{n}]; the tables are {}",
                    all.iter()
                        .map(|t| format!("[{t}]"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            };
            self.refuse(&name.span(), reason);
            return;
        }
        let Some(table) = value.get_ref().as_table() else {
            let reason = format!(
                "[{n}] must be a table, found {}",
                value.get_ref().type_str()
            );
            self.refuse(&value.span(), reason);
            return;
        };
        for (k, v) in table.iter() {
            let kn = k.get_ref().as_ref();
            if n == "triggers" {
                self.trigger(kn, &k.span(), v);
            } else if n == "access" && kn == PASSWORD {
                self.password(v);
            } else if n == "access" && kn == ACCOUNTS {
                self.accounts(v);
            } else if let Some(s) = setting_of(n, kn) {
                self.setting(s, v);
            } else {
                let reason = match tables_of(kn) {
                    Some(tables) => format!("unknown key \"{kn}\" in [{n}] (it goes in {tables})"),
                    None => {
                        let mut keys: Vec<&str> = SETTINGS
                            .iter()
                            .filter(|s| s.group() == n)
                            .map(|s| s.name())
                            .collect();
                        if n == "access" {
                            keys.push(ACCOUNTS);
                        }
                        format!(
                            "unknown key \"{kn}\" in [{n}]; its keys are {}",
                            keys.join(", ")
                        )
                    }
                };
                self.refuse(&k.span(), reason);
            }
        }
    }

    /// A setting's value, checked by its kind, into the configuration.
    fn setting(&mut self, s: &'static Setting, value: &Spanned<DeValue<'_>>) {
        let Some((v, at)) = self.value(s, value) else {
            return;
        };
        if s.set(&mut self.contents.stored.config, v).is_err() {
            let written = self.written(&at).to_owned();
            let reason = format!(
                "{} = {written}: out of range, {} takes {} ({})",
                s.key,
                register_name(s),
                takes(s),
                s.help
            );
            self.refuse(&at, reason);
        }
    }

    /// A key's typed value and where to point at if it is out of range
    /// (an allow-list's bad entry), or `None` after reporting why there is
    /// none.
    fn value(&mut self, s: &Setting, value: &Spanned<DeValue<'_>>) -> Option<(Value, Span)> {
        let span = value.span();
        let v = value.get_ref();
        let name = s.key;
        let wrong_type = |what: &str| format!("{name}: expected {what}, found {}", v.type_str());
        let got = match s.kind {
            Kind::Number { .. } => {
                let Some(n) = v.as_integer() else {
                    self.refuse(&span, wrong_type("an integer"));
                    return None;
                };
                match i64::from_str_radix(n.as_str(), n.radix())
                    .ok()
                    .and_then(|n| u16::try_from(n).ok())
                {
                    Some(n) => Value::Number(n),
                    None => {
                        let reason = format!(
                            "{name} = {}: out of range, {} takes {} ({})",
                            self.written(&span),
                            register_name(s),
                            takes(s),
                            s.help
                        );
                        self.refuse(&span, reason);
                        return None;
                    }
                }
            }
            Kind::Flag => {
                let Some(on) = v.as_bool() else {
                    self.refuse(&span, wrong_type("true or false"));
                    return None;
                };
                Value::Flag(on)
            }
            Kind::Choice(words) => {
                let choices = quoted(words);
                let Some(t) = v.as_str() else {
                    self.refuse(&span, wrong_type(&format!("one of {choices}")));
                    return None;
                };
                match words.iter().position(|w| *w == t) {
                    Some(i) => Value::Choice(i as u8),
                    None => {
                        let reason = format!("{name} = \"{t}\" is not one of {choices}");
                        self.refuse(&span, reason);
                        return None;
                    }
                }
            }
            Kind::Address | Kind::Mask => {
                let Some(t) = v.as_str() else {
                    self.refuse(&span, wrong_type("an address \"a.b.c.d\""));
                    return None;
                };
                match t.parse() {
                    Ok(ip) => Value::Address(ip),
                    Err(_) => {
                        let reason = format!("{name} = \"{t}\" is not an IPv4 address a.b.c.d");
                        self.refuse(&span, reason);
                        return None;
                    }
                }
            }
            Kind::AllowList => Value::AllowList(self.allow_list(name, value)?),
            Kind::Host => {
                let Some(t) = v.as_str() else {
                    self.refuse(&span, wrong_type("a host name"));
                    return None;
                };
                match HostName::new(t) {
                    Some(h) => Value::Host(h),
                    None => {
                        let reason = format!("{name} = \"{t}\": {}", takes(s));
                        self.refuse(&span, reason);
                        return None;
                    }
                }
            }
        };
        Some((got, span))
    }

    fn allow_list(&mut self, name: &str, value: &Spanned<DeValue<'_>>) -> Option<AllowList> {
        let Some(entries) = value.get_ref().as_array() else {
            let reason = format!(
                "{name}: expected an array of \"a.b.c.d/prefix\" strings, found {}",
                value.get_ref().type_str()
            );
            self.refuse(&value.span(), reason);
            return None;
        };
        let mut list = AllowList::EVERYONE;
        let mut ok = true;
        for (i, e) in entries.iter().enumerate() {
            let span = e.span();
            let Some(slot) = list.0.get_mut(i) else {
                let reason = format!("{name}: at most {ALLOW_ENTRIES} entries");
                self.refuse(&span, reason);
                return None;
            };
            let Some(t) = e.get_ref().as_str() else {
                let reason = format!(
                    "{name}: expected a network \"a.b.c.d/prefix\", found {}",
                    e.get_ref().type_str()
                );
                self.refuse(&span, reason);
                ok = false;
                continue;
            };
            // The one allow-list grammar (the web form's too).
            match AllowEntry::parse(t) {
                Ok(entry) => *slot = entry,
                Err(_) => {
                    let reason = format!(
                        "{name}: \"{t}\" is not a network a.b.c.d/prefix (prefix 1-32; a.b.c.d alone = /32)"
                    );
                    self.refuse(&span, reason);
                    ok = false;
                }
            }
        }
        ok.then_some(list)
    }

    fn trigger(&mut self, key: &str, key_span: &Span, value: &Spanned<DeValue<'_>>) {
        let Some(n) = (0..TRIGGERS).find(|n| n.to_string() == key) else {
            let reason = format!(
                "unknown trigger entry \"{key}\": the entries are 0 to {}",
                TRIGGERS - 1
            );
            self.refuse(key_span, reason);
            return;
        };
        let span = value.span();
        let bytes: Vec<u8> = match value.get_ref() {
            DeValue::String(s) => s.as_bytes().to_vec(),
            DeValue::Array(a) => {
                let mut bytes = Vec::new();
                for b in a.iter() {
                    match b
                        .get_ref()
                        .as_integer()
                        .and_then(|i| u8::from_str_radix(i.as_str(), i.radix()).ok())
                    {
                        Some(b) => bytes.push(b),
                        None => {
                            let reason = format!("triggers.{n}: a byte is an integer 1-255");
                            self.refuse(&b.span(), reason);
                            return;
                        }
                    }
                }
                bytes
            }
            v => {
                let reason = format!(
                    "triggers.{n} (TRIG{n}_TEXT): expected a string, found {}",
                    v.type_str()
                );
                self.refuse(&span, reason);
                return;
            }
        };
        if bytes.len() > TRIGGER_TEXT {
            let reason = format!(
                "triggers.{n} (TRIG{n}_TEXT): {} bytes, at most {TRIGGER_TEXT}",
                bytes.len()
            );
            self.refuse(&span, reason);
        } else if bytes.contains(&0) {
            let reason = format!("triggers.{n} (TRIG{n}_TEXT): a NUL character would end the text");
            self.refuse(&span, reason);
        } else if let Some(e) = self.contents.triggers.get_mut(n) {
            e.set(&bytes);
        }
    }

    fn password(&mut self, value: &Spanned<DeValue<'_>>) {
        let span = value.span();
        let form = format!(
            "\"{SCHEME}$ROUNDS$SALT$HASH\" (salt {SALT_LEN} and hash {HASH_LEN} bytes in hex)"
        );
        let Some(s) = value.get_ref().as_str() else {
            let reason = format!(
                "access.password: expected the salted hash {form}, found {}",
                value.get_ref().type_str()
            );
            self.refuse(&span, reason);
            return;
        };
        match parse_hash(s) {
            Some(hash) => {
                // The previous version's one password: the administrator
                // the binary image migrates it to, too.
                let name = UserName::new(hans_gateway::storage::image::MIGRATED_ADMIN.as_bytes());
                let added = name.map(|name| {
                    self.contents.stored.accounts.add(Account {
                        name,
                        role: Role::Admin,
                        hash,
                    })
                });
                if !matches!(added, Some(Ok(_))) {
                    let reason = "access.password: an account \"admin\" is in access.accounts too (password is the previous version's key: remove it)".to_owned();
                    self.refuse(&span, reason);
                }
            }
            None => {
                let reason = format!(
                    "access.password: not a salted hash {form} with 1 to {} rounds (the file never holds the password itself: set it on the web page)",
                    10 * ITERATIONS
                );
                self.refuse(&span, reason);
            }
        }
    }
}

impl Reader<'_> {
    /// `accounts = [{ name = "...", role = "admin", password = "pbkdf2-sha256$..." }, ...]`.
    fn accounts(&mut self, value: &Spanned<DeValue<'_>>) {
        let span = value.span();
        let form = "an array of { name = \"...\", role = \"viewer\" | \"operator\" | \"admin\", password = \"pbkdf2-sha256$ROUNDS$SALT$HASH\" }";
        let Some(list) = value.get_ref().as_array() else {
            self.refuse(&span, format!("access.accounts: expected {form}"));
            return;
        };
        for item in list.iter() {
            let at = item.span();
            match account(item.get_ref()) {
                Ok((a, trusted)) => match self.contents.stored.accounts.add(a) {
                    Ok(i) => self.contents.stored.accounts.set_trusted(i, trusted),
                    Err(e) => self.refuse(&at, format!("access.accounts: {}", e.as_str())),
                },
                Err(why) => self.refuse(&at, format!("access.accounts: {why}; expected {form}")),
            }
        }
        let accounts = &self.contents.stored.accounts;
        if !accounts.is_empty() && !accounts.admin_exists() {
            self.refuse(&span, "access.accounts: none is an admin (the first account is one, and the last stays one)".to_owned());
        }
    }
}

/// One account of `access.accounts` and its own addresses, or why not.
fn account(v: &DeValue<'_>) -> Result<(Account, Trusted), String> {
    let t = v.as_table().ok_or("an account is a table")?;
    let mut name = None;
    let mut role = None;
    let mut hash = None;
    let mut trusted: Trusted = [None; TRUSTED];
    for (k, v) in t.iter() {
        let text = v.get_ref().as_str();
        match k.get_ref().as_ref() {
            "name" => {
                name = Some(
                    text.and_then(|s| UserName::new(s.as_bytes()))
                        .ok_or("a name is 1 to 16 of a-z 0-9 . _ - beginning with a letter")?,
                )
            }
            "role" => role = Some(text.and_then(Role::parse).ok_or("unknown role")?),
            "password" => {
                hash = Some(text.and_then(parse_hash).ok_or(
                    "the password is a salted hash (the file never holds the password itself)",
                )?)
            }
            "trusted" => {
                let why = format!(
                    "trusted is an array of up to {TRUSTED} addresses \"a.b.c.d\" (the addresses the account last logged in from; the gateway keeps it)"
                );
                let list = v.get_ref().as_array().ok_or(why.clone())?;
                if list.len() > TRUSTED {
                    return Err(why);
                }
                for (slot, ip) in trusted.iter_mut().zip(list.iter()) {
                    let ip = ip
                        .get_ref()
                        .as_str()
                        .and_then(|s| s.parse::<std::net::Ipv4Addr>().ok())
                        .filter(|ip| !ip.is_unspecified())
                        .ok_or(why.clone())?;
                    *slot = Some(ip);
                }
            }
            other => return Err(format!("unknown key \"{other}\"")),
        }
    }
    match (name, role, hash) {
        (Some(name), Some(role), Some(hash)) => Ok((Account { name, role, hash }, trusted)),
        _ => Err("name, role and password are needed".to_owned()),
    }
}

/// `pbkdf2-sha256$ROUNDS$SALT$HASH`, the rounds checked as the binary
/// image's are ([`PasswordHash::from_bytes`]).
fn parse_hash(s: &str) -> Option<PasswordHash> {
    let mut parts = s.split('$');
    let (scheme, rounds, salt, hash) = (parts.next()?, parts.next()?, parts.next()?, parts.next()?);
    if scheme != SCHEME || parts.next().is_some() {
        return None;
    }
    let h = PasswordHash {
        iterations: rounds.parse().ok()?,
        salt: unhex(salt)?,
        hash: unhex(hash)?,
    };
    PasswordHash::from_bytes(&h.to_bytes())
}

fn unhex<const N: usize>(s: &str) -> Option<[u8; N]> {
    let mut out = [0u8; N];
    hans_gateway::hex::decode(s.as_bytes(), &mut out)?;
    Some(out)
}
