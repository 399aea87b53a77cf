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
        protocol: ProtocolSetting::Detect,
        net: NetConfig::DEFAULT,
        write_protect: false,
        modbus_allow: AllowList::EVERYONE,
        web_allow: AllowList::EVERYONE,
    };

    /// This configuration with the network and access settings of `other`
    /// (the recovery start: a board started with its button held keeps the
    /// stored settings but takes the factory network and access ones).
    pub fn with_network_of(mut self, other: &Config) -> Config {
        self.net = other.net;
        self.write_protect = other.write_protect;
        self.modbus_allow = other.modbus_allow;
        self.web_allow = other.web_allow;
        self
    }
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
    /// A network mask in two registers, as [`Domain::Ipv4`]: contiguous
    /// ones from the top (255.255.255.0); 0.0.0.0 is refused.
    Mask,
    /// An allow-list of [`ALLOW_ENTRIES`] entries, three registers each:
    /// the address (as [`Domain::Ipv4`]) and the prefix length 0-32
    /// (0 = unused entry).
    AllowList,
}

impl Domain {
    /// Registers a value of this domain takes.
    pub const fn registers(self) -> u16 {
        match self {
            Domain::Ipv4 | Domain::Mask => 2,
            Domain::AllowList => 3 * ALLOW_ENTRIES as u16,
            _ => 1,
        }
    }

    /// `true` if `v` is a valid value of a one-register domain (every
    /// value, for the others: see [`Domain::check`]).
    pub const fn contains(self, v: u16) -> bool {
        match self {
            Domain::Range(lo, hi) => lo <= v && v <= hi,
            Domain::OffOrRange(lo, hi) => v == 0 || (lo <= v && v <= hi),
            _ => true,
        }
    }

    /// Checks a value given as its registers (`words.len()` is
    /// [`Domain::registers`]); `Err(i)` names the first bad register, relative.
    pub fn check(self, words: &[u16]) -> Result<(), u16> {
        match self {
            Domain::Mask => {
                let m = ipv4(words);
                let bits = u32::from(m);
                if bits == 0 || bits.leading_ones() + bits.trailing_zeros() != 32 {
                    return Err(0);
                }
                Ok(())
            }
            Domain::AllowList => {
                for (i, e) in words.chunks(3).enumerate() {
                    if e.get(2).copied().unwrap_or(0) > 32 {
                        return Err(i as u16 * 3 + 2);
                    }
                }
                Ok(())
            }
            Domain::Ipv4 => Ok(()),
            _ => match words.first() {
                Some(&v) if self.contains(v) => Ok(()),
                _ => Err(0),
            },
        }
    }
}

/// The address held in two registers (`a.b.c.d` = `a × 256 + b`,
/// `c × 256 + d`).
pub fn ipv4(words: &[u16]) -> Ipv4Addr {
    let w = |i: usize| words.get(i).copied().unwrap_or(0).to_be_bytes();
    let ([a, b], [c, d]) = (w(0), w(1));
    Ipv4Addr::new(a, b, c, d)
}

/// The two registers of an address.
pub fn ipv4_words(ip: Ipv4Addr) -> [u16; 2] {
    let [a, b, c, d] = ip.octets();
    [u16::from_be_bytes([a, b]), u16::from_be_bytes([c, d])]
}

/// One setting: its registers (one, two for an address, twelve for an
/// allow-list).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Field {
    /// Register name (`REGISTERS.md`).
    pub name: &'static str,
    /// Its address.
    pub addr: u16,
    /// Registers it takes.
    pub len: u16,
    /// Where its registers start in [`Words`] (the settings' registers,
    /// one block after the other, in [`FIELDS`] order).
    pub slot: u16,
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
    // The slot follows from the block the address is in: the settings of
    // 100-115 first, those of 160-193 after them.
    let slot = if addr >= r::NET_IP {
        r::CONFIG_LEN + (addr - r::NET_IP)
    } else {
        addr - r::CONFIG_ROBOT_IP
    };
    Field {
        name,
        addr,
        len: domain.registers(),
        slot,
        domain,
        unit,
        help,
    }
}

/// Status sources this build has: polling, and the DataSheet with the
/// feature `datasheet`.
const STATUS_SOURCES: u16 = if cfg!(feature = "datasheet") { 2 } else { 1 };

