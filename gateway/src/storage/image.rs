//! The stored image: the configuration, the trigger table and the web
//! page's accounts.
//!
//! Format 5 (written since the accounts' own addresses; format 4 the same
//! without them; format 3 the same up to the triggers, then one password
//! instead of the accounts):
//!
//! | offset | bytes | content |
//! |---|---|---|
//! | 0 | 4 | magic `HGW1` |
//! | 4 | 2 | format version 5 |
//! | 6 | 2 | S, the bytes of the settings that follow |
//! | 8 | S | each setting: its stable id (2), the value's length L (1), the value (L) |
//! | 8 + S | 3072 | the 16 trigger entries, 96 registers each |
//! | 3080 + S | 1 | N, the accounts that follow (at most 8) |
//! | 3081 + S | 70 N | each account: name length (1), name (16, zero-padded), role (1: 1 viewer, 2 operator, 3 admin), password: PBKDF2 rounds, salt, hash (52) |
//! | 3081 + S + 70 N | 16 N | each account's own addresses (`access::accounts::TRUSTED`: 4 of 4 octets, the most recent first; 0.0.0.0 = none), in the accounts' order |
//! | 3081 + S + 86 N | 4 | CRC-32 (IEEE) of everything before |
//!
//! Format 4 (the previous version's) is read: its accounts have no own
//! addresses yet.
//!
//! A value is stored by its kind: a number as 2 bytes, a flag or a choice
//! (its index) as 1, an address or mask as its 4 octets, an allow-list as
//! 4 entries of 4 octets and a prefix, a host name as its bytes. Settings
//! are keyed by id, so renumbering a register changes nothing here, a later
//! version that adds settings reads an older image (the new settings take
//! their defaults), and an older version skips ids it does not know.
//!
//! Format 3 (the settings schema's first) held one password (52 bytes:
//! PBKDF2 rounds, 0 = none, salt, hash) where format 4 holds the accounts:
//! a password it holds becomes the administrator account `admin`.
//! Formats 2 (register map 1.2: settings as register address and value
//! pairs) and 1 (register map 1.1: the 16 registers 100-115 in order, no
//! password) are read through the register view and migrated: the next
//! save writes format 5.
//!
//! Numbers little-endian; a trigger entry's register holds two characters,
//! the first in its high byte (as the PLC sees them). An image that fails
//! any check (length, magic, version, CRC, a value out of range) is refused
//! as a whole: nothing of it is used.

use super::StorageError;
use crate::access::accounts::{
    Account, AccountError, Accounts, Role, UserName, ACCOUNTS, ACCOUNT_STORED, TRUSTED,
};
use crate::access::password::{PasswordHash, STORED_LEN};
use crate::config::schema::{self, stored_len, Kind, Value};
use crate::config::{AllowEntry, AllowList, Config, HostName, SETTINGS};
use crate::crc::crc32;
use crate::registers::config::{self as reg, Layout};
use crate::state::inputs::{Text, TRIGGERS, TRIGGER_TEXT};

const MAGIC: &[u8; 4] = b"HGW1";
const FORMAT: u16 = 5;
/// Bytes of one account's own addresses (format 5).
const TRUSTED_STORED: usize = 4 * TRUSTED;
/// The name of the administrator a format-3 password becomes.
pub const MIGRATED_ADMIN: &str = "admin";
const TRIGGER_WORDS: usize = TRIGGERS * TRIGGER_TEXT / 2;
const TRIGGER_BYTES: usize = TRIGGER_WORDS * 2;

/// Bytes of the settings section at their longest.
// Evaluated by the compiler: an index out of bounds fails the build.
#[allow(clippy::indexing_slicing)]
const SETTINGS_MAX: usize = {
    let mut n = 0;
    let mut i = 0;
    while i < SETTINGS.len() {
        n += 3 + stored_len(&SETTINGS[i].kind);
        i += 1;
    }
    n
};
/// The longest image this version writes (with the longest host names).
pub const IMAGE_LEN: usize =
    8 + SETTINGS_MAX + TRIGGER_BYTES + 1 + ACCOUNTS * (ACCOUNT_STORED + TRUSTED_STORED) + 4;
