//! The register view of the configuration: which settings of the schema
//! ([`crate::config::schema`]) the PLC reaches, at which registers, and how
//! their values are laid out in words.
//!
//! A setting with registers is one line of [`REGISTERS`]; a setting
//! without is simply not named here. The PLC edits the registers (the edit
//! is held as words: a value out of range is kept until `CONFIG_COMMAND`
//! 1 names it), and [`decode`] turns them into a checked [`Config`].
//!
//! Word layouts: a number, flag or choice is one register (a flag 0/1, a
//! choice its index); an address or mask two (`a.b.c.d` = `a × 256 + b`,
//! `c × 256 + d`); an allow-list three per entry (address, prefix 0-32,
//! 0 = unused); [`Layout::Bits`] packs flags into one register, bit 0
//! first.

use core::net::Ipv4Addr;

use super::map as r;
use crate::config::schema::{self as s, Kind, Setting, Value};
use crate::config::{AllowEntry, AllowList, Config, ALLOW_ENTRIES};

/// How a setting's value sits in registers.
#[derive(Clone, Copy, Debug)]
pub enum Layout {
    /// One setting in as many registers as its kind takes.
    Value(&'static Setting),
    /// Flags packed into one register, the first in bit 0.
    Bits(&'static [&'static Setting]),
}

/// A block of configuration registers.
#[derive(Clone, Copy, Debug)]
pub struct ConfigRegister {
    /// Register name (`REGISTERS.md`).
    pub name: &'static str,
    /// Its first address.
    pub addr: u16,
    /// What it holds.
    pub layout: Layout,
}

impl ConfigRegister {
    /// Registers it takes.
    pub const fn count(&self) -> u16 {
        match self.layout {
            Layout::Value(s) => words_of(&s.kind),
            Layout::Bits(_) => 1,
        }
    }
}

/// Registers a value of `kind` takes (0: the kind has no register form).
pub const fn words_of(kind: &Kind) -> u16 {
    match kind {
        Kind::Number { .. } | Kind::Flag | Kind::Choice(_) => 1,
        Kind::Address | Kind::Mask => 2,
        Kind::AllowList => 3 * ALLOW_ENTRIES as u16,
        Kind::Host => 0,
    }
}

const fn at(name: &'static str, addr: u16, setting: &'static Setting) -> ConfigRegister {
    ConfigRegister {
        name,
        addr,
        layout: Layout::Value(setting),
    }
}

