//! The gateway's configuration: the typed model ([`Config`]) and its
//! schema ([`schema`]: every setting once, by a stable key, with its type,
//! range, unit, default and help).
//!
//! The configuration knows no view: the Modbus registers
//! (`registers::config`), the web form, the TOML file and the stored
//! image read and write it through the schema. Saving is
//! [`crate::storage`]'s.

use core::net::{Ipv4Addr, SocketAddrV4};

pub mod schema;

pub use schema::{FieldError, Kind, Setting, Value, SETTINGS};

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

/// How the map's real numbers (the `f32` registers: override, positions,
/// a channel's parameters and results) are carried in their two registers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NumberFormat {
    /// IEEE-754 single precision (the default).
    #[default]
    F32 = 0,
    /// A 32-bit signed integer in thousandths (420.5 mm = 420500), for PLCs
    /// that cannot pack floats; unknown = `i32::MIN`.
    Thousandths = 1,
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

/// Which protocol the controller speaks (`CFG_PROTOCOL`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ProtocolSetting {
    /// Ask the controller at each connection (`PackageVersion`: its
    /// version is the level; a controller without the command is V5).
    #[default]
    Detect = 0,
    /// HR-TCP V1.0.0.3 (controllers before HR5.50.3).
    V5 = 1,
    /// The V6 document (V1.0.19.1, HR6.6.1).
    V6 = 2,
}

/// The gateway's own network settings. On a board they are applied at
/// start (a change takes effect at the next start); on Linux the operating
/// system owns the interface and the command line the listening addresses,
/// so these are kept and shown but not used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NetConfig {
    /// Static address (when `dhcp` is off).
    pub ip: Ipv4Addr,
    /// Network mask (contiguous ones).
    pub mask: Ipv4Addr,
    /// Default gateway; `0.0.0.0` = none.
    pub gateway: Ipv4Addr,
    /// Ask a DHCP server for the address instead.
    pub dhcp: bool,
    /// Port of the Modbus server, default 502.
    pub modbus_port: u16,
    /// Port of the web page, default 80; 0 = no web page.
    pub web_port: u16,
}

impl NetConfig {
    /// The factory defaults: 192.168.1.50/24, gateway 192.168.1.1, Modbus
    /// on 502, the web page on 80.
    pub const DEFAULT: NetConfig = NetConfig {
        ip: Ipv4Addr::new(192, 168, 1, 50),
        mask: Ipv4Addr::new(255, 255, 255, 0),
        gateway: Ipv4Addr::new(192, 168, 1, 1),
        dhcp: false,
        modbus_port: 502,
        web_port: 80,
    };

    /// The mask as a prefix length (the mask is contiguous: checked when
    /// it is set).
    pub fn prefix_len(&self) -> u8 {
        u32::from(self.mask).leading_ones() as u8
    }
}

impl Default for NetConfig {
    fn default() -> Self {
        NetConfig::DEFAULT
    }
}

/// Entries of each allow-list.
pub const ALLOW_ENTRIES: usize = 4;

/// One entry of an allow-list: a network `ip/prefix`; prefix 0 = unused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AllowEntry {
    /// Address (bits beyond the prefix are ignored).
    pub ip: Ipv4Addr,
    /// Prefix length 1-32 (32 = one address); 0 = unused entry.
    pub prefix: u8,
}

impl AllowEntry {
    /// An unused entry.
    pub const UNUSED: AllowEntry = AllowEntry {
        ip: Ipv4Addr::UNSPECIFIED,
        prefix: 0,
    };

    /// `true` if the entry is used and `addr` is inside its network.
    pub fn matches(&self, addr: Ipv4Addr) -> bool {
        if self.prefix == 0 {
            return false;
        }
        let mask = u32::MAX << (32 - u32::from(self.prefix.min(32)));
        (u32::from(addr) ^ u32::from(self.ip)) & mask == 0
    }
}

