//! The gateway's configuration and the table of its settings.
//!
//! [`FIELDS`] describes every setting once: its register, unit, range and
//! meaning. The register view checks an edit with it
//! ([`Config::from_words`]), and other views (a web form) take units and
//! ranges from the same table. Saving is [`crate::storage`]'s.

use core::net::{Ipv4Addr, SocketAddrV4};

use crate::registers::map as r;

/// Word order of 32-bit values in two registers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WordOrder {
    /// High word at the lower address ("big-endian words", the default).
    #[default]
    HighFirst = 0,
    /// Low word at the lower address.
    LowFirst = 1,
}

/// Who opens the robot connection (chapter 3.1 of the protocol document).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LinkMode {
    /// The gateway connects to the controller's command port.
    #[default]
    Connect = 0,
    /// The controller connects to the gateway (its client mode); a new
    /// connection replaces the old one.
    Listen = 1,
}

/// What the watchdog does when the PLC heartbeat stops during a motion.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WatchdogAction {
    /// Report only (the motion goes on).
    ReportOnly = 0,
    /// Send `GrpStop` (default).
    #[default]
    Stop = 1,
    /// Send `GrpInterrupt` (pause).
    Pause = 2,
}

/// Where the status mirror comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StatusSource {
    /// Poll the command port (`ReadRobotState`, `ReadCurFSM`, ...).
    #[default]
    Polling = 0,
    /// Read the DataSheet port's JSON packets (spares the command port).
    DataSheet = 1,
}

/// The configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// Robot controller address (connect mode). `0.0.0.0` = not configured:
    /// the link stays down.
    pub robot_ip: Ipv4Addr,
    /// Robot command port (connect mode), default 10003.
    pub robot_port: u16,
    /// Connect or listen.
    pub link_mode: LinkMode,
    /// Port listened on in listen mode, default 10003.
    pub listen_port: u16,
    /// Status poll period \[ms\], 10-100, default 100.
    pub poll_ms: u16,
    /// Reply timeout \[ms\], 50-60000, default 1000.
    pub reply_timeout_ms: u16,
    /// Word order of 32-bit values.
    pub word_order: WordOrder,
    /// Watchdog period \[ms\], 0 = off (default), else 50-60000.
    pub watchdog_ms: u16,
    /// Watchdog action.
    pub watchdog_action: WatchdogAction,
    /// Also wait for blending done before a motion is Done.
    pub wait_blending_done: bool,
    /// Also wait for in position before a motion is Done.
    pub wait_in_position: bool,
    /// \[ms\] a motion may report "not moving" after being accepted before that
    /// counts as finished (the moving flag lags ~50 ms), 0-5000, default 200.
    pub start_grace_ms: u16,
    /// Send `GrpReset` after a motion ends in a robot error (default off).
    pub auto_reset: bool,
    /// Status source.
    pub status_source: StatusSource,
    /// DataSheet port, default 10005 (10 Hz).
    pub datasheet_port: u16,
    /// Robot id, 0-5.
    pub robot_id: u8,
}

impl Default for Config {
    fn default() -> Self {
        Config::DEFAULT
    }
}

impl Config {
    /// The factory defaults (as `Default`, usable in constants).
    pub const DEFAULT: Config = Config {
        robot_ip: Ipv4Addr::UNSPECIFIED,
        robot_port: 10003,
        link_mode: LinkMode::Connect,
        listen_port: 10003,
        poll_ms: 100,
        reply_timeout_ms: 1000,
        word_order: WordOrder::HighFirst,
        watchdog_ms: 0,
        watchdog_action: WatchdogAction::Stop,
        wait_blending_done: false,
        wait_in_position: false,
        start_grace_ms: 200,
        auto_reset: false,
        status_source: StatusSource::Polling,
        datasheet_port: 10005,
        robot_id: 0,
    };
}

/// What a setting's register may hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Domain {
    /// An IPv4 address in two registers (`a.b.c.d` = `a × 256 + b`,
    /// `c × 256 + d`); every value is valid, 0.0.0.0 = not configured.
    Ipv4,
    /// `min..=max`.
    Range(u16, u16),
    /// 0 (off) or `min..=max`.
    OffOrRange(u16, u16),
}

impl Domain {
    /// `true` if `v` is a valid value (of the first register, for
    /// [`Domain::Ipv4`]).
    pub const fn contains(self, v: u16) -> bool {
        match self {
            Domain::Ipv4 => true,
            Domain::Range(lo, hi) => lo <= v && v <= hi,
            Domain::OffOrRange(lo, hi) => v == 0 || (lo <= v && v <= hi),
        }
    }
}

/// One setting: a `CFG_*` register (two for the robot address).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Field {
    /// Register name (`REGISTERS.md`).
    pub name: &'static str,
    /// Its address.
    pub addr: u16,
    /// Registers it takes.
    pub len: u16,
    /// Valid values.
    pub domain: Domain,
    /// Unit, empty for none.
    pub unit: &'static str,
    /// What the values mean, short.
    pub help: &'static str,
}

