use super::write::toml_string;
use super::*;
use core::net::Ipv4Addr;
use hans_gateway::access::accounts::{Account, Role, UserName};
use hans_gateway::access::password::PasswordHash;
use hans_gateway::config::{
    AllowEntry, AllowList, LinkMode, NetConfig, ProtocolSetting, StatusSource,
};
use hans_gateway::config::{Kind, NumberFormat, WatchdogAction, WordOrder, SETTINGS};
use hans_gateway::registers::config::register_of;
use hans_gateway::state::inputs::TRIGGER_TEXT;
use hans_gateway::storage::IMAGE_LEN;
use std::format;
use std::string::{String, ToString};
use std::vec::Vec;
use toml::de::DeTable;

fn ip(a: u8, b: u8, c: u8, d: u8) -> Ipv4Addr {
    Ipv4Addr::new(a, b, c, d)
}

fn net(ip: Ipv4Addr, prefix: u8) -> AllowEntry {
    AllowEntry { ip, prefix }
}

/// Every setting away from its default, both allow-lists partly used,
/// awkward trigger texts, a password.
fn full() -> Contents {
    let mut c = Contents::new(Config {
        robot_ip: ip(192, 168, 0, 10),
        robot_port: 10004,
        link_mode: LinkMode::Listen,
        listen_port: 10010,
        poll_ms: 20,
        reply_timeout_ms: 2500,
        word_order: WordOrder::LowFirst,
        number_format: NumberFormat::Thousandths,
        watchdog_ms: 500,
        watchdog_action: WatchdogAction::Pause,
        wait_blending_done: true,
        wait_in_position: true,
        start_grace_ms: 300,
        auto_reset: true,
        status_source: StatusSource::DataSheet,
        datasheet_port: 10006,
        robot_id: 2,
        protocol: ProtocolSetting::V6,
        net: NetConfig {
            ip: ip(10, 0, 0, 2),
            mask: ip(255, 255, 0, 0),
            gateway: ip(10, 0, 0, 1),
            dhcp: true,
            modbus_port: 5020,
            web_port: 8080,
        },
        write_protect: true,
        modbus_allow: AllowList([
            net(ip(192, 168, 0, 0), 24),
            net(ip(10, 0, 0, 7), 32),
            AllowEntry::UNUSED,
            AllowEntry::UNUSED,
        ]),
        web_allow: AllowList([
            net(ip(127, 0, 0, 1), 32),
            net(ip(10, 0, 0, 0), 8),
            net(ip(172, 16, 0, 0), 12),
            net(ip(0, 0, 0, 0), 1),
        ]),
        mqtt: hans_gateway::config::MqttConfig {
            broker: hans_gateway::config::HostName::new("broker.plant.local").unwrap(),
            ..hans_gateway::config::MqttConfig::DEFAULT
        },
        web_host: hans_gateway::config::HostName::new("gw-cell-7.plant.local").unwrap(),
        read_without_login: false,
        ntp_server: ip(10, 0, 0, 123),
        modbus_config: true,
        plc_address: ip(192, 168, 0, 20),
        enip_enabled: true,
        enip_allow: AllowList([
            net(ip(192, 168, 1, 20), 32),
            AllowEntry::UNUSED,
            AllowEntry::UNUSED,
            AllowEntry::UNUSED,
        ]),
    });
    for (name, role) in [("admin", Role::Admin), ("line.3_op", Role::Operator)] {
        c.stored
            .accounts
            .add(Account {
                name: UserName::new(name.as_bytes()).unwrap(),
                role,
                hash: PasswordHash {
                    iterations: 10_000,
                    salt: core::array::from_fn(|i| i as u8 * 17),
                    hash: core::array::from_fn(|i| 255 - i as u8),
                },
            })
            .unwrap();
    }
    let t = &mut c.triggers;
    t[0].set(b"GrpStop,0,;");
    t[3].set(br#"RAW,"quoted, with commas",\back\slash,;"#);
    t[7].set("MoveL,0,1,2,3,4,5,6,; # é".as_bytes());
    t[9].set(b"tab\there\nnewline\x01ctl\x7f,;");
    t[12].set(b"\xff\xfe not UTF-8");
    t[15].set(&[b'x'; TRIGGER_TEXT]);
    c
}

#[test]
fn a_full_configuration_round_trips() {
    let c = full();
    let text = render(&c);
    let back = parse(&text, &Config::DEFAULT).unwrap_or_else(|e| panic!("{e:?}\n{text}"));
    assert_eq!(back, c, "{text}");
    // Read against other defaults too: the file holds every setting.
    let mut other = Config::DEFAULT;
    other.poll_ms = 77;
    other.net.web_port = 1;
    assert_eq!(parse(&text, &other).unwrap(), c);
    // And the defaults.
    let d = Contents::new(Config::DEFAULT);
    assert_eq!(parse(&render(&d), &other).unwrap(), d);
}

#[test]
fn the_written_file_is_readable() {
    let text = render(&full());
    for needle in [
        "[robot]\n",
        "address = \"192.168.0.10\"\n",
        "# CFG_POLL_MS: status poll period; takes 10-100 ms\npoll_ms = 20\n",
        "mode = \"listen\"\n",
        "word_order = \"low-first\"\n",
        "action = \"pause\"\n",
        "wait_in_position = true\n",
        "modbus_allow = [\"192.168.0.0/24\", \"10.0.0.7/32\"]\n",
        "salted hash",
        "{ name = \"admin\", role = \"admin\", password = \"pbkdf2-sha256$10000$00112233445566778899aabbccddeeff$fffefdfc",
        "{ name = \"line.3_op\", role = \"operator\", password = \"pbkdf2-sha256$10000$",
        "0 = \"GrpStop,0,;\"\n",
        "3 = \"RAW,\\\"quoted, with commas\\\",\\\\back\\\\slash,;\"\n",
        "7 = \"MoveL,0,1,2,3,4,5,6,; # é\"\n",
        "12 = [255, 254, 32, 110",
    ] {
        assert!(text.contains(needle), "{needle:?} not in\n{text}");
    }
    // Empty entries are left out; no key is written twice.
    assert!(!text.contains("\n1 = "), "{text}");
    let none = render(&Contents::new(Config::DEFAULT));
    assert!(none.contains("# accounts = [] (none yet)"), "{none}");
    assert!(!none.contains("[triggers]\n0 ="), "{none}");
}

/// A value outside its setting's range, for every key: the problem names
/// the line, the key and (for a range) the register.
#[test]
fn every_setting_out_of_range_is_refused_with_its_line() {
    for s in SETTINGS {
        let (bad, names_register) = match s.kind {
            Kind::Number { max, .. } if max < u16::MAX => ((max + 1).to_string(), true),
            Kind::Number { min, .. } if min > 0 => ((min - 1).to_string(), true),
            Kind::Number { .. } => ("65536".to_owned(), true),
            Kind::Choice(_) => ("\"bogus\"".to_owned(), false),
            Kind::Flag => ("1".to_owned(), false),
            Kind::Mask => ("\"255.0.255.0\"".to_owned(), true),
            Kind::Address => ("\"192.168.0\"".to_owned(), false),
            Kind::AllowList => ("[\"10.0.0.0/8\", \"1.2.3.4/33\"]".to_owned(), false),
            Kind::Host => ("\"two words\"".to_owned(), false),
        };
        let text = format!(
            "# a comment\n[triggers]\n0 = \"x\"\n\n[{}]\n{} = {bad}\n",
            s.group(),
            s.name()
        );
        let err = parse(&text, &Config::DEFAULT).expect_err(&text);
        assert_eq!(err.len(), 1, "{err:?}");
        let p = &err[0];
        assert_eq!(p.line, 6, "{text}{p}");
        assert!(p.reason.contains(s.key), "{p}");
        if names_register {
            assert!(p.reason.contains(&register_name(s)), "{p}");
            assert!(p.reason.contains("out of range"), "{p}");
        }
    }
    // The message of a range, in full.
    let err = parse("[link]\npoll_ms = 5\n", &Config::DEFAULT).unwrap_err();
    assert_eq!(
        err[0].to_string(),
        "2:11: link.poll_ms = 5: out of range, CFG_POLL_MS takes 10-100 ms (status poll period)"
    );
    // An allow-list's problem points at its entry.
    let text = "[access]\nweb_allow = [\n  \"10.0.0.0/8\",\n  \"1.2.3.4/33\",\n]\n";
    let err = parse(text, &Config::DEFAULT).unwrap_err();
    assert_eq!((err[0].line, err[0].column), (4, 3), "{err:?}");
    let five = "[access]\nmodbus_allow = [\"1.0.0.0/8\", \"2.0.0.0/8\", \"3.0.0.0/8\", \"4.0.0.0/8\", \"5.0.0.0/8\"]\n";
    let err = parse(five, &Config::DEFAULT).unwrap_err();
    assert!(err[0].reason.contains("at most 4"), "{err:?}");
    let fifth = five.lines().nth(1).unwrap().find("\"5.0").unwrap() + 1;
    assert_eq!((err[0].line, err[0].column), (2, fifth), "{err:?}");
    for bad in ["\"1.2.3.4/0\"", "\"1.2.3.4/\"", "\"1.2.3/8\"", "7"] {
        let text = format!("[access]\nmodbus_allow = [{bad}]\n");
        let err = parse(&text, &Config::DEFAULT).expect_err(bad);
        assert_eq!(err[0].line, 2, "{err:?}");
    }
}

/// The Linux gateway has the DataSheet reader: the choice reads (a build
/// without it refuses the value, naming what it takes: the schema's test).
#[test]
fn the_datasheet_status_source_is_a_choice_on_linux() {
    let r = parse("[link]\nstatus_source = \"datasheet\"\n", &Config::DEFAULT);
    assert_eq!(
        r.unwrap().stored.config.status_source,
        StatusSource::DataSheet
    );
}

#[test]
fn unknown_keys_and_tables_are_refused_not_ignored() {
    let text = "poll_ms = 50\nport = 1\n[robot]\nadress = \"10.0.0.1\"\n[robots]\nport = 1\n[link]\naddress = \"1.2.3.4\"\n";
    let err = parse(text, &Config::DEFAULT).unwrap_err();
    let lines: Vec<String> = err.iter().map(|p| p.to_string()).collect();
    assert_eq!(
        lines,
        [
            "1:1: unknown key \"poll_ms\" outside the tables (it goes in [link])",
            "2:1: unknown key \"port\" outside the tables (it goes in [robot] or [mqtt])",
            "4:1: unknown key \"adress\" in [robot]; its keys are address, port, id",
            "5:2: unknown table [robots]; the tables are [robot], [link], [motion], [watchdog], [registers], [network], [access], [web], [mqtt], [enip], [triggers]",
            "8:1: unknown key \"address\" in [link] (it goes in [robot] or [network])",
        ]
    );
    let err = parse("[access]\npasword = \"x\"\n", &Config::DEFAULT).unwrap_err();
    assert!(
        err[0]
            .reason
            .ends_with("read_without_login, modbus_config, plc_address, accounts"),
        "{err:?}"
    );
}

#[test]
fn a_value_of_the_wrong_type_is_refused() {
    for (text, line, why) in [
        (
            "[robot]\nport = \"10003\"\n",
            2,
            "robot.port: expected an integer, found string",
        ),
        (
            "[link]\npoll_ms = 50.0\n",
            2,
            "expected an integer, found float",
        ),
        (
            "[link]\nmode = 1\n",
            2,
            "link.mode: expected one of \"connect\", \"listen\", found integer",
        ),
        (
            "[network]\ndhcp = \"yes\"\n",
            2,
            "network.dhcp: expected true or false",
        ),
        ("[robot]\naddress = 3232235530\n", 2, "expected an address"),
        (
            "[access]\nweb_allow = \"10.0.0.0/8\"\n",
            2,
            "expected an array",
        ),
        ("robot = 5\n", 1, "[robot] must be a table, found integer"),
        (
            "[triggers]\n0 = 5\n",
            2,
            "triggers.0 (TRIG0_TEXT): expected a string, found integer",
        ),
        (
            "[access]\npassword = 1\n",
            2,
            "access.password: expected the salted hash",
        ),
    ] {
        let err = parse(text, &Config::DEFAULT).expect_err(text);
        assert_eq!(err[0].line, line, "{text}: {err:?}");
        assert!(err[0].reason.contains(why), "{text}: {err:?}");
    }
}

#[test]
fn malformed_toml_is_refused_with_its_line_and_column() {
    let text = "[robot]\nport = 10003\naddress = \"10.0.0.1\n[link]\n";
    let err = parse(text, &Config::DEFAULT).unwrap_err();
    assert_eq!(err.len(), 1);
    assert_eq!(err[0].line, 3, "{err:?}");
    let err = parse("[robot]\nport = 1\nport = 2\n", &Config::DEFAULT).unwrap_err();
    assert_eq!(err[0].line, 3, "duplicate key: {err:?}");
    let err = parse("[link]\npoll_ms = = 5\n", &Config::DEFAULT).unwrap_err();
    assert_eq!((err[0].line, err[0].column), (2, 11), "{err:?}");
    // Not UTF-8: the place of the first bad byte.
    let Err(Error::Toml(err)) = read_bytes(b"[robot]\nport = 1\n# caf\xe9\n", &Config::DEFAULT)
    else {
        panic!("accepted");
    };
    assert_eq!((err[0].line, err[0].column), (3, 6), "{err:?}");
}

#[test]
fn keys_left_out_take_the_defaults() {
    let mut defaults = Config::DEFAULT;
    defaults.robot_port = 4000;
    let c = parse("", &defaults).unwrap();
    assert_eq!(c, Contents::new(defaults));
    let c = parse(
        "[motion]\nwait_in_position = true\n[triggers]\n5 = \"GrpReset,0,;\"\n",
        &defaults,
    )
    .unwrap();
    assert!(c.stored.config.wait_in_position && !c.stored.config.wait_blending_done);
    assert_eq!(c.stored.config.robot_port, 4000);
    assert_eq!(c.triggers[5].bytes(), b"GrpReset,0,;");
    assert!(c.stored.accounts.is_empty());
    // A bit set by default is cleared by `false`.
    defaults.wait_blending_done = true;
    let c = parse("[motion]\nwait_blending_done = false\n", &defaults).unwrap();
    assert!(!c.stored.config.wait_blending_done);
    // An allow-list given replaces the whole default list.
    defaults.web_allow.0[2] = net(ip(1, 2, 3, 4), 32);
    let c = parse("[access]\nweb_allow = [\"9.9.9.9\"]\n", &defaults).unwrap();
    assert_eq!(
        c.stored.config.web_allow.0,
        [
            net(ip(9, 9, 9, 9), 32),
            AllowEntry::UNUSED,
            AllowEntry::UNUSED,
            AllowEntry::UNUSED
        ]
    );
}

#[test]
fn triggers_and_the_password_are_checked() {
    for (text, why) in [
        ("[triggers]\n16 = \"x\"\n", "the entries are 0 to 15"),
        ("[triggers]\n03 = \"x\"\n", "unknown trigger entry \"03\""),
        ("[triggers]\n1 = \"a\\u0000b\"\n", "NUL"),
        ("[triggers]\n1 = [71, 256]\n", "integer 1-255"),
        ("[access]\npassword = \"hunter2hunter2\"\n", "never holds the password itself"),
        ("[access]\npassword = \"pbkdf2-sha256$0$00112233445566778899aabbccddeeff$00112233445566778899aabbccddeeff00112233445566778899aabbccddeeff\"\n", "1 to 100000 rounds"),
        ("[access]\npassword = \"pbkdf2-sha256$10000$0011$00112233445566778899aabbccddeeff00112233445566778899aabbccddeeff\"\n", "salted hash"),
        ("[access]\naccounts = [{ name = \"Root\", role = \"admin\", password = \"x\" }]\n", "a name is 1 to 16"),
        ("[access]\naccounts = [{ name = \"op\", role = \"operator\", password = \"pbkdf2-sha256$10000$00112233445566778899aabbccddeeff$00112233445566778899aabbccddeeff00112233445566778899aabbccddeeff\" }]\n", "none is an admin"),
        ("[access]\naccounts = [{ name = \"op\", role = \"boss\" }]\n", "unknown role"),
        ("[access]\naccounts = \"admin\"\n", "expected an array"),
        ("[access]\npassword = \"md5$10000$00112233445566778899aabbccddeeff$00112233445566778899aabbccddeeff00112233445566778899aabbccddeeff\"\n", "salted hash"),
    ] {
        let err = parse(text, &Config::DEFAULT).expect_err(text);
        assert_eq!(err[0].line, 2, "{text}: {err:?}");
        assert!(err[0].reason.contains(why), "{text}: {err:?}");
    }
    let long = format!("[triggers]\n1 = \"{}\"\n", "y".repeat(TRIGGER_TEXT + 1));
    let err = parse(&long, &Config::DEFAULT).unwrap_err();
    assert!(err[0].reason.contains("193 bytes, at most 192"), "{err:?}");
    let c = parse("[triggers]\n1 = \"\"\n2 = [71, 255]\n", &Config::DEFAULT).unwrap();
    assert!(c.triggers[1].is_empty());
    assert_eq!(c.triggers[2].bytes(), [71, 255]);
}

#[test]
fn every_problem_is_reported_in_the_order_of_the_file() {
    let text = "[watchdog]\nperiod_ms = 10\n[robot]\nport = 0\n[link]\nmode = \"x\"\n";
    let err = parse(text, &Config::DEFAULT).unwrap_err();
    let lines: Vec<usize> = err.iter().map(|p| p.line).collect();
    assert_eq!(lines, [2, 4, 6], "{err:?}");
    let e = FileError {
        path: PathBuf::from("gw.toml"),
        error: Error::Toml(err),
    };
    let shown = e.to_string();
    assert!(shown.starts_with("gw.toml:2:13: watchdog.period_ms = 10: out of range, CFG_WATCHDOG_MS takes 0 (off) or 50-60000 ms"), "{shown}");
    assert_eq!(shown.lines().count(), 3);
    assert!(shown.lines().all(|l| l.starts_with("gw.toml:")), "{shown}");
}

/// The binary image an older version wrote is read; a damaged one refused.
#[test]
fn a_binary_image_of_an_older_version_is_read() {
    let c = full();
    let mut img = [0u8; IMAGE_LEN];
    let n = image::encode(&c.stored, &c.triggers, &mut img).unwrap();
    let img = &mut img[..n];
    let (back, format) = read_bytes(img, &Config::DEFAULT).unwrap();
    assert_eq!((back, format), (c, Format::BinaryImage));
    img[100] ^= 1;
    assert!(matches!(
        read_bytes(img, &Config::DEFAULT),
        Err(Error::Image(ImageError::Crc))
    ));
    let e = FileError {
        path: PathBuf::from("old.cfg"),
        error: Error::Image(ImageError::Crc),
    };
    assert_eq!(
        e.to_string(),
        "old.cfg: a binary configuration image of an older version, refused: CRC mismatch (damaged)"
    );
}

#[test]
fn the_keys_cover_every_setting_once_and_the_documentation_lists_them() {
    // Every setting is a key once (the schema's own key).
    let all = tables();
    for (i, s) in SETTINGS.iter().enumerate() {
        assert!(all.contains(&s.group()), "{}", s.key);
        assert!(setting_of(s.group(), s.name()).is_some_and(|x| x.id == s.id));
        // A table's keys are together, tables in the order of tables().
        if let Some(prev) = i.checked_sub(1).map(|p| SETTINGS[p]) {
            let at = |t| all.iter().position(|x| *x == t).unwrap();
            assert!(at(prev.group()) <= at(s.group()), "{}", s.key);
        }
    }
    assert_eq!(all.last(), Some(&"triggers"));
    let doc = include_str!("../config_file.rs");
    for s in SETTINGS {
        let register = match register_of(s) {
            Some((g, Some(b))) => format!("{} bit {b}", g.name),
            Some((g, None)) => g.name.to_owned(),
            None => "(none)".to_owned(),
        };
        let row = format!("//! | `{}` | {register} |", s.key);
        assert!(
            doc.contains(&row),
            "{row} not in the module's documentation"
        );
        if let Kind::Choice(words) = s.kind {
            for (i, w) in words.iter().enumerate() {
                assert!(doc.contains(&format!("`\"{w}\"` ({i})")), "{w}");
            }
        }
    }
}

#[test]
fn strings_are_escaped_as_toml_reads_them() {
    for s in [
        "",
        "plain",
        "\"",
        "\\",
        "a'b",
        "\u{0}\u{1f}\u{7f}\u{80}\u{9f}",
        "é ü 中",
        "\t\r\n",
    ] {
        let text = format!("[triggers]\n0 = {}\n", toml_string(s));
        let doc = DeTable::parse(&text).unwrap_or_else(|e| panic!("{s:?}: {e}"));
        let v = doc
            .get_ref()
            .get("triggers")
            .and_then(|t| t.get_ref().get("0"))
            .unwrap();
        assert_eq!(v.get_ref().as_str(), Some(s));
    }
}

/// `examples/gateway.toml`, the documented example, reads as this.
#[test]
fn the_example_file_reads_as_documented() {
    let text = include_str!("../../examples/gateway.toml");
    let c = parse(text, &Config::DEFAULT).unwrap_or_else(|e| panic!("{e:?}"));
    let mut want = Contents::new(Config {
        robot_ip: ip(192, 168, 0, 10),
        poll_ms: 50,
        watchdog_ms: 500,
        wait_in_position: true,
        net: NetConfig {
            ip: ip(192, 168, 0, 50),
            gateway: ip(192, 168, 0, 1),
            ..NetConfig::DEFAULT
        },
        modbus_allow: AllowList([
            net(ip(192, 168, 0, 0), 24),
            net(ip(10, 0, 0, 7), 32),
            AllowEntry::UNUSED,
            AllowEntry::UNUSED,
        ]),
        ..Config::DEFAULT
    });
    want.triggers[0].set(b"GrpStop,0,;");
    want.triggers[1].set(b"GrpReset,0,;");
    want.triggers[2].set(b"SetOverride,0,50,;");
    assert_eq!(c, want);
}
