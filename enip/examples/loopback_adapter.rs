//! A std runner for tests only: the adapter on loopback sockets, so that
//! scanners nobody here wrote (pycomm3, cpppo, ethernetip, Wireshark's
//! dissectors) can be pointed at it. Not the gateway's listener: that one
//! runs on embassy-net with the gateway's admission rules.
//!
//! ```text
//! cargo run -p hans-enip --example loopback_adapter -- \
//!     [--bind 127.0.0.1] [--port 44818] [--io-port 2222] [--seconds 120]
//! cargo run -p hans-enip --example loopback_adapter -- --eds FILE   (writes its EDS and stops)
//! ```
//! Port 0 picks a free port. It prints `listening tcp=P udp=P io=Q` first,
//! then one line per event (`opened`, `closed ... reason=TimedOut`,
//! `run`/`idle`) with the connection's counters on close, and stops after
//! `--seconds` (a bound, so that a test that forgets it cannot leave it
//! running).
//!
//! The application: input assembly 100 (32 bytes) is the output assembly
//! 150 (32 bytes) echoed, with its last byte counting the writes; 198 and
//! 199 are the input-only and listen-only heartbeat points.

use std::collections::HashMap;
use std::io::{ErrorKind, Read, Write};
use std::net::{Ipv4Addr, SocketAddr, TcpListener, TcpStream, UdpSocket};
use std::time::Duration;

use hans_enip::wire::cip::GeneralStatus;
use hans_enip::*;

const INPUT: u16 = 100;
const OUTPUT: u16 = 150;
const SIZE: usize = 32;
/// The most TCP connections the runner keeps; more are closed at once.
const MAX_CLIENTS: usize = 8;

static ASSEMBLIES: [Assembly<'static>; 2] = [
    Assembly {
        instance: INPUT,
        kind: AssemblyKind::Input,
        size: SIZE as u16,
        name: "Robot to PLC",
    },
    Assembly {
        instance: OUTPUT,
        kind: AssemblyKind::Output,
        size: SIZE as u16,
        name: "PLC to robot",
    },
];
static CONNECTIONS: [IoConnection<'static>; 3] = [
    IoConnection {
        kind: ConnectionKind::ExclusiveOwner,
        o_to_t: OUTPUT,
        t_to_o: INPUT,
        config: 1,
        name: "Exclusive Owner",
    },
    IoConnection {
        kind: ConnectionKind::InputOnly,
        o_to_t: 198,
        t_to_o: INPUT,
        config: 1,
        name: "Input Only",
    },
    IoConnection {
        kind: ConnectionKind::ListenOnly,
        o_to_t: 199,
        t_to_o: INPUT,
        config: 1,
        name: "Listen Only",
    },
];
static DEVICE: Device<'static> = Device {
    assemblies: &ASSEMBLIES,
    connections: &CONNECTIONS,
};

struct Echo {
    output: [u8; SIZE],
    writes: u8,
    ip: Ipv4Addr,
    events: Vec<Event>,
}

impl Application for Echo {
    fn identity(&self) -> Identity<'_> {
        Identity {
            // 0xFFFF-style values are not assigned by ODVA: a test device.
            vendor_id: 0xFFFE,
            device_type: 0x0C,
            product_code: 0x0001,
            revision: Revision { major: 1, minor: 1 },
            status: 0,
            serial: 0x00C0_FFEE,
            product_name: "hans-enip loopback",
        }
    }
    fn tcp_ip(&self) -> TcpIpInfo<'_> {
        TcpIpInfo {
            status: 1,
            config_capability: 0,
            config_control: 0,
            ip: self.ip,
            netmask: Ipv4Addr::new(255, 0, 0, 0),
            gateway: Ipv4Addr::UNSPECIFIED,
            dns1: Ipv4Addr::UNSPECIFIED,
            dns2: Ipv4Addr::UNSPECIFIED,
            domain: "",
            host_name: "loopback",
        }
    }
    fn ethernet_link(&self) -> EthernetLinkInfo {
        EthernetLinkInfo {
            speed_mbps: 1000,
            flags: 0x03,
            mac: [0x02, 0, 0, 0, 0, 1],
        }
    }
    fn read_assembly(&mut self, instance: u16, buf: &mut [u8]) {
        buf.copy_from_slice(&self.output);
        if instance == INPUT {
            if let Some(last) = buf.last_mut() {
                *last = self.writes;
            }
        }
    }
    fn write_assembly(
        &mut self,
        _instance: u16,
        data: &[u8],
        _origin: WriteOrigin,
    ) -> Result<(), GeneralStatus> {
        self.output.copy_from_slice(data);
        self.writes = self.writes.wrapping_add(1);
        Ok(())
    }
    fn event(&mut self, event: Event) {
        self.events.push(event);
    }
}