impl AllowEntry {
    /// Reads `a.b.c.d/prefix` (prefix 1-32) or `a.b.c.d` (one address).
    pub fn parse(t: &str) -> Result<AllowEntry, FieldError> {
        let (ip, prefix) = match t.split_once('/') {
            Some((ip, p)) => {
                let p = match p.bytes().all(|b| b.is_ascii_digit()) {
                    true => p.parse::<u8>().map_err(|_| FieldError::NotANetwork)?,
                    false => return Err(FieldError::NotANetwork),
                };
                (ip, p)
            }
            None => (t, 32),
        };
        if !(1..=32).contains(&prefix) {
            return Err(FieldError::NotANetwork);
        }
        let ip = ip.parse().map_err(|_| FieldError::NotANetwork)?;
        Ok(AllowEntry { ip, prefix })
    }
}

/// The client addresses a server accepts: empty (every entry unused) =
/// everyone, the factory default.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct AllowList(pub [AllowEntry; ALLOW_ENTRIES]);

impl Default for AllowList {
    fn default() -> Self {
        AllowList::EVERYONE
    }
}

impl AllowList {
    /// Nobody listed: everyone is allowed.
    pub const EVERYONE: AllowList = AllowList([AllowEntry::UNUSED; ALLOW_ENTRIES]);

    /// `true` if no entry is used.
    pub fn is_empty(&self) -> bool {
        self.0.iter().all(|e| e.prefix == 0)
    }

    /// `true` if a client at `addr` may connect.
    pub fn permits(&self, addr: Ipv4Addr) -> bool {
        self.is_empty() || self.0.iter().any(|e| e.matches(addr))
    }

    /// `true` if a client at `peer` may connect: its address is permitted,
    /// or its address is not known and the list is empty (everyone). The
    /// one rule of every listener.
    pub fn admits(&self, peer: Option<core::net::SocketAddrV4>) -> bool {
        match peer {
            Some(p) => self.permits(*p.ip()),
            None => self.is_empty(),
        }
    }

    /// Reads up to [`ALLOW_ENTRIES`] entries ([`AllowEntry::parse`])
    /// separated by spaces or commas, into the list's entries in order;
    /// empty text = everyone. The one allow-list grammar of every view.
    pub fn parse(t: &str) -> Result<AllowList, FieldError> {
        Self::from_entries(t.split([' ', ',']).filter(|e| !e.is_empty()))
    }

    /// The list of these entries (each as [`AllowEntry::parse`] reads it).
    pub fn from_entries<'a>(
        mut entries: impl Iterator<Item = &'a str>,
    ) -> Result<AllowList, FieldError> {
        let mut list = AllowList::EVERYONE;
        for slot in list.0.iter_mut() {
            let Some(e) = entries.next() else { break };
            *slot = AllowEntry::parse(e.trim())?;
        }
        match entries.next() {
            Some(_) => Err(FieldError::TooManyEntries),
            None => Ok(list),
        }
    }

    /// Writes the used entries as `a.b.c.d/prefix`, separated by spaces.
    pub fn format(&self, out: &mut impl core::fmt::Write) -> core::fmt::Result {
        for (i, e) in self.0.iter().filter(|e| e.prefix != 0).enumerate() {
            if i > 0 {
                out.write_str(" ")?;
            }
            write!(out, "{}/{}", e.ip, e.prefix)?;
        }
        Ok(())
    }
}

/// A host name or address of up to [`HostName::MAX`] bytes (letters,
/// digits, `.`, `-`, `_`, `:`); empty = none. Fixed size, so that
/// [`Config`] stays `Copy`.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct HostName {
    bytes: [u8; HostName::MAX],
    len: u8,
}

impl core::fmt::Debug for HostName {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "{:?}", self.as_str())
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for HostName {
    fn format(&self, f: defmt::Formatter) {
        defmt::write!(f, "{=str}", self.as_str())
    }
}

impl HostName {
    /// Longest name.
    pub const MAX: usize = 63;
    /// No name.
    pub const EMPTY: HostName = HostName {
        bytes: [0; HostName::MAX],
        len: 0,
    };

