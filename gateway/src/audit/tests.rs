//! The audit log: the log on its own (ring, loss, refusal periods, time),
//! then through the real gateway in the test world (restarts, Modbus, the
//! page, recovery, the watchdog, a failing medium, the export).

extern crate std;

use core::net::Ipv4Addr;
use std::string::{String, ToString};
use std::vec::Vec;

use embassy_time::{Duration, Instant};

use super::log::{REFUSED_PERIOD, REFUSED_PERIOD_MAX};
use super::*;
use crate::config::{AllowList, Config, WatchdogAction};
use crate::registers::map as r;
use crate::testkit::world::{MemStorage, World, WorldConfig, SETUP_CODE};

fn secs(s: u64) -> Duration {
    Duration::from_secs(s)
}

fn at(s: u64) -> Instant {
    Instant::from_secs(s)
}

/// The stamped records in the ring, oldest first.
fn ring(log: &Log) -> Vec<Record> {
    let mut v = Vec::new();
    let (Some(last), _, _) = log.summary() else {
        return v;
    };
    let mut next = 0;
    while let Some(r) = log.copy(next, last) {
        v.push(r);
        if r.seq >= last {
            break;
        }
        next = r.seq + 1;
    }
    v
}

fn details(records: &[Record], kind: Kind) -> Vec<String> {
    records
        .iter()
        .filter(|r| r.kind == kind)
        .map(|r| r.detail.as_str().to_string())
        .collect()
}

/// Keeps what waits, as the storage task does; the records kept.
fn keep_all(log: &Log) -> Vec<u32> {
    let mut buf = [0u8; RECORD_MAX];
    let mut kept = Vec::new();
    while let Some((seq, n)) = log.next_to_keep(&mut buf) {
        assert_eq!(Record::parse(&buf[..n]).unwrap().0.seq, seq);
        kept.push(seq);
        log.kept(seq, true);
    }
    kept
}

fn note(log: &Log, n: u32) {
    log.add(Kind::Config, &Who::SYSTEM, |d| {
        d.push(format!("{n}").as_bytes())
    });
}

// ------------------------------------------------------------ the log

#[test]
fn the_ring_keeps_the_newest_numbered_and_stamped() {
    let log = Log::new();
    assert_eq!(log.start(false), 1, "nothing kept: boot 1");
    for n in 0..70 {
        note(&log, n);
    }
    assert!(ring(&log).is_empty(), "not shown before its time");
    log.stamp(at(5));
    let got = ring(&log);
    assert_eq!(got.len(), RING);
    assert_eq!(got.first().unwrap().seq, 70 - RING as u32 + 1);
    assert_eq!(got.last().unwrap().seq, 70);
    assert!(got
        .iter()
        .all(|r| r.boot == 1 && r.uptime_ms == 5000 && r.wall.is_none()));
    // Nothing is kept: nothing waits, nothing is lost.
    assert_eq!(keep_all(&log), Vec::<u32>::new());
    assert!(details(&ring(&log), Kind::Lost).is_empty());
}

#[test]
fn the_boot_counter_and_the_sequence_go_on_from_the_newest_kept_record() {
    let log = Log::new();
    for (seq, boot) in [(40, 6), (41, 7), (42, 7)] {
        log.restore(Record {
            seq,
            boot,
            ..Record::EMPTY
        });
    }
    assert_eq!(log.start(true), 8);
    note(&log, 0);
    log.stamp(at(1));
    let got = ring(&log);
    assert_eq!(
        got.iter().map(|r| (r.seq, r.boot)).collect::<Vec<_>>(),
        [(40, 6), (41, 7), (42, 7), (43, 8)]
    );
    assert_eq!(keep_all(&log), [43], "the restored ones are kept already");
}

#[test]
fn records_the_medium_cannot_keep_up_with_are_counted_and_reported() {
    let log = Log::new();
    log.start(true);
    for n in 0..RING as u32 + 5 {
        note(&log, n);
    }
    log.stamp(at(1));
    // 1-5 were pushed out before they were kept.
    let mut buf = [0u8; RECORD_MAX];
    assert_eq!(log.next_to_keep(&mut buf).map(|(s, _)| s), Some(6));
    assert!(log.kept(6, true));
    log.stamp(at(2));
    let lost = details(&ring(&log), Kind::Lost);
    assert_eq!(lost, ["5 records lost (the medium was full or failed)"]);
    let kept = keep_all(&log);
    assert_eq!(kept.len(), RING - 1 + 1, "the rest, then the lost record");
    // A record the medium fails on is lost too, and reported after the
    // next one is kept; a failure stops the work (no retry loop).
    note(&log, 100);
    note(&log, 101);
    log.stamp(at(3));
    let (seq, _) = log.next_to_keep(&mut buf).unwrap();
    assert!(!log.kept(seq, false));
    let (next, _) = log.next_to_keep(&mut buf).unwrap();
    assert_eq!(next, seq + 1);
    assert!(log.kept(next, true));
    log.stamp(at(4));
    assert_eq!(
        details(&ring(&log), Kind::Lost).last().map(String::as_str),
        Some("1 records lost (the medium was full or failed)")
    );
}