/// The longest image read (a newer version's, with more settings).
pub const IMAGE_MAX: usize = IMAGE_LEN + 1024;
/// Settings registers of a format-1 image (100-115).
const V1_CONFIG: usize = 16;
const V1_WORDS: usize = V1_CONFIG + TRIGGER_WORDS;
const V1_LEN: usize = 8 + V1_WORDS * 2 + 4;

/// The trigger entries as stored.
pub type Entries = [Text<TRIGGER_TEXT>; TRIGGERS];

/// What an image holds besides the trigger entries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Stored {
    /// The configuration.
    pub config: Config,
    /// The web page's accounts.
    pub accounts: Accounts,
}

/// Writes the image of `stored` and the trigger `entries` into `out` and
/// returns its length (at most [`IMAGE_LEN`]).
pub fn encode(stored: &Stored, entries: &Entries, out: &mut [u8]) -> Result<usize, StorageError> {
    let mut w = Writer { out, at: 8 };
    for s in SETTINGS {
        let mut v = [0u8; HostName::MAX];
        let n = put_value(&s.get(&stored.config), &mut v);
        w.put(&s.id.to_le_bytes());
        w.put(&[n as u8]);
        w.put(v.get(..n).unwrap_or(&[]));
    }
    let settings = w.at - 8;
    for e in entries {
        for i in 0..TRIGGER_TEXT / 2 {
            w.put(&e.word(i).to_le_bytes());
        }
    }
    w.put(&[stored.accounts.len() as u8]);
    for a in stored.accounts.iter() {
        w.put(&a.to_bytes());
    }
    for i in (0..ACCOUNTS).filter(|&i| stored.accounts.at(i).is_some()) {
        for t in stored.accounts.trusted(i) {
            w.put(&t.unwrap_or(core::net::Ipv4Addr::UNSPECIFIED).octets());
        }
    }
    let body = w.at;
    w.at = 0;
    w.put(MAGIC);
    w.put(&FORMAT.to_le_bytes());
    w.put(&(settings as u16).to_le_bytes());
    let crc = crc32(w.out.get(..body).ok_or(StorageError::TooLarge)?);
    w.at = body;
    w.put(&crc.to_le_bytes());
    if w.at > w.out.len() {
        return Err(StorageError::TooLarge);
    }
    Ok(w.at)
}

/// Writes `v` as stored; returns its length.
fn put_value(v: &Value, out: &mut [u8]) -> usize {
    let mut w = Writer { out, at: 0 };
    match v {
        Value::Number(n) => w.put(&n.to_le_bytes()),
        Value::Flag(b) => w.put(&[u8::from(*b)]),
        Value::Choice(i) => w.put(&[*i]),
        Value::Address(ip) => w.put(&ip.octets()),
        Value::AllowList(l) => {
            for e in &l.0 {
                w.put(&e.ip.octets());
                w.put(&[e.prefix]);
            }
        }
        Value::Host(h) => w.put(h.as_bytes()),
    }
    w.at
}

/// Reads a stored value of `kind` (of exactly its length), unchecked.
fn get_value(kind: &Kind, b: &[u8]) -> Option<Value> {
    let fixed = stored_len(kind);
    if !matches!(kind, Kind::Host) && b.len() != fixed {
        return None;
    }
    let octets = |at: usize| -> Option<core::net::Ipv4Addr> {
        let o: [u8; 4] = b.get(at..at + 4)?.try_into().ok()?;
        Some(o.into())
    };
    Some(match kind {
        Kind::Number { .. } => Value::Number(u16::from_le_bytes(b.try_into().ok()?)),
        Kind::Flag => match b {
            [0] => Value::Flag(false),
            [1] => Value::Flag(true),
            _ => return None,
        },
        Kind::Choice(_) => Value::Choice(*b.first()?),
        Kind::Address | Kind::Mask => Value::Address(octets(0)?),
        Kind::AllowList => {
            let mut l = AllowList::EVERYONE;
            for (k, e) in l.0.iter_mut().enumerate() {
                *e = AllowEntry {
                    ip: octets(5 * k)?,
                    prefix: *b.get(5 * k + 4)?,
                };
            }
            Value::AllowList(l)
        }
        Kind::Host => Value::Host(HostName::from_bytes(b)?),
    })
}

struct Writer<'a> {
    out: &'a mut [u8],
    at: usize,
}

