//! A test application, a device, and a scanner's side of the protocol
//! written with the crate's own emitters (the independent checks against
//! other implementations are in scripts/enip-tests.sh).
#![allow(dead_code)]

use core::net::{Ipv4Addr, SocketAddrV4};

use hans_enip::wire::cip::{GeneralStatus, Request, ResponseHeader, Service};
use hans_enip::wire::conn_mgr::{
    ConnectionType, ForwardClose, ForwardOpen, NetParams, Transport, Triad,
};
use hans_enip::wire::cpf::{Cpf, CpfWriter, ItemType, Sockaddr};
use hans_enip::wire::encap::{Command, Header, Status, HEADER_LEN};
use hans_enip::wire::session::SendDataRepr;
use hans_enip::wire::Writer;
use hans_enip::*;

pub const INPUT: u16 = 100;
pub const OUTPUT: u16 = 150;
pub const CONFIG: u16 = 151;
pub const HEARTBEAT_IN: u16 = 198;
pub const HEARTBEAT_LISTEN: u16 = 199;
pub const SIZE: u16 = 8;

pub static ASSEMBLIES: [Assembly<'static>; 3] = [
    Assembly {
        instance: INPUT,
        kind: AssemblyKind::Input,
        size: SIZE,
        name: "Inputs",
    },
    Assembly {
        instance: OUTPUT,
        kind: AssemblyKind::Output,
        size: SIZE,
        name: "Outputs",
    },
    Assembly {
        instance: CONFIG,
        kind: AssemblyKind::Config,
        size: 4,
        name: "Config",
    },
];
pub static CONNECTIONS: [IoConnection<'static>; 3] = [
    IoConnection {
        kind: ConnectionKind::ExclusiveOwner,
        o_to_t: OUTPUT,
        t_to_o: INPUT,
        config: CONFIG,
        name: "Exclusive Owner",
    },
    IoConnection {
        kind: ConnectionKind::InputOnly,
        o_to_t: HEARTBEAT_IN,
        t_to_o: INPUT,
        config: CONFIG,
        name: "Input Only",
    },
    IoConnection {
        kind: ConnectionKind::ListenOnly,
        o_to_t: HEARTBEAT_LISTEN,
        t_to_o: INPUT,
        config: CONFIG,
        name: "Listen Only",
    },
];
pub static DEVICE: Device<'static> = Device {
    assemblies: &ASSEMBLIES,
    connections: &CONNECTIONS,
};

pub const VENDOR: u16 = 0xFFF0;
pub const DEVICE_TYPE: u16 = 0x0C;
pub const PRODUCT: u16 = 0x0042;

/// Input = the output last written, with byte 7 counting writes.
pub struct TestApp {
    pub output: [u8; SIZE as usize],
    pub config: [u8; 4],
    pub writes: u32,
    pub events: Vec<Event>,
    pub resets: Vec<u8>,
    pub accept_reset: bool,
}

impl TestApp {
    pub fn new() -> Self {
        TestApp {
            output: [0; 8],
            config: [0; 4],
            writes: 0,
            events: Vec::new(),
            resets: Vec::new(),
            accept_reset: false,
        }
    }
}

impl Application for TestApp {
    fn identity(&self) -> Identity<'_> {
        Identity {
            vendor_id: VENDOR,
            device_type: DEVICE_TYPE,
            product_code: PRODUCT,
            revision: Revision { major: 1, minor: 3 },
            status: 0x0004,
            serial: 0x1234_5678,
            product_name: "Hans EtherNet/IP test",
        }
    }
    fn tcp_ip(&self) -> TcpIpInfo<'_> {
        TcpIpInfo {
            status: 1,
            config_capability: 0x04,
            config_control: 0,
            ip: Ipv4Addr::new(192, 168, 1, 50),
            netmask: Ipv4Addr::new(255, 255, 255, 0),
            gateway: Ipv4Addr::new(192, 168, 1, 1),
            dns1: Ipv4Addr::new(192, 168, 1, 2),
            dns2: Ipv4Addr::UNSPECIFIED,
            domain: "plant.local",
            host_name: "hans-gw",
        }
    }
    fn ethernet_link(&self) -> EthernetLinkInfo {
        EthernetLinkInfo {
            speed_mbps: 100,
            flags: 0x0F,
            mac: [0x02, 0, 0, 0x12, 0x34, 0x56],
        }
    }
    fn read_assembly(&mut self, instance: u16, buf: &mut [u8]) {
        match instance {
            INPUT | OUTPUT => {
                buf.copy_from_slice(&self.output);
                if instance == INPUT {
                    buf[7] = self.writes as u8;
                }
            }
            CONFIG => buf.copy_from_slice(&self.config),
            _ => panic!("read of {instance}"),
        }
    }
    fn write_assembly(
        &mut self,
        instance: u16,
        data: &[u8],
        _origin: WriteOrigin,
    ) -> Result<(), GeneralStatus> {
        match instance {
            OUTPUT => self.output.copy_from_slice(data),
            CONFIG => self.config.copy_from_slice(data),
            _ => panic!("write of {instance}"),
        }
        self.writes += 1;
        Ok(())
    }
    fn event(&mut self, event: Event) {
        self.events.push(event);
    }
    fn reset(&mut self, kind: u8) -> bool {
        self.resets.push(kind);
        self.accept_reset
    }
}

