//! The settings schema: every setting of the gateway once, by a stable key.
//!
//! A [`Setting`] is a key (`link.poll_ms`), a stable id (the stored image
//! is keyed by it), a [`Kind`] (type and range), a unit, a help text and
//! whether it takes effect only at the next start. Its value lives in a
//! field of [`Config`], reached through the setting's own getter and
//! setter, and its default is that field in [`Config::DEFAULT`].
//!
//! Everything else is a view of this table and defines no setting of its
//! own: the Modbus registers (`registers::config` says which settings have
//! registers, and where), `/api/fields` and the web form, the TOML file on
//! Linux (its keys are these keys) and the stored image. A setting without
//! registers is normal (the MQTT broker's address has none).
//!
//! ## Adding a setting
//! One `const` here, listed in [`SETTINGS`] with a new id (ids are never
//! reused or renumbered); if the PLC should reach it, one line in the
//! register view. A test checks that keys and ids are unique.
//!
//! ## Text form
//! One text form per kind, the same for the web form, `/api/config` and
//! the file's strings: numbers in decimal, flags `true`/`false` (`1`/`0`
//! read too), choices by their word (their index read too), addresses
//! `a.b.c.d`, allow-lists `a.b.c.d/prefix` entries separated by spaces (or
//! commas; an entry without `/prefix` is one address; empty = everyone),
//! host names as they are.

use core::fmt::Write;
use core::net::Ipv4Addr;

use super::{
    AllowList, Config, HostName, LinkMode, NumberFormat, ProtocolSetting, StatusSource,
    WatchdogAction, WordOrder, ALLOW_ENTRIES,
};

/// What a setting holds, and which values are valid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// A whole number `min..=max`; with `off`, 0 (off) too.
    Number {
        /// Smallest value (besides 0 when `off`).
        min: u16,
        /// Largest value.
        max: u16,
        /// 0 means off and is valid.
        off: bool,
    },
    /// On or off.
    Flag,
    /// One of these words (stored as its index).
    Choice(&'static [&'static str]),
    /// An IPv4 address; 0.0.0.0 = not configured.
    Address,
    /// A network mask: contiguous ones from the top, not 0.0.0.0.
    Mask,
    /// Up to [`ALLOW_ENTRIES`] networks; none = everyone.
    AllowList,
    /// A host name or address (letters, digits, `.`, `-`, `_`, `:`), up to
    /// [`HostName::MAX`] bytes; empty = none.
    Host,
}

/// A setting's value, typed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Value {
    /// [`Kind::Number`].
    Number(u16),
    /// [`Kind::Flag`].
    Flag(bool),
    /// [`Kind::Choice`]: the index of the word.
    Choice(u8),
    /// [`Kind::Address`] or [`Kind::Mask`].
    Address(Ipv4Addr),
    /// [`Kind::AllowList`].
    AllowList(AllowList),
    /// [`Kind::Host`].
    Host(HostName),
}

/// Why a setting's value or text was refused (the web page shows it
/// beside the field; the file names it with its line).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FieldError {
    /// Not a number.
    NotANumber,
    /// Outside the setting's range.
    OutOfRange,
    /// Not an address `a.b.c.d`.
    NotAnAddress,
    /// Not a contiguous network mask.
    NotAMask,
    /// An allow-list entry is not `a.b.c.d/prefix` with a prefix 1-32.
    NotANetwork,
    /// More than [`ALLOW_ENTRIES`] entries.
    TooManyEntries,
    /// Not one of the setting's words.
    NotAChoice,
    /// Not `true` or `false`.
    NotAFlag,
    /// Not a host name (or too long).
    NotAHost,
    /// A value of another kind.
    WrongKind,
}

impl FieldError {
    /// A short text.
    pub fn as_str(self) -> &'static str {
        match self {
            FieldError::NotANumber => "not a whole number",
            FieldError::OutOfRange => "out of range",
            FieldError::NotAnAddress => "not an address a.b.c.d",
            FieldError::NotAMask => "not a network mask (e.g. 255.255.255.0)",
            FieldError::NotANetwork => "entries are a.b.c.d or a.b.c.d/prefix (prefix 1-32)",
            FieldError::TooManyEntries => "at most 4 entries",
            FieldError::NotAChoice => "not one of the choices",
            FieldError::NotAFlag => "not true or false",
            FieldError::NotAHost => "not a host name (letters, digits, . - _ :, up to 63)",
            FieldError::WrongKind => "a value of another kind",
        }
    }
}

impl Kind {
    /// Checks that `v` is of this kind and in range.
    pub fn check(&self, v: &Value) -> Result<(), FieldError> {
        match (*self, v) {
            (Kind::Number { min, max, off }, &Value::Number(n)) => {
                if (off && n == 0) || (min..=max).contains(&n) {
                    Ok(())
                } else {
                    Err(FieldError::OutOfRange)
                }
            }
            (Kind::Flag, Value::Flag(_)) | (Kind::Address, Value::Address(_)) => Ok(()),
            (Kind::Choice(words), &Value::Choice(i)) => match usize::from(i) < words.len() {
                true => Ok(()),
                false => Err(FieldError::NotAChoice),
            },
            (Kind::Mask, &Value::Address(m)) => {
                let bits = u32::from(m);
                if bits == 0 || bits.leading_ones() + bits.trailing_zeros() != 32 {
                    Err(FieldError::NotAMask)
                } else {
                    Ok(())
                }
            }
            (Kind::AllowList, Value::AllowList(l)) => match l.0.iter().all(|e| e.prefix <= 32) {
                true => Ok(()),
                false => Err(FieldError::NotANetwork),
            },
            (Kind::Host, Value::Host(h)) => match HostName::is_valid(h.as_bytes()) {
                true => Ok(()),
                false => Err(FieldError::NotAHost),
            },
            _ => Err(FieldError::WrongKind),
        }
    }