/// Every configuration register, in address order: the block 100-117,
/// then 160-193 (`REGISTERS.md`).
pub const REGISTERS: [ConfigRegister; 26] = [
    at("CFG_ROBOT_IP", r::CONFIG_ROBOT_IP, &s::ROBOT_ADDRESS),
    at("CFG_ROBOT_PORT", r::CONFIG_ROBOT_PORT, &s::ROBOT_PORT),
    at("CFG_LINK_MODE", r::CONFIG_LINK_MODE, &s::LINK_MODE),
    at(
        "CFG_LISTEN_PORT",
        r::CONFIG_LISTEN_PORT,
        &s::LINK_LISTEN_PORT,
    ),
    at("CFG_POLL_MS", r::CONFIG_POLL_MS, &s::LINK_POLL_MS),
    at(
        "CFG_REPLY_TIMEOUT_MS",
        r::CONFIG_REPLY_TIMEOUT_MS,
        &s::LINK_REPLY_TIMEOUT_MS,
    ),
    at(
        "CFG_FLOAT_WORD_ORDER",
        r::CONFIG_FLOAT_WORD_ORDER,
        &s::REGISTERS_WORD_ORDER,
    ),
    at(
        "CFG_WATCHDOG_MS",
        r::CONFIG_WATCHDOG_MS,
        &s::WATCHDOG_PERIOD_MS,
    ),
    at(
        "CFG_WATCHDOG_ACTION",
        r::CONFIG_WATCHDOG_ACTION,
        &s::WATCHDOG_ACTION,
    ),
    ConfigRegister {
        name: "CFG_MOTION_POLICY",
        addr: r::CONFIG_MOTION_POLICY,
        layout: Layout::Bits(&[&s::MOTION_WAIT_BLENDING_DONE, &s::MOTION_WAIT_IN_POSITION]),
    },
    at(
        "CFG_START_GRACE_MS",
        r::CONFIG_START_GRACE_MS,
        &s::MOTION_START_GRACE_MS,
    ),
    at(
        "CFG_AUTO_RESET",
        r::CONFIG_AUTO_RESET,
        &s::MOTION_AUTO_RESET,
    ),
    at(
        "CFG_STATUS_SOURCE",
        r::CONFIG_STATUS_SOURCE,
        &s::LINK_STATUS_SOURCE,
    ),
    at(
        "CFG_DATASHEET_PORT",
        r::CONFIG_DATASHEET_PORT,
        &s::LINK_DATASHEET_PORT,
    ),
    at("CFG_ROBOT_ID", r::CONFIG_ROBOT_ID, &s::ROBOT_ID),
    at("CFG_PROTOCOL", r::CONFIG_PROTOCOL, &s::LINK_PROTOCOL),
    at(
        "CFG_NUMBER_FORMAT",
        r::CONFIG_NUMBER_FORMAT,
        &s::REGISTERS_NUMBER_FORMAT,
    ),
    at("NET_IP", r::NET_IP, &s::NETWORK_ADDRESS),
    at("NET_MASK", r::NET_MASK, &s::NETWORK_MASK),
    at("NET_GATEWAY", r::NET_GATEWAY, &s::NETWORK_GATEWAY),
    at("NET_DHCP", r::NET_DHCP, &s::NETWORK_DHCP),
    at(
        "NET_MODBUS_PORT",
        r::NET_MODBUS_PORT,
        &s::NETWORK_MODBUS_PORT,
    ),
    at("NET_WEB_PORT", r::NET_WEB_PORT, &s::NETWORK_WEB_PORT),
    at(
        "CFG_WRITE_PROTECT",
        r::CONFIG_WRITE_PROTECT,
        &s::ACCESS_WRITE_PROTECT,
    ),
    at("MODBUS_ALLOW", r::MODBUS_ALLOW, &s::ACCESS_MODBUS_ALLOW),
    at("WEB_ALLOW", r::WEB_ALLOW, &s::ACCESS_WEB_ALLOW),
];

/// Registers of the settings: 100-117 and 160-193.
pub const CONFIG_WORDS: usize = (r::CONFIG_LEN + r::NET_LEN) as usize;

// The PLC's edit is held in the state as words it does not interpret.
const _: () = assert!(CONFIG_WORDS == crate::state::PLC_EDIT_WORDS);

/// The settings as their registers: those of 100-117, then those of
/// 160-193.
pub type Words = [u16; CONFIG_WORDS];

/// A configuration register holds a value outside its range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct InvalidValue {
    /// The register.
    pub addr: u16,
}

/// The place of register `addr` in [`Words`], if it is a setting's.
pub fn slot_of(addr: u16) -> Option<usize> {
    let in_block = |start: u16, len: u16| addr.checked_sub(start).filter(|&o| o < len);
    if let Some(o) = in_block(r::CONFIG_ROBOT_IP, r::CONFIG_LEN) {
        return Some(usize::from(o));
    }
    in_block(r::NET_IP, r::NET_LEN).map(|o| usize::from(r::CONFIG_LEN + o))
}

/// The register block holding `addr`.
pub fn register_at(addr: u16) -> Option<&'static ConfigRegister> {
    REGISTERS
        .iter()
        .find(|g| g.addr <= addr && addr < g.addr + g.count())
}

/// Where `setting` is in the registers: its block, and its bit for a
/// packed flag.
pub fn register_of(setting: &Setting) -> Option<(&'static ConfigRegister, Option<u8>)> {
    REGISTERS.iter().find_map(|g| match g.layout {
        Layout::Value(x) if x.id == setting.id => Some((g, None)),
        Layout::Bits(flags) => flags
            .iter()
            .position(|x| x.id == setting.id)
            .map(|b| (g, Some(b as u8))),
        _ => None,
    })
}