impl Writer<'_> {
    /// Writes `b` at the cursor; past the end nothing is written, but the
    /// cursor moves on (the caller compares it with the buffer's length).
    fn put(&mut self, b: &[u8]) {
        if let Some(dst) = self.out.get_mut(self.at..self.at + b.len()) {
            dst.copy_from_slice(b);
        }
        self.at += b.len();
    }
}

/// Why a stored image was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ImageError {
    /// Wrong length, magic or format version.
    Format,
    /// The CRC does not match.
    Crc,
    /// A setting's value is out of range (its key).
    Invalid(&'static str),
    /// An account is invalid (name, role, hash), named twice, or none of
    /// them is an administrator.
    Accounts,
}

impl ImageError {
    /// A short text for logs.
    pub fn as_str(self) -> &'static str {
        match self {
            ImageError::Format => "not an image of this format",
            ImageError::Crc => "CRC mismatch (damaged)",
            ImageError::Invalid(_) => "a setting out of range",
            ImageError::Accounts => "an invalid account",
        }
    }
}

fn word(b: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([
        b.get(at).copied().unwrap_or(0),
        b.get(at + 1).copied().unwrap_or(0),
    ])
}

/// Reads an image: the configuration (settings it does not hold keep
/// their values in `defaults`) and the password are returned, the trigger
/// texts are written into `entries`. Nothing is changed on error.
pub fn decode(
    image: &[u8],
    defaults: &Config,
    entries: &mut Entries,
) -> Result<Stored, ImageError> {
    if image.len() < 8 + 4 || image.len() > IMAGE_MAX || image.get(..4) != Some(&MAGIC[..]) {
        return Err(ImageError::Format);
    }
    let (body, crc) = image.split_at(image.len() - 4);
    let format = word(image, 4);
    let n = usize::from(word(image, 6));
    let (settings_end, expected_len) = match format {
        1 if n == V1_WORDS => (8 + 2 * V1_CONFIG, V1_LEN),
        2 => (8 + 4 * n, 8 + 4 * n + TRIGGER_BYTES + STORED_LEN + 4),
        3 => (8 + n, 8 + n + TRIGGER_BYTES + STORED_LEN + 4),
        4 | 5 => {
            let count = usize::from(image.get(8 + n + TRIGGER_BYTES).copied().unwrap_or(0));
            if count > ACCOUNTS {
                return Err(ImageError::Format);
            }
            let each = match format {
                4 => ACCOUNT_STORED,
                _ => ACCOUNT_STORED + TRUSTED_STORED,
            };
            (8 + n, 8 + n + TRIGGER_BYTES + 1 + count * each + 4)
        }
        _ => return Err(ImageError::Format),
    };
    if image.len() != expected_len {
        return Err(ImageError::Format);
    }
    if crc != crc32(body).to_le_bytes() {
        return Err(ImageError::Crc);
    }
    let settings = image.get(8..settings_end).unwrap_or(&[]);
    let config = match format {
        3..=5 => read_settings(settings, defaults)?,
        _ => migrate(format, settings, defaults)?,
    };
    let at = settings_end + TRIGGER_BYTES;
    let accounts = match format {
        4 | 5 => read_accounts(image.get(at..body.len()).unwrap_or(&[]), format == 5)?,
        2 | 3 => migrate_password(image.get(at..at + STORED_LEN)),
        _ => Accounts::NONE,
    };
    for (k, e) in entries.iter_mut().enumerate() {
        for i in 0..TRIGGER_TEXT / 2 {
            e.set_word(i, word(image, settings_end + k * TRIGGER_TEXT + 2 * i));
        }
    }
    Ok(Stored { config, accounts })
}

/// The accounts of formats 4 and 5 (count, then each; in format 5
/// `trusted`, then each one's own addresses); an invalid one refuses the
/// image.
fn read_accounts(b: &[u8], trusted: bool) -> Result<Accounts, ImageError> {
    let mut accounts = Accounts::NONE;
    let count = usize::from(b.first().copied().unwrap_or(0));
    let records = b.get(1..1 + count * ACCOUNT_STORED).unwrap_or(&[]);
    let addresses = b.get(1 + count * ACCOUNT_STORED..).unwrap_or(&[]);
    for (k, record) in records.chunks(ACCOUNT_STORED).enumerate() {
        let a = Account::from_bytes(record).ok_or(ImageError::Accounts)?;
        let i = accounts.add(a).map_err(|_| ImageError::Accounts)?;
        if trusted {
            let own = addresses
                .get(k * TRUSTED_STORED..(k + 1) * TRUSTED_STORED)
                .ok_or(ImageError::Format)?;
            let mut list = [None; TRUSTED];
            for (slot, o) in list.iter_mut().zip(own.chunks(4)) {
                let ip = core::net::Ipv4Addr::new(
                    o.first().copied().unwrap_or(0),
                    o.get(1).copied().unwrap_or(0),
                    o.get(2).copied().unwrap_or(0),
                    o.get(3).copied().unwrap_or(0),
                );
                *slot = (!ip.is_unspecified()).then_some(ip);
            }
            accounts.set_trusted(i, list);
        }
    }
    if !accounts.is_empty() && !accounts.admin_exists() {
        return Err(ImageError::Accounts);
    }
    Ok(accounts)
}