    /// The kind's name in `/api/fields`.
    pub fn name(&self) -> &'static str {
        match self {
            Kind::Number { .. } => "number",
            Kind::Flag => "flag",
            Kind::Choice(_) => "choice",
            Kind::Address => "address",
            Kind::Mask => "mask",
            Kind::AllowList => "allow-list",
            Kind::Host => "host",
        }
    }

    /// Reads a value of this kind from its text form (see the module
    /// documentation), checked.
    pub fn parse(&self, text: &str) -> Result<Value, FieldError> {
        let t = text.trim();
        let v = match *self {
            Kind::Number { .. } => Value::Number(parse_number(t)?),
            Kind::Flag => Value::Flag(match t {
                "true" | "1" => true,
                "false" | "0" => false,
                _ => return Err(FieldError::NotAFlag),
            }),
            Kind::Choice(words) => {
                let i = match words.iter().position(|w| *w == t) {
                    Some(i) => i,
                    None => usize::from(parse_number(t).map_err(|_| FieldError::NotAChoice)?),
                };
                Value::Choice(u8::try_from(i).map_err(|_| FieldError::NotAChoice)?)
            }
            Kind::Address | Kind::Mask => {
                Value::Address(t.parse().map_err(|_| FieldError::NotAnAddress)?)
            }
            Kind::AllowList => Value::AllowList(AllowList::parse(t)?),
            Kind::Host => Value::Host(HostName::new(t).ok_or(FieldError::NotAHost)?),
        };
        self.check(&v)?;
        Ok(v)
    }

    /// Writes `v` in its text form.
    pub fn format(&self, v: &Value, out: &mut impl Write) -> core::fmt::Result {
        match (*self, v) {
            (_, Value::Number(n)) => write!(out, "{n}"),
            (_, Value::Flag(b)) => out.write_str(if *b { "true" } else { "false" }),
            (Kind::Choice(words), &Value::Choice(i)) => {
                out.write_str(words.get(usize::from(i)).copied().unwrap_or("?"))
            }
            (_, Value::Choice(i)) => write!(out, "{i}"),
            (_, Value::Address(ip)) => write!(out, "{ip}"),
            (_, Value::AllowList(l)) => l.format(out),
            (_, Value::Host(h)) => out.write_str(h.as_str()),
        }
    }
}

/// A decimal `u16` (digits only: no sign, no spaces inside).
fn parse_number(t: &str) -> Result<u16, FieldError> {
    if t.is_empty() || !t.bytes().all(|b| b.is_ascii_digit()) {
        return Err(FieldError::NotANumber);
    }
    t.parse().map_err(|_| FieldError::OutOfRange)
}

/// One setting (see the module documentation).
#[derive(Clone, Copy)]
pub struct Setting {
    /// Stable key, `group.name` (the TOML file's table and key).
    pub key: &'static str,
    /// Stable id in the stored image: never reused, never renumbered.
    pub id: u16,
    /// Type and valid values.
    pub kind: Kind,
    /// Unit, empty for none.
    pub unit: &'static str,
    /// What the values mean, short (empty in builds without the web page
    /// and the TOML file: the core firmware shows it nowhere).
    pub help: &'static str,
    /// Takes effect at the next start (network settings on a board).
    pub restart: bool,
    get: fn(&Config) -> Value,
    set: fn(&mut Config, Value),
}

impl core::fmt::Debug for Setting {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(self.key)
    }
}

impl PartialEq for Setting {
    fn eq(&self, other: &Self) -> bool {
        self.id == other.id
    }
}

impl Eq for Setting {}

#[cfg(feature = "defmt")]
impl defmt::Format for Setting {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "{=str}", self.key)
    }
}

impl Setting {
    /// The setting's value in `c`.
    pub fn get(&self, c: &Config) -> Value {
        (self.get)(c)
    }

    /// Sets the setting in `c` to `v`, checked against its kind; nothing
    /// is changed on error.
    pub fn set(&self, c: &mut Config, v: Value) -> Result<(), FieldError> {
        self.kind.check(&v)?;
        (self.set)(c, v);
        Ok(())
    }

    /// The factory default.
    pub fn default_value(&self) -> Value {
        self.get(&Config::DEFAULT)
    }

    /// The group of the key (`link` of `link.poll_ms`).
    pub fn group(&self) -> &'static str {
        self.key.split_once('.').map_or(self.key, |(g, _)| g)
    }

    /// The name of the key inside its group (`poll_ms` of `link.poll_ms`).
    pub fn name(&self) -> &'static str {
        self.key.split_once('.').map_or(self.key, |(_, n)| n)
    }

    /// A short name in words for people (`Robot reply timeout` of
    /// `link.reply_timeout_ms`), from [`LABELS`]; empty in builds without
    /// the web page (as [`Setting::help`]) or for a key without one.
    pub fn label(&self) -> &'static str {
        if !cfg!(feature = "web") {
            return "";
        }
        LABELS
            .iter()
            .find(|(key, _)| *key == self.key)
            .map_or("", |(_, label)| *label)
    }

    /// Reads the setting from its text form into `c`, checked; nothing is
    /// changed on error.
    pub fn parse_into(&self, text: &str, c: &mut Config) -> Result<(), FieldError> {
        let v = self.kind.parse(text)?;
        self.set(c, v)
    }

    /// Writes the setting's value in `c` in its text form.
    pub fn format(&self, c: &Config, out: &mut impl Write) -> core::fmt::Result {
        self.kind.format(&self.get(c), out)
    }
}

