//! The EtherNet/IP adapter (feature `enip`): a Rockwell Logix PLC (or any
//! EtherNet/IP scanner) drives the robot through two I/O assemblies, with
//! the same handshakes, queue and rules as a Modbus PLC. The protocol is
//! the crate `hans-enip` (sans-IO); this module is its listener on the
//! gateway's sockets and its application over the gateway's state. The
//! PLC programmer's document is `ENIP.md` beside this crate's
//! `Cargo.toml`; the EDS file `hans-gateway.eds` beside it is written from
//! the same definitions (a test fails when they differ).
//!
//! | file | what |
//! |---|---|
//! | `assembly.rs` | the assemblies' layout, and the view: input encoded from the state, output decoded into the PLC's inputs and their edges |
//! | `app.rs` | the adapter's application: identity, interface values, the events (ownership, a lost heartbeat) |
//! | here | the listener: TCP 44818 sessions through `crate::admission`, UDP 44818 discovery, UDP 2222 class 1 I/O and the adapter's clock |
//!
//! ## Rules
//! * Off until `enip.enabled` is set (page, TOML file; at the next start);
//!   Linux serves it only where `--enip-listen` says.
//! * Who may talk: `enip.allow`, checked before anything is read:
//!   at accept for TCP, per datagram for UDP (a refused datagram is
//!   dropped unparsed and counted in `ENIP_REFUSED`). Applying a new list
//!   closes the TCP sessions it no longer permits; a class 1 connection
//!   from a refused address then times out (its datagrams are dropped).
//! * Admission as every listener (`crate::admission`'s `Slots`): [`SESSIONS`] TCP sessions
//!   on [`SOCKETS`] sockets, [`PER_ADDRESS`] from one address, idle ones
//!   taken by newcomers after [`EVICT_IDLE`], an encapsulation packet
//!   whole within [`FRAME_DEADLINE`] of its first byte, a silent session
//!   closed after [`IDLE_TIMEOUT`].
//! * Connections: [`CONNECTIONS`] in all, [`app::PER_ORIGINATOR`] per
//!   originator; one that never sends is freed after
//!   [`FIRST_PACKET_TIMEOUT_US`]. Discovery replies at most
//!   [`DISCOVERY_PER_SECOND`] a second (the rest dropped): the port cannot
//!   be used to amplify a flood toward a forged address.
//! * Configuration: EtherNet/IP changes none (no setting is reachable
//!   through it: the TCP/IP and Ethernet Link objects are read-only, the
//!   Identity's Reset is refused), so the write protection has nothing to
//!   guard here.
//! * Who owns the command inputs, and a lost heartbeat: `crate::state::owner`,
//!   `crate::plc`, ENIP.md.

pub mod app;
pub mod assembly;

use core::cell::RefCell;
use core::convert::Infallible;
use core::net::{Ipv4Addr, SocketAddrV4};
use core::pin::pin;

use embassy_futures::join::{join, join4};
use embassy_futures::select::{select, select3, Either, Either3};
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::signal::Signal;
use embassy_time::{Duration, Instant};
use hans_enip::{
    Adapter, Assembly, AssemblyKind, ConnectionKind, Device, Frame, Framer, IoConnection,
    IoOutcome, LinkId, TcpAction,
};

use crate::admission::{self, octets, Limits, Refusal};
use crate::clock::{with_deadline, Clock};
use crate::hub::Hub;
use crate::net::{Net, Socket, UdpBuffers, UdpSocket, PACKET_META};
use app::App;
use assembly::{CONFIG, INPUT, INPUT_ONLY, LISTEN_ONLY, OUTPUT, SIZE};

/// How a platform runs the adapter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EnipOptions {
    /// The encapsulation protocol's port, TCP and UDP (44818).
    pub port: u16,
    /// The class 1 I/O port, UDP (2222).
    pub io_port: u16,
    /// The Identity object's serial number: unique per device (boards:
    /// the last four bytes of the MAC address).
    pub serial: u32,
    /// The MAC address the Ethernet Link object reports.
    pub mac: [u8; 6],
    /// The address the TCP/IP Interface object reports where the platform
    /// does not manage the network (Linux: the listen address); boards
    /// report their configured address.
    pub ip: Ipv4Addr,
}

impl Default for EnipOptions {
    fn default() -> Self {
        EnipOptions {
            port: 44818,
            io_port: 2222,
            serial: 1,
            mac: [0x02, 0, 0, 0, 0, 1],
            ip: Ipv4Addr::UNSPECIFIED,
        }
    }
}