    /// `true` if `b` is a valid name (empty included).
    pub fn is_valid(b: &[u8]) -> bool {
        b.len() <= Self::MAX
            && b.iter()
                .all(|&c| c.is_ascii_alphanumeric() || matches!(c, b'.' | b'-' | b'_' | b':'))
    }

    /// The name `t`, checked when the constant is evaluated (defaults).
    // Indexing within the lengths just asserted; used for constants, so a
    // bad name fails the build, never a device.
    #[allow(clippy::indexing_slicing)]
    pub(crate) const fn from_static(t: &str) -> HostName {
        let b = t.as_bytes();
        assert!(b.len() <= HostName::MAX);
        let mut h = HostName::EMPTY;
        let mut i = 0;
        while i < b.len() {
            let c = b[i];
            assert!(c.is_ascii_alphanumeric() || c == b'.' || c == b'-' || c == b'_');
            h.bytes[i] = c;
            i += 1;
        }
        h.len = b.len() as u8;
        h
    }

    /// The name `t`, if valid.
    pub fn new(t: &str) -> Option<HostName> {
        Self::from_bytes(t.as_bytes())
    }

    /// The name of these bytes, if valid.
    pub fn from_bytes(b: &[u8]) -> Option<HostName> {
        if !Self::is_valid(b) {
            return None;
        }
        let mut h = HostName::EMPTY;
        h.bytes.get_mut(..b.len())?.copy_from_slice(b);
        h.len = b.len() as u8;
        Some(h)
    }

    /// The name's bytes.
    pub fn as_bytes(&self) -> &[u8] {
        self.bytes.get(..usize::from(self.len)).unwrap_or(&[])
    }

    /// The name (ASCII, checked when it was made).
    pub fn as_str(&self) -> &str {
        core::str::from_utf8(self.as_bytes()).unwrap_or("")
    }
}

/// The Sparkplug B edge node's settings (`mqtt.*`, used with the feature
/// `mqtt`): where it publishes and how often. Off in the factory state:
/// nothing leaves the device until someone names a broker and turns it on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MqttConfig {
    /// Publish (with a broker named).
    pub enabled: bool,
    /// The broker's address (boards: an IPv4 address; Linux also resolves
    /// a host name); empty = none.
    pub broker: HostName,
    /// The broker's port, default 1883.
    pub port: u16,
    /// TLS to the broker (Linux: the CAs of `--mqtt-ca`, else the
    /// system's; boards have no TLS client and report it).
    pub tls: bool,
    /// The Sparkplug group id, default `cells`.
    pub group: HostName,
    /// The edge node id (also the MQTT client id); empty = the platform's
    /// own (a board: `hans-` and its MAC address; Linux: the host name).
    pub edge: HostName,
    /// A Sparkplug 3.0 primary host id: births wait for its STATE online
    /// message; empty = none.
    pub primary_host: HostName,
    /// The keep-alive \[s\], 5-3600, default 30: the broker publishes the
    /// NDEATH 1.5 times this after the gateway goes silent.
    pub keep_alive_s: u16,
    /// The shortest time between two data rounds \[ms\], 10-60000,
    /// default 100.
    pub period_ms: u16,
    /// Joints deadband \[0.01 degree\], 0-10000, default 10 (0.1 degree).
    pub joint_deadband: u16,
    /// Pose deadband \[0.01 mm or degree\], 0-10000, default 10.
    pub pose_deadband: u16,
}