/// The setting whose key is `key`.
pub fn by_key(key: &str) -> Option<&'static Setting> {
    SETTINGS.iter().copied().find(|s| s.key == key)
}

/// The setting whose stored id is `id`.
pub fn by_id(id: u16) -> Option<&'static Setting> {
    SETTINGS.iter().copied().find(|s| s.id == id)
}

// The values the getters and setters are given are checked against the
// setting's kind first, so a setter's fallback arm is never taken.
fn number(v: Value) -> u16 {
    match v {
        Value::Number(n) => n,
        _ => 0,
    }
}
fn flag(v: Value) -> bool {
    matches!(v, Value::Flag(true))
}
fn choice(v: Value) -> u8 {
    match v {
        Value::Choice(i) => i,
        _ => 0,
    }
}
fn address(v: Value) -> Ipv4Addr {
    match v {
        Value::Address(a) => a,
        _ => Ipv4Addr::UNSPECIFIED,
    }
}
fn allow_list(v: Value) -> AllowList {
    match v {
        Value::AllowList(l) => l,
        _ => AllowList::EVERYONE,
    }
}
fn host(v: Value) -> HostName {
    match v {
        Value::Host(h) => h,
        _ => HostName::EMPTY,
    }
}

/// Declares a setting: key, id, kind, unit, help, restart, and the field
/// of `Config` it lives in with the conversions to and from [`Value`].
macro_rules! setting {
    ($name:ident, $key:literal, $id:literal, $kind:expr, $unit:literal, $help:literal, $restart:literal,
     |$c:ident| $get:expr, |$s:ident, $v:ident| $set:expr) => {
        #[doc = concat!("`", $key, "`: ", $help, ".")]
        pub const $name: Setting = Setting {
            key: $key,
            id: $id,
            kind: $kind,
            unit: $unit,
            // Shown by the page and the Linux TOML file (whose gateway has
            // the page) only: the core firmware (neither) keeps ~2 KiB of
            // flash without the texts.
            help: if cfg!(feature = "web") { $help } else { "" },
            restart: $restart,
            get: |$c| $get,
            set: |$s, $v| $set,
        };
    };
}

const fn num(min: u16, max: u16) -> Kind {
    Kind::Number {
        min,
        max,
        off: false,
    }
}

/// Status sources this build has: polling, and the DataSheet with the
/// feature `datasheet`.
const STATUS_SOURCES: &[&str] = if cfg!(feature = "datasheet") {
    &["polling", "datasheet"]
} else {
    &["polling"]
};

setting!(
    ROBOT_ADDRESS,
    "robot.address",
    1,
    Kind::Address,
    "",
    "robot controller address; 0.0.0.0 = not configured",
    false,
    |c| Value::Address(c.robot_ip),
    |c, v| c.robot_ip = address(v)
);
setting!(
    ROBOT_PORT,
    "robot.port",
    2,
    num(1, 65535),
    "",
    "robot command port",
    false,
    |c| Value::Number(c.robot_port),
    |c, v| c.robot_port = number(v)
);
setting!(
    ROBOT_ID,
    "robot.id",
    3,
    num(0, 5),
    "",
    "robot id nRbtID",
    false,
    |c| Value::Number(c.robot_id.into()),
    |c, v| c.robot_id = number(v) as u8
);
setting!(
    LINK_MODE,
    "link.mode",
    4,
    Kind::Choice(&["connect", "listen"]),
    "",
    "connect = the gateway connects to the robot, listen = the robot connects",
    false,
    |c| Value::Choice(c.link_mode as u8),
    |c, v| c.link_mode = if choice(v) == 1 {
        LinkMode::Listen
    } else {
        LinkMode::Connect
    }
);
setting!(
    LINK_LISTEN_PORT,
    "link.listen_port",
    5,
    num(1, 65535),
    "",
    "port listened on in listen mode",
    false,
    |c| Value::Number(c.listen_port),
    |c, v| c.listen_port = number(v)
);
setting!(
    LINK_REPLY_TIMEOUT_MS,
    "link.reply_timeout_ms",
    6,
    num(50, 60000),
    "ms",
    "robot reply timeout",
    false,
    |c| Value::Number(c.reply_timeout_ms),
    |c, v| c.reply_timeout_ms = number(v)
);
setting!(LINK_STATUS_SOURCE, "link.status_source", 7, Kind::Choice(STATUS_SOURCES), "",
    "polling = poll the command port, datasheet = the DataSheet port (builds with the DataSheet reader)", false,
    |c| Value::Choice(c.status_source as u8),
    |c, v| c.status_source = if choice(v) == 1 { StatusSource::DataSheet } else { StatusSource::Polling });