/// TCP sessions served at once (a PLC, a configuration tool, a browse).
pub const SESSIONS: usize = 3;
/// Sockets: one more than [`SESSIONS`], so that one always accepts a
/// newcomer (which may then take an idle session's slot).
pub const SOCKETS: usize = SESSIONS + 1;
/// Sessions from one address.
pub const PER_ADDRESS: usize = 2;
/// Class 1 and class 3 connections at once: an exclusive owner, an
/// input-only and a listen-only one (an HMI, a second PLC watching), and
/// one class 3.
pub const CONNECTIONS: usize = 4;
/// An encapsulation packet must be whole this long after its first byte
/// (600 bytes at most: one segment, as a Modbus frame).
pub const FRAME_DEADLINE: Duration = Duration::from_secs(1);
/// A session that has sent nothing for this long is closed (the
/// specification's encapsulation inactivity timeout, 120 s by default; a
/// Logix PLC's session is quiet while its class 1 connection runs on UDP,
/// which does not end with it).
pub const IDLE_TIMEOUT: Duration = Duration::from_secs(120);
/// A session quiet this long is idle: a newcomer may take its slot.
pub const EVICT_IDLE: Duration = Duration::from_secs(2);
/// A connection that sends nothing is freed after this (or its own
/// timeout if longer): a scanner sends its first datagram within one RPI
/// of the reply, so a half-open Forward_Open holds its slot 3 s at most.
pub const FIRST_PACKET_TIMEOUT_US: u32 = 3_000_000;
/// Discovery (UDP 44818) replies per second at most.
pub const DISCOVERY_PER_SECOND: u32 = 20;

/// The encapsulation data a session's framer holds: the largest request
/// (a Set_Attribute_Single of the output assembly, or a class 3 request
/// of 504 bytes, with their headers) fits.
const FRAME_DATA: usize = 600;
/// A reply: the input assembly read explicitly (496 bytes) with its
/// headers fits.
const REPLY: usize = 600;
/// An I/O datagram: the output assembly with its CPF and headers (540
/// bytes), and room to tell a longer one (dropped).
const IO_DATAGRAM: usize = 576;

/// The sessions' table (`crate::admission`).
pub(crate) type Slots = admission::Slots<SOCKETS, SESSIONS, PER_ADDRESS>;
/// The sessions' times.
pub(crate) const LIMITS: Limits = Limits {
    evict_idle: EVICT_IDLE,
    claim_wait: Duration::from_millis(EVICT_IDLE.as_millis() + FRAME_DEADLINE.as_millis()),
    waiting_per_address: 0,
};
/// The listener's name in log lines.
pub(crate) const NAME: &str = "enip";

/// The assemblies.
pub static ASSEMBLIES: [Assembly<'static>; 2] = [
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

/// The class 1 connections a scanner may open.
pub static IO_CONNECTIONS: [IoConnection<'static>; 3] = [
    IoConnection {
        kind: ConnectionKind::ExclusiveOwner,
        o_to_t: OUTPUT,
        t_to_o: INPUT,
        config: CONFIG,
        name: "Exclusive Owner",
    },
    IoConnection {
        kind: ConnectionKind::InputOnly,
        o_to_t: INPUT_ONLY,
        t_to_o: INPUT,
        config: CONFIG,
        name: "Input Only",
    },
    IoConnection {
        kind: ConnectionKind::ListenOnly,
        o_to_t: LISTEN_ONLY,
        t_to_o: INPUT,
        config: CONFIG,
        name: "Listen Only",
    },
];

/// The device the adapter serves and the EDS describes.
pub static DEVICE: Device<'static> = Device {
    assemblies: &ASSEMBLIES,
    connections: &IO_CONNECTIONS,
};

/// Writes the gateway's EDS file (what `hans-gateway.eds` holds).
pub fn write_eds(out: &mut impl core::fmt::Write) -> core::fmt::Result {
    let identity = app::identity(0);
    let mut info = hans_enip::eds::EdsInfo::new(&identity, &DEVICE, "hans-gateway project");
    info.catalog = "HANS-GW-ENIP";
    info.description = "Hans / Huayan Elfin robot gateway: EtherNet/IP adapter";
    info.date = (2026, 12, 1);
    info.time = (0, 0, 0);
    info.max_connections = CONNECTIONS as u16;
    info.rpi_us = (2_000, 10_000_000, 10_000);
    hans_enip::eds::write_eds(out, &info)
}