pub const PEER: Ipv4Addr = Ipv4Addr::new(127, 0, 0, 2);

pub type TestAdapter = Adapter<'static, 2, 3>;

pub fn adapter() -> TestAdapter {
    Adapter::new(&DEVICE, Config::default())
}

/// An encapsulation packet.
pub fn encap(command: Command, session: u32, data: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; HEADER_LEN + data.len()];
    Header {
        command,
        length: data.len() as u16,
        session,
        status: Status::Success,
        context: *b"testctx!",
        options: 0,
    }
    .emit(&mut out)
    .unwrap();
    out[HEADER_LEN..].copy_from_slice(data);
    out
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

/// SendRRData's data around a request, with optional extra items.
pub fn rr_data(request: &[u8], t_o: Option<SocketAddrV4>) -> Vec<u8> {
    let mut buf = vec![0u8; 2048];
    let mut w = Writer::new(&mut buf);
    SendDataRepr::emit_prefix(0, 10, &mut w).unwrap();
    let mut c = CpfWriter::begin(&mut w).unwrap();
    c.item(&mut w, ItemType::NullAddress, &[]).unwrap();
    c.item(&mut w, ItemType::UnconnectedData, request).unwrap();
    if let Some(a) = t_o {
        c.item_with::<hans_enip::wire::Error>(&mut w, ItemType::SockaddrTO, |w| {
            Sockaddr { addr: a }.emit(w)
        })
        .unwrap();
    }
    let n = w.len();
    buf.truncate(n);
    buf
}

/// Feeds a byte stream through a framer into the adapter; the replies.
pub fn feed<const S: usize, const C: usize>(
    a: &mut Adapter<'static, S, C>,
    link: u32,
    bytes: &[u8],
    now: Instant,
    app: &mut TestApp,
) -> Vec<Result<Vec<u8>, TcpAction>> {
    let mut framer = Framer::<600>::new();
    let mut out = Vec::new();
    let mut rest = bytes;
    while !rest.is_empty() {
        let n = framer.push(rest);
        rest = &rest[n..];
        if let Some(frame) = framer.frame() {
            let mut buf = [0u8; 1024];
            match a.handle_tcp(LinkId(link), PEER, frame, now, app, &mut buf) {
                TcpAction::Reply(n) => out.push(Ok(buf[..n].to_vec())),
                other => out.push(Err(other)),
            }
        }
    }
    out
}

/// One request, one reply expected.
pub fn one<const S: usize, const C: usize>(
    a: &mut Adapter<'static, S, C>,
    link: u32,
    bytes: &[u8],
    now: Instant,
    app: &mut TestApp,
) -> Vec<u8> {
    let mut r = feed(a, link, bytes, now, app);
    assert_eq!(r.len(), 1, "one reply expected");
    r.remove(0).expect("a reply")
}

/// Registers a session on `link`; its handle.
pub fn register<const S: usize, const C: usize>(
    a: &mut Adapter<'static, S, C>,
    link: u32,
    app: &mut TestApp,
) -> u32 {
    let r = one(
        a,
        link,
        &encap(Command::RegisterSession, 0, &[1, 0, 0, 0]),
        Instant::ZERO,
        app,
    );
    let h = Header::parse(&r).unwrap();
    assert_eq!(h.status, Status::Success);
    assert_ne!(h.session, 0);
    h.session
}