#[test]
fn a_configuration_change_is_one_record_per_setting_with_old_and_new_value() {
    let log = Log::new();
    log.start(false);
    let before = Config::default();
    let mut after = before;
    after.poll_ms = 50;
    after.web_allow =
        AllowList::parse("10.0.0.0/8 192.168.100.0/24 172.16.0.0/12 127.0.0.1").unwrap();
    let who = Who::web(b"alice", Some(Ipv4Addr::new(10, 0, 0, 5)));
    log.config_changed(&before, &before, &who);
    log.config_changed(&before, &after, &who);
    log.stamp(at(1));
    let got = ring(&log);
    assert_eq!(
        details(&got, Kind::Config),
        [
            "link.poll_ms: 100 -> 50",
            "access.web_allow:  -> 10.0.0.0/8 192.168.10...",
        ]
    );
    assert!(got.iter().all(|r| r.actor.as_str() == "alice"
        && r.interface == Interface::Web
        && r.from == Some(Ipv4Addr::new(10, 0, 0, 5))));
}

#[test]
fn a_trigger_entry_is_recorded_when_it_changes() {
    let log = Log::new();
    log.start(false);
    let mut entries = [crate::state::inputs::Text::EMPTY; crate::state::inputs::TRIGGERS];
    entries[1].set(b"GrpReset,0,;");
    log.triggers_are(&entries);
    log.triggers_changed(&entries, &Who::SYSTEM);
    entries[3].set(b"GrpStop,0,;");
    log.triggers_changed(&entries, &Who::modbus(None));
    log.triggers_changed(&entries, &Who::modbus(None));
    log.stamp(at(1));
    let got = ring(&log);
    assert_eq!(details(&got, Kind::Config), ["triggers.3 = GrpStop,0,;"]);
    assert_eq!(got[0].interface, Interface::Modbus);
}

#[test]
fn refused_connections_are_one_record_per_period_and_the_period_grows_while_they_go_on() {
    let log = Log::new();
    log.start(false);
    let (a, b) = (Ipv4Addr::new(10, 9, 9, 1), Ipv4Addr::new(10, 9, 9, 2));
    for _ in 0..3 {
        log.refused(Interface::Modbus, Some(a));
    }
    log.refused(Interface::Modbus, Some(b));
    log.refused(Interface::Web, Some(a));
    assert_eq!(
        log.refusals_due(),
        None,
        "the period starts at the first stamp"
    );
    log.stamp(at(10));
    assert_eq!(log.refusals_due(), Some(at(10) + REFUSED_PERIOD));
    log.end_refusal_periods(at(69));
    assert!(ring(&log).is_empty(), "not yet");
    log.end_refusal_periods(at(70));
    let got = ring(&log);
    assert_eq!(got.len(), 2);
    assert_eq!(
        (got[0].interface, got[0].from, got[0].detail.as_str()),
        (
            Interface::Modbus,
            Some(b),
            "4 connections refused in 60 s (allow-list)"
        )
    );
    assert_eq!((got[1].interface, got[1].from), (Interface::Web, Some(a)));
    assert_eq!(log.refusals_due(), None);
    // They go on: 120 s, 240 s, ... up to an hour.
    let mut t = 70;
    let mut periods = Vec::new();
    for _ in 0..8 {
        t += 1;
        log.refused(Interface::Modbus, Some(a));
        log.stamp(at(t));
        let due = log.refusals_due().unwrap();
        periods.push((due - at(t)).as_secs());
        t = due.as_secs();
        log.end_refusal_periods(due);
    }
    assert_eq!(periods, [120, 240, 480, 960, 1920, 3600, 3600, 3600]);
    assert_eq!(REFUSED_PERIOD_MAX, secs(3600));
    // Quiet for a whole period: back to the first.
    log.refused(Interface::Modbus, Some(a));
    log.stamp(at(t + 3601));
    assert_eq!(log.refusals_due(), Some(at(t + 3601) + REFUSED_PERIOD));
}

#[test]
fn the_events_of_the_accounts_read_as_documented() {
    let log = Log::new();
    log.start(false);
    let from = Some(Ipv4Addr::new(10, 0, 0, 7));
    log.record(Event::Login {
        name: b"alice",
        ok: true,
        from,
    });
    log.record(Event::Login {
        name: b"=cmd|x\x01",
        ok: false,
        from,
    });
    log.record(Event::Logout {
        name: b"alice",
        from,
    });
    for change in [
        AccountChange::Created { role: "operator" },
        AccountChange::Role { role: "admin" },
        AccountChange::Password,
        AccountChange::Removed,
    ] {
        log.record(Event::Account {
            name: b"bob",
            change,
            by: b"alice",
            from,
        });
    }
    log.record(Event::Restart {
        who: Who::web(b"alice", from),
    });
    log.record(Event::Firmware {
        who: Who::web(b"alice", from),
        detail: "1.2.0 installed",
    });
    log.stamp(at(1));
    let got: Vec<_> = ring(&log)
        .iter()
        .map(|r| {
            (
                r.kind.as_str(),
                r.actor_str().to_string(),
                r.detail.as_str().to_string(),
            )
        })
        .collect();
    let s = |k: &'static str, a: &str, d: &str| (k, a.to_string(), d.to_string());
    assert_eq!(
        got,
        [
            s("login", "alice", ""),
            s("login-failed", "=cmd|x?", ""),
            s("logout", "alice", ""),
            s("account-created", "alice", "bob, role operator"),
            s("account-role", "alice", "bob, role admin"),
            s("account-password", "alice", "bob"),
            s("account-removed", "alice", "bob"),
            s("restart", "alice", ""),
            s("firmware", "alice", "1.2.0 installed"),
        ]
    );
    assert!(ring(&log)
        .iter()
        .all(|r| r.from == from && r.interface == Interface::Web));
}