/// The password of formats 2 and 3: the administrator [`MIGRATED_ADMIN`].
fn migrate_password(b: Option<&[u8]>) -> Accounts {
    let mut accounts = Accounts::NONE;
    let hash = b
        .and_then(|b| b.try_into().ok())
        .and_then(PasswordHash::from_bytes);
    if let (Some(hash), Some(name)) = (hash, UserName::new(MIGRATED_ADMIN.as_bytes())) {
        let r: Result<usize, AccountError> = accounts.add(Account {
            name,
            role: Role::Admin,
            hash,
        });
        debug_assert!(r.is_ok());
    }
    accounts
}

/// Format 3's settings over `defaults`; ids this version does not know
/// are skipped.
fn read_settings(mut b: &[u8], defaults: &Config) -> Result<Config, ImageError> {
    let mut c = *defaults;
    while !b.is_empty() {
        let (Some(&[i0, i1, len]), Some(rest)) = (b.get(..3), b.get(3..)) else {
            return Err(ImageError::Format);
        };
        let id = u16::from_le_bytes([i0, i1]);
        let value = rest.get(..usize::from(len)).ok_or(ImageError::Format)?;
        b = rest.get(usize::from(len)..).unwrap_or(&[]);
        let Some(s) = schema::by_id(id) else { continue };
        let v = get_value(&s.kind, value).ok_or(ImageError::Invalid(s.key))?;
        s.set(&mut c, v).map_err(|_| ImageError::Invalid(s.key))?;
    }
    Ok(c)
}

