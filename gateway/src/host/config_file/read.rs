//! Reading the file: toml's spanned parse tree, walked key by key with
//! [`KEYS`]; each value becomes its setting's registers and is checked by
//! the setting's domain where it is written, so that every problem is
//! reported with its place.

extern crate std;

use core::net::Ipv4Addr;
use std::borrow::{Cow, ToOwned};
use std::format;
use std::string::{String, ToString};
use std::vec::Vec;

use toml::de::{DeTable, DeValue};
use toml::Spanned;

use super::{
    field_of_key, quoted, takes, Contents, Form, Key, Problem, KEYS, PASSWORD, SCHEME, TABLES,
};
use crate::access::password::{PasswordHash, HASH_LEN, ITERATIONS, SALT_LEN};
use crate::config::{field_of, ipv4_words, Config, Field, Words, ALLOW_ENTRIES};
use crate::state::inputs::{TRIGGERS, TRIGGER_TEXT};

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
        words: defaults.to_words(),
        contents: Contents::new(*defaults),
        found: [None; KEYS.len()],
        problems: Vec::new(),
    };
    for (name, value) in doc.get_ref().iter() {
        r.table(name, value);
    }
    match Config::from_words(&r.words) {
        Ok(config) => r.contents.stored.config = config,
        // A key out of range was reported where it was read.
        Err(_) if !r.problems.is_empty() => {}
        Err(e) => {
            // Each key's registers were checked as it was read; the whole
            // check stays the last word (and names the key if it differs).
            let at = KEYS
                .iter()
                .zip(&r.found)
                .find(|(k, _)| {
                    field_of_key(k).is_some_and(|f| f.addr <= e.addr && e.addr < f.addr + f.len)
                })
                .and_then(|(_, at)| *at);
            let name = field_of(e.addr).map_or("a setting", |f| f.name);
            let reason = format!("{name} (register {}) is out of range", e.addr);
            r.problems.push(problem(text, at.unwrap_or(0), reason));
        }
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
    let tables: Vec<String> = KEYS
        .iter()
        .filter(|k| k.key == key)
        .map(|k| format!("[{}]", k.table))
        .collect();
    (!tables.is_empty()).then(|| tables.join(" or "))
}