#[test]
fn wall_time_comes_from_the_host_clock_or_a_time_server() {
    let log = Log::new();
    log.start(false);
    note(&log, 0);
    log.stamp(at(1));
    assert_eq!(ring(&log)[0].wall, None, "no clock: unknown");
    log.set_wall_time(1_800_000_000, at(2), Some(Ipv4Addr::new(10, 0, 0, 3)));
    log.set_wall_time(1_800_000_010, at(12), None);
    log.set_wall_time(1_800_000_100, at(22), None);
    note(&log, 1);
    log.stamp(at(30));
    let got = ring(&log);
    assert_eq!(
        details(&got, Kind::Time),
        [
            "set by a time server (was unknown)",
            "set by a time server, moved by 80 s"
        ]
    );
    assert_eq!(got.last().unwrap().wall, Some(1_800_000_108));
    fn host() -> Option<u64> {
        Some(1_900_000_000)
    }
    log.use_host_clock(host);
    note(&log, 2);
    log.stamp(at(31));
    assert_eq!(ring(&log).last().unwrap().wall, Some(1_900_000_000));
}

// ------------------------------------------------------ the test world

fn world(config: WorldConfig) -> World {
    let mut w = World::new(config);
    w.run_for(Duration::from_millis(300));
    w
}

fn log_of(w: &World) -> Vec<Record> {
    ring(&w.gateway.hub().audit)
}

/// The records the storage kept.
fn kept(storage: &MemStorage) -> Vec<Record> {
    storage
        .audit
        .borrow()
        .iter()
        .map(|b| Record::parse(b).unwrap().0)
        .collect()
}

#[test]
fn every_start_is_counted_and_the_records_survive_a_restart() {
    let mut w = world(WorldConfig::default());
    let first = log_of(&w);
    let kinds: Vec<_> = first.iter().map(|r| (r.seq, r.boot, r.kind)).collect();
    assert_eq!(kinds, [(1, 1, Kind::Start), (2, 1, Kind::ConfigLoaded)]);
    assert!(first[0].detail.as_str().starts_with("hans-gateway "));
    assert_eq!(first[1].detail.as_str(), "nothing stored: defaults");
    // The world's storage is a device's flash (a file people edit would
    // be named `file`: Linux `--config`, linux/tests/cli.rs).
    assert_eq!(first[1].interface, Interface::System);
    assert_eq!(kept(&w.config.storage), first, "kept as they were made");
    w.run_for(secs(10));
    w.restart();
    w.run_for(Duration::from_millis(300));
    let second = log_of(&w);
    let kinds: Vec<_> = second.iter().map(|r| (r.seq, r.boot, r.kind)).collect();
    assert_eq!(
        kinds,
        [
            (1, 1, Kind::Start),
            (2, 1, Kind::ConfigLoaded),
            (3, 2, Kind::Start),
            (4, 2, Kind::ConfigLoaded),
        ]
    );
    assert!(second[3].detail.as_str().starts_with("nothing stored"));
    assert_eq!(kept(&w.config.storage).len(), 4);
}

#[test]
fn a_configuration_applied_over_modbus_is_recorded_setting_by_setting() {
    let mut w = world(WorldConfig::default());
    w.set(r::CONFIG_POLL_MS, &[50]);
    w.set(r::CONFIG_WATCHDOG_MS, &[500]);
    w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    w.run_for(Duration::from_millis(10));
    let got = log_of(&w);
    let config: Vec<_> = got.iter().filter(|r| r.kind == Kind::Config).collect();
    assert_eq!(
        config.iter().map(|r| r.detail.as_str()).collect::<Vec<_>>(),
        ["link.poll_ms: 100 -> 50", "watchdog.period_ms: 0 -> 500"]
    );
    assert!(config
        .iter()
        .all(|r| r.interface == Interface::Modbus && r.actor_str() == "-"));
    // Kept beside the configuration, and after it was stored.
    let stored = kept(&w.config.storage);
    assert_eq!(details(&stored, Kind::Config).len(), 2);
    assert!(!w.config.storage.data.borrow().is_empty());
    // Discarded edits are no change.
    w.set(r::CONFIG_POLL_MS, &[60]);
    w.set(r::CONTROL_CONFIG_COMMAND, &[2]);
    w.run_for(Duration::from_millis(10));
    assert_eq!(details(&log_of(&w), Kind::Config).len(), 2);
}

#[test]
fn a_host_refused_by_the_listen_port_is_recorded_with_its_address() {
    let controller = Ipv4Addr::new(10, 0, 0, 2);
    let mut w = world(WorldConfig {
        listen_mode: true,
        config: Config {
            robot_ip: controller,
            ..Config::default()
        },
        ..WorldConfig::default()
    });
    let port = w.model(|m| m.config.active.listen_port);
    let intruder = Ipv4Addr::new(10, 0, 0, 66);
    for k in 0..3 {
        let s = w
            .net
            .connect(core::net::SocketAddrV4::new(intruder, 40000 + k), port)
            .expect("the gateway listens");
        w.run_for(secs(1));
        assert!(!s.is_open(), "refused");
    }
    w.run_for(secs(61));
    let got = log_of(&w);
    let refused: Vec<_> = got.iter().filter(|r| r.kind == Kind::Refused).collect();
    assert_eq!(refused.len(), 1, "{got:?}");
    assert_eq!(refused[0].interface, Interface::Robot);
    assert_eq!(refused[0].from, Some(intruder));
    assert!(
        refused[0]
            .detail
            .as_str()
            .starts_with("3 connections refused")
            && refused[0].detail.as_str().ends_with("(not the controller)"),
        "{}",
        refused[0].detail.as_str()
    );
}