setting!(
    LINK_POLL_MS,
    "link.poll_ms",
    8,
    num(10, 100),
    "ms",
    "status poll period",
    false,
    |c| Value::Number(c.poll_ms),
    |c, v| c.poll_ms = number(v)
);
setting!(
    LINK_DATASHEET_PORT,
    "link.datasheet_port",
    9,
    num(1, 65535),
    "",
    "DataSheet port",
    false,
    |c| Value::Number(c.datasheet_port),
    |c, v| c.datasheet_port = number(v)
);
setting!(
    LINK_PROTOCOL,
    "link.protocol",
    10,
    Kind::Choice(&["detect", "v5", "v6"]),
    "",
    "detect = ask at each connection (PackageVersion), v5 = HR-TCP 1.0.0.3, v6 = the V6 document",
    false,
    |c| Value::Choice(c.protocol as u8),
    |c, v| c.protocol = match choice(v) {
        1 => ProtocolSetting::V5,
        2 => ProtocolSetting::V6,
        _ => ProtocolSetting::Detect,
    }
);
setting!(
    MOTION_WAIT_BLENDING_DONE,
    "motion.wait_blending_done",
    11,
    Kind::Flag,
    "",
    "Done also waits for blending done",
    false,
    |c| Value::Flag(c.wait_blending_done),
    |c, v| c.wait_blending_done = flag(v)
);
setting!(
    MOTION_WAIT_IN_POSITION,
    "motion.wait_in_position",
    12,
    Kind::Flag,
    "",
    "Done also waits for in position",
    false,
    |c| Value::Flag(c.wait_in_position),
    |c, v| c.wait_in_position = flag(v)
);
setting!(
    MOTION_START_GRACE_MS,
    "motion.start_grace_ms",
    13,
    num(0, 5000),
    "ms",
    "time a motion may read not moving after its start",
    false,
    |c| Value::Number(c.start_grace_ms),
    |c, v| c.start_grace_ms = number(v)
);
setting!(
    MOTION_AUTO_RESET,
    "motion.auto_reset",
    14,
    Kind::Flag,
    "",
    "GrpReset after a motion error",
    false,
    |c| Value::Flag(c.auto_reset),
    |c, v| c.auto_reset = flag(v)
);
setting!(
    WATCHDOG_PERIOD_MS,
    "watchdog.period_ms",
    15,
    Kind::Number {
        min: 50,
        max: 60000,
        off: true
    },
    "ms",
    "PLC watchdog period, 0 = off",
    false,
    |c| Value::Number(c.watchdog_ms),
    |c, v| c.watchdog_ms = number(v)
);
setting!(
    WATCHDOG_ACTION,
    "watchdog.action",
    16,
    Kind::Choice(&["report-only", "stop", "pause"]),
    "",
    "what the watchdog does to a motion: report only, stop (GrpStop) or pause (GrpInterrupt)",
    false,
    |c| Value::Choice(c.watchdog_action as u8),
    |c, v| c.watchdog_action = match choice(v) {
        0 => WatchdogAction::ReportOnly,
        2 => WatchdogAction::Pause,
        _ => WatchdogAction::Stop,
    }
);
setting!(
    REGISTERS_WORD_ORDER,
    "registers.word_order",
    17,
    Kind::Choice(&["high-first", "low-first"]),
    "",
    "word order of 32-bit values in two registers",
    false,
    |c| Value::Choice(c.word_order as u8),
    |c, v| c.word_order = if choice(v) == 1 {
        WordOrder::LowFirst
    } else {
        WordOrder::HighFirst
    }
);
setting!(
    REGISTERS_NUMBER_FORMAT,
    "registers.number_format",
    41,
    Kind::Choice(&["f32", "thousandths"]),
    "",
    "real numbers in two registers (override, positions, a channel's parameters and results): f32, or thousandths as a 32-bit integer for PLCs that cannot pack floats",
    false,
    |c| Value::Choice(c.number_format as u8),
    |c, v| c.number_format = if choice(v) == 1 {
        NumberFormat::Thousandths
    } else {
        NumberFormat::F32
    }
);
setting!(
    NETWORK_ADDRESS,
    "network.address",
    18,
    Kind::Address,
    "",
    "the gateway's address (without DHCP); at the next start",
    true,
    |c| Value::Address(c.net.ip),
    |c, v| c.net.ip = address(v)
);
setting!(
    NETWORK_MASK,
    "network.mask",
    19,
    Kind::Mask,
    "",
    "network mask, e.g. 255.255.255.0; at the next start",
    true,
    |c| Value::Address(c.net.mask),
    |c, v| c.net.mask = address(v)
);
setting!(
    NETWORK_GATEWAY,
    "network.gateway",
    20,
    Kind::Address,
    "",
    "default gateway, 0.0.0.0 = none; at the next start",
    true,
    |c| Value::Address(c.net.gateway),
    |c, v| c.net.gateway = address(v)
);
setting!(
    NETWORK_DHCP,
    "network.dhcp",
    21,
    Kind::Flag,
    "",
    "address from a DHCP server (builds with DHCP); at the next start",
    true,
    |c| Value::Flag(c.net.dhcp),
    |c, v| c.net.dhcp = flag(v)
);
setting!(
    NETWORK_MODBUS_PORT,
    "network.modbus_port",
    22,
    num(1, 65535),
    "",
    "Modbus TCP port; at the next start",
    true,
    |c| Value::Number(c.net.modbus_port),
    |c, v| c.net.modbus_port = number(v)
);
setting!(
    NETWORK_WEB_PORT,
    "network.web_port",
    23,
    num(0, 65535),
    "",
    "web page port, 0 = no web page; at the next start",
    true,
    |c| Value::Number(c.net.web_port),
    |c, v| c.net.web_port = number(v)
);
setting!(
    ACCESS_WRITE_PROTECT,
    "access.write_protect",
    24,
    Kind::Flag,
    "",
    "configuration registers and trigger texts read-only over Modbus",
    false,
    |c| Value::Flag(c.write_protect),
    |c, v| c.write_protect = flag(v)
);
setting!(
    ACCESS_MODBUS_ALLOW,
    "access.modbus_allow",
    25,
    Kind::AllowList,
    "",
    "Modbus clients allowed: up to 4 entries a.b.c.d or a.b.c.d/prefix (1-32); none = everyone",
    false,
    |c| Value::AllowList(c.modbus_allow),
    |c, v| c.modbus_allow = allow_list(v)
);
setting!(
    ACCESS_WEB_ALLOW,
    "access.web_allow",
    26,
    Kind::AllowList,
    "",
    "web clients allowed: up to 4 entries a.b.c.d or a.b.c.d/prefix (1-32); none = everyone",
    false,
    |c| Value::AllowList(c.web_allow),
    |c, v| c.web_allow = allow_list(v)
);
setting!(
    MQTT_BROKER,
    "mqtt.broker",
    27,
    Kind::Host,
    "",
    "MQTT broker for the Sparkplug B telemetry: an address (boards), or a host name (Linux); empty = none; at the next start",
    true,
    |c| Value::Host(c.mqtt.broker),
    |c, v| c.mqtt.broker = host(v)
);
setting!(MQTT_ENABLED, "mqtt.enabled", 31, Kind::Flag, "",
    "publish the cell's state to the broker (Sparkplug B; MQTT sees the robot, never moves it); at the next start", true,
    |c| Value::Flag(c.mqtt.enabled), |c, v| c.mqtt.enabled = flag(v));