/// Every setting, in register order.
pub const FIELDS: [Field; 25] = [
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
    field(
        "CFG_PROTOCOL",
        r::CONFIG_PROTOCOL,
        Domain::Range(0, 2),
        "",
        "0 = detect at each connection (PackageVersion), 1 = V5 (HR-TCP 1.0.0.3), 2 = V6",
    ),
    field(
        "NET_IP",
        r::NET_IP,
        Domain::Ipv4,
        "",
        "the gateway's address (without DHCP); at the next start",
    ),
    field(
        "NET_MASK",
        r::NET_MASK,
        Domain::Mask,
        "",
        "network mask, e.g. 255.255.255.0; at the next start",
    ),
    field(
        "NET_GATEWAY",
        r::NET_GATEWAY,
        Domain::Ipv4,
        "",
        "default gateway, 0.0.0.0 = none; at the next start",
    ),
    field(
        "NET_DHCP",
        r::NET_DHCP,
        Domain::Range(0, 1),
        "",
        "1 = address from a DHCP server (builds with DHCP); at the next start",
    ),
    field(
        "NET_MODBUS_PORT",
        r::NET_MODBUS_PORT,
        Domain::Range(1, 65535),
        "",
        "Modbus TCP port; at the next start",
    ),
    field(
        "NET_WEB_PORT",
        r::NET_WEB_PORT,
        Domain::Range(0, 65535),
        "",
        "web page port, 0 = no web page; at the next start",
    ),
    field(
        "CFG_WRITE_PROTECT",
        r::CONFIG_WRITE_PROTECT,
        Domain::Range(0, 1),
        "",
        "1 = configuration registers and trigger texts read-only over Modbus",
    ),
    field(
        "MODBUS_ALLOW",
        r::MODBUS_ALLOW,
        Domain::AllowList,
        "",
        "Modbus clients allowed: up to 4 entries a.b.c.d or a.b.c.d/prefix (1-32); none = everyone",
    ),
    field(
        "WEB_ALLOW",
        r::WEB_ALLOW,
        Domain::AllowList,
        "",
        "web clients allowed: up to 4 entries a.b.c.d or a.b.c.d/prefix (1-32); none = everyone",
    ),
];

/// Why a setting's text was refused (the web page shows it beside the
/// field).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FieldError {
    /// Not a number.
    NotANumber,
    /// Outside the field's range (see [`Domain`]).
    OutOfRange,
    /// Not an address `a.b.c.d`.
    NotAnAddress,
    /// Not a contiguous network mask.
    NotAMask,
    /// An allow-list entry is not `a.b.c.d/prefix` with a prefix 1-32.
    NotANetwork,
    /// More than [`ALLOW_ENTRIES`] entries.
    TooManyEntries,
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
        }
    }
}

/// Reads `a.b.c.d`.
pub fn parse_ipv4(t: &str) -> Option<Ipv4Addr> {
    let mut o = [0u8; 4];
    let mut parts = t.split('.');
    for slot in o.iter_mut() {
        let p = parts.next()?;
        if p.is_empty() || p.len() > 3 || !p.bytes().all(|b| b.is_ascii_digit()) {
            return None;
        }
        *slot = p.parse().ok()?;
    }
    if parts.next().is_some() {
        return None;
    }
    Some(Ipv4Addr::from(o))
}