/// A world whose Modbus allow-list admits only the first PLC's address
/// (10.0.0.10), and an address it refuses.
fn allow_list_world() -> (World, Ipv4Addr) {
    let w = world(WorldConfig {
        config: Config {
            modbus_allow: AllowList::parse("10.0.0.10").unwrap(),
            ..Config::default()
        },
        ..WorldConfig::default()
    });
    (w, Ipv4Addr::new(10, 0, 0, 99))
}

#[test]
fn refused_modbus_clients_are_counted_over_a_period_not_recorded_one_by_one() {
    let (mut w, stranger) = allow_list_world();
    for _ in 0..5 {
        let i = w.connect_plc(stranger);
        assert!(!w.plc_open(i));
    }
    assert!(details(&log_of(&w), Kind::Refused).is_empty());
    w.run_for(secs(61));
    let got = log_of(&w);
    let refused: Vec<_> = got.iter().filter(|r| r.kind == Kind::Refused).collect();
    assert_eq!(refused.len(), 1);
    assert_eq!(refused[0].from, Some(stranger));
    assert_eq!(refused[0].interface, Interface::Modbus);
    assert_eq!(
        refused[0].detail.as_str(),
        "5 connections refused in 60 s (allow-list)"
    );
    // A storm of ten minutes: a handful of records, not hundreds.
    for _ in 0..60 {
        w.connect_plc(stranger);
        w.run_for(secs(10));
    }
    let n = details(&log_of(&w), Kind::Refused).len();
    assert!((2..=4).contains(&n), "{n} records");
}

/// A stop in order (Linux's SIGTERM, `Gateway::run_until`) keeps what
/// the running periods counted and says it stopped; before, the counts of
/// the period running at the stop were lost with the RAM (an attacker's
/// last minutes to an hour of refused connections or failed logins
/// vanished from the evidence at every stop or update), and nothing told
/// an ordered stop from a power cut.
#[test]
fn a_stop_keeps_what_the_periods_counted_and_says_it_stopped() {
    let (mut w, stranger) = allow_list_world();
    for _ in 0..7 {
        let i = w.connect_plc(stranger);
        assert!(!w.plc_open(i));
    }
    w.run_for(secs(20));
    w.gateway
        .hub()
        .audit
        .login_failed(b"nobody", false, Some(stranger));
    w.gateway
        .hub()
        .audit
        .login_failed(b"nobody", false, Some(stranger));
    w.run_for(secs(10));
    assert!(
        details(&kept(&w.config.storage), Kind::Refused).is_empty(),
        "counted, the period runs"
    );
    let stopped = w.stop("SIGTERM").expect("the run ended within 10 s");
    assert!(stopped.kept, "every record kept before the run ended");
    let on_medium = kept(&w.config.storage);
    assert_eq!(
        details(&on_medium, Kind::Refused),
        ["7 connections refused in 30 s (allow-list)"]
    );
    assert_eq!(
        details(&on_medium, Kind::LoginFailed),
        [
            "",
            "1 more failed logins in 10 s (1 unknown names), 1 addresses"
        ],
        "the first recorded as it came, the other counted"
    );
    let last = on_medium.last().unwrap();
    assert_eq!(
        (last.kind, last.detail.as_str(), last.interface),
        (Kind::Stop, "SIGTERM", Interface::System)
    );
    assert!(last.kind.security(), "a stop is a security record");
    // The next start reads them back; its records follow the stop's.
    w.restart();
    let after = log_of(&w);
    let stop = after.iter().position(|r| r.kind == Kind::Stop).unwrap();
    assert_eq!(after.get(stop + 1).map(|r| r.kind), Some(Kind::Start));
}

#[test]
fn a_recovery_start_is_recorded_with_the_settings_it_changed() {
    // Configuration over Modbus allowed (the network settings are
    // protected).
    let mut w = world(WorldConfig {
        config: crate::config::Config {
            modbus_config: true,
            ..crate::config::Config::default()
        },
        ..WorldConfig::default()
    });
    // A network address stored over Modbus ...
    w.set(r::NET_IP, &[0x0A01, 0x0203]);
    w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    w.run_for(Duration::from_millis(10));
    assert_eq!(
        details(&log_of(&w), Kind::Config),
        ["network.address: 192.168.1.50 -> 10.1.2.3"]
    );
    // ... then a start with the button held.
    w.config.recovery = true;
    w.restart();
    w.run_for(Duration::from_millis(300));
    let got = log_of(&w);
    let recovery = got.iter().find(|r| r.kind == Kind::Recovery).unwrap();
    assert_eq!(recovery.interface, Interface::Button);
    assert_eq!(recovery.boot, 2);
    let by_button: Vec<_> = got
        .iter()
        .filter(|r| r.kind == Kind::Config && r.interface == Interface::Button)
        .map(|r| r.detail.as_str())
        .collect();
    assert_eq!(by_button, ["network.address: 10.1.2.3 -> 192.168.1.50"]);
    let loaded = got.iter().rfind(|r| r.kind == Kind::ConfigLoaded).unwrap();
    assert!(
        loaded
            .detail
            .as_str()
            .starts_with("stored configuration, crc "),
        "{loaded:?}"
    );
}