setting!(
    MQTT_PORT,
    "mqtt.port",
    32,
    num(1, 65535),
    "",
    "the broker's port (1883: MQTT without TLS); at the next start",
    true,
    |c| Value::Number(c.mqtt.port),
    |c, v| c.mqtt.port = number(v)
);
setting!(MQTT_TLS, "mqtt.tls", 40, Kind::Flag, "",
    "TLS to the broker (port 8883 usually): Linux checks its certificate against the CAs of --mqtt-ca or the system's; boards have no TLS client; at the next start", true,
    |c| Value::Flag(c.mqtt.tls), |c, v| c.mqtt.tls = flag(v));
setting!(
    MQTT_GROUP,
    "mqtt.group_id",
    33,
    Kind::Host,
    "",
    "Sparkplug group id, 1-32 characters; at the next start",
    true,
    |c| Value::Host(c.mqtt.group),
    |c, v| c.mqtt.group = host(v)
);
setting!(MQTT_EDGE, "mqtt.edge_id", 34, Kind::Host, "",
    "Sparkplug edge node id (also the MQTT client id), 1-32 characters; empty = hans- and the MAC address (boards), the host name (Linux); at the next start", true,
    |c| Value::Host(c.mqtt.edge), |c, v| c.mqtt.edge = host(v));
setting!(MQTT_PRIMARY_HOST, "mqtt.primary_host", 35, Kind::Host, "",
    "Sparkplug primary host id: births wait for its STATE online message; empty = none; at the next start", true,
    |c| Value::Host(c.mqtt.primary_host), |c, v| c.mqtt.primary_host = host(v));
setting!(MQTT_KEEP_ALIVE, "mqtt.keep_alive_s", 36, num(5, 3600), "s",
    "MQTT keep-alive: the broker declares the gateway dead (NDEATH) 1.5 times this after it goes silent; at the next start", true,
    |c| Value::Number(c.mqtt.keep_alive_s), |c, v| c.mqtt.keep_alive_s = number(v));
setting!(
    MQTT_PERIOD,
    "mqtt.period_ms",
    37,
    num(10, 60000),
    "ms",
    "shortest time between two publications of changed values; at the next start",
    true,
    |c| Value::Number(c.mqtt.period_ms),
    |c, v| c.mqtt.period_ms = number(v)
);
setting!(
    MQTT_JOINT_DEADBAND,
    "mqtt.joint_deadband",
    38,
    num(0, 10000),
    "0.01 deg",
    "a joint angle is published when it moved by this much (10 = 0.1 degree); at the next start",
    true,
    |c| Value::Number(c.mqtt.joint_deadband),
    |c, v| c.mqtt.joint_deadband = number(v)
);
setting!(MQTT_POSE_DEADBAND, "mqtt.pose_deadband", 39, num(0, 10000), "0.01 mm",
    "a pose coordinate is published when it moved by this much (10 = 0.1 mm or degree); at the next start", true,
    |c| Value::Number(c.mqtt.pose_deadband), |c, v| c.mqtt.pose_deadband = number(v));

setting!(WEB_HOST_NAME, "web.host_name", 28, Kind::Host, "",
    "a DNS name the page also answers to, besides the device's addresses (others get 421: DNS rebinding); empty = addresses only", false,
    |c| Value::Host(c.web_host), |c, v| c.web_host = host(v));

setting!(ACCESS_READ_WITHOUT_LOGIN, "access.read_without_login", 29, Kind::Flag, "",
    "the page shows the status, configuration and logs without a login; off: every page and API needs an account (viewer or above)", false,
    |c| Value::Flag(c.read_without_login), |c, v| c.read_without_login = flag(v));

setting!(
    NETWORK_NTP_SERVER,
    "network.ntp_server",
    30,
    Kind::Address,
    "",
    "NTP server whose time the audit log's records carry (boards; Linux uses the host's clock); 0.0.0.0 = none",
    false,
    |c| Value::Address(c.ntp_server),
    |c, v| c.ntp_server = address(v)
);

// ---- Protected settings and the PLC's slot (issue 25).

