//! An EtherNet/IP scanner on the simulated network (feature `enip`): a
//! Logix PLC's side of a TCP session, an exclusive-owner class 1
//! connection and its output image, written with `hans-enip`'s own
//! emitters (the scanners nobody here wrote are scripts/enip-tests.sh's).
//! The gateway's tests (`crate::enip`) and the deterministic simulation
//! drive the adapter with it.

extern crate std;

use core::net::{Ipv4Addr, SocketAddrV4};
use std::vec;
use std::vec::Vec;

use embassy_time::Duration;
use hans_enip::wire::cip::{GeneralStatus, Request, ResponseHeader, Service};
use hans_enip::wire::conn_mgr::{
    ConnectionType, ForwardClose, ForwardOpen, ForwardOpenReply, NetParams, Transport, Triad,
};
use hans_enip::wire::cpf::{Cpf, CpfWriter, ItemType};
use hans_enip::wire::encap::{Command, Header, Status, HEADER_LEN};
use hans_enip::wire::io::IoPacket;
use hans_enip::wire::session::SendDataRepr;
use hans_enip::wire::Writer;

use super::net::SimStream;
use super::world::World;
use crate::enip::assembly::{input, output, CONFIG, INPUT, OUTPUT, SIZE};
use crate::registers as r;

/// The adapter's encapsulation port in the world.
pub const PORT: u16 = 44818;
/// The class 1 I/O port.
pub const IO_PORT: u16 = 2222;
/// The Connection Manager's path (class 6, instance 1).
pub const CM_PATH: [u8; 4] = [0x20, 0x06, 0x24, 0x01];

fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}