#[test]
fn the_watchdog_trip_is_recorded() {
    let mut w = world(WorldConfig {
        config: Config {
            watchdog_ms: 200,
            watchdog_action: WatchdogAction::Stop,
            ..Config::default()
        },
        ..WorldConfig::default()
    });
    w.robot.model.motion_time = Duration::from_millis(1000);
    let ch = r::CHANNEL_BASE;
    let five = 5.0f32.to_bits();
    w.set(
        ch,
        &[
            0,
            crate::job::code::MOVE_REL_J,
            1,
            0,
            0,
            0,
            (five >> 16) as u16,
            five as u16,
        ],
    );
    w.set(ch, &[1]);
    w.run_for(secs(1));
    let got = details(&log_of(&w), Kind::Watchdog);
    assert_eq!(
        got,
        ["PLC heartbeat unchanged for 200 ms during a motion; action stop"]
    );
}

#[test]
fn records_a_failing_medium_loses_are_counted_and_reported_once_it_works() {
    let mut w = world(WorldConfig::default());
    w.config.storage.fail.set(true);
    for poll in [50, 60] {
        w.set(r::CONFIG_POLL_MS, &[poll]);
        // Applied, not saved: exception 04.
        assert_eq!(w.write(r::CONTROL_CONFIG_COMMAND, &[1]), Err(4));
        // Past the period in which changes over Modbus after the first
        // are only counted.
        w.run_for(secs(61));
    }
    assert_eq!(kept(&w.config.storage).len(), 2, "only the start's");
    w.config.storage.fail.set(false);
    w.set(r::CONFIG_POLL_MS, &[70]);
    w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    w.run_for(Duration::from_millis(10));
    let stored = kept(&w.config.storage);
    assert_eq!(
        details(&stored, Kind::Config),
        ["link.poll_ms: 60 -> 70"],
        "the records it failed on are gone"
    );
    assert_eq!(
        details(&stored, Kind::Lost),
        ["2 records lost (the medium was full or failed)"]
    );
    // The page still shows them all.
    assert_eq!(details(&log_of(&w), Kind::Config).len(), 3);
}

// ---------------------------------------------------------- the export

const PC: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 50);
const HOST: &str = "192.168.1.50";

/// Sends a request; the answer's head (lower case) and body (chunks
/// joined).
fn http(w: &mut World, method: &str, path: &str, headers: &str, body: &str) -> (String, Vec<u8>) {
    let req = format!(
        "{method} {path} HTTP/1.1\r\nHost: {HOST}\r\nConnection: close\r\n{headers}Content-Length: {}\r\n\r\n{body}",
        body.len()
    );
    let raw = w.http(PC, req.as_bytes(), secs(10));
    let end = raw
        .windows(4)
        .position(|x| x == b"\r\n\r\n")
        .expect("an answer");
    let head = String::from_utf8_lossy(&raw[..end]).to_ascii_lowercase();
    let mut rest = &raw[end + 4..];
    if method == "HEAD" || !head.contains("transfer-encoding: chunked") {
        return (head, rest.to_vec());
    }
    let mut out = Vec::new();
    loop {
        let line = rest.windows(2).position(|x| x == b"\r\n").unwrap();
        let n = usize::from_str_radix(std::str::from_utf8(&rest[..line]).unwrap(), 16).unwrap();
        rest = &rest[line + 2..];
        if n == 0 {
            break;
        }
        out.extend_from_slice(&rest[..n]);
        rest = &rest[n + 2..];
    }
    (head, out)
}

fn web_world() -> World {
    world(WorldConfig {
        web: true,
        ..WorldConfig::default()
    })
}

