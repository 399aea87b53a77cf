//! The configuration file of the Linux binary (`--config FILE`): TOML that
//! people edit and keep in version control. Boards keep the binary image
//! ([`hans_gateway::storage::image`]); this file is another view of the same
//! stored state: the settings, the sixteen trigger entries and the web
//! password's salted hash.
//!
//! ```toml
//! [robot]
//! address = "192.168.0.10"
//!
//! [link]
//! poll_ms = 50
//!
//! [access]
//! modbus_allow = ["192.168.0.0/24", "10.0.0.7"]
//!
//! [triggers]
//! 3 = "GrpStop,0,;"
//! ```
//!
//! A commented example with every key is `examples/gateway.toml` beside
//! the crate's `Cargo.toml`.
//!
//! ## Rules
//! * Each key is one setting of the schema ([`hans_gateway::config::schema`]):
//!   `[link] poll_ms` is the setting `link.poll_ms`. Its value is checked
//!   by the setting's kind, the same rule as every other view's: no range
//!   is written twice.
//! * A key left out takes its factory default; a trigger entry left out is
//!   empty; no `accounts` means none exists (the first administrator is
//!   created on the web page with the setup code).
//! * An unknown table or key, a value of the wrong type or out of range is
//!   refused, each with its line and column and the reason; every problem
//!   of the file is reported, not only the first. Nothing of a refused file
//!   is used, and the binary does not start on it.
//! * Addresses are strings `"a.b.c.d"`; allow-lists arrays of up to four
//!   networks `"a.b.c.d/prefix"` (prefix 1-32; `"a.b.c.d"` alone is `/32`;
//!   `[]` = everyone), loaded into the list's entries in order; settings
//!   that are a choice are words (`mode = "listen"`), switches `true` /
//!   `false`.
//! * A trigger entry is a string (its UTF-8 bytes, at most 192, no NUL);
//!   an entry that is not UTF-8 (only a PLC can write one, and it can
//!   never fire: the gateway sends printable ASCII only) is written as an
//!   array of its byte values, so that a save loses nothing.
//! * An account's password is `"pbkdf2-sha256$ROUNDS$SALT$HASH"` (salt 16
//!   bytes and hash 32 bytes, in hex): PBKDF2-HMAC-SHA256 of the password,
//!   never the password itself (`access::password`). Manage the accounts
//!   on the web page. Accounts given must include an administrator. The
//!   previous version's `password` key is read as the administrator
//!   `admin`.
//! * A save rewrites the whole file ([`render`]) with every key and a
//!   comment naming its register and range. Comments written by hand are
//!   not kept: keeping them (toml_edit) would cost a second TOML crate
//!   and an edit-in-place writer for a file the gateway rewrites whole.
//! * A file of an older version, holding the binary image (magic `HGW1`),
//!   is still read, and written as TOML at its next save.
//!
//! ## Keys and registers
//! | key | register | value |
//! |---|---|---|
//! | `robot.address` | CFG_ROBOT_IP | `"a.b.c.d"` |
//! | `robot.port` | CFG_ROBOT_PORT | integer |
//! | `robot.id` | CFG_ROBOT_ID | integer |
//! | `link.mode` | CFG_LINK_MODE | `"connect"` (0), `"listen"` (1) |
//! | `link.listen_port` | CFG_LISTEN_PORT | integer |
//! | `link.reply_timeout_ms` | CFG_REPLY_TIMEOUT_MS | integer |
//! | `link.status_source` | CFG_STATUS_SOURCE | `"polling"` (0), `"datasheet"` (1) |
//! | `link.poll_ms` | CFG_POLL_MS | integer |
//! | `link.datasheet_port` | CFG_DATASHEET_PORT | integer |
//! | `link.protocol` | CFG_PROTOCOL | `"detect"` (0), `"v5"` (1), `"v6"` (2) |
//! | `motion.wait_blending_done` | CFG_MOTION_POLICY bit 0 | `true` / `false` |
//! | `motion.wait_in_position` | CFG_MOTION_POLICY bit 1 | `true` / `false` |
//! | `motion.start_grace_ms` | CFG_START_GRACE_MS | integer |
//! | `motion.auto_reset` | CFG_AUTO_RESET | `true` / `false` |
//! | `watchdog.period_ms` | CFG_WATCHDOG_MS | integer, 0 = off |
//! | `watchdog.action` | CFG_WATCHDOG_ACTION | `"report-only"` (0), `"stop"` (1), `"pause"` (2) |
//! | `registers.word_order` | CFG_FLOAT_WORD_ORDER | `"high-first"` (0), `"low-first"` (1) |
//! | `registers.number_format` | CFG_NUMBER_FORMAT | `"f32"` (0), `"thousandths"` (1) |
//! | `network.address` | NET_IP | `"a.b.c.d"` |
//! | `network.mask` | NET_MASK | `"a.b.c.d"` |
//! | `network.gateway` | NET_GATEWAY | `"a.b.c.d"` |
//! | `network.dhcp` | NET_DHCP | `true` / `false` |
//! | `network.modbus_port` | NET_MODBUS_PORT | integer |
//! | `network.web_port` | NET_WEB_PORT | integer, 0 = no web page |
//! | `network.ntp_server` | (none) | `"a.b.c.d"`, `"0.0.0.0"` = none (boards; Linux uses the host's clock) |
//! | `access.write_protect` | CFG_WRITE_PROTECT | `true` / `false` |
//! | `access.modbus_allow` | MODBUS_ALLOW | `["a.b.c.d/prefix", ...]` |
//! | `access.web_allow` | WEB_ALLOW | `["a.b.c.d/prefix", ...]` |
//! | `access.read_without_login` | (none) | `true` / `false` |
//! | `web.host_name` | (none) | `"host"`, `""` = addresses only |
//! | `mqtt.enabled` | (none) | `true` / `false` |
//! | `mqtt.broker` | (none) | `"host"`, `""` = none |
//! | `mqtt.port` | (none) | integer |
//! | `mqtt.tls` | (none) | `true` / `false` |
//! | `mqtt.group_id` | (none) | `"id"` |
//! | `mqtt.edge_id` | (none) | `"id"`, `""` = the platform's name |
//! | `mqtt.primary_host` | (none) | `"id"`, `""` = none |
//! | `mqtt.keep_alive_s` | (none) | integer |
//! | `mqtt.period_ms` | (none) | integer |
//! | `mqtt.joint_deadband` | (none) | integer, 0.01 degree |
//! | `mqtt.pose_deadband` | (none) | integer, 0.01 mm or degree |
//! | `access.modbus_config` | (none) | `true` / `false`: configuration over Modbus (the protected settings) |
//! | `access.plc_address` | (none) | `"a.b.c.d"`, `"0.0.0.0"` = none: the PLC's reserved Modbus slot |
//! | `access.accounts` | (the web page's accounts) | `[{ name = "...", role = "admin", password = "pbkdf2-sha256$ROUNDS$SALT$HASH", trusted = ["a.b.c.d", ...] }, ...]` (`trusted`: the addresses the account last logged in from, up to 4, kept by the gateway) |
//! | `enip.enabled` | (none) | `true` / `false` (the EtherNet/IP adapter, gateway/ENIP.md; Linux: where `--enip-listen` says) |
//! | `enip.allow` | (none) | `["a.b.c.d/prefix", ...]` |
//! | `access.password` | (the previous version's one password: read as the administrator `admin`, never written) | `"pbkdf2-sha256$ROUNDS$SALT$HASH"` |
//! | `triggers.N` | TRIGN_TEXT (N = 0-15) | string |