setting!(ACCESS_MODBUS_CONFIG, "access.modbus_config", 60, Kind::Flag, "",
    "configuration over Modbus: the PLC may change the protected settings (robot endpoint, link mode, network and access settings) with CONFIG_COMMAND 1; off (the factory state) = only the page and the file change them", false,
    |c| Value::Flag(c.modbus_config), |c, v| c.modbus_config = flag(v));

setting!(ACCESS_PLC_ADDRESS, "access.plc_address", 61, Kind::Address, "",
    "the PLC's address: its Modbus sessions hold a reserved slot no other client takes, and are never closed for a newcomer; 0.0.0.0 = none (then the Modbus allow-list's entries are the PLC's)", false,
    |c| Value::Address(c.plc_address), |c, v| c.plc_address = address(v));

/// The protected settings: where the robot link goes (the robot endpoint
/// and the link mode), the gateway's own network settings and every
/// access setting. Modbus changes none of them unless configuration over
/// Modbus is allowed ([`ACCESS_MODBUS_CONFIG`], set on the page or in the
/// file) or the device was started in recovery (someone at the device):
/// a client without an account cannot re-point the robot link, move or
/// close the gateway's ports, or open the allow-lists. The EtherNet/IP
/// adapter's settings ([`ENIP_ENABLED`], [`ENIP_ALLOW`]) are access
/// settings too, in builds that have them.
pub const PROTECTED: [&Setting; PROTECTED_BASE.len() + ENIP.len()] =
    join(&[&PROTECTED_BASE, &ENIP]);

/// The protected settings every build has.
const PROTECTED_BASE: [&Setting; 18] = [
    &ROBOT_ADDRESS,
    &ROBOT_PORT,
    &LINK_MODE,
    &LINK_LISTEN_PORT,
    &NETWORK_ADDRESS,
    &NETWORK_MASK,
    &NETWORK_GATEWAY,
    &NETWORK_DHCP,
    &NETWORK_MODBUS_PORT,
    &NETWORK_WEB_PORT,
    &NETWORK_NTP_SERVER,
    &ACCESS_WRITE_PROTECT,
    &ACCESS_MODBUS_ALLOW,
    &ACCESS_WEB_ALLOW,
    &ACCESS_READ_WITHOUT_LOGIN,
    &ACCESS_MODBUS_CONFIG,
    &ACCESS_PLC_ADDRESS,
    &WEB_HOST_NAME,
];

impl Setting {
    /// A protected setting ([`PROTECTED`]).
    pub fn protected(&self) -> bool {
        PROTECTED.iter().any(|p| p.id == self.id)
    }
}

setting!(ENIP_ENABLED, "enip.enabled", 50, Kind::Flag, "",
    "serve the EtherNet/IP adapter (a Logix PLC drives the robot through I/O assemblies: gateway/ENIP.md) on TCP/UDP 44818 and UDP 2222; at the next start", true,
    |c| Value::Flag(c.enip_enabled), |c, v| c.enip_enabled = flag(v));
setting!(
    ENIP_ALLOW,
    "enip.allow",
    51,
    Kind::AllowList,
    "",
    "EtherNet/IP scanners allowed (sessions, discovery, I/O): up to 4 entries a.b.c.d or a.b.c.d/prefix (1-32); none = everyone",
    false,
    |c| Value::AllowList(c.enip_allow),
    |c, v| c.enip_allow = allow_list(v)
);

/// The settings every build has, in the order the views list them (a
/// group's settings together).
const BASE: [&Setting; 32] = [
    &ROBOT_ADDRESS,
    &ROBOT_PORT,
    &ROBOT_ID,
    &LINK_MODE,
    &LINK_LISTEN_PORT,
    &LINK_REPLY_TIMEOUT_MS,
    &LINK_STATUS_SOURCE,
    &LINK_POLL_MS,
    &LINK_DATASHEET_PORT,
    &LINK_PROTOCOL,
    &MOTION_WAIT_BLENDING_DONE,
    &MOTION_WAIT_IN_POSITION,
    &MOTION_START_GRACE_MS,
    &MOTION_AUTO_RESET,
    &WATCHDOG_PERIOD_MS,
    &WATCHDOG_ACTION,
    &REGISTERS_WORD_ORDER,
    &REGISTERS_NUMBER_FORMAT,
    &NETWORK_ADDRESS,
    &NETWORK_MASK,
    &NETWORK_GATEWAY,
    &NETWORK_DHCP,
    &NETWORK_MODBUS_PORT,
    &NETWORK_WEB_PORT,
    &NETWORK_NTP_SERVER,
    &ACCESS_WRITE_PROTECT,
    &ACCESS_MODBUS_ALLOW,
    &ACCESS_WEB_ALLOW,
    &ACCESS_READ_WITHOUT_LOGIN,
    &ACCESS_MODBUS_CONFIG,
    &ACCESS_PLC_ADDRESS,
    &WEB_HOST_NAME,
];

/// The telemetry's settings (builds with the feature `mqtt`). A build
/// without them skips their ids in a stored image and keeps their
/// defaults in [`Config`]: an image written by a field device loads on a
/// core firmware and back.
#[cfg(feature = "mqtt")]
const MQTT: [&Setting; 11] = [
    &MQTT_ENABLED,
    &MQTT_BROKER,
    &MQTT_PORT,
    &MQTT_TLS,
    &MQTT_GROUP,
    &MQTT_EDGE,
    &MQTT_PRIMARY_HOST,
    &MQTT_KEEP_ALIVE,
    &MQTT_PERIOD,
    &MQTT_JOINT_DEADBAND,
    &MQTT_POSE_DEADBAND,
];