/// Formats 1 and 2 held the settings' registers: they are laid over the
/// registers of `defaults` and read through the register view.
fn migrate(format: u16, b: &[u8], defaults: &Config) -> Result<Config, ImageError> {
    let mut words = reg::encode(defaults);
    if format == 1 {
        for (i, slot) in words.iter_mut().take(V1_CONFIG).enumerate() {
            *slot = word(b, 2 * i);
        }
    } else {
        for at in (0..b.len()).step_by(4) {
            // Registers this version does not know are skipped.
            if let Some(slot) = reg::slot_of(word(b, at)).and_then(|s| words.get_mut(s)) {
                *slot = word(b, at + 2);
            }
        }
    }
    reg::decode(&words, defaults).map_err(|bad| {
        let key = match reg::register_at(bad.addr).map(|g| g.layout) {
            Some(Layout::Value(s)) => s.key,
            Some(Layout::Bits(flags)) => flags.first().map_or("?", |s| s.key),
            None => "?",
        };
        ImageError::Invalid(key)
    })
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use crate::access::accounts::NAME_MAX;
    use crate::access::password::{HASH_LEN, SALT_LEN};
    use crate::config::schema::{LINK_POLL_MS, MQTT_BROKER};
    use crate::registers::map as r;
    use core::net::Ipv4Addr;
    use std::vec::Vec;

    fn sample() -> (Stored, Entries) {
        let mut entries: Entries = [Text::EMPTY; TRIGGERS];
        entries[3].set(b"GrpStop,0,;");
        entries[15].set(b"SetBoxDO,1,1,;");
        let mut config = Config {
            robot_port: 4242,
            write_protect: true,
            ..Config::default()
        };
        config.net.ip = Ipv4Addr::new(10, 0, 0, 9);
        config.web_allow.0[0] = AllowEntry {
            ip: Ipv4Addr::new(10, 0, 0, 0),
            prefix: 8,
        };
        let mut accounts = Accounts::NONE;
        for (name, role) in [("root", Role::Admin), ("cell-op", Role::Operator)] {
            accounts
                .add(Account {
                    name: UserName::new(name.as_bytes()).unwrap(),
                    role,
                    hash: PasswordHash {
                        iterations: 1234,
                        salt: [5; SALT_LEN],
                        hash: [name.len() as u8; HASH_LEN],
                    },
                })
                .unwrap();
        }
        (Stored { config, accounts }, entries)
    }

    fn image(stored: &Stored, entries: &Entries) -> Vec<u8> {
        let mut img = std::vec![0u8; IMAGE_LEN];
        let n = encode(stored, entries, &mut img).unwrap();
        img.truncate(n);
        img
    }

    /// Replaces the CRC after an edit.
    fn reseal(img: &mut [u8]) {
        let n = img.len() - 4;
        let crc = crc32(&img[..n]);
        img[n..].copy_from_slice(&crc.to_le_bytes());
    }

    #[test]
    fn image_round_trip_and_corruption() {
        let (mut stored, entries) = sample();
        MQTT_BROKER
            .parse_into("broker.plant.local", &mut stored.config)
            .unwrap();
        let img = image(&stored, &entries);
        assert!(img.len() <= IMAGE_LEN);
        assert_eq!(word(&img, 4), 5);
        assert_eq!(
            encode(&stored, &entries, &mut [0u8; 100]),
            Err(StorageError::TooLarge)
        );
        let mut back: Entries = [Text::EMPTY; TRIGGERS];
        assert_eq!(decode(&img, &Config::DEFAULT, &mut back), Ok(stored));
        assert_eq!(back, entries);
        let mut bad = img.clone();
        bad[100] ^= 1;
        let mut untouched: Entries = [Text::EMPTY; TRIGGERS];
        assert_eq!(
            decode(&bad, &Config::DEFAULT, &mut untouched),
            Err(ImageError::Crc)
        );
        assert_eq!(untouched, [Text::EMPTY; TRIGGERS]);
        assert_eq!(
            decode(&img[..10], &Config::DEFAULT, &mut back),
            Err(ImageError::Format)
        );
        let none = Stored {
            accounts: Accounts::NONE,
            ..stored
        };
        // Accounts without an administrator, or an invalid one, refuse
        // the image.
        let mut no_admin = stored;
        no_admin.accounts.set_role(b"cell-op", Role::Admin).unwrap();
        no_admin.accounts.set_role(b"root", Role::Viewer).unwrap();
        let mut img2 = image(&no_admin, &entries);
        let role_at = img2.len() - 4 - 2 * TRUSTED_STORED - ACCOUNT_STORED + 1 + NAME_MAX;
        assert_eq!(img2[role_at], Role::Admin as u8);
        img2[role_at] = Role::Viewer as u8;
        reseal(&mut img2);
        assert_eq!(
            decode(&img2, &Config::DEFAULT, &mut back),
            Err(ImageError::Accounts)
        );
        img2[role_at] = 7;
        reseal(&mut img2);
        assert_eq!(
            decode(&img2, &Config::DEFAULT, &mut back),
            Err(ImageError::Accounts)
        );
        assert_eq!(
            decode(&image(&none, &entries), &Config::DEFAULT, &mut back),
            Ok(none)
        );
        // The longest image fits IMAGE_LEN exactly.
        let mut longest = stored;
        for k in 0..ACCOUNTS - 2 {
            let name = std::format!("account-{k}");
            let mut a = *stored.accounts.get(b"root").unwrap();
            a.name = UserName::new(name.as_bytes()).unwrap();
            longest.accounts.add(a).unwrap();
        }
        let name = "h".repeat(HostName::MAX);
        for s in SETTINGS.iter().filter(|s| matches!(s.kind, Kind::Host)) {
            s.parse_into(&name, &mut longest.config).unwrap();
        }
        assert_eq!(image(&longest, &entries).len(), IMAGE_LEN);
    }

    /// Issue 25: the addresses an account logged in from are kept with it
    /// (format 5), and the previous version's format 4 (without them)
    /// still reads.
    #[test]
    fn the_accounts_own_addresses_are_kept_and_format_4_still_reads() {
        let (mut stored, entries) = sample();
        let root = stored.accounts.index_of(b"root").unwrap();
        let op = stored.accounts.index_of(b"cell-op").unwrap();
        assert!(stored.accounts.trust(root, Ipv4Addr::new(10, 0, 0, 50)));
        assert!(stored.accounts.trust(root, Ipv4Addr::new(10, 0, 0, 51)));
        assert!(!stored.accounts.trust(root, Ipv4Addr::new(10, 0, 0, 50)));
        assert!(stored.accounts.trust(op, Ipv4Addr::new(192, 168, 1, 7)));
        let img = image(&stored, &entries);
        let mut back: Entries = [Text::EMPTY; TRIGGERS];
        let got = decode(&img, &Config::DEFAULT, &mut back).unwrap();
        assert_eq!(got, stored);
        assert_eq!(
            got.accounts
                .own_address(root, Some(Ipv4Addr::new(10, 0, 0, 50))),
            Some(1)
        );
        // The same image as format 4 wrote it: the own addresses left out.
        let mut v4 = img[..img.len() - 4 - 2 * TRUSTED_STORED].to_vec();
        v4[4..6].copy_from_slice(&4u16.to_le_bytes());
        v4.extend_from_slice(&[0; 4]);
        reseal(&mut v4);
        let got = decode(&v4, &Config::DEFAULT, &mut back).unwrap();
        assert_eq!(got.config, stored.config);
        assert_eq!(got.accounts.get(b"root"), stored.accounts.get(b"root"));
        assert_eq!(got.accounts.trusted(root), [None; TRUSTED]);
        // A format-5 image cut short of its addresses is refused.
        let mut short = img[..img.len() - 8].to_vec();
        short.extend_from_slice(&[0; 4]);
        reseal(&mut short);
        assert_eq!(
            decode(&short, &Config::DEFAULT, &mut back),
            Err(ImageError::Format)
        );
    }

    #[test]
    fn settings_are_keyed_by_id_unknown_ids_skipped_bad_values_refused() {
        let (stored, entries) = sample();
        let img = image(&stored, &entries);
        let n = usize::from(word(&img, 6));
        // A "newer" image: one more setting (id 999, 3 bytes) in front.
        let mut newer = img[..8].to_vec();
        newer[6..8].copy_from_slice(&(n as u16 + 6).to_le_bytes());
        newer.extend_from_slice(&[0xE7, 0x03, 3, 1, 2, 3]);
        newer.extend_from_slice(&img[8..]);
        reseal(&mut newer);
        let mut back: Entries = [Text::EMPTY; TRIGGERS];
        assert_eq!(decode(&newer, &Config::DEFAULT, &mut back), Ok(stored));
        // The poll period stored as 5 ms (below 10) refuses the whole image.
        let mut bad = img.clone();
        let mut at = 8;
        while word(&bad, at) != LINK_POLL_MS.id {
            at += 3 + usize::from(bad[at + 2]);
        }
        bad[at + 3..at + 5].copy_from_slice(&5u16.to_le_bytes());
        reseal(&mut bad);
        assert_eq!(
            decode(&bad, &Config::DEFAULT, &mut back),
            Err(ImageError::Invalid("link.poll_ms"))
        );
        // A value of the wrong length is refused too.
        let mut bad = img;
        bad[at + 2] = 1;
        assert!(decode(&bad, &Config::DEFAULT, &mut back).is_err());
    }

    /// A format-1 image (register map 1.1), built byte by byte as that
    /// version wrote it.
    #[test]
    fn a_format_1_image_is_read_with_defaults_for_the_new_settings() {
        let (stored, entries) = sample();
        let mut img = Vec::new();
        img.extend_from_slice(b"HGW1");
        img.extend_from_slice(&1u16.to_le_bytes());
        img.extend_from_slice(&(V1_WORDS as u16).to_le_bytes());
        for w in &reg::encode(&stored.config)[..16] {
            img.extend_from_slice(&w.to_le_bytes());
        }
        for e in &entries {
            for i in 0..TRIGGER_TEXT / 2 {
                img.extend_from_slice(&e.word(i).to_le_bytes());
            }
        }
        let crc = crc32(&img);
        img.extend_from_slice(&crc.to_le_bytes());
        assert_eq!(img.len(), 3116);
        let mut factory = Config::DEFAULT;
        factory.net.web_port = 8080;
        let mut back: Entries = [Text::EMPTY; TRIGGERS];
        let got = decode(&img, &factory, &mut back).unwrap();
        assert_eq!(got.config.robot_port, 4242);
        assert_eq!(got.config.net, factory.net);
        assert!(!got.config.write_protect);
        assert!(got.accounts.is_empty());
        assert_eq!(back, entries);
    }

    /// Images written by the firmware of register map 1.2 (format 2),
    /// stored as files by that build: a factory one and one with every
    /// setting changed, three trigger entries and a password.
    #[test]
    fn format_2_images_of_the_previous_firmware_are_migrated() {
        let factory = include_bytes!("../../tests/fixtures/image-format2-factory.bin");
        let full = include_bytes!("../../tests/fixtures/image-format2-full.bin");
        assert_eq!(word(full, 4), 2);
        let mut back: Entries = [Text::EMPTY; TRIGGERS];
        let got = decode(factory, &Config::DEFAULT, &mut back).unwrap();
        assert_eq!(got.config, Config::DEFAULT);
        assert!(got.accounts.is_empty());
        assert_eq!(back, [Text::EMPTY; TRIGGERS]);

        let got = decode(full, &Config::DEFAULT, &mut back).unwrap();
        let c = &got.config;
        let ip = Ipv4Addr::new;
        assert_eq!(
            c.robot(),
            core::net::SocketAddrV4::new(ip(192, 168, 0, 10), 10004)
        );
        assert_eq!(c.link_mode, crate::config::LinkMode::Listen);
        assert_eq!(
            (c.listen_port, c.poll_ms, c.reply_timeout_ms),
            (10007, 50, 2500)
        );
        assert_eq!(c.word_order, crate::config::WordOrder::LowFirst);
        assert_eq!(c.watchdog_ms, 500);
        assert_eq!(c.watchdog_action, crate::config::WatchdogAction::Pause);
        assert!(c.wait_blending_done && !c.wait_in_position && c.auto_reset);
        assert_eq!(c.start_grace_ms, 300);
        assert_eq!(c.status_source, crate::config::StatusSource::DataSheet);
        assert_eq!((c.datasheet_port, c.robot_id), (10006, 2));
        assert_eq!(c.protocol, crate::config::ProtocolSetting::V6);
        assert_eq!(c.net.ip, ip(10, 20, 30, 40));
        assert_eq!(c.net.mask, ip(255, 255, 0, 0));
        assert_eq!(c.net.gateway, ip(10, 20, 0, 1));
        assert!(c.net.dhcp && c.write_protect);
        assert_eq!((c.net.modbus_port, c.net.web_port), (5020, 8080));
        let mut text = std::string::String::new();
        c.modbus_allow.format(&mut text).unwrap();
        assert_eq!(text, "10.20.0.0/16 127.0.0.1/32");
        assert_eq!(c.web_allow.0[1].ip, ip(192, 168, 7, 0));
        assert_eq!(c.mqtt.broker, HostName::EMPTY, "new settings take defaults");
        // The password becomes the administrator "admin".
        assert_eq!(got.accounts.len(), 1);
        let admin = got.accounts.get(MIGRATED_ADMIN.as_bytes()).unwrap();
        assert_eq!(admin.role, Role::Admin);
        let p = admin.hash;
        assert_eq!(
            (p.iterations, p.salt, p.hash),
            (10000, [0x5a; SALT_LEN], [0xc3; HASH_LEN])
        );
        assert_eq!(back[0].bytes(), b"GrpStop,0,;");
        assert_eq!(back[7].bytes(), b"SetBoxDO,0,3,1,;");
        assert_eq!(back[15].bytes(), b"SetOverride,0,0.5,;");
        assert!(back[1].is_empty());
        // Saved again, it is format 5 and reads back the same.
        let again = image(&got, &back);
        assert_eq!(word(&again, 4), 5);
        let mut back2: Entries = [Text::EMPTY; TRIGGERS];
        assert_eq!(decode(&again, &Config::DEFAULT, &mut back2), Ok(got));
        assert_eq!(back2, back);
        // Format 2 names a bad register's setting.
        let mut bad = full.to_vec();
        let mut at = 8;
        while word(&bad, at) != r::CONFIG_POLL_MS {
            at += 4;
        }
        bad[at + 2..at + 4].copy_from_slice(&5u16.to_le_bytes());
        reseal(&mut bad);
        assert_eq!(
            decode(&bad, &Config::DEFAULT, &mut back),
            Err(ImageError::Invalid("link.poll_ms"))
        );
    }
}