/// An encapsulation packet: `command` for `session` with `data`.
pub fn encap(command: Command, session: u32, data: &[u8]) -> Vec<u8> {
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

/// SendRRData's data: an unconnected `request` (null address item).
pub fn rr_data(request: &[u8]) -> Vec<u8> {
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

/// A Message Router request.
pub fn mr(service: Service, path: &[u8], data: &[u8]) -> Vec<u8> {
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

/// Point-to-point network parameters of `size` bytes.
pub fn p2p(size: u16) -> NetParams {
    NetParams {
        redundant_owner: false,
        kind: ConnectionType::PointToPoint,
        priority: 2,
        variable: false,
        size,
    }
}

/// The connection triad of this scanner's connection `serial`.
pub fn triad(serial: u16) -> Triad {
    Triad {
        serial,
        vendor: 0x0001,
        originator_serial: 0x0BAD_CAFE,
    }
}

/// An O->T datagram (Run) for connection `id`, sequence `seq`, with the
/// output image `out`.
pub fn o_t_datagram(id: u32, seq: u32, out: &[u8]) -> Vec<u8> {
    let mut payload = Vec::from(1u32.to_le_bytes());
    payload.extend_from_slice(out);
    let mut buf = vec![0u8; 600];
    let mut wr = Writer::new(&mut buf);
    IoPacket {
        connection_id: id,
        sequence: seq,
        sequence_count: seq as u16,
        data: &payload,
    }
    .emit(&mut wr)
    .unwrap();
    let n = wr.len();
    buf.truncate(n);
    buf
}

/// A UINT of an assembly image.
pub fn u16_at(d: &[u8], at: usize) -> u16 {
    assert!(
        d.len() >= at + 2,
        "no input image: no T->O datagram came (the connection is gone)"
    );
    u16::from_le_bytes([d[at], d[at + 1]])
}

/// A DINT of an assembly image.
pub fn i32_at(d: &[u8], at: usize) -> i32 {
    i32::from_le_bytes([d[at], d[at + 1], d[at + 2], d[at + 3]])
}

/// A scanner's side: its TCP session, its connection, its output image.
pub struct Scanner {
    /// Its address.
    pub ip: Ipv4Addr,
    /// The TCP session.
    pub tcp: SimStream,
    /// The session handle.
    pub session: u32,
    /// The open exclusive-owner connection.
    pub conn: Option<ForwardOpenReply>,
    /// The last O->T sequence number sent.
    pub seq: u32,
    /// The output image (assembly 150).
    pub out: Vec<u8>,
}

impl Scanner {
    /// Connects from `ip` and registers a session.
    pub fn connect(w: &mut World, ip: Ipv4Addr) -> Scanner {
        let tcp = w
            .net
            .connect(SocketAddrV4::new(ip, 40_000), PORT)
            .expect("the adapter listens");
        let mut s = Scanner {
            ip,
            tcp,
            session: 0,
            conn: None,
            seq: 0,
            out: vec![0; SIZE],
        };
        s.register(w);
        s
    }

    fn register(&mut self, w: &mut World) {
        let reply = self.exchange(w, &encap(Command::RegisterSession, 0, &[1, 0, 0, 0]));
        let h = Header::parse(&reply).unwrap();
        assert_eq!(h.status, Status::Success);
        self.session = h.session;
    }

    /// A new TCP session if the gateway closed this one (an idle session
    /// is closed after 120 s; a class 1 connection does not end with it).
    pub fn ensure_session(&mut self, w: &mut World) {
        if !self.tcp.is_open() {
            self.tcp = w
                .net
                .connect(SocketAddrV4::new(self.ip, 40_001), PORT)
                .expect("the adapter listens");
            self.register(w);
        }
    }

    /// Sends an encapsulation packet; its reply, whole. Taken as soon as
    /// the gateway has written it (what is due at that instant first, as
    /// `World::request` does): the time it returns at does not depend on
    /// what else the world has scheduled later.
    pub fn exchange(&mut self, w: &mut World, packet: &[u8]) -> Vec<u8> {
        w.catch_up();
        self.tcp.write(packet);
        let end = w.now() + ms(2000);
        let mut got = Vec::new();
        loop {
            w.catch_up();
            got.extend(self.tcp.read());
            if Header::parse(&got).is_ok_and(|h| got.len() >= HEADER_LEN + h.length as usize) {
                return got;
            }
            assert!(w.turn(end), "no reply");
        }
    }

    /// An explicit request; its response header and data.
    pub fn ask(&mut self, w: &mut World, request: &[u8]) -> (ResponseHeader, Vec<u8>) {
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
    pub fn open(&mut self, w: &mut World, serial: u16) -> ResponseHeader {
        self.open_at(w, serial, 10_000, 2)
    }

    /// An exclusive-owner Forward_Open at `rpi_us`, timeout multiplier
    /// `mult` (timeout RPI x 4 << mult); its response header. The sequence
    /// starts again.
    pub fn open_at(&mut self, w: &mut World, serial: u16, rpi_us: u32, mult: u8) -> ResponseHeader {
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
            multiplier: mult,
            o_t_rpi: rpi_us,
            o_t_params: p2p(SIZE as u16 + 6),
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
        let (h, data) = self.ask(w, &mr(Service::ForwardOpen, &CM_PATH, &buf[..n]));
        if h.status == GeneralStatus::Success {
            self.conn = Some(ForwardOpenReply::parse(&data).unwrap());
            self.seq = 0;
        }
        h
    }

    /// Forward_Close of the open connection; its response header.
    pub fn close(&mut self, w: &mut World) -> ResponseHeader {
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
        self.ask(w, &mr(Service::ForwardClose, &CM_PATH, &buf[..n]))
            .0
    }

    /// Sends one O->T datagram (Run) with the output image.
    pub fn produce(&mut self, w: &mut World) {
        let c = self.conn.expect("open");
        self.seq = self.seq.wrapping_add(1);
        let d = o_t_datagram(c.o_t_id, self.seq, &self.out);
        let from = SocketAddrV4::new(self.ip, IO_PORT);
        assert!(w.net.send_udp(from, IO_PORT, &d));
    }

    /// The T->O datagrams received since the last call: the last input
    /// image, if any.
    pub fn consume(&mut self, w: &mut World) -> Option<Vec<u8>> {
        let mut last = None;
        for (_, bytes) in w.net.recv_udp(SocketAddrV4::new(self.ip, IO_PORT)) {
            let p = IoPacket::parse(&bytes).unwrap();
            last = Some(p.data.to_vec());
        }
        last
    }

    /// Runs `d` producing every 10 ms; the last input image received.
    pub fn cycle(&mut self, w: &mut World, d: Duration) -> Vec<u8> {
        let end = w.now() + d;
        let mut last = Vec::new();
        while w.now() < end {
            self.produce(w);
            w.run_for(ms(10));
            if let Some(i) = self.consume(w) {
                last = i;
            }
        }
        last
    }

    /// Cycles until the input's channel 0 status is no longer Busy.
    pub fn until_ended(&mut self, w: &mut World, limit: Duration) -> u16 {
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

    /// Writes a UINT into the output image.
    pub fn put_u16(&mut self, at: usize, v: u16) {
        self.out[at..at + 2].copy_from_slice(&v.to_le_bytes());
    }

    /// Writes a REAL into the output image.
    pub fn put_real(&mut self, at: usize, v: f32) {
        self.out[at..at + 4].copy_from_slice(&v.to_le_bytes());
    }

    /// Channel `ch`'s block in the output image.
    pub fn channel(ch: u8) -> usize {
        if ch == 0 {
            output::CH0
        } else {
            output::CH1
        }
    }

    /// Channel `ch`: code, sequence, parameters; Execute low.
    pub fn command_on(&mut self, ch: u8, code: u16, seq: u16, params: &[f32]) {
        let at = Self::channel(ch);
        self.put_u16(at, 0);
        self.put_u16(at + 2, code);
        self.put_u16(at + 4, seq);
        for p in 0..12 {
            self.put_real(at + 8 + 4 * p, params.get(p).copied().unwrap_or(0.0));
        }
    }

    /// Channel `ch`'s Execute.
    pub fn execute_on(&mut self, ch: u8, on: bool) {
        self.put_u16(Self::channel(ch), u16::from(on));
    }

    /// Channel 0: code, sequence, parameters; Execute low.
    pub fn command(&mut self, code: u16, seq: u16, params: &[f32]) {
        self.command_on(0, code, seq, params);
    }

    /// Channel 0's Execute.
    pub fn execute(&mut self, on: bool) {
        self.execute_on(0, on);
    }
}