const fn field(
    name: &'static str,
    addr: u16,
    domain: Domain,
    unit: &'static str,
    help: &'static str,
) -> Field {
    let len = match domain {
        Domain::Ipv4 => 2,
        _ => 1,
    };
    Field {
        name,
        addr,
        len,
        domain,
        unit,
        help,
    }
}

/// Status sources this build has: polling, and the DataSheet with the
/// feature `datasheet`.
const STATUS_SOURCES: u16 = if cfg!(feature = "datasheet") { 2 } else { 1 };

/// Every setting, in register order.
pub const FIELDS: [Field; 15] = [
    field(
        "CFG_ROBOT_IP",
        r::CONFIG_ROBOT_IP,
        Domain::Ipv4,
        "",
        "robot controller address; 0.0.0.0 = not configured",
    ),
    field(
        "CFG_ROBOT_PORT",
        r::CONFIG_ROBOT_PORT,
        Domain::Range(1, 65535),
        "",
        "robot command port",
    ),
    field(
        "CFG_LINK_MODE",
        r::CONFIG_LINK_MODE,
        Domain::Range(0, 1),
        "",
        "0 = connect to the robot, 1 = the robot connects (listen)",
    ),
    field(
        "CFG_LISTEN_PORT",
        r::CONFIG_LISTEN_PORT,
        Domain::Range(1, 65535),
        "",
        "port listened on in mode 1",
    ),
    field(
        "CFG_POLL_MS",
        r::CONFIG_POLL_MS,
        Domain::Range(10, 100),
        "ms",
        "status poll period",
    ),
    field(
        "CFG_REPLY_TIMEOUT_MS",
        r::CONFIG_REPLY_TIMEOUT_MS,
        Domain::Range(50, 60000),
        "ms",
        "robot reply timeout",
    ),
    field(
        "CFG_FLOAT_WORD_ORDER",
        r::CONFIG_FLOAT_WORD_ORDER,
        Domain::Range(0, 1),
        "",
        "0 = high word first, 1 = low word first",
    ),
    field(
        "CFG_WATCHDOG_MS",
        r::CONFIG_WATCHDOG_MS,
        Domain::OffOrRange(50, 60000),
        "ms",
        "PLC watchdog period, 0 = off",
    ),
    field(
        "CFG_WATCHDOG_ACTION",
        r::CONFIG_WATCHDOG_ACTION,
        Domain::Range(0, 2),
        "",
        "0 = report only, 1 = stop, 2 = pause",
    ),
    field(
        "CFG_MOTION_POLICY",
        r::CONFIG_MOTION_POLICY,
        Domain::Range(0, 3),
        "bits",
        "Done also needs: bit 0 blending done, bit 1 in position",
    ),
    field(
        "CFG_START_GRACE_MS",
        r::CONFIG_START_GRACE_MS,
        Domain::Range(0, 5000),
        "ms",
        "time a motion may read not moving after its start",
    ),
    field(
        "CFG_AUTO_RESET",
        r::CONFIG_AUTO_RESET,
        Domain::Range(0, 1),
        "",
        "1 = GrpReset after a motion error",
    ),
    field(
        "CFG_STATUS_SOURCE",
        r::CONFIG_STATUS_SOURCE,
        Domain::Range(0, STATUS_SOURCES - 1),
        "",
        "0 = poll the command port, 1 = DataSheet (builds with the DataSheet reader)",
    ),
    field(
        "CFG_DATASHEET_PORT",
        r::CONFIG_DATASHEET_PORT,
        Domain::Range(1, 65535),
        "",
        "DataSheet port",
    ),
    field(
        "CFG_ROBOT_ID",
        r::CONFIG_ROBOT_ID,
        Domain::Range(0, 5),
        "",
        "robot id nRbtID",
    ),
];

/// What the last configuration command did (register `CONFIG_RESULT`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConfigResult {
    /// Done: for apply, applied and saved; for discard and defaults, the
    /// edit replaced.
    #[default]
    Ok = 0,
    /// A value was out of range: nothing applied (exception 03).
    Invalid = 1,
    /// Applied, but the storage failed (exception 04).
    SaveFailed = 2,
    /// Applied, not saved: the gateway has no persistent storage.
    NotSaved = 3,
}

/// A configuration register holds a value outside its range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InvalidValue {
    /// The register.
    pub addr: u16,
}

/// The configuration as its registers, in register order.
pub type Words = [u16; r::CONFIG_LEN as usize];

impl Config {
    /// The robot's command endpoint.
    pub fn robot(&self) -> SocketAddrV4 {
        SocketAddrV4::new(self.robot_ip, self.robot_port)
    }