/// The state of a read: the settings' registers so far, what was found.
struct Reader<'t> {
    text: &'t str,
    words: Words,
    contents: Contents,
    /// Where each key of [`KEYS`] was found.
    found: [Option<usize>; KEYS.len()],
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
        if !TABLES.contains(&n) {
            let reason = match tables_of(n) {
                Some(tables) => {
                    format!("unknown key \"{n}\" outside the tables (it goes in {tables})")
                }
                None => format!(
                    "unknown table [{n}]; the tables are {}",
                    TABLES.map(|t| format!("[{t}]")).join(", ")
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
            } else if let Some(i) = KEYS.iter().position(|x| x.table == n && x.key == kn) {
                self.setting(i, v);
            } else {
                let reason = match tables_of(kn) {
                    Some(tables) => format!("unknown key \"{kn}\" in [{n}] (it goes in {tables})"),
                    None => {
                        let mut keys: Vec<&str> = KEYS
                            .iter()
                            .filter(|x| x.table == n)
                            .map(|x| x.key)
                            .collect();
                        if n == "access" {
                            keys.push(PASSWORD);
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

    /// Key `i` of [`KEYS`]: its value into its setting's registers, checked
    /// by the setting's domain.
    fn setting(&mut self, i: usize, value: &Spanned<DeValue<'_>>) {
        let (Some(k), Some(f)) = (KEYS.get(i), KEYS.get(i).and_then(field_of_key)) else {
            return;
        };
        let span = value.span();
        if let Some(slot) = self.found.get_mut(i) {
            *slot = Some(span.start);
        }
        let name = format!("{}.{}", k.table, k.key);
        let Some(words) = self.value_words(k, f, &name, value) else {
            return;
        };
        let s = usize::from(f.slot);
        if let Some(regs) = self.words.get_mut(s..s + usize::from(f.len)) {
            for (r, w) in regs.iter_mut().zip(&words) {
                *r = *w;
            }
        }
        let regs = self.words.get(s..s + usize::from(f.len)).unwrap_or(&[]);
        if let Err(rel) = f.domain.check(regs) {
            // An allow-list names its entry (three registers each).
            let at = match (k.form, value.get_ref().as_array()) {
                (Form::AllowList, Some(a)) => a
                    .get(usize::from(rel / 3))
                    .map_or(span.clone(), |e| e.span()),
                _ => span.clone(),
            };
            let written = self.written(&at).to_owned();
            let reason = format!(
                "{name} = {written}: out of range, {} takes {} ({})",
                f.name,
                takes(k, f),
                f.help
            );
            self.refuse(&at, reason);
        }
    }

    /// The registers of a key's value (for a bit: its whole register), or
    /// `None` after reporting why there are none.
    fn value_words(
        &mut self,
        k: &Key,
        f: &Field,
        name: &str,
        value: &Spanned<DeValue<'_>>,
    ) -> Option<Vec<u16>> {
        let span = value.span();
        let v = value.get_ref();
        let wrong_type = |what: &str| format!("{name}: expected {what}, found {}", v.type_str());
        let at = usize::from(f.slot);
        match k.form {
            Form::Number => {
                let Some(n) = v.as_integer() else {
                    self.refuse(&span, wrong_type("an integer"));
                    return None;
                };
                match i64::from_str_radix(n.as_str(), n.radix())
                    .ok()
                    .and_then(|n| u16::try_from(n).ok())
                {
                    Some(n) => Some(std::vec![n]),
                    None => {
                        let reason = format!(
                            "{name} = {}: out of range, {} takes {} ({})",
                            self.written(&span),
                            f.name,
                            takes(k, f),
                            f.help
                        );
                        self.refuse(&span, reason);
                        None
                    }
                }
            }
            Form::Flag | Form::Bit(_) => {
                let Some(on) = v.as_bool() else {
                    self.refuse(&span, wrong_type("true or false"));
                    return None;
                };
                Some(std::vec![match k.form {
                    Form::Bit(b) => {
                        let w = self.words.get(at).copied().unwrap_or(0) & !(1 << b);
                        w | (u16::from(on) << b)
                    }
                    _ => u16::from(on),
                }])
            }
            Form::Word(words) => {
                let choices = quoted(words);
                let Some(s) = v.as_str() else {
                    self.refuse(&span, wrong_type(&format!("one of {choices}")));
                    return None;
                };
                match words.iter().position(|w| *w == s) {
                    Some(i) => Some(std::vec![i as u16]),
                    None => {
                        let reason = format!("{name} = \"{s}\" is not one of {choices}");
                        self.refuse(&span, reason);
                        None
                    }
                }
            }
            Form::Address => {
                let Some(s) = v.as_str() else {
                    self.refuse(&span, wrong_type("an address \"a.b.c.d\""));
                    return None;
                };
                match s.parse::<Ipv4Addr>() {
                    Ok(ip) => Some(ipv4_words(ip).to_vec()),
                    Err(_) => {
                        let reason = format!("{name} = \"{s}\" is not an IPv4 address a.b.c.d");
                        self.refuse(&span, reason);
                        None
                    }
                }
            }
            Form::AllowList => self.allow_list(name, value),
        }
    }

    fn allow_list(&mut self, name: &str, value: &Spanned<DeValue<'_>>) -> Option<Vec<u16>> {
        let Some(entries) = value.get_ref().as_array() else {
            let reason = format!(
                "{name}: expected an array of \"a.b.c.d/prefix\" strings, found {}",
                value.get_ref().type_str()
            );
            self.refuse(&value.span(), reason);
            return None;
        };
        let mut words = std::vec![0u16; 3 * ALLOW_ENTRIES];
        let mut ok = true;
        for (i, e) in entries.iter().enumerate() {
            let span = e.span();
            if i >= ALLOW_ENTRIES {
                let reason = format!("{name}: at most {ALLOW_ENTRIES} entries");
                self.refuse(&span, reason);
                return None;
            }
            let Some(s) = e.get_ref().as_str() else {
                let reason = format!(
                    "{name}: expected a network \"a.b.c.d/prefix\", found {}",
                    e.get_ref().type_str()
                );
                self.refuse(&span, reason);
                ok = false;
                continue;
            };
            let (ip, prefix) = s.split_once('/').unwrap_or((s, "32"));
            // The prefix is checked by the list's domain (1-32 here: 0
            // would be an unused entry).
            match (ip.parse::<Ipv4Addr>(), prefix.parse::<u16>()) {
                (Ok(ip), Ok(p)) if p > 0 => {
                    let [a, b] = ipv4_words(ip);
                    for (w, v) in words.iter_mut().skip(3 * i).zip([a, b, p]) {
                        *w = v;
                    }
                }
                _ => {
                    let reason = format!(
                        "{name}: \"{s}\" is not a network a.b.c.d/prefix (prefix 1-32; a.b.c.d alone = /32)"
                    );
                    self.refuse(&span, reason);
                    ok = false;
                }
            }
        }
        ok.then_some(words)
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
            Some(h) => self.contents.stored.password = Some(h),
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
    if s.len() != 2 * N || !s.is_ascii() {
        return None;
    }
    for (b, pair) in out.iter_mut().zip(s.as_bytes().chunks(2)) {
        *b = u8::from_str_radix(core::str::from_utf8(pair).ok()?, 16).ok()?;
    }
    Some(out)
}