struct Client {
    link: LinkId,
    stream: TcpStream,
    peer: Ipv4Addr,
    framer: Framer<1024>,
}

fn arg(args: &[String], name: &str, default: &str) -> String {
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .cloned()
        .unwrap_or_else(|| default.to_string())
}

fn main() -> std::io::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let bind: Ipv4Addr = arg(&args, "--bind", "127.0.0.1")
        .parse()
        .expect("--bind: an IPv4 address");
    let port: u16 = arg(&args, "--port", "44818")
        .parse()
        .expect("--port: a number");
    let io_port: u16 = arg(&args, "--io-port", "2222")
        .parse()
        .expect("--io-port: a number");
    let seconds: u64 = arg(&args, "--seconds", "120")
        .parse()
        .expect("--seconds: a number");
    assert!(bind.is_loopback(), "a test runner: loopback addresses only");
    if let Some(i) = args.iter().position(|a| a == "--eds") {
        // Write the device's EDS and stop.
        let path = args.get(i + 1).expect("--eds PATH");
        let app = Echo {
            output: [0; SIZE],
            writes: 0,
            ip: bind,
            events: Vec::new(),
        };
        let identity = app.identity();
        let mut info = hans_enip::eds::EdsInfo::new(&identity, &DEVICE, "hans-enip tests");
        info.catalog = "LOOPBACK-1";
        let mut text = String::new();
        hans_enip::eds::write_eds(&mut text, &info).expect("EDS text");
        std::fs::write(path, text)?;
        return Ok(());
    }

    // TCP and UDP on the same port number (port 0: a free one for both).
    let (listener, udp) = loop {
        let l = TcpListener::bind((bind, port))?;
        let p = l.local_addr()?.port();
        match UdpSocket::bind((bind, p)) {
            Ok(u) => break (l, u),
            Err(e) if port == 0 => eprintln!("udp {p} taken ({e}), trying another"),
            Err(e) => return Err(e),
        }
    };
    let io = UdpSocket::bind((bind, io_port))?;
    listener.set_nonblocking(true)?;
    udp.set_nonblocking(true)?;
    io.set_nonblocking(true)?;
    let tcp_port = listener.local_addr()?.port();
    let io_port = io.local_addr()?.port();
    println!("listening tcp={tcp_port} udp={tcp_port} io={io_port}");

    let config = Config {
        encap_port: tcp_port,
        io_port: 2222,
        seed: std::process::id() | 1,
        ..Config::default()
    };
    let mut adapter: Adapter<'_, 8, 8> = Adapter::new(&DEVICE, config);
    let mut app = Echo {
        output: [0; SIZE],
        writes: 0,
        ip: bind,
        events: Vec::new(),
    };
    let start = std::time::Instant::now();
    let now = || Instant::from_micros(start.elapsed().as_micros() as u64);
    let mut clients: Vec<Client> = Vec::new();
    let mut next_link = 1u32;
    let mut buf = [0u8; 2048];
    let mut out = [0u8; 2048];
    let mut last_info: HashMap<u32, ConnectionInfo> = HashMap::new();

    while start.elapsed() < Duration::from_secs(seconds) {
        for info in adapter.connections() {
            last_info.insert(info.id.0, info);
        }
        // New TCP connections.
        loop {
            match listener.accept() {
                Ok((stream, SocketAddr::V4(peer))) if clients.len() < MAX_CLIENTS => {
                    stream.set_nonblocking(true)?;
                    stream.set_nodelay(true)?;
                    clients.push(Client {
                        link: LinkId(next_link),
                        stream,
                        peer: *peer.ip(),
                        framer: Framer::new(),
                    });
                    next_link += 1;
                }
                Ok(_) => {} // dropped: over the bound, or not IPv4
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(e) => return Err(e),
            }
        }
        // TCP bytes.
        let mut closed = Vec::new();
        for (i, c) in clients.iter_mut().enumerate() {
            let n = match c.stream.read(&mut buf) {
                Ok(0) => {
                    closed.push(i);
                    continue;
                }
                Ok(n) => n,
                Err(e) if e.kind() == ErrorKind::WouldBlock => continue,
                Err(_) => {
                    closed.push(i);
                    continue;
                }
            };
            let mut rest = &buf[..n];
            while !rest.is_empty() {
                let used = c.framer.push(rest);
                rest = &rest[used..];
                let Some(frame) = c.framer.frame() else {
                    continue;
                };
                match adapter.handle_tcp(c.link, c.peer, frame, now(), &mut app, &mut out) {
                    TcpAction::Reply(n) => {
                        c.stream.set_nonblocking(false)?;
                        let ok = c.stream.write_all(&out[..n]).is_ok();
                        c.stream.set_nonblocking(true)?;
                        if !ok {
                            closed.push(i);
                            break;
                        }
                    }
                    TcpAction::Close => {
                        closed.push(i);
                        break;
                    }
                    TcpAction::None => {}
                }
            }
        }
        closed.dedup();
        for i in closed.into_iter().rev() {
            let c = clients.swap_remove(i);
            adapter.tcp_closed(c.link, now(), &mut app);
        }
        // UDP 44818: discovery.
        while let Ok((n, _from)) = udp.recv_from(&mut buf) {
            if let Some(m) = adapter.handle_udp(&buf[..n], &mut app, &mut out) {
                let _ = udp.send_to(&out[..m], _from);
            }
        }
        // UDP 2222: class 1 data.
        while let Ok((n, from)) = io.recv_from(&mut buf) {
            if let SocketAddr::V4(from) = from {
                let r = adapter.handle_io(from, &buf[..n], now(), &mut app);
                if r != IoOutcome::Consumed {
                    let seq = hans_enip::wire::io::IoPacket::parse(&buf[..n])
                        .map(|p| (p.connection_id, p.sequence));
                    println!("io dropped {r:?} from {from}: (id, sequence) {seq:x?}");
                }
            }
        }
        // Remember the counters, so that a close can report them.
        for info in adapter.connections() {
            last_info.insert(info.id.0, info);
        }
        // Timeouts and T->O production.
        while let Some((dest, n)) = adapter.poll(now(), &mut app, &mut out) {
            let _ = io.send_to(&out[..n], SocketAddr::V4(dest));
        }
        for e in app.events.drain(..) {
            report(&e, &last_info, &adapter);
        }
        // Sleep until the next deadline, 0.5 ms at most (the sockets are polled).
        let wait = adapter.poll_at().map_or(500, |t| {
            t.as_micros().saturating_sub(now().as_micros()).min(500)
        });
        std::thread::sleep(Duration::from_micros(wait.max(50)));
    }
    println!("stopped after {seconds} s");
    Ok(())
}

fn report(e: &Event, last: &HashMap<u32, ConnectionInfo>, adapter: &Adapter<'_, 8, 8>) {
    match e {
        Event::Opened {
            connection, kind, ..
        } => {
            let info = adapter.connections().find(|c| c.id == *connection);
            let rpi = info.map_or(0, |i| i.t_o_rpi_us);
            println!(
                "opened id={:#010x} kind={kind:?} rpi_us={rpi}",
                connection.0
            );
        }
        Event::Closed {
            connection,
            kind,
            reason,
        } => {
            let (r, m, p) = last
                .get(&connection.0)
                .map_or((0, 0, 0), |i| (i.received, i.missed, i.produced));
            println!(
                "closed id={:#010x} kind={kind:?} reason={reason:?} received={r} missed={m} produced={p}",
                connection.0
            );
        }
        Event::RunIdle { connection, run } => {
            println!(
                "{} id={:#010x}",
                if *run { "run" } else { "idle" },
                connection.0
            );
        }
    }
    use std::io::Write as _;
    let _ = std::io::stdout().flush();
}