    /// The configuration as its [`r::CONFIG_LEN`] registers.
    pub fn to_words(&self) -> Words {
        let ip = self.robot_ip.octets();
        [
            u16::from_be_bytes([ip[0], ip[1]]),
            u16::from_be_bytes([ip[2], ip[3]]),
            self.robot_port,
            self.link_mode as u16,
            self.listen_port,
            self.poll_ms,
            self.reply_timeout_ms,
            self.word_order as u16,
            self.watchdog_ms,
            self.watchdog_action as u16,
            u16::from(self.wait_blending_done) | (u16::from(self.wait_in_position) << 1),
            self.start_grace_ms,
            u16::from(self.auto_reset),
            self.status_source as u16,
            self.datasheet_port,
            u16::from(self.robot_id),
        ]
    }

    /// Reads and checks the configuration from its registers: every field
    /// against [`FIELDS`]; the first invalid one is named.
    pub fn from_words(w: &Words) -> Result<Config, InvalidValue> {
        let at = |reg: u16| {
            w.get(usize::from(reg.wrapping_sub(r::CONFIG_ROBOT_IP)))
                .copied()
                .unwrap_or(0)
        };
        for f in FIELDS {
            if !f.domain.contains(at(f.addr)) {
                return Err(InvalidValue { addr: f.addr });
            }
        }
        let [a, b] = at(r::CONFIG_ROBOT_IP).to_be_bytes();
        let [c, d] = at(r::CONFIG_ROBOT_IP + 1).to_be_bytes();
        let policy = at(r::CONFIG_MOTION_POLICY);
        Ok(Config {
            robot_ip: Ipv4Addr::new(a, b, c, d),
            robot_port: at(r::CONFIG_ROBOT_PORT),
            link_mode: match at(r::CONFIG_LINK_MODE) {
                0 => LinkMode::Connect,
                _ => LinkMode::Listen,
            },
            listen_port: at(r::CONFIG_LISTEN_PORT),
            poll_ms: at(r::CONFIG_POLL_MS),
            reply_timeout_ms: at(r::CONFIG_REPLY_TIMEOUT_MS),
            word_order: match at(r::CONFIG_FLOAT_WORD_ORDER) {
                0 => WordOrder::HighFirst,
                _ => WordOrder::LowFirst,
            },
            watchdog_ms: at(r::CONFIG_WATCHDOG_MS),
            watchdog_action: match at(r::CONFIG_WATCHDOG_ACTION) {
                0 => WatchdogAction::ReportOnly,
                1 => WatchdogAction::Stop,
                _ => WatchdogAction::Pause,
            },
            wait_blending_done: policy & 1 != 0,
            wait_in_position: policy & 2 != 0,
            start_grace_ms: at(r::CONFIG_START_GRACE_MS),
            auto_reset: at(r::CONFIG_AUTO_RESET) == 1,
            status_source: match at(r::CONFIG_STATUS_SOURCE) {
                0 => StatusSource::Polling,
                _ => StatusSource::DataSheet,
            },
            datasheet_port: at(r::CONFIG_DATASHEET_PORT),
            robot_id: at(r::CONFIG_ROBOT_ID) as u8,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn words_round_trip_and_ranges_are_checked() {
        let c = Config {
            robot_ip: Ipv4Addr::new(192, 168, 0, 7),
            link_mode: LinkMode::Listen,
            watchdog_ms: 500,
            watchdog_action: WatchdogAction::Pause,
            wait_in_position: true,
            word_order: WordOrder::LowFirst,
            ..Config::default()
        };
        let w = c.to_words();
        assert_eq!(w[0], 0xC0A8);
        assert_eq!(Config::from_words(&w), Ok(c));
        let mut bad = w;
        bad[usize::from(r::CONFIG_POLL_MS - r::CONFIG_ROBOT_IP)] = 101;
        assert_eq!(
            Config::from_words(&bad),
            Err(InvalidValue {
                addr: r::CONFIG_POLL_MS
            })
        );
        let mut bad = w;
        bad[usize::from(r::CONFIG_WATCHDOG_MS - r::CONFIG_ROBOT_IP)] = 10;
        assert!(Config::from_words(&bad).is_err());
        bad[usize::from(r::CONFIG_WATCHDOG_MS - r::CONFIG_ROBOT_IP)] = 0;
        assert!(Config::from_words(&bad).is_ok());
    }

    #[test]
    fn the_field_table_covers_every_register_once_and_holds_the_defaults() {
        let mut next = r::CONFIG_ROBOT_IP;
        for f in FIELDS {
            assert_eq!(f.addr, next, "{}", f.name);
            next += f.len;
        }
        assert_eq!(next, r::CONFIG_ROBOT_IP + r::CONFIG_LEN);
        let w = Config::DEFAULT.to_words();
        for f in FIELDS {
            let v = w[usize::from(f.addr - r::CONFIG_ROBOT_IP)];
            assert!(
                f.domain.contains(v),
                "default of {} out of its range",
                f.name
            );
        }
    }
}