impl Field {
    /// The setting's registers in `words`.
    fn words<'w>(&self, words: &'w Words) -> &'w [u16] {
        let s = usize::from(self.slot);
        words.get(s..s + usize::from(self.len)).unwrap_or(&[])
    }

    /// Writes the setting's value as text: a number, `a.b.c.d`, or an
    /// allow-list as `a.b.c.d/prefix` entries separated by spaces (empty:
    /// everyone).
    pub fn format(&self, words: &Words, out: &mut impl core::fmt::Write) -> core::fmt::Result {
        let w = self.words(words);
        match self.domain {
            Domain::Ipv4 | Domain::Mask => {
                let [a, b, c, d] = ipv4(w).octets();
                write!(out, "{a}.{b}.{c}.{d}")
            }
            Domain::AllowList => {
                let mut first = true;
                for e in allow_list(w).0.iter().filter(|e| e.prefix != 0) {
                    if !first {
                        out.write_str(" ")?;
                    }
                    first = false;
                    let [a, b, c, d] = e.ip.octets();
                    write!(out, "{a}.{b}.{c}.{d}/{}", e.prefix)?;
                }
                Ok(())
            }
            _ => write!(out, "{}", w.first().copied().unwrap_or(0)),
        }
    }

    /// Reads the setting's value from text (as [`Self::format`] writes
    /// it; an allow-list entry without `/prefix` is one address, entries
    /// separated by spaces or commas) into `words`, checked as the
    /// registers are. Nothing is written on error.
    pub fn parse(&self, text: &str, words: &mut Words) -> Result<(), FieldError> {
        let t = text.trim();
        let mut v = [0u16; 3 * ALLOW_ENTRIES];
        let n = usize::from(self.len);
        match self.domain {
            Domain::Ipv4 | Domain::Mask => {
                let ip = parse_ipv4(t).ok_or(FieldError::NotAnAddress)?;
                let [a, b] = ipv4_words(ip);
                v[0] = a;
                v[1] = b;
            }
            Domain::AllowList => {
                let mut entries = t.split([' ', ',']).filter(|e| !e.is_empty());
                for chunk in v.chunks_mut(3) {
                    let Some(e) = entries.next() else { break };
                    let (ip, prefix) = match e.split_once('/') {
                        Some((ip, p)) => {
                            let p: u8 = p.parse().map_err(|_| FieldError::NotANetwork)?;
                            (ip, p)
                        }
                        None => (e, 32),
                    };
                    if !(1..=32).contains(&prefix) {
                        return Err(FieldError::NotANetwork);
                    }
                    let ip = parse_ipv4(ip).ok_or(FieldError::NotANetwork)?;
                    let [a, b] = ipv4_words(ip);
                    chunk.copy_from_slice(&[a, b, u16::from(prefix)]);
                }
                if entries.next().is_some() {
                    return Err(FieldError::TooManyEntries);
                }
            }
            _ => {
                if t.is_empty() || !t.bytes().all(|b| b.is_ascii_digit()) {
                    return Err(FieldError::NotANumber);
                }
                v[0] = t.parse().map_err(|_| FieldError::OutOfRange)?;
            }
        }
        let v = v.get(..n).unwrap_or(&[]);
        self.domain.check(v).map_err(|_| match self.domain {
            Domain::Mask => FieldError::NotAMask,
            Domain::AllowList => FieldError::NotANetwork,
            _ => FieldError::OutOfRange,
        })?;
        let s = usize::from(self.slot);
        if let Some(dst) = words.get_mut(s..s + n) {
            dst.copy_from_slice(v);
        }
        Ok(())
    }
}

/// The field whose registers hold `addr`.
pub fn field_of(addr: u16) -> Option<&'static Field> {
    FIELDS
        .iter()
        .find(|f| f.addr <= addr && addr < f.addr + f.len)
}

/// The field named `name`.
pub fn field_named(name: &str) -> Option<&'static Field> {
    FIELDS.iter().find(|f| f.name == name)
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
}

/// A configuration register holds a value outside its range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InvalidValue {
    /// The register.
    pub addr: u16,
}

/// Registers of the settings: 100-115 and 160-193.
pub const CONFIG_WORDS: usize = (r::CONFIG_LEN + r::NET_LEN) as usize;

/// The settings as their registers: those of 100-115, then those of
/// 160-193 (a field's [`Field::slot`] is its place here).
pub type Words = [u16; CONFIG_WORDS];

/// The place of register `addr` in [`Words`], if it is a setting's.
pub fn slot_of(addr: u16) -> Option<usize> {
    let in_block = |start: u16, len: u16| addr.checked_sub(start).filter(|&o| o < len);
    if let Some(o) = in_block(r::CONFIG_ROBOT_IP, r::CONFIG_LEN) {
        return Some(usize::from(o));
    }
    in_block(r::NET_IP, r::NET_LEN).map(|o| usize::from(r::CONFIG_LEN + o))
}

fn allow_words(list: &AllowList, out: &mut [u16]) {
    for (e, w) in list.0.iter().zip(out.chunks_mut(3)) {
        let [a, b] = ipv4_words(e.ip);
        for (slot, v) in w.iter_mut().zip([a, b, u16::from(e.prefix)]) {
            *slot = v;
        }
    }
}

fn allow_list(words: &[u16]) -> AllowList {
    let mut list = AllowList::EVERYONE;
    for (e, w) in list.0.iter_mut().zip(words.chunks(3)) {
        e.ip = ipv4(w);
        e.prefix = w.get(2).copied().unwrap_or(0).min(32) as u8;
    }
    list
}

impl Config {
    /// The robot's command endpoint.
    pub fn robot(&self) -> SocketAddrV4 {
        SocketAddrV4::new(self.robot_ip, self.robot_port)
    }