/// The Message Router response inside a SendRRData reply.
pub fn rr_response(reply: &[u8]) -> (ResponseHeader, Vec<u8>) {
    let h = Header::parse(reply).unwrap();
    assert_eq!(h.status, Status::Success, "encapsulation status");
    assert_eq!(h.length as usize, reply.len() - HEADER_LEN);
    assert_eq!(h.context, *b"testctx!");
    let sd = SendDataRepr::parse(&reply[HEADER_LEN..]).unwrap();
    let cpf = Cpf::parse(sd.cpf).unwrap();
    assert_eq!(cpf.get(0).unwrap().kind, ItemType::NullAddress);
    let item = cpf.get(1).unwrap();
    assert_eq!(item.kind, ItemType::UnconnectedData);
    let (rh, data) = ResponseHeader::parse(item.data).unwrap();
    (rh, data.to_vec())
}

/// Sends one explicit request on a registered session; its response.
pub fn ask<const S: usize, const C: usize>(
    a: &mut Adapter<'static, S, C>,
    link: u32,
    session: u32,
    request: &[u8],
    now: Instant,
    app: &mut TestApp,
) -> (ResponseHeader, Vec<u8>) {
    let r = one(
        a,
        link,
        &encap(Command::SendRrData, session, &rr_data(request, None)),
        now,
        app,
    );
    rr_response(&r)
}

pub fn p2p(size: u16) -> NetParams {
    NetParams {
        redundant_owner: false,
        kind: ConnectionType::PointToPoint,
        priority: 2,
        variable: false,
        size,
    }
}

pub const CM_PATH: [u8; 4] = [0x20, 0x06, 0x24, 0x01];

/// A class 1 exclusive-owner Forward_Open at `rpi` us.
pub fn fo_owner(serial: u16, rpi: u32, multiplier: u8) -> ForwardOpen<'static> {
    ForwardOpen {
        large: false,
        priority_tick: 0x0A,
        timeout_ticks: 0x0E,
        o_t_id: 0,
        t_o_id: 0x7000_0000 + u32::from(serial),
        triad: Triad {
            serial,
            vendor: 0x0001,
            originator_serial: 0x0BAD_CAFE,
        },
        multiplier,
        o_t_rpi: rpi,
        o_t_params: p2p(SIZE + 6),
        t_o_rpi: rpi,
        t_o_params: p2p(SIZE + 2),
        transport: Transport {
            server: false,
            trigger: 0,
            class: 1,
        },
        path: &[
            0x20,
            0x04,
            0x24,
            CONFIG as u8,
            0x2C,
            OUTPUT as u8,
            0x2C,
            INPUT as u8,
        ],
    }
}

pub fn fo_request(fo: &ForwardOpen<'_>) -> Vec<u8> {
    let mut buf = vec![0u8; 512];
    let mut w = Writer::new(&mut buf);
    fo.emit(&mut w).unwrap();
    let n = w.len();
    let service = if fo.large {
        Service::LargeForwardOpen
    } else {
        Service::ForwardOpen
    };
    mr(service, &CM_PATH, &buf[..n])
}

pub fn fc_request(triad: Triad) -> Vec<u8> {
    let fc = ForwardClose {
        priority_tick: 0x0A,
        timeout_ticks: 0x0E,
        triad,
        path: &[0x20, 0x04, 0x24, 0x97],
    };
    let mut buf = vec![0u8; 64];
    let mut w = Writer::new(&mut buf);
    fc.emit(&mut w).unwrap();
    let n = w.len();
    mr(Service::ForwardClose, &CM_PATH, &buf[..n])
}

/// An O->T datagram of an exclusive owner.
pub fn o_t(id: u32, seq: u32, count: u16, run: bool, data: &[u8]) -> Vec<u8> {
    let mut payload = Vec::from((run as u32).to_le_bytes());
    payload.extend_from_slice(data);
    let mut buf = vec![0u8; 600];
    let mut w = Writer::new(&mut buf);
    hans_enip::wire::io::IoPacket {
        connection_id: id,
        sequence: seq,
        sequence_count: count,
        data: &payload,
    }
    .emit(&mut w)
    .unwrap();
    let n = w.len();
    buf.truncate(n);
    buf
}

pub fn from_peer() -> SocketAddrV4 {
    SocketAddrV4::new(PEER, 2222)
}

pub fn ok(h: &ResponseHeader) {
    assert_eq!(h.status, GeneralStatus::Success, "{h:?}");
}
