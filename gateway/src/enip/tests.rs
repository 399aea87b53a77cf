//! The adapter in the gateway, in virtual time: the real gateway future on
//! the simulated network with the scripted robot (`crate::testkit`), and a
//! scanner written here with `hans-enip`'s own emitters (the scanners
//! nobody here wrote are scripts/enip-tests.sh's). What is tested is the
//! gateway's side: the assemblies as a view of the state, the ownership
//! rule between Modbus and EtherNet/IP, and a class 1 timeout as a lost
//! heartbeat.

extern crate std;

use core::net::{Ipv4Addr, SocketAddrV4};
use std::vec;
use std::vec::Vec;

use embassy_time::Duration;
use hans_enip::wire::cip::{GeneralStatus, Request, ResponseHeader, Service};
use hans_enip::wire::conn_mgr::{
    ConnectionType, ExtendedStatus, ForwardClose, ForwardOpen, ForwardOpenReply, NetParams,
    Transport, Triad,
};
use hans_enip::wire::cpf::{Cpf, CpfWriter, ItemType};
use hans_enip::wire::encap::{Command, Header, Status, HEADER_LEN};
use hans_enip::wire::io::IoPacket;
use hans_enip::wire::session::SendDataRepr;
use hans_enip::wire::Writer;

use super::assembly::{input, output, CONFIG, INPUT, OUTPUT, SIZE};
use crate::config::{Config, WatchdogAction};
use crate::error::GatewayError;
use crate::job::code;
use crate::registers as r;
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

/// A scanner's side: its TCP session, its connection, its output image.
struct Scanner {
    tcp: SimStream,
    session: u32,
    conn: Option<ForwardOpenReply>,
    seq: u32,
    out: Vec<u8>,
}

fn encap(command: Command, session: u32, data: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; HEADER_LEN + data.len()];
    Header {
        command,
        length: data.len() as u16,
        session,
        status: Status::Success,
        context: *b"gw-test!",
        options: 0,
    }
    .emit(&mut out)
    .unwrap();
    out[HEADER_LEN..].copy_from_slice(data);
    out
}

fn rr_data(request: &[u8]) -> Vec<u8> {
    let mut buf = vec![0u8; 1024];
    let mut w = Writer::new(&mut buf);
    SendDataRepr::emit_prefix(0, 10, &mut w).unwrap();
    let mut c = CpfWriter::begin(&mut w).unwrap();
    c.item(&mut w, ItemType::NullAddress, &[]).unwrap();
    c.item(&mut w, ItemType::UnconnectedData, request).unwrap();
    let n = w.len();
    buf.truncate(n);
    buf
}

fn mr(service: Service, path: &[u8], data: &[u8]) -> Vec<u8> {
    let mut buf = vec![0u8; 1024];
    let mut w = Writer::new(&mut buf);
    Request {
        service,
        path,
        data,
    }
    .emit(&mut w)
    .unwrap();
    let n = w.len();
    buf.truncate(n);
    buf
}

const CM_PATH: [u8; 4] = [0x20, 0x06, 0x24, 0x01];

fn p2p(size: u16) -> NetParams {
    NetParams {
        redundant_owner: false,
        kind: ConnectionType::PointToPoint,
        priority: 2,
        variable: false,
        size,
    }
}

fn triad(serial: u16) -> Triad {
    Triad {
        serial,
        vendor: 0x0001,
        originator_serial: 0x0BAD_CAFE,
    }
}

impl Scanner {
    /// Connects from `ip` and registers a session.
    fn connect(w: &mut World, ip: Ipv4Addr) -> Scanner {
        let tcp = w
            .net
            .connect(SocketAddrV4::new(ip, 40_000), 44818)
            .expect("the adapter listens");
        let mut s = Scanner {
            tcp,
            session: 0,
            conn: None,
            seq: 0,
            out: vec![0; SIZE],
        };
        let reply = s.exchange(w, &encap(Command::RegisterSession, 0, &[1, 0, 0, 0]));
        let h = Header::parse(&reply).unwrap();
        assert_eq!(h.status, Status::Success);
        s.session = h.session;
        s
    }

    /// Sends an encapsulation packet; its reply, whole.
    fn exchange(&mut self, w: &mut World, packet: &[u8]) -> Vec<u8> {
        self.tcp.write(packet);
        let mut got = Vec::new();
        let done = w.run_until_cond(ms(2000), |_| {
            got.extend(self.tcp.read());
            Header::parse(&got).is_ok_and(|h| got.len() >= HEADER_LEN + h.length as usize)
        });
        assert!(done, "no reply");
        got
    }

    /// An explicit request; its response header and data.
    fn ask(&mut self, w: &mut World, request: &[u8]) -> (ResponseHeader, Vec<u8>) {
        let packet = encap(Command::SendRrData, self.session, &rr_data(request));
        let reply = self.exchange(w, &packet);
        let sd = SendDataRepr::parse(&reply[HEADER_LEN..]).unwrap();
        let cpf = Cpf::parse(sd.cpf).unwrap();
        let item = cpf.get(1).unwrap();
        let (h, data) = ResponseHeader::parse(item.data).unwrap();
        (h, data.to_vec())
    }