impl MqttConfig {
    /// The factory defaults: off, no broker, port 1883, group `cells`.
    pub const DEFAULT: MqttConfig = MqttConfig {
        enabled: false,
        broker: HostName::EMPTY,
        port: 1883,
        tls: false,
        group: HostName::from_static("cells"),
        edge: HostName::EMPTY,
        primary_host: HostName::EMPTY,
        keep_alive_s: 30,
        period_ms: 100,
        joint_deadband: 10,
        pose_deadband: 10,
    };
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
    /// How the `f32` registers carry their numbers.
    pub number_format: NumberFormat,
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
    /// The controller's protocol level, or detect it.
    pub protocol: ProtocolSetting,
    /// The gateway's network settings.
    pub net: NetConfig,
    /// The configuration registers (and the trigger texts) are
    /// write-protected over Modbus; only an authorized web session edits
    /// the configuration, and lifts this.
    pub write_protect: bool,
    /// Who may open a Modbus session.
    pub modbus_allow: AllowList,
    /// Who may open the web page.
    pub web_allow: AllowList,
    /// The Sparkplug B telemetry to an MQTT broker (no registers: the
    /// page and the TOML file set it).
    pub mqtt: MqttConfig,
    /// A DNS name the web page is also served under (besides the device's
    /// addresses); empty = addresses only.
    pub web_host: HostName,
    /// The web page's status, configuration and logs are read without a
    /// login (off: an account is needed for everything).
    pub read_without_login: bool,
    /// The NTP server whose time the audit log's records carry (boards);
    /// `0.0.0.0` = none.
    pub ntp_server: Ipv4Addr,
    /// Configuration over Modbus: the PLC may change the protected
    /// settings ([`schema::PROTECTED`]). Off in the factory state; only the
    /// page and the file set it.
    pub modbus_config: bool,
    /// The PLC's address: its Modbus sessions hold a reserved slot;
    /// `0.0.0.0` = none (then the Modbus allow-list's entries are the
    /// PLC's).
    pub plc_address: Ipv4Addr,
    /// The EtherNet/IP adapter is served (builds with the feature `enip`;
    /// off in the factory state; at the next start).
    pub enip_enabled: bool,
    /// Who may talk EtherNet/IP (sessions, discovery, I/O datagrams).
    pub enip_allow: AllowList,
}