    /// The configuration as its registers ([`Words`]).
    pub fn to_words(&self) -> Words {
        let mut w: Words = [0; CONFIG_WORDS];
        let mut put = |addr: u16, values: &[u16]| {
            if let Some(s) = slot_of(addr) {
                for (slot, &v) in w.iter_mut().skip(s).zip(values) {
                    *slot = v;
                }
            }
        };
        put(r::CONFIG_ROBOT_IP, &ipv4_words(self.robot_ip));
        put(
            r::CONFIG_ROBOT_PORT,
            &[
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
                self.protocol as u16,
            ],
        );
        let n = &self.net;
        put(r::NET_IP, &ipv4_words(n.ip));
        put(r::NET_MASK, &ipv4_words(n.mask));
        put(r::NET_GATEWAY, &ipv4_words(n.gateway));
        put(
            r::NET_DHCP,
            &[
                u16::from(n.dhcp),
                n.modbus_port,
                n.web_port,
                u16::from(self.write_protect),
            ],
        );
        let mut lists = [0u16; 6 * ALLOW_ENTRIES];
        let (m, web) = lists.split_at_mut(3 * ALLOW_ENTRIES);
        allow_words(&self.modbus_allow, m);
        allow_words(&self.web_allow, web);
        put(r::MODBUS_ALLOW, &lists);
        w
    }