type Shared<'d> = RefCell<Adapter<'d, SESSIONS, CONNECTIONS>>;

/// The adapter's time.
fn now_of<C: Clock>(clock: &C) -> hans_enip::Instant {
    hans_enip::Instant::from_micros(clock.now().as_micros())
}

/// Runs the adapter, if it is on, until the future is dropped.
pub(crate) async fn serve<N: Net, C: Clock>(
    hub: &Hub,
    clock: &C,
    net: &N,
    opts: &EnipOptions,
    host_name: &str,
    seed: u32,
) -> Infallible {
    let enabled = hub.peek(|m| m.config.active.enip_enabled);
    if !enabled {
        info!("enip: off (enip.enabled)");
        return core::future::pending().await;
    }
    info!(
        "enip: EtherNet/IP adapter on tcp/udp {}, I/O on udp {}",
        opts.port, opts.io_port
    );
    let config = hans_enip::Config {
        encap_port: opts.port,
        first_packet_timeout_us: FIRST_PACKET_TIMEOUT_US,
        seed,
        ..hans_enip::Config::default()
    };
    let adapter: Shared<'static> = RefCell::new(Adapter::new(&DEVICE, config));
    let slots = Slots::new(NAME, &LIMITS);
    let produce = Signal::<NoopRawMutex, ()>::new();
    let ctx = Ctx {
        hub,
        clock,
        opts,
        host_name,
        adapter: &adapter,
        slots: &slots,
        produce: &produce,
    };
    let mut bufs = [[[0u8; FRAME_DATA + 40]; 2]; SOCKETS];
    let [b0, b1, b2, b3] = bufs.each_mut().map(|b| {
        let [rx, tx] = b.each_mut();
        net.socket(rx, tx)
    });
    let (s0, s1) = (pin!(session(&ctx, b0, 0)), pin!(session(&ctx, b1, 1)));
    let (s2, s3) = (pin!(session(&ctx, b2, 2)), pin!(session(&ctx, b3, 3)));
    let sessions = join4(s0, s1, s2, s3);
    let io = pin!(io(&ctx, net));
    let discovery = pin!(discovery(&ctx, net));
    let warden = pin!(warden(&ctx));
    let _ = join(sessions, join(io, join(discovery, warden))).await;
    core::future::pending().await
}

/// What the listener's futures share.
struct Ctx<'a, 'd, C: Clock> {
    hub: &'a Hub,
    clock: &'a C,
    opts: &'a EnipOptions,
    host_name: &'a str,
    adapter: &'a Shared<'d>,
    slots: &'a Slots,
    /// Wakes the I/O future: a connection opened (its production starts).
    produce: &'a Signal<NoopRawMutex, ()>,
}

impl<C: Clock> Ctx<'_, '_, C> {
    fn app(&self) -> App<'_, C> {
        App {
            hub: self.hub,
            clock: self.clock,
            opts: self.opts,
            host_name: self.host_name,
        }
    }

    /// `enip.allow` permits `peer` (nothing counted).
    fn permits(&self, peer: Option<SocketAddrV4>) -> bool {
        self.hub.peek(|m| m.config.active.enip_allow.admits(peer))
    }

    /// Counts a refusal (`ENIP_REFUSED`).
    fn refused(&self) {
        self.hub
            .with(|m| m.owner.enip_refused = m.owner.enip_refused.wrapping_add(1));
    }
}

/// Serves sessions on TCP socket `i`, one after the other, forever.
async fn session<S: Socket, C: Clock>(ctx: &Ctx<'_, '_, C>, mut sock: S, i: usize) -> Infallible {
    let slots = ctx.slots;
    loop {
        if sock.accept(ctx.opts.port).await.is_err() {
            ctx.clock.sleep(Duration::from_millis(500)).await;
            continue;
        }
        let peer = sock.remote();
        // The allow-list before anything is read.
        if !ctx.permits(peer) {
            ctx.refused();
            slots.refused(Refusal::NotAllowed, peer);
            sock.close().await;
            continue;
        }
        if let Err(why) = slots
            .claim(i, peer, crate::admission::Guard::NONE, ctx.clock)
            .await
        {
            slots.refused(why, peer);
            sock.close().await;
            continue;
        }
        let [a, b, c, d] = octets(peer);
        info!("enip: session from {}.{}.{}.{}", a, b, c, d);
        serve_session(ctx, &mut sock, i, peer).await;
        sock.close().await;
        slots.release(i);
        let now = now_of(ctx.clock);
        let mut app = ctx.app();
        if let Ok(mut ad) = ctx.adapter.try_borrow_mut() {
            ad.tcp_closed(LinkId(i as u32), now, &mut app);
        }
    }
}