    /// An exclusive-owner Forward_Open at 10 ms RPI, multiplier x16
    /// (timeout 160 ms); its response header.
    fn open(&mut self, w: &mut World, serial: u16) -> ResponseHeader {
        let path = [
            0x20,
            0x04,
            0x24,
            CONFIG as u8,
            0x2C,
            OUTPUT as u8,
            0x2C,
            INPUT as u8,
        ];
        let fo = ForwardOpen {
            large: false,
            priority_tick: 0x0A,
            timeout_ticks: 0x0E,
            o_t_id: 0,
            t_o_id: 0x7000_0000 + u32::from(serial),
            triad: triad(serial),
            multiplier: 2,
            o_t_rpi: 10_000,
            o_t_params: p2p(SIZE as u16 + 6),
            t_o_rpi: 10_000,
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
        let (h, data) = self.ask(w, &mr(Service::ForwardOpen, &CM_PATH, &buf[..n]));
        if h.status == GeneralStatus::Success {
            self.conn = Some(ForwardOpenReply::parse(&data).unwrap());
        }
        h
    }

    fn close(&mut self, w: &mut World) {
        let c = self.conn.take().expect("open");
        let fc = ForwardClose {
            priority_tick: 0x0A,
            timeout_ticks: 0x0E,
            triad: c.triad,
            path: &[0x20, 0x04, 0x24, CONFIG as u8],
        };
        let mut buf = vec![0u8; 64];
        let mut wr = Writer::new(&mut buf);
        fc.emit(&mut wr).unwrap();
        let n = wr.len();
        let (h, _) = self.ask(w, &mr(Service::ForwardClose, &CM_PATH, &buf[..n]));
        assert_eq!(h.status, GeneralStatus::Success, "{h:?}");
    }

    /// Sends one O->T datagram (Run) with the output image.
    fn produce(&mut self, w: &mut World) {
        let c = self.conn.expect("open");
        self.seq = self.seq.wrapping_add(1);
        let mut payload = Vec::from(1u32.to_le_bytes());
        payload.extend_from_slice(&self.out);
        let mut buf = vec![0u8; 600];
        let mut wr = Writer::new(&mut buf);
        IoPacket {
            connection_id: c.o_t_id,
            sequence: self.seq,
            sequence_count: self.seq as u16,
            data: &payload,
        }
        .emit(&mut wr)
        .unwrap();
        let n = wr.len();
        let from = SocketAddrV4::new(LOGIX, 2222);
        assert!(w.net.send_udp(from, 2222, &buf[..n]));
    }

    /// Runs `d` producing every 10 ms; the last input image received.
    fn cycle(&mut self, w: &mut World, d: Duration) -> Vec<u8> {
        let end = w.now() + d;
        let mut last = Vec::new();
        while w.now() < end {
            self.produce(w);
            w.run_for(ms(10));
            for (_, bytes) in w.net.recv_udp(SocketAddrV4::new(LOGIX, 2222)) {
                let p = IoPacket::parse(&bytes).unwrap();
                last = p.data.to_vec();
            }
        }
        last
    }

    /// Cycles until the input's channel 0 status is no longer Busy.
    fn until_ended(&mut self, w: &mut World, limit: Duration) -> u16 {
        let end = w.now() + limit;
        while w.now() < end {
            let i = self.cycle(w, ms(10));
            let s = u16_at(&i, input::CH0);
            if s != 0 && s & r::ST_BUSY == 0 {
                return s;
            }
        }
        panic!("still busy after {limit:?}");
    }

    fn put_u16(&mut self, at: usize, v: u16) {
        self.out[at..at + 2].copy_from_slice(&v.to_le_bytes());
    }

    fn put_real(&mut self, at: usize, v: f32) {
        self.out[at..at + 4].copy_from_slice(&v.to_le_bytes());
    }

    /// Channel 0: code, sequence, parameters; Execute low.
    fn command(&mut self, code: u16, seq: u16, params: &[f32]) {
        self.put_u16(output::CH0, 0);
        self.put_u16(output::CH0 + 2, code);
        self.put_u16(output::CH0 + 4, seq);
        for (i, p) in params.iter().enumerate() {
            self.put_real(output::CH0 + 8 + 4 * i, *p);
        }
    }

    fn execute(&mut self, on: bool) {
        self.put_u16(output::CH0, u16::from(on));
    }
}

fn u16_at(d: &[u8], at: usize) -> u16 {
    u16::from_le_bytes([d[at], d[at + 1]])
}

fn i32_at(d: &[u8], at: usize) -> i32 {
    i32::from_le_bytes([d[at], d[at + 1], d[at + 2], d[at + 3]])
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
    s.close(&mut w);
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
    s.close(&mut w);
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
    s.close(&mut w);
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
