//! The adapter in the gateway, in virtual time: the real gateway future on
//! the simulated network with the scripted robot (`crate::testkit`), and
//! the testkit's scanner (`crate::testkit::enip`; the scanners nobody here
//! wrote are scripts/enip-tests.sh's). What is tested is the
//! gateway's side: the assemblies as a view of the state, the ownership
//! rule between Modbus and EtherNet/IP, and a class 1 timeout as a lost
//! heartbeat.

extern crate std;

use core::net::{Ipv4Addr, SocketAddrV4};
use std::vec;
use std::vec::Vec;

use embassy_time::Duration;
use hans_enip::wire::cip::{GeneralStatus, ResponseHeader, Service};
use hans_enip::wire::conn_mgr::{ExtendedStatus, ForwardOpen, Transport};
use hans_enip::wire::encap::{Command, Header, Status, HEADER_LEN};
use hans_enip::wire::Writer;

use super::assembly::{input, output, CONFIG, INPUT, OUTPUT, SIZE};
use crate::config::{Config, WatchdogAction};
use crate::error::GatewayError;
use crate::job::code;
use crate::registers as r;
use crate::testkit::enip::{encap, i32_at, mr, o_t_datagram, p2p, triad, u16_at, Scanner, CM_PATH};
use crate::testkit::net::SimStream;
use crate::testkit::world::{World, WorldConfig};

/// The Logix PLC's address (the Modbus PLC is the world's 10.0.0.10).
const LOGIX: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 50);
const CH0: u16 = r::CHANNEL_BASE;

fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}

fn world(config: Config) -> World {
    let mut w = World::new(WorldConfig {
        config: Config {
            enip_enabled: true,
            ..config
        },
        ..WorldConfig::default()
    });
    w.run_for(ms(300));
    w.robot.model.motion_time = ms(1000);
    w
}

fn sent(w: &World, name: &str) -> usize {
    w.robot
        .log
        .iter()
        .filter(|m| m.text.starts_with(name))
        .count()
}

const MOVE: [f32; 2] = [0.0, 5.0]; // MoveRelJ: axis 0, +5°

#[test]
fn a_move_fired_through_the_assemblies_is_busy_then_done_as_over_modbus() {
    let mut w = world(Config::default());
    let mut s = Scanner::connect(&mut w, LOGIX);
    assert_eq!(s.open(&mut w, 1).status, GeneralStatus::Success);
    s.command(code::MOVE_REL_J, 7, &MOVE);
    // The first Run datagram is the baseline: no edge.
    let i = s.cycle(&mut w, ms(50));
    assert_eq!(u16_at(&i, input::COMMAND_OWNER), 1, "owned, Run");
    assert_eq!(w.reg(r::STATUS_COMMAND_OWNER), 1);
    s.execute(true);
    let i = s.cycle(&mut w, ms(30));
    assert_ne!(u16_at(&i, input::CH0) & r::ST_BUSY, 0);
    assert_eq!(u16_at(&i, input::CH0 + 2), 7, "sequence echo");
    // The registers show the same handshake.
    assert_ne!(w.reg(CH0 + r::CH_STATUS) & r::ST_BUSY, 0);
    assert_eq!(s.until_ended(&mut w, ms(3000)), r::ST_DONE);
    assert_eq!(sent(&w, "MoveRelJ"), 1);
    // Execute falls: the outputs clear, as over Modbus.
    s.execute(false);
    let i = s.cycle(&mut w, ms(30));
    assert_eq!(u16_at(&i, input::CH0), 0);
    assert_eq!(s.close(&mut w).status, GeneralStatus::Success);
    w.run_for(ms(20));
    assert_eq!(w.reg(r::STATUS_COMMAND_OWNER), 0, "Modbus owns again");
    assert_eq!(w.reg(r::STATUS_ENIP_CONNECTIONS), 0);
}