/// Serves one session until it leaves, falls silent, is too slow with a
/// packet, ends its session, or is asked to close.
async fn serve_session<S: Socket, C: Clock>(
    ctx: &Ctx<'_, '_, C>,
    sock: &mut S,
    i: usize,
    peer: Option<SocketAddrV4>,
) {
    let session = ctx.slots.session(i);
    let ip = peer.map_or(Ipv4Addr::UNSPECIFIED, |p| *p.ip());
    let mut framer = Framer::<FRAME_DATA>::new();
    let mut rx = [0u8; 256];
    let mut reply = [0u8; REPLY];
    // When the first byte of the packet in the framer came.
    let mut started: Option<Instant> = None;
    loop {
        let deadline = match started {
            Some(t) => t + FRAME_DEADLINE,
            None => ctx.clock.now() + IDLE_TIMEOUT,
        };
        let read = select(sock.read(&mut rx), session.closing());
        let n = match with_deadline(ctx.clock, deadline, read).await {
            Ok(Either::First(Ok(n))) if n > 0 => n,
            Ok(Either::First(_)) => return,
            Ok(Either::Second(why)) => {
                ctx.slots.closed(why, peer);
                return;
            }
            Err(_) => {
                if started.is_some() {
                    info!(
                        "enip: packet not whole {} ms after its first byte, closing",
                        FRAME_DEADLINE.as_millis()
                    );
                } else {
                    info!("enip: session idle, closing");
                }
                return;
            }
        };
        let mut rest = rx.get(..n).unwrap_or(&[]);
        if started.is_none() {
            started = Some(ctx.clock.now());
            session.started();
        }
        while !rest.is_empty() {
            let used = framer.push(rest);
            rest = rest.get(used..).unwrap_or(&[]);
            let Some(frame) = framer.frame() else {
                continue;
            };
            if let Some(why) = session.check(ctx.permits(peer)) {
                ctx.slots.closed(why, peer);
                return;
            }
            let action = handle(ctx, i, ip, frame, &mut reply);
            ctx.produce.signal(());
            match action {
                TcpAction::Reply(n) => {
                    let out = reply.get(..n).unwrap_or(&[]);
                    if sock.write_all(out).await.is_err() {
                        return;
                    }
                }
                TcpAction::Close => return,
                TcpAction::None => {}
            }
        }
        if framer.is_idle() {
            started = None;
            session.answered(ctx.clock.now());
        }
    }
}

/// One encapsulation packet through the adapter.
fn handle<C: Clock>(
    ctx: &Ctx<'_, '_, C>,
    i: usize,
    ip: Ipv4Addr,
    frame: Frame<'_>,
    reply: &mut [u8],
) -> TcpAction {
    let now = now_of(ctx.clock);
    let mut app = ctx.app();
    match ctx.adapter.try_borrow_mut() {
        Ok(mut ad) => ad.handle_tcp(LinkId(i as u32), ip, frame, now, &mut app, reply),
        Err(_) => TcpAction::None,
    }
}

/// Closes, each time a configuration is applied, the sessions the new
/// `enip.allow` no longer permits.
async fn warden<C: Clock>(ctx: &Ctx<'_, '_, C>) -> Infallible {
    let Some(mut applied) = ctx.hub.config_applied.receiver() else {
        return core::future::pending().await;
    };
    loop {
        let list = applied.changed().await.enip_allow;
        ctx.slots.close_unless(|peer| list.admits(peer));
    }
}