#[cfg(not(feature = "mqtt"))]
const MQTT: [&Setting; 0] = [];

/// The EtherNet/IP adapter's settings (builds with the feature `enip`),
/// kept like the telemetry's in builds without it.
#[cfg(feature = "enip")]
const ENIP: [&Setting; 2] = [&ENIP_ENABLED, &ENIP_ALLOW];
#[cfg(not(feature = "enip"))]
const ENIP: [&Setting; 0] = [];

/// Every setting of this build, in the order the views list them.
pub const SETTINGS: [&Setting; BASE.len() + MQTT.len() + ENIP.len()] = join(&[&BASE, &MQTT, &ENIP]);

/// The lists `parts` one after the other, as one array of `N` (their
/// total length). Only evaluated in constants: a wrong `N` is a compile
/// error, never a run-time one.
// Indexing in a constant: evaluated by the compiler, which refuses an
// index out of range.
#[allow(clippy::indexing_slicing)]
const fn join<const N: usize>(parts: &[&[&'static Setting]]) -> [&'static Setting; N] {
    let mut out = [&ROBOT_ADDRESS; N];
    let (mut i, mut p) = (0, 0);
    while p < parts.len() {
        let mut k = 0;
        while k < parts[p].len() {
            out[i] = parts[p][k];
            i += 1;
            k += 1;
        }
        p += 1;
    }
    assert!(i == N, "join: N is not the parts' total length");
    out
}

/// The settings' names in words, for the page (which shows the key
/// beside it): one per setting of every build (a test checks). A table of
/// its own rather than one more argument of every `setting!`, so that a
/// setting and its label are added in two short lines.
pub const LABELS: &[(&str, &str)] = &[
    ("robot.address", "Robot address"),
    ("robot.port", "Robot command port"),
    ("robot.id", "Robot id"),
    ("link.mode", "Who connects"),
    ("link.listen_port", "Port the robot connects to"),
    ("link.reply_timeout_ms", "Robot reply timeout"),
    ("link.status_source", "Status source"),
    ("link.poll_ms", "Status poll period"),
    ("link.datasheet_port", "DataSheet port"),
    ("link.protocol", "Protocol version"),
    ("motion.wait_blending_done", "Done waits for blending"),
    ("motion.wait_in_position", "Done waits for in position"),
    ("motion.start_grace_ms", "Motion start grace time"),
    ("motion.auto_reset", "Reset after a motion error"),
    ("watchdog.period_ms", "PLC watchdog period"),
    ("watchdog.action", "Watchdog action"),
    ("registers.word_order", "32-bit word order"),
    ("registers.number_format", "Real number format"),
    ("network.address", "Gateway address"),
    ("network.mask", "Network mask"),
    ("network.gateway", "Default gateway"),
    ("network.dhcp", "Address from DHCP"),
    ("network.modbus_port", "Modbus TCP port"),
    ("network.web_port", "Web page port"),
    ("network.ntp_server", "Time server (NTP)"),
    ("access.write_protect", "Registers write-protected"),
    ("access.modbus_allow", "Modbus clients allowed"),
    ("access.web_allow", "Web clients allowed"),
    ("access.read_without_login", "Read without login"),
    ("access.modbus_config", "Configuration over Modbus"),
    ("access.plc_address", "PLC address (reserved slot)"),
    ("web.host_name", "Page's DNS name"),
    ("mqtt.enabled", "Telemetry on"),
    ("mqtt.broker", "MQTT broker"),
    ("mqtt.port", "Broker port"),
    ("mqtt.tls", "TLS to the broker"),
    ("mqtt.group_id", "Sparkplug group"),
    ("mqtt.edge_id", "Sparkplug edge node"),
    ("mqtt.primary_host", "Sparkplug primary host"),
    ("mqtt.keep_alive_s", "MQTT keep-alive"),
    ("mqtt.period_ms", "Shortest publish interval"),
    ("mqtt.joint_deadband", "Joint deadband"),
    ("mqtt.pose_deadband", "Pose deadband"),
    ("enip.enabled", "EtherNet/IP adapter on"),
    ("enip.allow", "EtherNet/IP scanners allowed"),
];

/// Bytes of a value of `kind` in the stored image (the longest, for a
/// host name).
pub const fn stored_len(kind: &Kind) -> usize {
    match kind {
        Kind::Number { .. } => 2,
        Kind::Flag | Kind::Choice(_) => 1,
        Kind::Address | Kind::Mask => 4,
        Kind::AllowList => 5 * ALLOW_ENTRIES,
        Kind::Host => HostName::MAX,
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::string::String;

    #[test]
    fn keys_and_ids_are_unique_and_defaults_valid() {
        for (i, a) in SETTINGS.iter().enumerate() {
            assert!(a.key.contains('.'), "{}", a.key);
            assert!(a.id != 0, "{}", a.key);
            for b in SETTINGS.iter().skip(i + 1) {
                assert_ne!(a.key, b.key);
                assert_ne!(a.id, b.id, "{} and {}", a.key, b.key);
            }
            assert_eq!(a.kind.check(&a.default_value()), Ok(()), "{}", a.key);
            assert_eq!(by_key(a.key).map(|s| s.id), Some(a.id));
            assert_eq!(by_id(a.id).map(|s| s.key), Some(a.key));
        }
    }

    #[test]
    #[cfg(feature = "web")]
    fn every_setting_has_a_label_in_words_and_every_label_a_setting() {
        for s in SETTINGS {
            let l = s.label();
            assert!(!l.is_empty(), "{} has no label in LABELS", s.key);
            assert!(l.len() <= 32, "{}: label {l:?} longer than 32", s.key);
            assert!(
                l.starts_with(|c: char| c.is_ascii_uppercase() || c.is_ascii_digit()),
                "{}: {l:?}",
                s.key
            );
            assert!(
                !l.contains(['.', '_']),
                "{}: a label is words: {l:?}",
                s.key
            );
        }
        // Each label once, and each for a setting (of this build or one
        // with more features: the MQTT settings).
        for (i, (key, label)) in LABELS.iter().enumerate() {
            assert!(
                LABELS
                    .iter()
                    .skip(i + 1)
                    .all(|(k, l)| k != key && l != label),
                "{key} or {label:?} twice"
            );
            assert!(
                by_key(key).is_some() || key.starts_with("mqtt."),
                "{key}: a label without a setting"
            );
        }
    }

    #[test]
    fn every_setting_reads_back_its_text_and_its_own_field() {
        for s in SETTINGS {
            let mut t = String::new();
            s.format(&Config::DEFAULT, &mut t).unwrap();
            let mut c = Config::DEFAULT;
            s.parse_into(&t, &mut c).unwrap();
            assert_eq!(c, Config::DEFAULT, "{}: {t:?}", s.key);
        }
        // Each setter writes the field its getter reads, and no other.
        let changed = |s: &Setting| match s.kind {
            Kind::Number { max, .. } => Value::Number(max),
            Kind::Flag => Value::Flag(!matches!(s.default_value(), Value::Flag(true))),
            Kind::Choice(w) => Value::Choice((w.len() as u8 - 1).min(match s.default_value() {
                Value::Choice(0) => 1,
                _ => 0,
            })),
            Kind::Address => Value::Address(Ipv4Addr::new(10, 9, 8, 7)),
            Kind::Mask => Value::Address(Ipv4Addr::new(255, 255, 252, 0)),
            Kind::AllowList => Value::AllowList(AllowList::parse("10.0.0.0/8").unwrap()),
            Kind::Host => Value::Host(HostName::new("broker.plant").unwrap()),
        };
        for s in SETTINGS {
            let v = changed(s);
            if v == s.default_value() {
                continue; // a one-word choice (a build without the DataSheet)
            }
            let mut c = Config::DEFAULT;
            s.set(&mut c, v).unwrap();
            assert_eq!(s.get(&c), v, "{}", s.key);
            for o in SETTINGS.iter().filter(|o| o.id != s.id) {
                assert_eq!(o.get(&c), o.default_value(), "{} changed {}", s.key, o.key);
            }
        }
    }

    #[test]
    fn text_is_checked_by_kind() {
        let mut c = Config::DEFAULT;
        assert_eq!(LINK_POLL_MS.parse_into(" 50 ", &mut c), Ok(()));
        assert_eq!(c.poll_ms, 50);
        for (t, e) in [
            ("101", FieldError::OutOfRange),
            ("5x", FieldError::NotANumber),
            ("-5", FieldError::NotANumber),
            ("70000", FieldError::OutOfRange),
        ] {
            assert_eq!(LINK_POLL_MS.parse_into(t, &mut c), Err(e), "{t}");
        }
        assert_eq!(c.poll_ms, 50, "nothing written on error");
        assert_eq!(WATCHDOG_PERIOD_MS.parse_into("0", &mut c), Ok(()));
        assert_eq!(
            WATCHDOG_PERIOD_MS.parse_into("10", &mut c),
            Err(FieldError::OutOfRange)
        );
        assert_eq!(LINK_MODE.parse_into("listen", &mut c), Ok(()));
        assert_eq!(c.link_mode, LinkMode::Listen);
        assert_eq!(LINK_MODE.parse_into("0", &mut c), Ok(()), "index read too");
        assert_eq!(c.link_mode, LinkMode::Connect);
        assert_eq!(
            LINK_MODE.parse_into("2", &mut c),
            Err(FieldError::NotAChoice)
        );
        assert_eq!(
            LINK_MODE.parse_into("sideways", &mut c),
            Err(FieldError::NotAChoice)
        );
        assert_eq!(ACCESS_WRITE_PROTECT.parse_into("1", &mut c), Ok(()));
        assert!(c.write_protect);
        assert_eq!(
            ACCESS_WRITE_PROTECT.parse_into("yes", &mut c),
            Err(FieldError::NotAFlag)
        );
        // One IPv4 grammar everywhere: core's (no leading zeros).
        for t in ["10.1.2", "10.1.2.256", "010.0.0.1", "1.2.3.4.5", " "] {
            assert_eq!(
                NETWORK_ADDRESS.parse_into(t, &mut c),
                Err(FieldError::NotAnAddress),
                "{t:?}"
            );
        }
        assert_eq!(
            NETWORK_MASK.parse_into("255.0.255.0", &mut c),
            Err(FieldError::NotAMask)
        );
        assert_eq!(
            NETWORK_MASK.parse_into("0.0.0.0", &mut c),
            Err(FieldError::NotAMask)
        );
        assert_eq!(
            MQTT_BROKER.parse_into("broker-1.plant.local", &mut c),
            Ok(())
        );
        assert_eq!(c.mqtt.broker.as_str(), "broker-1.plant.local");
        assert_eq!(
            MQTT_BROKER.parse_into("bad host", &mut c),
            Err(FieldError::NotAHost)
        );
        let long = "a".repeat(HostName::MAX + 1);
        assert_eq!(
            MQTT_BROKER.parse_into(&long, &mut c),
            Err(FieldError::NotAHost)
        );
    }
}