#[test]
fn a_refused_motion_ends_in_error_with_the_same_error_id_as_over_modbus() {
    let mut w = world(Config::default());
    let mut s = Scanner::connect(&mut w, LOGIX);
    assert_eq!(s.open(&mut w, 1).status, GeneralStatus::Success);
    // An unknown command code: Error, ErrorID 39501 from the gateway.
    s.command(9999, 3, &[]);
    s.cycle(&mut w, ms(20));
    s.execute(true);
    let st = s.until_ended(&mut w, ms(1000));
    assert_eq!(st, r::ST_ERROR);
    let i = s.cycle(&mut w, ms(10));
    let modbus = w.read(CH0 + r::CH_ERROR_ID, 3).unwrap();
    let id = ((u32::from(modbus[0]) << 16) | u32::from(modbus[1])) as i32;
    assert_eq!(i32_at(&i, input::CH0 + 4), id);
    assert_eq!(u16_at(&i, input::CH0 + 8), modbus[2]);
    assert_ne!(id, 0);
}

#[test]
fn modbus_may_not_write_the_command_inputs_while_an_owner_connection_is_open() {
    let mut w = world(Config::default());
    let mut s = Scanner::connect(&mut w, LOGIX);
    assert_eq!(s.open(&mut w, 1).status, GeneralStatus::Success);
    s.cycle(&mut w, ms(30));
    // Execute, the heartbeat, trigger bits: refused whole (exception 01).
    assert_eq!(w.write(CH0, &[1, code::MOVE_REL_J, 1]), Err(1));
    assert_eq!(w.write(r::CONTROL_HEARTBEAT, &[5]), Err(1));
    assert_eq!(w.write(r::TRIG_BITS, &[1]), Err(1));
    // Reading is free, and so are the registers outside the command inputs.
    assert_eq!(w.reg(r::STATUS_COMMAND_OWNER), 1);
    assert!(w.write(r::CONFIG_WATCHDOG_MS, &[500]).is_ok());
    assert_eq!(sent(&w, "MoveRelJ"), 0);
    // An explicit write of the output assembly is refused as well.
    let data = vec![0u8; SIZE];
    let set = mr(
        Service::SetAttributeSingle,
        &[0x20, 0x04, 0x24, OUTPUT as u8, 0x30, 0x03],
        &data,
    );
    let (h, _) = s.ask(&mut w, &set);
    assert_eq!(h.status, GeneralStatus::DeviceStateConflict);
    // Closed: Modbus owns the inputs again.
    assert_eq!(s.close(&mut w).status, GeneralStatus::Success);
    w.run_for(ms(20));
    assert!(w.write(r::CONTROL_HEARTBEAT, &[5]).is_ok());
}

#[test]
fn an_owner_forward_open_is_refused_while_a_modbus_command_is_busy() {
    let mut w = world(Config::default());
    // Modbus fires a move.
    let mut words = vec![0, code::MOVE_REL_J, 1, 0];
    for p in MOVE {
        let b = p.to_bits();
        words.extend([(b >> 16) as u16, b as u16]);
    }
    w.set(CH0, &words);
    w.set(CH0, &[1]);
    w.run_for(ms(20));
    assert_ne!(w.reg(CH0 + r::CH_STATUS) & r::ST_BUSY, 0);
    let mut s = Scanner::connect(&mut w, LOGIX);
    let h = s.open(&mut w, 1);
    assert_eq!(h.status, GeneralStatus::ConnectionFailure);
    assert_eq!(
        h.additional.first().copied(),
        Some(ExtendedStatus::OwnershipConflict.into())
    );
    assert_eq!(w.reg(r::STATUS_ENIP_REFUSED), 1);
    // Once the Modbus command has ended, the PLC's retry succeeds.
    let ended = w.run_until_cond(ms(3000), |w| w.reg(CH0 + r::CH_STATUS) & r::ST_BUSY == 0);
    assert!(ended);
    assert_eq!(s.open(&mut w, 2).status, GeneralStatus::Success);
}