/// UDP 44818: ListIdentity (and ListServices, ListInterfaces) from
/// scanners that discover devices; anything else is dropped unanswered.
async fn discovery<N: Net, C: Clock>(ctx: &Ctx<'_, '_, C>, net: &N) -> Infallible {
    let mut rx_meta = [PACKET_META; 4];
    let mut tx_meta = [PACKET_META; 2];
    let (mut rx, mut tx) = ([0u8; 256], [0u8; 512]);
    let bufs = UdpBuffers {
        rx_meta: &mut rx_meta,
        rx: &mut rx,
        tx_meta: &mut tx_meta,
        tx: &mut tx,
    };
    let Ok(mut sock) = net.udp(ctx.opts.port, bufs) else {
        warn!("enip: udp {} cannot be bound: no discovery", ctx.opts.port);
        return core::future::pending().await;
    };
    let mut datagram = [0u8; 64];
    let mut reply = [0u8; 256];
    // A second's budget of replies.
    let (mut second, mut left) = (ctx.clock.now(), DISCOVERY_PER_SECOND);
    loop {
        let Ok((n, from)) = sock.recv_from(&mut datagram).await else {
            ctx.clock.sleep(Duration::from_millis(100)).await;
            continue;
        };
        if !ctx.permits(Some(from)) {
            ctx.refused();
            continue;
        }
        let now = ctx.clock.now();
        if now >= second + Duration::from_secs(1) {
            (second, left) = (now, DISCOVERY_PER_SECOND);
        }
        if left == 0 {
            continue;
        }
        let mut app = ctx.app();
        let answer = match ctx.adapter.try_borrow_mut() {
            Ok(mut ad) => ad.handle_udp(datagram.get(..n).unwrap_or(&[]), &mut app, &mut reply),
            Err(_) => None,
        };
        if let Some(len) = answer {
            left -= 1;
            let _ = sock.send_to(reply.get(..len).unwrap_or(&[]), from).await;
        }
    }
}

/// UDP 2222: consumes the O->T datagrams and produces the T->O ones at
/// their RPI; closes the connections whose watchdog expired.
async fn io<N: Net, C: Clock>(ctx: &Ctx<'_, '_, C>, net: &N) -> Infallible {
    let mut rx_meta = [PACKET_META; 8];
    let mut tx_meta = [PACKET_META; 4];
    let (mut rx, mut tx) = ([0u8; 2 * IO_DATAGRAM], [0u8; 2 * IO_DATAGRAM]);
    let bufs = UdpBuffers {
        rx_meta: &mut rx_meta,
        rx: &mut rx,
        tx_meta: &mut tx_meta,
        tx: &mut tx,
    };
    let Ok(mut sock) = net.udp(ctx.opts.io_port, bufs) else {
        warn!(
            "enip: udp {} cannot be bound: no class 1 I/O",
            ctx.opts.io_port
        );
        return core::future::pending().await;
    };
    let mut datagram = [0u8; IO_DATAGRAM];
    let mut out = [0u8; IO_DATAGRAM];
    // Far enough to be never, near enough not to overflow.
    let never = Duration::from_secs(3600);
    loop {
        let next = ctx
            .adapter
            .try_borrow()
            .ok()
            .and_then(|ad| ad.poll_at())
            .map_or(ctx.clock.now() + never, |t| {
                Instant::from_micros(t.as_micros())
            });
        let got = select3(
            sock.recv_from(&mut datagram),
            ctx.clock.sleep_until(next),
            ctx.produce.wait(),
        )
        .await;
        if let Either3::First(Ok((n, from))) = got {
            if ctx.permits(Some(from)) {
                let now = now_of(ctx.clock);
                let mut app = ctx.app();
                if let Ok(mut ad) = ctx.adapter.try_borrow_mut() {
                    let got = ad.handle_io(from, datagram.get(..n).unwrap_or(&[]), now, &mut app);
                    io_counters(ctx.hub, &ad, got);
                }
            } else {
                ctx.refused();
            }
        }
        loop {
            let now = now_of(ctx.clock);
            let mut app = ctx.app();
            let due = match ctx.adapter.try_borrow_mut() {
                Ok(mut ad) => ad.poll(now, &mut app, &mut out),
                Err(_) => None,
            };
            let Some((to, n)) = due else { break };
            let _ = sock.send_to(out.get(..n).unwrap_or(&[]), to).await;
        }
    }
}

/// After a datagram on the I/O port: the counters in the typed state
/// (`ENIP_MISSED`, `ENIP_IO_DROPPED`, the owner's own counts).
fn io_counters(hub: &Hub, ad: &Adapter<'_, SESSIONS, CONNECTIONS>, got: IoOutcome) {
    let owner = hub.peek(|m| m.owner.enip_owner.map(|o| o.connection));
    let info = owner.and_then(|id| ad.connections().find(|c| c.id.0 == id));
    // The register shows the total's low 16 bits: it wraps as it does.
    let missed = ad.io_missed() as u16;
    hub.with(|m| {
        m.owner.enip_missed = missed;
        if got != IoOutcome::Consumed {
            m.owner.enip_io_dropped = m.owner.enip_io_dropped.wrapping_add(1);
        }
        if let (Some(o), Some(c)) = (m.owner.enip_owner.as_mut(), info) {
            o.received = c.received;
            o.missed = c.missed;
        }
    });
}

#[cfg(test)]
mod tests;