/// The address held in two registers.
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

/// Writes `v` as registers into `out` (of [`words_of`] its kind).
fn put_value(v: &Value, out: &mut [u16]) {
    let mut put = |i: usize, w: u16| {
        if let Some(slot) = out.get_mut(i) {
            *slot = w;
        }
    };
    match *v {
        Value::Number(n) => put(0, n),
        Value::Flag(b) => put(0, u16::from(b)),
        Value::Choice(i) => put(0, u16::from(i)),
        Value::Address(ip) => {
            let [a, b] = ipv4_words(ip);
            put(0, a);
            put(1, b);
        }
        Value::AllowList(l) => {
            for (k, e) in l.0.iter().enumerate() {
                let [a, b] = ipv4_words(e.ip);
                put(3 * k, a);
                put(3 * k + 1, b);
                put(3 * k + 2, u16::from(e.prefix));
            }
        }
        Value::Host(_) => {}
    }
}

/// Reads a value of `kind` from its registers, checked; `Err(i)` names
/// the first bad register, relative.
fn get_value(kind: &Kind, w: &[u16]) -> Result<Value, u16> {
    let first = w.first().copied().unwrap_or(0);
    let v = match kind {
        Kind::Number { .. } => Value::Number(first),
        Kind::Flag => match first {
            0 | 1 => Value::Flag(first == 1),
            _ => return Err(0),
        },
        Kind::Choice(_) => Value::Choice(u8::try_from(first).map_err(|_| 0u16)?),
        Kind::Address | Kind::Mask => Value::Address(ipv4(w)),
        Kind::AllowList => {
            let mut list = AllowList::EVERYONE;
            for (k, (e, c)) in list.0.iter_mut().zip(w.chunks(3)).enumerate() {
                let prefix = c.get(2).copied().unwrap_or(0);
                if prefix > 32 {
                    return Err(3 * k as u16 + 2);
                }
                *e = AllowEntry {
                    ip: ipv4(c),
                    prefix: prefix as u8,
                };
            }
            Value::AllowList(list)
        }
        Kind::Host => return Err(0),
    };
    kind.check(&v).map_err(|_| 0u16)?;
    Ok(v)
}

fn block<'w>(words: &'w Words, g: &ConfigRegister) -> &'w [u16] {
    let s = slot_of(g.addr).unwrap_or(0);
    words.get(s..s + usize::from(g.count())).unwrap_or(&[])
}

/// The configuration's registers.
pub fn encode(c: &Config) -> Words {
    let mut words: Words = [0; CONFIG_WORDS];
    for g in &REGISTERS {
        let s = slot_of(g.addr).unwrap_or(0);
        let Some(out) = words.get_mut(s..s + usize::from(g.count())) else {
            continue;
        };
        match g.layout {
            Layout::Value(x) => put_value(&x.get(c), out),
            Layout::Bits(flags) => {
                let bits = flags.iter().enumerate().fold(0u16, |acc, (b, x)| {
                    acc | (u16::from(x.get(c) == Value::Flag(true)) << b)
                });
                put_value(&Value::Number(bits), out);
            }
        }
    }
    words
}