#[test]
fn a_class_1_timeout_during_a_motion_is_a_lost_heartbeat_the_watchdog_stops() {
    // A long watchdog period: the stop must come from the lost connection
    // (RPI 10 ms x 16 = 160 ms), not from the period.
    let mut w = world(Config {
        watchdog_ms: 5000,
        watchdog_action: WatchdogAction::Stop,
        ..Config::default()
    });
    w.robot.model.motion_time = ms(3000);
    let mut s = Scanner::connect(&mut w, LOGIX);
    assert_eq!(s.open(&mut w, 1).status, GeneralStatus::Success);
    s.command(code::MOVE_REL_J, 1, &MOVE);
    s.cycle(&mut w, ms(20));
    s.execute(true);
    s.put_u16(output::HEARTBEAT, 1);
    let i = s.cycle(&mut w, ms(100));
    assert_ne!(u16_at(&i, input::CH0) & r::ST_BUSY, 0);
    // The PLC goes silent (cable pulled): no Forward_Close.
    let silent = w.now();
    let tripped = w.run_until_cond(ms(1000), |w| w.reg(r::STATUS_WATCHDOG_TRIPS) == 1);
    assert!(tripped, "no watchdog trip");
    let after = w.now() - silent;
    assert!(
        after >= ms(150) && after <= ms(300),
        "tripped {after:?} after the last datagram (timeout 160 ms)"
    );
    assert_eq!(sent(&w, "GrpStop"), 1);
    let ended = w.run_until_cond(ms(500), |w| w.reg(CH0 + r::CH_STATUS) & r::ST_BUSY == 0);
    assert!(ended);
    assert_eq!(w.reg(CH0 + r::CH_STATUS), r::ST_ERROR);
    let e = w.read(CH0 + r::CH_ERROR_ID, 2).unwrap();
    let id = ((u32::from(e[0]) << 16) | u32::from(e[1])) as i32;
    assert_eq!(id, GatewayError::Watchdog.code());
    assert_eq!(w.reg(r::STATUS_COMMAND_OWNER), 0);
}

#[test]
fn a_forward_close_without_a_motion_trips_nothing() {
    let mut w = world(Config {
        watchdog_ms: 200,
        watchdog_action: WatchdogAction::Stop,
        ..Config::default()
    });
    let mut s = Scanner::connect(&mut w, LOGIX);
    assert_eq!(s.open(&mut w, 1).status, GeneralStatus::Success);
    s.cycle(&mut w, ms(50));
    assert_eq!(s.close(&mut w).status, GeneralStatus::Success);
    w.run_for(ms(1000));
    assert_eq!(w.reg(r::STATUS_WATCHDOG_TRIPS), 0);
    // A motion fired later over Modbus is not stopped by the old loss.
    w.robot.model.motion_time = ms(100);
    let mut words = vec![0, code::MOVE_REL_J, 1, 0];
    for p in MOVE {
        let b = p.to_bits();
        words.extend([(b >> 16) as u16, b as u16]);
    }
    w.set(CH0, &words);
    w.set(CH0, &[1]);
    let ended = w.run_until_cond(ms(1000), |w| w.reg(CH0 + r::CH_STATUS) & r::ST_BUSY == 0);
    assert!(ended);
    assert_eq!(w.reg(CH0 + r::CH_STATUS), r::ST_DONE);
}

#[test]
fn off_in_the_factory_state() {
    let mut w = World::new(WorldConfig::default());
    w.run_for(ms(300));
    assert!(w
        .net
        .connect(SocketAddrV4::new(LOGIX, 40_000), 44818)
        .is_none());
}

/// An assembly's fields as ENIP.md's table rows.
fn table(fields: &[super::assembly::Field]) -> std::string::String {
    use std::fmt::Write;
    let mut t = std::string::String::from("| byte | tag | type |\n|---|---|---|\n");
    for f in fields {
        let ty = match (f.ty, f.count) {
            (super::assembly::Ty::Text, n) => std::format!("STRING ({n} chars)"),
            (ty, 1) => std::string::String::from(ty.name()),
            (ty, n) => std::format!("{}[{n}]", ty.name()),
        };
        let _ = writeln!(t, "| {} | {} | {} |", f.offset, f.name, ty);
    }
    t
}