impl Config {
    /// Checks every setting against its kind and range; the first out of
    /// range is named (a configuration built field by field, not through
    /// the schema, may hold one).
    pub fn check(&self) -> Result<(), &'static Setting> {
        match SETTINGS
            .iter()
            .find(|s| s.kind.check(&s.get(self)).is_err())
        {
            Some(s) => Err(s),
            None => Ok(()),
        }
    }

    /// The robot's command endpoint.
    pub fn robot(&self) -> SocketAddrV4 {
        SocketAddrV4::new(self.robot_ip, self.robot_port)
    }
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
        number_format: NumberFormat::F32,
        watchdog_ms: 0,
        watchdog_action: WatchdogAction::Stop,
        wait_blending_done: false,
        wait_in_position: false,
        start_grace_ms: 200,
        auto_reset: false,
        status_source: StatusSource::Polling,
        datasheet_port: 10005,
        robot_id: 0,
        protocol: ProtocolSetting::Detect,
        net: NetConfig::DEFAULT,
        write_protect: false,
        modbus_allow: AllowList::EVERYONE,
        web_allow: AllowList::EVERYONE,
        mqtt: MqttConfig::DEFAULT,
        web_host: HostName::EMPTY,
        read_without_login: true,
        ntp_server: Ipv4Addr::UNSPECIFIED,
        modbus_config: false,
        plc_address: Ipv4Addr::UNSPECIFIED,
        enip_enabled: false,
        enip_allow: AllowList::EVERYONE,
    };

    /// This configuration with the network and access settings of `other`
    /// (the recovery start: a board started with its button held keeps the
    /// stored settings but takes the factory network and access ones).
    pub fn with_network_of(mut self, other: &Config) -> Config {
        self.net = other.net;
        self.write_protect = other.write_protect;
        self.modbus_allow = other.modbus_allow;
        self.web_allow = other.web_allow;
        self.web_host = other.web_host;
        self.read_without_login = other.read_without_login;
        self.modbus_config = other.modbus_config;
        self.plc_address = other.plc_address;
        self.enip_enabled = other.enip_enabled;
        self.enip_allow = other.enip_allow;
        self
    }

    /// The first protected setting ([`schema::PROTECTED`]: the robot
    /// endpoint, the link mode, the network and access settings) whose
    /// value differs between this configuration and `other`; `None` if
    /// they agree on all of them.
    pub fn protected_change(&self, other: &Config) -> Option<&'static Setting> {
        schema::PROTECTED
            .iter()
            .copied()
            .find(|s| s.get(self) != s.get(other))
    }

    /// This configuration with the protected settings of `other` (what
    /// `CONFIG_COMMAND` 3 loads while configuration over Modbus is off:
    /// the factory settings, the protected ones as they are).
    pub fn with_protected_of(mut self, other: &Config) -> Config {
        for s in schema::PROTECTED {
            // A value read from a configuration is of its setting's kind.
            let _ = s.set(&mut self, s.get(other));
        }
        self
    }

    /// `true` if a Modbus client at `peer` is the PLC: the configured PLC
    /// address, or, without one, inside a Modbus allow-list entry. Its
    /// sessions hold the reserved slot (`crate::admission`).
    pub fn is_plc(&self, peer: Option<core::net::SocketAddrV4>) -> bool {
        let Some(ip) = peer.map(|p| *p.ip()) else {
            return false;
        };
        if !self.plc_address.is_unspecified() {
            return ip == self.plc_address;
        }
        !self.modbus_allow.is_empty() && self.modbus_allow.permits(ip)
    }

    /// `true` if a slot is reserved for the PLC: a PLC address is
    /// configured, or a Modbus allow-list names who may connect.
    pub fn reserves_plc_slot(&self) -> bool {
        !self.plc_address.is_unspecified() || !self.modbus_allow.is_empty()
    }
}

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
    /// Not applied: the edit changes a protected setting (the robot
    /// endpoint, the link mode, a network or access setting:
    /// [`schema::PROTECTED`]) and configuration over Modbus is off
    /// (exception 01). An administrator allows it on the web page
    /// (`access.modbus_config`), or the device is started in recovery (the
    /// board's button).
    Protected = 4,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn allow_lists_match_networks_and_empty_means_everyone() {
        let ip = Ipv4Addr::new;
        let mut l = AllowList::EVERYONE;
        assert!(l.permits(ip(10, 1, 2, 3)));
        l.0[2] = AllowEntry {
            ip: ip(127, 0, 0, 1),
            prefix: 32,
        };
        assert!(l.permits(ip(127, 0, 0, 1)));
        assert!(!l.permits(ip(127, 0, 0, 2)));
        l.0[0] = AllowEntry {
            ip: ip(192, 168, 7, 99), // host bits beyond the prefix ignored
            prefix: 24,
        };
        assert!(l.permits(ip(192, 168, 7, 1)));
        assert!(!l.permits(ip(192, 168, 8, 1)));
        l.0[1] = AllowEntry {
            ip: ip(0, 0, 0, 0),
            prefix: 1,
        };
        assert!(l.permits(ip(127, 0, 0, 2)));
        assert!(!l.permits(ip(128, 0, 0, 2)));
    }

    #[test]
    fn allow_lists_read_and_write_as_text() {
        extern crate std;
        use std::string::String;
        let l = AllowList::parse("10.0.0.0/8, 127.0.0.1").unwrap();
        let mut s = String::new();
        l.format(&mut s).unwrap();
        assert_eq!(s, "10.0.0.0/8 127.0.0.1/32");
        assert_eq!(AllowList::parse("").unwrap(), AllowList::EVERYONE);
        for (t, e) in [
            (
                "1.1.1.1 2.2.2.2 3.3.3.3 4.4.4.4 5.5.5.5",
                FieldError::TooManyEntries,
            ),
            ("1.2.3.4/33", FieldError::NotANetwork),
            ("1.2.3.4/0", FieldError::NotANetwork),
            ("1.2.3.4/+8", FieldError::NotANetwork),
            ("010.2.3.4/8", FieldError::NotANetwork),
            ("1.2.3/8", FieldError::NotANetwork),
        ] {
            assert_eq!(AllowList::parse(t), Err(e), "{t}");
        }
    }
}