    /// Reads and checks the configuration from its registers: every field
    /// against [`FIELDS`]; the first invalid register is named.
    pub fn from_words(w: &Words) -> Result<Config, InvalidValue> {
        for f in FIELDS {
            let s = usize::from(f.slot);
            let words = w.get(s..s + usize::from(f.len)).unwrap_or(&[]);
            f.domain
                .check(words)
                .map_err(|o| InvalidValue { addr: f.addr + o })?;
        }
        let at = |reg: u16| slot_of(reg).and_then(|s| w.get(s)).copied().unwrap_or(0);
        let ip_at = |reg: u16| ipv4(&[at(reg), at(reg + 1)]);
        let list_at = |reg: u16| {
            let s = slot_of(reg).unwrap_or(0);
            allow_list(w.get(s..s + 3 * ALLOW_ENTRIES).unwrap_or(&[]))
        };
        let policy = at(r::CONFIG_MOTION_POLICY);
        Ok(Config {
            robot_ip: ip_at(r::CONFIG_ROBOT_IP),
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
            protocol: match at(r::CONFIG_PROTOCOL) {
                0 => ProtocolSetting::Detect,
                1 => ProtocolSetting::V5,
                _ => ProtocolSetting::V6,
            },
            net: NetConfig {
                ip: ip_at(r::NET_IP),
                mask: ip_at(r::NET_MASK),
                gateway: ip_at(r::NET_GATEWAY),
                dhcp: at(r::NET_DHCP) == 1,
                modbus_port: at(r::NET_MODBUS_PORT),
                web_port: at(r::NET_WEB_PORT),
            },
            write_protect: at(r::CONFIG_WRITE_PROTECT) == 1,
            modbus_allow: list_at(r::MODBUS_ALLOW),
            web_allow: list_at(r::WEB_ALLOW),
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
        let mut next_slot = 0;
        for f in FIELDS {
            assert_eq!(usize::from(f.slot), next_slot, "{}", f.name);
            assert_eq!(slot_of(f.addr), Some(next_slot), "{}", f.name);
            assert_eq!(
                slot_of(f.addr + f.len - 1),
                Some(next_slot + usize::from(f.len) - 1)
            );
            assert_eq!(field_of(f.addr + f.len - 1).map(|g| g.name), Some(f.name));
            next_slot += usize::from(f.len);
        }
        assert_eq!(next_slot, CONFIG_WORDS);
        // Each block is covered without a gap.
        assert_eq!(slot_of(r::CONFIG_ROBOT_IP + r::CONFIG_LEN), None);
        assert_eq!(slot_of(r::NET_IP + r::NET_LEN), None);
        assert_eq!(slot_of(r::NET_IP - 1), None);
        assert_eq!(
            Config::from_words(&Config::DEFAULT.to_words()),
            Ok(Config::DEFAULT)
        );
    }

    #[test]
    fn network_and_access_settings_round_trip_and_are_checked() {
        let mut c = Config::DEFAULT;
        c.net = NetConfig {
            ip: Ipv4Addr::new(10, 20, 30, 2),
            mask: Ipv4Addr::new(255, 255, 0, 0),
            gateway: Ipv4Addr::UNSPECIFIED,
            dhcp: true,
            modbus_port: 5020,
            web_port: 0,
        };
        c.write_protect = true;
        c.modbus_allow.0[1] = AllowEntry {
            ip: Ipv4Addr::new(192, 168, 0, 0),
            prefix: 24,
        };
        c.web_allow.0[3] = AllowEntry {
            ip: Ipv4Addr::new(127, 0, 0, 1),
            prefix: 32,
        };
        let w = c.to_words();
        assert_eq!(Config::from_words(&w), Ok(c));
        assert_eq!(c.net.prefix_len(), 16);
        let at = |a: u16| slot_of(a).unwrap();
        for (mask, ok) in [
            ([0xFFFF, 0xFF00], true),
            ([0xFFFF, 0xFFFF], true),
            ([0x8000, 0], true),
            ([0, 0], false),
            ([0xFF00, 0xFF00], false),
            ([0x7FFF, 0xFF00], false),
        ] {
            let mut w = w;
            w[at(r::NET_MASK)] = mask[0];
            w[at(r::NET_MASK) + 1] = mask[1];
            let r = Config::from_words(&w);
            assert_eq!(r.is_ok(), ok, "{mask:x?}");
            if !ok {
                assert_eq!(r, Err(InvalidValue { addr: r::NET_MASK }));
            }
        }
        let mut bad = w;
        bad[at(r::WEB_ALLOW) + 3 * 2 + 2] = 33;
        assert_eq!(
            Config::from_words(&bad),
            Err(InvalidValue {
                addr: r::WEB_ALLOW + 8
            })
        );
    }

    #[test]
    fn settings_read_and_write_as_text_checked_as_registers() {
        extern crate std;
        use std::string::String;
        let mut w = Config::DEFAULT.to_words();
        let text = |name: &str, w: &Words| {
            let mut s = String::new();
            field_named(name).unwrap().format(w, &mut s).unwrap();
            s
        };
        let set = |name: &str, t: &str, w: &mut Words| field_named(name).unwrap().parse(t, w);
        assert_eq!(text("CFG_POLL_MS", &w), "100");
        assert_eq!(set("CFG_POLL_MS", " 50 ", &mut w), Ok(()));
        assert_eq!(text("CFG_POLL_MS", &w), "50");
        assert_eq!(
            set("CFG_POLL_MS", "101", &mut w),
            Err(FieldError::OutOfRange)
        );
        assert_eq!(
            set("CFG_POLL_MS", "5x", &mut w),
            Err(FieldError::NotANumber)
        );
        assert_eq!(
            set("CFG_POLL_MS", "-5", &mut w),
            Err(FieldError::NotANumber)
        );
        assert_eq!(
            set("CFG_ROBOT_PORT", "70000", &mut w),
            Err(FieldError::OutOfRange)
        );
        assert_eq!(text("CFG_POLL_MS", &w), "50", "nothing written on error");
        assert_eq!(set("NET_IP", "10.1.2.3", &mut w), Ok(()));
        assert_eq!(text("NET_IP", &w), "10.1.2.3");
        assert_eq!(
            set("NET_IP", "10.1.2", &mut w),
            Err(FieldError::NotAnAddress)
        );
        assert_eq!(
            set("NET_IP", "10.1.2.256", &mut w),
            Err(FieldError::NotAnAddress)
        );
        assert_eq!(
            set("NET_MASK", "255.0.255.0", &mut w),
            Err(FieldError::NotAMask)
        );
        assert_eq!(text("MODBUS_ALLOW", &w), "");
        assert_eq!(set("MODBUS_ALLOW", "10.0.0.0/8, 127.0.0.1", &mut w), Ok(()));
        assert_eq!(text("MODBUS_ALLOW", &w), "10.0.0.0/8 127.0.0.1/32");
        assert_eq!(
            set(
                "MODBUS_ALLOW",
                "1.1.1.1 2.2.2.2 3.3.3.3 4.4.4.4 5.5.5.5",
                &mut w
            ),
            Err(FieldError::TooManyEntries)
        );
        assert_eq!(
            set("WEB_ALLOW", "1.2.3.4/33", &mut w),
            Err(FieldError::NotANetwork)
        );
        assert_eq!(
            set("WEB_ALLOW", "1.2.3.4/0", &mut w),
            Err(FieldError::NotANetwork)
        );
        assert_eq!(set("MODBUS_ALLOW", "", &mut w), Ok(()));
        let c = Config::from_words(&w).unwrap();
        assert!(c.modbus_allow.is_empty());
        assert_eq!(c.net.ip, Ipv4Addr::new(10, 1, 2, 3));
        // Every field's default reads back from its text.
        let d = Config::DEFAULT.to_words();
        for f in FIELDS {
            let mut s = String::new();
            f.format(&d, &mut s).unwrap();
            let mut back = Config::DEFAULT.to_words();
            f.parse(&s, &mut back).unwrap();
            assert_eq!(back, d, "{}", f.name);
        }
    }

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
}