/// `gateway/NAME` holds `want` (with `HANS_BLESS=1`: is made to).
fn generated(name: &str, text: &str, want: &str, whole: bool) {
    let path = std::format!("{}/{name}", env!("CARGO_MANIFEST_DIR"));
    let holds = if whole {
        text == want
    } else {
        text.contains(want)
    };
    if !holds && std::env::var_os("HANS_BLESS").is_some() && whole {
        std::fs::write(&path, want).unwrap();
        return;
    }
    assert!(
        holds,
        "{path} is not what the definitions give; it should hold:\n{want}"
    );
}

#[test]
fn enip_md_tables_are_the_assemblies_layout() {
    let doc = include_str!("../../ENIP.md");
    generated("ENIP.md", doc, &table(super::assembly::INPUT_FIELDS), false);
    generated(
        "ENIP.md",
        doc,
        &table(super::assembly::OUTPUT_FIELDS),
        false,
    );
}

#[test]
fn the_eds_file_is_written_from_the_definitions() {
    let mut eds = std::string::String::new();
    super::write_eds(&mut eds).unwrap();
    let file = std::fs::read_to_string(std::format!(
        "{}/hans-gateway.eds",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap_or_default();
    generated("hans-gateway.eds", &file, &eds, true);
}

// ------------------------------------------------------------------ attacks
// One test per bound of the listener (ENIP.md, "Attacks and bounds"): the
// attack, what the bound does, and the PLC's owner connection running on.

/// An attacker's address (nothing to do with the PLC).
fn attacker(n: u8) -> Ipv4Addr {
    Ipv4Addr::new(10, 0, 0, 60 + n)
}

/// A registered session from `ip`, port `port` (several from one address).
fn session_from(w: &mut World, ip: Ipv4Addr, port: u16) -> SimStream {
    let mut tcp = w
        .net
        .connect(SocketAddrV4::new(ip, port), 44818)
        .expect("the adapter listens");
    tcp.write(&encap(Command::RegisterSession, 0, &[1, 0, 0, 0]));
    tcp
}

/// Reads what has come on `tcp` within `limit`: a whole reply, or nothing.
fn reply_on(w: &mut World, tcp: &mut SimStream, limit: Duration) -> Vec<u8> {
    let mut got = Vec::new();
    w.run_until_cond(limit, |_| {
        got.extend(tcp.read());
        Header::parse(&got).is_ok_and(|h| got.len() >= HEADER_LEN + h.length as usize)
    });
    got
}

/// The PLC's owner connection, open and cycling, with a heartbeat.
fn plc_running(w: &mut World) -> Scanner {
    let mut s = Scanner::connect(w, LOGIX);
    assert_eq!(s.open(w, 1).status, GeneralStatus::Success);
    s.cycle(w, ms(50));
    assert_eq!(w.reg(r::STATUS_COMMAND_OWNER), 1);
    s
}

/// The PLC fires a move through its assemblies and sees it Done: its
/// connection works.
fn plc_moves(w: &mut World, s: &mut Scanner, seq: u16) {
    w.robot.model.motion_time = ms(200);
    s.command(code::MOVE_REL_J, seq, &MOVE);
    s.cycle(w, ms(20));
    s.execute(true);
    assert_eq!(s.until_ended(w, ms(3000)), r::ST_DONE, "the PLC's move");
    s.execute(false);
    s.cycle(w, ms(20));
}

#[test]
fn a_session_flood_from_one_address_holds_two_sessions_and_the_plc_runs_on() {
    let mut w = world(Config::default());
    let mut plc = plc_running(&mut w);
    let mut flood = Vec::new();
    for n in 0..8u16 {
        flood.push(session_from(&mut w, attacker(1), 41_000 + n));
        plc.cycle(&mut w, ms(30));
        // Never more than PER_ADDRESS of them open at once: the newest
        // takes the slot of its own address's oldest.
        let open = flood.iter().filter(|t| t.is_open()).count();
        assert!(
            open <= super::PER_ADDRESS,
            "{open} sessions from one address"
        );
    }
    assert!(plc.tcp.is_open(), "the PLC's session stays");
    let i = plc.cycle(&mut w, ms(100));
    assert_eq!(u16_at(&i, input::COMMAND_OWNER), 1);
    plc_moves(&mut w, &mut plc, 11);
    assert_eq!(w.reg(r::STATUS_WATCHDOG_TRIPS), 0);
}

#[test]
fn a_session_flood_from_many_addresses_never_holds_more_than_three_and_class_1_runs_on() {
    let mut w = world(Config::default());
    let mut plc = plc_running(&mut w);
    // Each flood connection, and whether it was served (its
    // RegisterSession answered).
    let mut flood: Vec<(SimStream, bool)> = Vec::new();
    // Forty sessions from twenty addresses over 12 s, each keeping its
    // session busy with a NOP now and then.
    for n in 0..40u16 {
        let t = session_from(&mut w, attacker((n % 20) as u8), 42_000 + n);
        flood.push((t, false));
        for _ in 0..30 {
            plc.cycle(&mut w, ms(10));
            for (t, served) in flood.iter_mut() {
                *served |= !t.read().is_empty();
            }
            // Served at once: at most SESSIONS (the others wait in the
            // backlog or for a slot, then are refused).
            let served = flood.iter().filter(|(t, s)| *s && t.is_open()).count()
                + usize::from(plc.tcp.is_open());
            assert!(
                served <= super::SESSIONS,
                "{served} sessions served at once"
            );
        }
        for (t, _) in flood.iter_mut().filter(|(t, _)| t.is_open()) {
            t.write(&encap(Command::Nop, 0, &[]));
        }
    }
    assert!(
        flood.iter().filter(|(_, s)| *s).count() >= 3,
        "the flood was served at all"
    );
    // The PLC's TCP session, quiet while its class 1 runs, may have given
    // its slot to a newcomer (it was idle); its connection runs on UDP
    // and never stopped.
    let i = plc.cycle(&mut w, ms(100));
    assert_eq!(u16_at(&i, input::COMMAND_OWNER), 1);
    assert_eq!(w.reg(r::STATUS_ENIP_CONNECTIONS), 1);
    plc_moves(&mut w, &mut plc, 12);
    assert_eq!(w.reg(r::STATUS_WATCHDOG_TRIPS), 0);
}

/// A class 1 Forward_Open of an input-only connection (heartbeat O->T) at
/// `rpi_us`, multiplier `mult`; the response header.
fn open_input_only(
    w: &mut World,
    s: &mut Scanner,
    serial: u16,
    rpi_us: u32,
    mult: u8,
) -> ResponseHeader {
    let path = [
        0x20,
        0x04,
        0x24,
        CONFIG as u8,
        0x2C,
        super::assembly::INPUT_ONLY as u8,
        0x2C,
        INPUT as u8,
    ];
    let fo = ForwardOpen {
        large: false,
        priority_tick: 0x0A,
        timeout_ticks: 0x0E,
        o_t_id: 0,
        t_o_id: 0x6000_0000 + u32::from(serial),
        triad: triad(serial),
        multiplier: mult,
        o_t_rpi: rpi_us,
        o_t_params: p2p(2),
        t_o_rpi: rpi_us,
        t_o_params: p2p(SIZE as u16 + 2),
        transport: Transport {
            server: false,
            trigger: 0,
            class: 1,
        },
        path: &path,
    };
    let mut buf = vec![0u8; 512];
    let mut wr = Writer::new(&mut buf);
    fo.emit(&mut wr).unwrap();
    let n = wr.len();
    s.ask(w, &mr(Service::ForwardOpen, &CM_PATH, &buf[..n])).0
}

fn out_of_connections(h: &ResponseHeader) -> bool {
    h.status == GeneralStatus::ConnectionFailure
        && h.additional.first().copied() == Some(ExtendedStatus::OutOfConnections.into())
}

#[test]
fn half_open_forward_opens_are_refused_beyond_the_table_and_freed_by_their_timeout() {
    let mut w = world(Config::default());
    let mut plc = plc_running(&mut w);
    let mut a = Scanner::connect(&mut w, attacker(1));
    let mut b = Scanner::connect(&mut w, attacker(2));
    // Connections opened and never fed: two from A (its cap)...
    assert_eq!(
        open_input_only(&mut w, &mut a, 100, 10_000, 0).status,
        GeneralStatus::Success
    );
    // (this one's own timeout, 1 s x 4 << 1 = 8 s, is longer than the
    // first-packet timeout: it holds its slot that long)
    assert_eq!(
        open_input_only(&mut w, &mut a, 101, 1_000_000, 1).status,
        GeneralStatus::Success
    );
    // ...a third from A: the per-originator cap (the table has room).
    assert_eq!(w.reg(r::STATUS_ENIP_CONNECTIONS), 3);
    let h = open_input_only(&mut w, &mut a, 102, 10_000, 0);
    assert!(out_of_connections(&h), "{h:?}");
    // One from B fills the table; B's second: the table is full.
    assert_eq!(
        open_input_only(&mut w, &mut b, 200, 10_000, 0).status,
        GeneralStatus::Success
    );
    let h = open_input_only(&mut w, &mut b, 201, 10_000, 0);
    assert!(out_of_connections(&h), "{h:?}");
    assert_eq!(w.reg(r::STATUS_ENIP_CONNECTIONS), super::CONNECTIONS as u16);
    // The half-open ones time out (3 s after their reply; the PLC's owner
    // runs on meanwhile); the long one after its own 8 s.
    let opened = w.now();
    plc.cycle(&mut w, ms(2800));
    assert_eq!(w.reg(r::STATUS_ENIP_CONNECTIONS), 4, "freed too early");
    let until = opened + Duration::from_micros(u64::from(super::FIRST_PACKET_TIMEOUT_US));
    let left = until - w.now() + ms(300);
    plc.cycle(&mut w, left);
    assert_eq!(
        w.reg(r::STATUS_ENIP_CONNECTIONS),
        2,
        "the half-open ones freed"
    );
    // The table has recovered: B's retry is served.
    assert_eq!(
        open_input_only(&mut w, &mut b, 202, 10_000, 0).status,
        GeneralStatus::Success
    );
    plc.cycle(&mut w, ms(5000));
    assert_eq!(w.reg(r::STATUS_ENIP_CONNECTIONS), 1, "the 8 s one freed");
    // The owner never lost its connection.
    assert_eq!(w.reg(r::STATUS_COMMAND_OWNER), 1);
    plc_moves(&mut w, &mut plc, 13);
    assert_eq!(w.reg(r::STATUS_WATCHDOG_TRIPS), 0);
}

#[test]
fn an_oversized_encapsulation_length_is_refused_typed_and_a_lying_one_closed_at_the_deadline() {
    let mut w = world(Config::default());
    let mut plc = plc_running(&mut w);
    let mut s = Scanner::connect(&mut w, attacker(1));
    // 2000 bytes of data: beyond the 600-byte buffer. Skipped, answered
    // with status 0x65 (invalid length); the session stays.
    let mut big = encap(Command::SendRrData, s.session, &[0x55; 2000]);
    big.truncate(HEADER_LEN);
    big.extend(std::iter::repeat_n(0x55, 2000));
    let reply = s.exchange(&mut w, &big);
    assert_eq!(Header::parse(&reply).unwrap().status, Status::InvalidLength);
    let h = Header::parse(&s.exchange(&mut w, &encap(Command::ListIdentity, 0, &[]))).unwrap();
    assert_eq!(h.status, Status::Success, "the session still served");
    // A length of 65535 and a trickle of data: closed one FRAME_DEADLINE
    // after the packet's first byte, whatever the trickle.
    let mut lie = encap(Command::SendRrData, s.session, &[]);
    lie[2..4].copy_from_slice(&u16::MAX.to_le_bytes());
    s.tcp.write(&lie);
    let first = w.now();
    let mut closed = None;
    while w.now() < first + ms(3000) {
        s.tcp.write(&[0; 10]);
        plc.cycle(&mut w, ms(50));
        if !s.tcp.is_open() {
            closed = Some(w.now() - first);
            break;
        }
    }
    let after = closed.expect("the lying session is closed");
    assert!(
        after >= super::FRAME_DEADLINE && after <= super::FRAME_DEADLINE + ms(100),
        "closed {after:?} after its first byte"
    );
    assert_eq!(w.reg(r::STATUS_COMMAND_OWNER), 1);
    plc_moves(&mut w, &mut plc, 14);
}

#[test]
fn oversized_cpf_item_counts_and_lengths_get_a_typed_refusal_and_nothing_else_moves() {
    let mut w = world(Config::default());
    let mut plc = plc_running(&mut w);
    let mut s = Scanner::connect(&mut w, attacker(1));
    let bad: [Vec<u8>; 3] = [
        // Interface handle, timeout, then 500 items declared, two present.
        [
            &[0, 0, 0, 0, 10, 0][..],
            &500u16.to_le_bytes(),
            &[0, 0, 0, 0, 0xB2, 0, 2, 0, 0x01, 0x02],
        ]
        .concat(),
        // Two items, the second claiming 4000 bytes.
        [
            &[0, 0, 0, 0, 10, 0, 2, 0, 0, 0, 0, 0, 0xB2, 0][..],
            &4000u16.to_le_bytes(),
            &[0x0E, 0x03, 0x20, 0x01, 0x24, 0x01],
        ]
        .concat(),
        // An item length past the packet by one.
        [
            &[0, 0, 0, 0, 10, 0, 2, 0, 0, 0, 0, 0, 0xB2, 0][..],
            &7u16.to_le_bytes(),
            &[0x0E, 0x03, 0x20, 0x01, 0x24, 0x01],
        ]
        .concat(),
    ];
    for data in &bad {
        let reply = s.exchange(&mut w, &encap(Command::SendRrData, s.session, data));
        let h = Header::parse(&reply).unwrap();
        assert_eq!(h.status, Status::IncorrectData, "{data:02x?}");
        plc.cycle(&mut w, ms(20));
    }
    // The session is still served, and nothing was opened or written.
    let (h, _) = s.ask(
        &mut w,
        &mr(Service::GetAttributesAll, &[0x20, 0x01, 0x24, 0x01], &[]),
    );
    assert_eq!(h.status, GeneralStatus::Success);
    assert_eq!(w.reg(r::STATUS_ENIP_CONNECTIONS), 1);
    plc_moves(&mut w, &mut plc, 15);
}

#[test]
fn a_slow_sender_dribbling_a_header_is_closed_at_the_per_packet_deadline() {
    let mut w = world(Config::default());
    let mut plc = plc_running(&mut w);
    let mut slow = session_from(&mut w, attacker(1), 43_000);
    let _ = reply_on(&mut w, &mut slow, ms(500));
    // A ListIdentity header, one byte every 150 ms (24 bytes: 3.6 s).
    let header = encap(Command::ListIdentity, 0, &[]);
    let first = w.now();
    let mut closed = None;
    for b in &header {
        slow.write(&[*b]);
        plc.cycle(&mut w, ms(150));
        if !slow.is_open() {
            closed = Some(w.now() - first);
            break;
        }
    }
    let after = closed.expect("the slow sender is closed");
    assert!(
        after >= super::FRAME_DEADLINE && after <= super::FRAME_DEADLINE + ms(200),
        "closed {after:?} after its first byte"
    );
    assert!(plc.tcp.is_open());
    let h = Header::parse(&plc.exchange(&mut w, &encap(Command::ListIdentity, 0, &[]))).unwrap();
    assert_eq!(h.status, Status::Success, "the PLC's session is served");
    assert_eq!(w.reg(r::STATUS_COMMAND_OWNER), 1);
}

#[test]
fn io_datagrams_from_refused_addresses_or_for_unknown_connections_are_dropped_and_counted() {
    let mut w = world(Config {
        enip_allow: crate::config::AllowList::parse("10.0.0.50").unwrap(),
        ..Config::default()
    });
    let mut plc = plc_running(&mut w);
    let id = plc.conn.unwrap().o_t_id;
    let refused0 = w.reg(r::STATUS_ENIP_REFUSED);
    // A forged datagram for the owner's connection, with Execute high and a
    // move, from an address the list refuses: dropped unread.
    let mut forged = plc.out.clone();
    forged[output::CH0 + 2..output::CH0 + 4].copy_from_slice(&code::MOVE_REL_J.to_le_bytes());
    forged[output::CH0..output::CH0 + 2].copy_from_slice(&1u16.to_le_bytes());
    for k in 0..25u32 {
        let d = o_t_datagram(id, 1_000_000 + k, &forged);
        assert!(w
            .net
            .send_udp(SocketAddrV4::new(attacker(1), 2222), 2222, &d));
        plc.cycle(&mut w, ms(10));
    }
    assert_eq!(w.reg(r::STATUS_ENIP_REFUSED), refused0 + 25);
    assert_eq!(sent(&w, "MoveRelJ"), 0, "nothing of them applied");
    // From the PLC's own address, for connection ids nobody opened.
    for k in 0..30u32 {
        let d = o_t_datagram(id ^ (0x100 + k), 5 + k, &forged);
        assert!(w.net.send_udp(SocketAddrV4::new(LOGIX, 2222), 2222, &d));
        plc.cycle(&mut w, ms(10));
    }
    assert_eq!(w.reg(r::STATUS_ENIP_IO_DROPPED), 30);
    assert_eq!(sent(&w, "MoveRelJ"), 0);
    // The owner's connection ran on throughout, none of its datagrams
    // missed.
    assert_eq!(w.reg(r::STATUS_COMMAND_OWNER), 1);
    assert_eq!(w.reg(r::STATUS_ENIP_MISSED), 0);
    plc_moves(&mut w, &mut plc, 16);
    assert_eq!(sent(&w, "MoveRelJ"), 1);
}

#[test]
fn o_t_datagrams_missing_from_the_sequence_are_counted_per_connection_and_in_enip_missed() {
    let mut w = world(Config::default());
    let mut s = plc_running(&mut w);
    assert_eq!(w.reg(r::STATUS_ENIP_MISSED), 0);
    // Three datagrams lost on the way (the sequence jumps by 4).
    s.seq += 3;
    s.cycle(&mut w, ms(50));
    assert_eq!(w.reg(r::STATUS_ENIP_MISSED), 3);
    let o = w.model(|m| m.owner.enip_owner).unwrap();
    assert_eq!(o.missed, 3);
    assert!(o.received >= 9, "{o:?}");
    // A duplicate (stale) is dropped and counted, not missed.
    let c = s.conn.unwrap();
    let d = o_t_datagram(c.o_t_id, s.seq, &s.out);
    assert!(w.net.send_udp(SocketAddrV4::new(LOGIX, 2222), 2222, &d));
    s.cycle(&mut w, ms(20));
    assert_eq!(w.reg(r::STATUS_ENIP_MISSED), 3);
    assert_eq!(w.reg(r::STATUS_ENIP_IO_DROPPED), 1);
}