extern crate std;

use core::fmt;
use std::borrow::ToOwned;
use std::format;
use std::io;
use std::path::{Path, PathBuf};
use std::string::String;
use std::vec::Vec;

use hans_gateway::config::{Config, Kind, Setting, ALLOW_ENTRIES, SETTINGS};
use hans_gateway::registers::config::register_of;
use hans_gateway::state::inputs::{Text, TRIGGERS};
use hans_gateway::storage::image::{self, Entries, ImageError, Stored};

/// The tables: the groups of the settings' keys, in the order of
/// [`SETTINGS`] (`access` also holds the password), then the trigger table.
fn tables() -> Vec<&'static str> {
    let mut t: Vec<&'static str> = Vec::new();
    for s in SETTINGS {
        if !t.contains(&s.group()) {
            t.push(s.group());
        }
    }
    t.push("triggers");
    t
}

/// The setting of key `name` in table `table`.
fn setting_of(table: &str, name: &str) -> Option<&'static Setting> {
    SETTINGS
        .iter()
        .copied()
        .find(|s| s.group() == table && s.name() == name)
}

/// The register a setting is shown by, for comments and messages:
/// `CFG_POLL_MS`, `CFG_MOTION_POLICY bit 1`, or its key when it has none.
fn register_name(s: &Setting) -> String {
    match register_of(s) {
        Some((g, Some(bit))) => format!("{} bit {bit}", g.name),
        Some((g, None)) => g.name.to_owned(),
        None => s.key.to_owned(),
    }
}

/// The accounts' key in `[access]`.
const ACCOUNTS: &str = "accounts";
/// The web password's key in `[access]` of the previous version (one
/// password: read as the administrator `admin`, never written).
const PASSWORD: &str = "password";
/// The scheme of the password's hash.
const SCHEME: &str = "pbkdf2-sha256";
/// The first bytes of a binary image (`storage::image`), which an older
/// version wrote to this file.
const IMAGE_MAGIC: &[u8; 4] = b"HGW1";

/// What the file holds: the stored state and the trigger table.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Contents {
    /// The configuration and the accounts.
    pub stored: Stored,
    /// The sixteen trigger entries.
    pub triggers: Entries,
}