/// Reads and checks the settings held in `words` over `base` (which gives
/// the settings without registers); the first invalid register is named.
pub fn decode(words: &Words, base: &Config) -> Result<Config, InvalidValue> {
    let mut c = *base;
    for g in &REGISTERS {
        let w = block(words, g);
        let bad = |o: u16| InvalidValue { addr: g.addr + o };
        match g.layout {
            Layout::Value(x) => {
                let v = get_value(&x.kind, w).map_err(bad)?;
                x.set(&mut c, v).map_err(|_| bad(0))?;
            }
            Layout::Bits(flags) => {
                let bits = w.first().copied().unwrap_or(0);
                if u32::from(bits) >> flags.len() != 0 {
                    return Err(bad(0));
                }
                for (b, x) in flags.iter().enumerate() {
                    x.set(&mut c, Value::Flag(bits >> b & 1 == 1))
                        .map_err(|_| bad(0))?;
                }
            }
        }
    }
    Ok(c)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{LinkMode, NetConfig, WatchdogAction, WordOrder};

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
        let w = encode(&c);
        assert_eq!(w[0], 0xC0A8);
        assert_eq!(
            w[usize::from(r::CONFIG_MOTION_POLICY - r::CONFIG_ROBOT_IP)],
            2
        );
        assert_eq!(decode(&w, &Config::DEFAULT), Ok(c));
        let at = |a: u16| slot_of(a).unwrap();
        for (reg, v, ok) in [
            (r::CONFIG_POLL_MS, 101, false),
            (r::CONFIG_WATCHDOG_MS, 10, false),
            (r::CONFIG_WATCHDOG_MS, 0, true),
            (r::CONFIG_LINK_MODE, 2, false),
            (r::CONFIG_MOTION_POLICY, 3, true),
            (r::CONFIG_MOTION_POLICY, 4, false),
            (r::CONFIG_AUTO_RESET, 2, false),
            (r::CONFIG_PROTOCOL, 3, false),
            (r::CONFIG_ROBOT_ID, 6, false),
        ] {
            let mut bad = w;
            bad[at(reg)] = v;
            let got = decode(&bad, &Config::DEFAULT);
            match ok {
                true => assert!(got.is_ok(), "{reg} = {v}"),
                false => assert_eq!(got, Err(InvalidValue { addr: reg }), "{reg} = {v}"),
            }
        }
    }

    #[test]
    fn the_register_table_covers_every_register_once() {
        let mut next_slot = 0;
        for g in &REGISTERS {
            assert!(g.count() > 0, "{}", g.name);
            assert_eq!(slot_of(g.addr), Some(next_slot), "{}", g.name);
            assert_eq!(
                register_at(g.addr + g.count() - 1).map(|x| x.name),
                Some(g.name)
            );
            next_slot += usize::from(g.count());
        }
        assert_eq!(next_slot, CONFIG_WORDS);
        assert_eq!(slot_of(r::CONFIG_ROBOT_IP + r::CONFIG_LEN), None);
        assert_eq!(slot_of(r::NET_IP + r::NET_LEN), None);
        assert_eq!(slot_of(r::NET_IP - 1), None);
        // A setting has at most one place; the MQTT broker has none.
        for x in crate::config::SETTINGS {
            let places = REGISTERS
                .iter()
                .filter(|g| match g.layout {
                    Layout::Value(y) => y.id == x.id,
                    Layout::Bits(f) => f.iter().any(|y| y.id == x.id),
                })
                .count();
            assert!(places <= 1, "{}", x.key);
            assert_eq!(register_of(x).is_some(), places == 1);
        }
        assert!(register_of(&s::MQTT_BROKER).is_none());
        assert_eq!(
            register_of(&s::MOTION_WAIT_IN_POSITION).map(|(g, b)| (g.name, b)),
            Some(("CFG_MOTION_POLICY", Some(1)))
        );
        assert_eq!(
            decode(&encode(&Config::DEFAULT), &Config::DEFAULT),
            Ok(Config::DEFAULT)
        );
    }

    #[test]
    fn settings_without_registers_come_from_the_base() {
        let mut base = Config::DEFAULT;
        s::MQTT_BROKER
            .parse_into("broker.plant", &mut base)
            .unwrap();
        let c = decode(&encode(&Config::DEFAULT), &base).unwrap();
        assert_eq!(c.mqtt.broker.as_str(), "broker.plant");
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
        let w = encode(&c);
        assert_eq!(decode(&w, &Config::DEFAULT), Ok(c));
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
            let got = decode(&w, &Config::DEFAULT);
            assert_eq!(got.is_ok(), ok, "{mask:x?}");
            if !ok {
                assert_eq!(got, Err(InvalidValue { addr: r::NET_MASK }));
            }
        }
        let mut bad = w;
        bad[at(r::WEB_ALLOW) + 3 * 2 + 2] = 33;
        assert_eq!(
            decode(&bad, &Config::DEFAULT),
            Err(InvalidValue {
                addr: r::WEB_ALLOW + 8
            })
        );
    }
}