/// Creates the administrator with the setup code; returns the headers of
/// its session (`Origin`, JSON, the cookie).
fn admin_session(w: &mut World) -> String {
    let origin = format!("Origin: http://{HOST}\r\nContent-Type: application/json\r\n");
    let setup = format!(r#"{{"code":"{SETUP_CODE}","name":"admin","password":"correct horse"}}"#);
    let (head, _) = http(w, "POST", "/api/setup", &origin, &setup);
    assert!(head.starts_with("http/1.1 200"), "{head}");
    let cookie = head
        .lines()
        .find_map(|l| l.strip_prefix("set-cookie: "))
        .and_then(|c| c.split(';').next())
        .unwrap()
        .to_string();
    format!("{origin}Cookie: {cookie}\r\n")
}

/// Guesses refused unchecked (429: the address must wait) were not in
/// the audit log at all: of the replay's 300,000 wrong logins (issue 25)
/// the log told of the 1,223 that were checked. Now they are counted over
/// a period like the failed ones, one record at its end.
#[test]
fn guesses_refused_unchecked_are_counted_too() {
    let mut w = web_world();
    let session = admin_session(&mut w);
    let origin = session.lines().take(2).collect::<Vec<_>>().join("\r\n") + "\r\n";
    let wrong = r#"{"name":"admin","password":"wrong horse"}"#;
    let mut refused = 0;
    for _ in 0..12 {
        let (head, _) = http(&mut w, "POST", "/api/login", &origin, wrong);
        if head.starts_with("http/1.1 429") {
            refused += 1;
        } else {
            assert!(head.starts_with("http/1.1 401"), "{head}");
        }
    }
    assert!(refused >= 5, "{refused} of 12 had to wait");
    w.run_for(secs(61));
    let got = details(&log_of(&w), Kind::LoginFailed);
    let line = format!("{refused} guesses not checked in 60 s (429: wait), 1 addresses");
    assert!(got.contains(&line), "{line:?} in {got:#?}");
}

#[test]
fn the_export_is_json_by_default_and_csv_as_a_download() {
    let mut w = web_world();
    // An account is needed to read it.
    let (head, _) = http(&mut w, "GET", "/api/audit", "", "");
    assert!(head.starts_with("http/1.1 403"), "{head}");
    let session = admin_session(&mut w);
    let (head, body) = http(&mut w, "GET", "/api/audit", &session, "");
    assert!(head.starts_with("http/1.1 200"), "{head}");
    assert!(head.contains("content-type: application/json"));
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(v["limit"], page::PAGE_MAX);
    assert_eq!(v["older"], false);
    assert_eq!(v["boot"], 1);
    assert!(v["now_unix"].is_null(), "the world has no wall clock");
    let records = v["records"].as_array().unwrap();
    assert_eq!(records[0]["kind"], "start");
    assert_eq!(records[0]["seq"], 1);
    assert_eq!(records[0]["actor"], "-");
    assert_eq!(records[0]["interface"], "system");
    assert!(records[0]["from"].is_null() && records[0]["time"].is_null());
    assert_eq!(records[1]["kind"], "config-loaded");

    let (head, body) = http(&mut w, "GET", "/api/audit?format=csv", &session, "");
    assert!(head.contains("content-type: text/csv"), "{head}");
    assert!(head.contains("content-disposition: attachment; filename=\"hans-gateway-audit.csv\""));
    let text = String::from_utf8(body).unwrap();
    let lines: Vec<_> = text.split("\r\n").collect();
    assert_eq!(
        lines[0],
        "seq,boot,uptime_ms,unix_time,time_utc,kind,actor,interface,from,detail"
    );
    assert!(lines[1].starts_with("1,1,"), "{}", lines[1]);
    assert!(
        lines[2].contains(",config-loaded,\"-\",system,,\"nothing stored: defaults\""),
        "{}",
        lines[2]
    );

    let (head, body) = http(&mut w, "HEAD", "/api/audit?format=csv", &session, "");
    assert!(
        head.starts_with("http/1.1 200") && head.contains("text/csv"),
        "{head}"
    );
    assert!(body.is_empty());
    let (head, _) = http(&mut w, "GET", "/api/audit?format=xml", &session, "");
    assert!(head.starts_with("http/1.1 400"), "{head}");
}

#[test]
fn a_change_from_the_page_is_recorded_with_its_client() {
    let mut w = web_world();
    let headers = admin_session(&mut w);
    let (head, _) = http(
        &mut w,
        "POST",
        "/api/config",
        &headers,
        r#"{"settings":{"link.poll_ms":"50"}}"#,
    );
    assert!(head.starts_with("http/1.1 200"), "{head}");
    let got = log_of(&w);
    let change = got.iter().find(|r| r.kind == Kind::Config).unwrap();
    assert_eq!(change.detail.as_str(), "link.poll_ms: 100 -> 50");
    assert_eq!(change.interface, Interface::Web);
    assert_eq!(
        kept(&w.config.storage).last().unwrap().detail,
        change.detail
    );
}

/// Issue 25, finding 1: any Modbus client re-pointed the robot link (the
/// robot's address and port, the link mode and the listen port were not
/// protected, and write protection is off by default, also with an
/// administrator), and the record had no address. Now refused on a fresh
/// device and on a commissioned one alike, recorded with the client's
/// address; the PLC's own writes (heartbeat, other settings) go on; once
/// an administrator allows configuration over Modbus, the change is made
/// and recorded with the address.
#[test]
fn modbus_cannot_re_point_the_robot_link_unless_configuration_over_modbus_is_allowed() {
    let plc = Some(Ipv4Addr::new(10, 0, 0, 10));
    for admin in [false, true] {
        let mut w = world(WorldConfig::default());
        if admin {
            w.add_admin();
        }
        let before = w.gateway.hub().peek(|m| m.config.active);
        let attacks: [(u16, &[u16]); 4] = [
            (r::CONFIG_ROBOT_IP, &[0x7F00, 0x0063]),
            (r::CONFIG_ROBOT_PORT, &[15003]),
            (r::CONFIG_LINK_MODE, &[1]),
            (r::CONFIG_LISTEN_PORT, &[15099]),
        ];
        for (reg, v) in attacks {
            w.set(reg, v);
            assert_eq!(w.write(r::CONTROL_CONFIG_COMMAND, &[1]), Err(1), "{reg}");
            assert_eq!(w.reg(r::CONTROL_CONFIG_RESULT), 4);
            w.set(r::CONTROL_CONFIG_COMMAND, &[2]);
        }
        let after = w.gateway.hub().peek(|m| m.config.active);
        assert_eq!(
            (
                after.robot_ip,
                after.robot_port,
                after.link_mode,
                after.listen_port
            ),
            (
                before.robot_ip,
                before.robot_port,
                before.link_mode,
                before.listen_port
            ),
            "admin {admin}"
        );
        // Defaults (3) leave the protected settings as they are.
        w.set(r::CONTROL_CONFIG_COMMAND, &[3]);
        assert_eq!(w.write(r::CONTROL_CONFIG_COMMAND, &[1]), Ok(()));
        let after = w.gateway.hub().peek(|m| m.config.active);
        assert_eq!(after.robot_ip, before.robot_ip);
        // The PLC's own registers stay writable.
        w.set(r::CONTROL_HEARTBEAT, &[7]);
        w.set(r::CONFIG_POLL_MS, &[40]);
        assert_eq!(w.write(r::CONTROL_CONFIG_COMMAND, &[1]), Ok(()));
        w.run_for(Duration::from_millis(10));
        let got = log_of(&w);
        let refused: Vec<_> = got
            .iter()
            .filter(|r| r.kind == Kind::ConfigRefused)
            .collect();
        assert_eq!(refused.len(), 1, "the first of a period recorded: {got:?}");
        assert_eq!(refused[0].from, plc);
        assert!(
            refused[0].detail.as_str().starts_with("robot.address"),
            "{:?}",
            refused[0]
        );
        let poll = got
            .iter()
            .find(|r| r.kind == Kind::Config && r.detail.as_str().starts_with("link.poll_ms"))
            .expect("the PLC's change recorded");
        assert_eq!(poll.from, plc, "with the client's address");
        // The period's end says how many more were refused.
        w.run_for(secs(61));
        let got = log_of(&w);
        let counted: Vec<_> = details(&got, Kind::ConfigRefused);
        assert_eq!(counted.len(), 2, "{counted:?}");
        assert!(counted[1].starts_with("3 more refused in "), "{counted:?}");
    }
    // Allowed by an administrator: made, and recorded with the address.
    let mut w = world(WorldConfig::default());
    w.add_admin();
    w.allow_modbus_config();
    w.set(r::CONFIG_ROBOT_PORT, &[15003]);
    assert_eq!(w.write(r::CONTROL_CONFIG_COMMAND, &[1]), Ok(()));
    w.run_for(Duration::from_millis(10));
    assert_eq!(w.gateway.hub().peek(|m| m.config.active.robot_port), 15003);
    let got = log_of(&w);
    let port = got
        .iter()
        .find(|r| r.kind == Kind::Config && r.detail.as_str().starts_with("robot.port"))
        .expect("recorded");
    assert_eq!(port.from, plc);
}

/// Issue 25, finding 4: a PLC toggling a setting wrote some 100 records
/// a second. Now the first apply of a period is recorded setting by
/// setting, the others are counted into one record at its end.
#[test]
fn settings_toggled_over_modbus_are_counted_not_recorded_one_by_one() {
    let mut w = world(WorldConfig::default());
    for k in 0..200u16 {
        w.set(r::CONFIG_POLL_MS, &[40 + k % 2]);
        w.set(r::CONTROL_CONFIG_COMMAND, &[1]);
    }
    w.run_for(secs(61));
    let got = details(&log_of(&w), Kind::Config);
    assert_eq!(got.len(), 2, "{got:?}");
    assert_eq!(got[0], "link.poll_ms: 100 -> 40");
    assert!(
        got[1] == "199 more applied in 60 s from 1 addresses, last link.poll_ms",
        "{got:?}"
    );
}

/// Issue 25, finding 4: wrong logins for unknown names from rotating
/// addresses were recorded one by one (the writer kept ~100 a second and
/// lost the rest, and the flood rotated the evidence away). Now the first
/// failure of a period is recorded with its name and address, the others
/// are one record at the period's end: how many, how many for unknown
/// names, from how many addresses. An account's records are untouched.
#[test]
fn failed_logins_are_counted_per_period_not_recorded_one_by_one() {
    let log = Log::new();
    log.start(false);
    log.record(Event::Account {
        name: b"alice",
        change: AccountChange::Created { role: "admin" },
        by: b"alice",
        from: None,
    });
    for k in 0..10_000u32 {
        let from = Ipv4Addr::new(10, 1, (k >> 8) as u8, k as u8);
        log.login_failed(b"nobody", false, Some(from));
    }
    log.setup_failed(Some(Ipv4Addr::new(10, 2, 0, 1)));
    log.login_failed(b"alice", true, Some(Ipv4Addr::new(10, 2, 0, 2)));
    log.stamp(at(5));
    log.end_refusal_periods(at(65));
    let got = ring(&log);
    assert_eq!(got.len(), 3, "{got:?}");
    assert_eq!(got[0].kind, Kind::AccountCreated);
    assert_eq!(got[1].kind, Kind::LoginFailed);
    assert_eq!(got[1].actor_str(), "nobody");
    assert_eq!(got[1].from, Some(Ipv4Addr::new(10, 1, 0, 0)));
    assert_eq!(
        got[2].detail.as_str(),
        "10001 more failed logins in 60 s (10000 unknown names), more than 16 addresses"
    );
    // The next period starts with a record again.
    log.login_failed(b"bob", false, None);
    log.stamp(at(70));
    assert_eq!(ring(&log).len(), 4);
}

#[test]
fn closing_ends_every_running_period_at_once_and_the_next_starts_afresh() {
    let log = Log::new();
    log.start(false);
    let a = Ipv4Addr::new(10, 9, 9, 1);
    log.refused(Interface::Web, Some(a));
    log.refused(Interface::Web, Some(a));
    log.stamp(at(10));
    // Counted, not stamped yet: closing stamps it first.
    log.refused(Interface::Robot, Some(a));
    log.close_periods(at(25));
    assert_eq!(
        details(&ring(&log), Kind::Refused),
        [
            "2 connections refused in 15 s (allow-list)",
            "1 connections refused in 0 s (not the controller)"
        ]
    );
    assert_eq!(log.refusals_due(), None, "nothing runs after closing");
    log.close_periods(at(30));
    assert_eq!(ring(&log).len(), 2, "a second closing records nothing");
}

/// Pages back from the newest with `limit`: every page's records (oldest
/// first each), newest page first, and the `before` each was asked with.
fn walk(w: &mut World, session: &str, limit: usize) -> Vec<Vec<u32>> {
    let mut pages = Vec::new();
    let mut before: Option<u64> = None;
    for _ in 0..200 {
        let path = match before {
            Some(b) => format!("/api/audit?before={b}&limit={limit}"),
            None => format!("/api/audit?limit={limit}"),
        };
        let (head, body) = http(w, "GET", &path, session, "");
        assert!(head.starts_with("http/1.1 200"), "{path}: {head}");
        let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
        let seqs: Vec<u32> = v["records"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| r["seq"].as_u64().unwrap() as u32)
            .collect();
        assert!(seqs.len() <= limit, "{path}: {seqs:?}");
        let older = v["older"].as_bool().unwrap();
        let next = v["next_before"].as_u64();
        pages.push(seqs.clone());
        if !older {
            assert!(next.is_none());
            assert!(!head.contains("audit-next-before"), "{head}");
            return pages;
        }
        assert_eq!(next, seqs.first().map(|s| u64::from(*s)), "{path}");
        assert!(
            head.contains(&format!("audit-next-before: {}", next.unwrap())),
            "{head}"
        );
        before = next;
    }
    panic!("no end after 200 pages");
}

/// Issue 25, finding 4: the page and `/api/audit` showed the newest 64
/// (the RAM ring) only. Now they page back through everything the medium
/// keeps: 300 records (far more than the ring), in pages of 32 and of 7,
/// each record once, back to the first.
#[test]
fn the_export_pages_back_through_everything_kept_not_only_the_ring() {
    let mut w = web_world();
    let session = admin_session(&mut w);
    for batch in 0..15 {
        for n in 0..20 {
            note(&w.gateway.hub().audit, batch * 20 + n);
        }
        w.run_for(Duration::from_millis(10));
    }
    let all: Vec<u32> = kept(&w.config.storage).iter().map(|r| r.seq).collect();
    assert!(all.len() > 300 && all.len() > 4 * RING, "{}", all.len());
    assert_eq!(all.first(), Some(&1));
    for limit in [page::PAGE_MAX, 7] {
        let pages = walk(&mut w, &session, limit);
        assert!(pages.iter().all(|p| !p.is_empty()));
        assert!(pages[..pages.len() - 1].iter().all(|p| p.len() == limit));
        let mut got: Vec<u32> = pages.into_iter().rev().flatten().collect();
        // The walk's own requests made no records; the newest page may
        // hold records made after it was read (none here).
        got.dedup();
        assert_eq!(got, all, "limit {limit}");
    }
    // Without a limit: a page of PAGE_MAX, the newest.
    let (_, body) = http(&mut w, "GET", "/api/audit", &session, "");
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(v["records"].as_array().unwrap().len(), page::PAGE_MAX);
    assert_eq!(
        v["records"][page::PAGE_MAX - 1]["seq"].as_u64(),
        all.last().map(|s| u64::from(*s))
    );
    // CSV pages the same way.
    let (head, body) = http(
        &mut w,
        "GET",
        "/api/audit?format=csv&before=3&limit=5",
        &session,
        "",
    );
    assert!(
        head.contains("text/csv") && !head.contains("audit-next-before"),
        "{head}"
    );
    let text = String::from_utf8(body).unwrap();
    let lines: Vec<_> = text.split("\r\n").filter(|l| !l.is_empty()).collect();
    assert_eq!(lines.len(), 3, "{text}");
    assert!(
        lines[1].starts_with("1,") && lines[2].starts_with("2,"),
        "{text}"
    );
}

#[test]
fn bad_paging_parameters_are_a_400_that_says_why_and_the_page_needs_an_account() {
    let mut w = web_world();
    let (head, _) = http(&mut w, "GET", "/api/audit?before=5", "", "");
    assert!(head.starts_with("http/1.1 403"), "{head}");
    let session = admin_session(&mut w);
    for (query, why) in [
        ("before=0", "before is a record's number"),
        ("before=abc", "before is a record's number"),
        ("before=99999999999", "before is a record's number"),
        ("limit=0", "limit is a number of records"),
        ("limit=-4", "limit is a number of records"),
        ("before=3&before=4", "each be given once"),
        ("format=xml&before=3", "format is json or csv"),
    ] {
        let (head, body) = http(&mut w, "GET", &format!("/api/audit?{query}"), &session, "");
        assert!(head.starts_with("http/1.1 400"), "{query}: {head}");
        let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
        assert!(v["error"].as_str().unwrap().contains(why), "{query}: {v}");
    }
    // A limit above the page's size is taken as that size.
    let (head, body) = http(&mut w, "GET", "/api/audit?limit=1000", &session, "");
    assert!(head.starts_with("http/1.1 200"), "{head}");
    let v: serde_json::Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(v["limit"], page::PAGE_MAX);
}