impl Contents {
    /// Factory settings, no trigger entry, no account.
    pub fn new(config: Config) -> Contents {
        Contents {
            stored: Stored {
                config,
                accounts: hans_gateway::access::accounts::Accounts::NONE,
            },
            triggers: [Text::EMPTY; TRIGGERS],
        }
    }
}

/// How the file was written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// TOML (this version).
    Toml,
    /// The binary image of an older version: read, and written as TOML at
    /// the next save.
    BinaryImage,
}

/// One thing wrong in the file, where it is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Problem {
    /// Line, from 1.
    pub line: usize,
    /// Column (characters), from 1.
    pub column: usize,
    /// What is wrong.
    pub reason: String,
}

impl fmt::Display for Problem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: {}", self.line, self.column, self.reason)
    }
}

/// Why a file was refused.
#[derive(Debug)]
pub enum Error {
    /// It cannot be read.
    Io(io::Error),
    /// TOML that is malformed or holds invalid settings: every problem, in
    /// the order of the file.
    Toml(Vec<Problem>),
    /// A binary image of an older version that is damaged.
    Image(ImageError),
}

/// A refused file: its path and why.
#[derive(Debug)]
pub struct FileError {
    /// The file.
    pub path: PathBuf,
    /// Why.
    pub error: Error,
}

/// One line per problem: `FILE:LINE:COLUMN: reason` (`FILE: reason` when
/// there is no line).
impl fmt::Display for FileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let path = self.path.display();
        match &self.error {
            Error::Io(e) => write!(f, "{path}: {e}"),
            Error::Image(e) => write!(
                f,
                "{path}: a binary configuration image of an older version, refused: {}",
                e.as_str()
            ),
            Error::Toml(problems) => {
                for (i, p) in problems.iter().enumerate() {
                    if i > 0 {
                        writeln!(f)?;
                    }
                    write!(f, "{path}:{p}")?;
                }
                Ok(())
            }
        }
    }
}

impl std::error::Error for FileError {}

/// Reads the file at `path`: `Ok(None)` if it does not exist (nothing
/// stored yet), the contents and their format if it is valid. Settings
/// the file leaves out take their value in `defaults`.
pub fn read_file(path: &Path, defaults: &Config) -> Result<Option<(Contents, Format)>, FileError> {
    let refused = |error| FileError {
        path: path.to_owned(),
        error,
    };
    match std::fs::read(path) {
        Ok(bytes) => read_bytes(&bytes, defaults).map(Some).map_err(refused),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(refused(Error::Io(e))),
    }
}

/// Reads a file's bytes: TOML, or the binary image of an older version.
pub fn read_bytes(bytes: &[u8], defaults: &Config) -> Result<(Contents, Format), Error> {
    // A binary image holds NUL bytes (in its header already); TOML cannot.
    if bytes.starts_with(IMAGE_MAGIC) && bytes.contains(&0) {
        let mut triggers = [Text::EMPTY; TRIGGERS];
        let stored = image::decode(bytes, defaults, &mut triggers).map_err(Error::Image)?;
        return Ok((Contents { stored, triggers }, Format::BinaryImage));
    }
    let text = match core::str::from_utf8(bytes) {
        Ok(t) => t,
        Err(e) => {
            let valid = bytes.get(..e.valid_up_to()).unwrap_or(&[]);
            let text = core::str::from_utf8(valid).unwrap_or("");
            let reason = "not UTF-8 text (a TOML file is UTF-8)".to_owned();
            return Err(Error::Toml(std::vec![problem(text, text.len(), reason)]));
        }
    };
    parse(text, defaults)
        .map(|c| (c, Format::Toml))
        .map_err(Error::Toml)
}

/// `"a", "b"`.
fn quoted(words: &[&str]) -> String {
    words
        .iter()
        .map(|w| format!("\"{w}\""))
        .collect::<Vec<_>>()
        .join(", ")
}

/// What a key may hold, from its setting's kind: `10-100 ms`, `"polling"`.
fn takes(s: &Setting) -> String {
    let unit = match s.unit {
        "" => String::new(),
        u => format!(" {u}"),
    };
    match s.kind {
        Kind::Choice(words) => quoted(words),
        Kind::Flag => "true or false".to_owned(),
        Kind::Number {
            min,
            max,
            off: false,
        } => format!("{min}-{max}{unit}"),
        Kind::Number { min, max, off: true } => format!("0 (off) or {min}-{max}{unit}"),
        Kind::Mask => "a mask of contiguous ones".to_owned(),
        Kind::Address => "an address a.b.c.d".to_owned(),
        Kind::AllowList => format!(
            "up to {ALLOW_ENTRIES} networks \"a.b.c.d/prefix\", prefix 1-32 (\"a.b.c.d\" alone = /32); [] = everyone"
        ),
        Kind::Host => format!(
            "a host name or address, up to {} characters; \"\" = none",
            hans_gateway::config::HostName::MAX
        ),
    }
}

mod read;
mod write;

pub use read::parse;
use read::problem;
pub use write::render;

#[cfg(test)]
mod tests;
