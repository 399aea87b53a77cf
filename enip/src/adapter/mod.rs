//! The adapter: a sans-IO state machine that answers the encapsulation
//! protocol on TCP and UDP port 44818, serves the CIP objects, and runs
//! class 1 I/O connections on UDP port 2222 and class 3 connections over
//! SendUnitData.
//!
//! ## How a caller drives it
//! * **TCP 44818**: one [`Framer`](crate::Framer) per TCP connection and a
//!   [`LinkId`] of the caller's choice for it. Push received bytes into the
//!   framer; each [`Frame`] goes to [`Adapter::handle_tcp`], which writes a
//!   reply into the caller's buffer and says what to do ([`TcpAction`]).
//!   When the TCP connection ends, call [`Adapter::tcp_closed`].
//! * **UDP 44818**: [`Adapter::handle_udp`] (ListIdentity, ListServices,
//!   ListInterfaces; anything else is dropped without a reply).
//! * **UDP 2222**: each datagram to [`Adapter::handle_io`].
//! * **Time**: call [`Adapter::poll`] at or after [`Adapter::poll_at`], and
//!   after every call above; it closes timed-out connections and returns the
//!   T->O datagrams that are due, one per call, until it returns `None`.
//!
//! ## Bounds
//! * `SESSIONS` registered sessions in all, one per TCP connection. A
//!   RegisterSession beyond that is refused with status 0x0002 (insufficient
//!   memory); a second one on the same TCP connection with 0x0001 (invalid
//!   command). A session ends with UnRegisterSession or its TCP connection.
//!   How many TCP connections the caller accepts, and how long an idle one
//!   may stay, is the caller's admission policy.
//! * `CONNECTIONS` class 1 and class 3 connections in all. A Forward_Open
//!   beyond that is refused with extended status 0x0113 (out of
//!   connections). Every connection has a watchdog; one that never sends is
//!   freed at the first-packet timeout ([`Config::first_packet_timeout_us`],
//!   10 s by default, or its own timeout if longer).
//! * RPIs from [`Config::min_rpi_us`] (2 ms) to [`Config::max_rpi_us`]
//!   (10 s); others are refused with 0x0111.
//! * Explicit messages as large as the caller's framer and reply buffer;
//!   a reply that does not fit is answered with general status 0x11 (reply
//!   data too large).

mod connections;
mod explicit;

use core::net::{Ipv4Addr, SocketAddrV4};

use crate::app::{Application, CloseReason, Event};
use crate::device::Device;
use crate::framer::Frame;
use crate::time::Instant;
use crate::wire::cpf::{parse_connected_address, Cpf, CpfWriter, ItemType, Sockaddr};
use crate::wire::encap::{Command, Header, Status, HEADER_LEN};
use crate::wire::identity_item::{IdentityItem, ServicesItem, STATE_OPERATIONAL};
use crate::wire::session::{RegisterRepr, SendDataRepr, PROTOCOL_VERSION};
use crate::wire::{Error, Writer};

use connections::Connection;
pub use connections::{ConnectionInfo, IoOutcome};

/// A TCP connection, named by the caller (a socket index, a counter...).
/// Must be unique among the caller's open TCP connections.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct LinkId(pub u32);

/// What to do after a TCP packet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum TcpAction {
    /// Nothing to send (NOP, a discarded packet, a connected message for no
    /// connection).
    None,
    /// Send the first `n` bytes of the reply buffer.
    Reply(usize),
    /// Close the TCP connection (after UnRegisterSession). Call
    /// [`Adapter::tcp_closed`] too.
    Close,
}

/// Settings of the adapter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Config {
    /// The TCP port of the encapsulation protocol, as ListIdentity reports
    /// it (44818).
    pub encap_port: u16,
    /// The UDP port T->O data goes to when the Forward_Open names none
    /// (2222).
    pub io_port: u16,
    /// The shortest RPI accepted, in microseconds (2,000: 2 ms).
    pub min_rpi_us: u32,
    /// The longest RPI accepted, in microseconds (10,000,000: 10 s).
    pub max_rpi_us: u32,
    /// How long a new connection may wait for its first packet, in
    /// microseconds, when that is longer than its own timeout (10 s by
    /// default: a scanner that needs a moment after the reply is not cut
    /// off, and a half-open connection holds its slot at most this long).
    pub first_packet_timeout_us: u32,
    /// The largest class 3 connection size accepted, in bytes (504).
    pub max_explicit_size: u16,
    /// Seeds the session handles and connection ids (give a random value at
    /// start-up so that they are not predictable).
    pub seed: u32,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            encap_port: 44818,
            io_port: 2222,
            min_rpi_us: 2_000,
            max_rpi_us: 10_000_000,
            first_packet_timeout_us: 10_000_000,
            max_explicit_size: 504,
            seed: 0x1F2E_3D4C,
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Session {
    handle: u32,
    link: LinkId,
}

/// The adapter, with room for `SESSIONS` sessions and `CONNECTIONS`
/// connections.
#[derive(Debug)]
pub struct Adapter<'d, const SESSIONS: usize, const CONNECTIONS: usize> {
    device: &'d Device<'d>,
    config: Config,
    sessions: heapless::Vec<Session, SESSIONS>,
    conns: heapless::Vec<Connection, CONNECTIONS>,
    rng: u32,
    /// O->T datagrams missed by every class 1 connection so far.
    io_missed: u32,
}

/// Writes a reply: the body after the header, then the header with the
/// body's length. `None` when the buffer cannot hold it.
fn reply(
    request: &Header,
    status: Status,
    out: &mut [u8],
    body: impl FnOnce(&mut Writer<'_>) -> Result<(), Error>,
) -> TcpAction {
    let Some((head, rest)) = out.split_at_mut_checked(HEADER_LEN) else {
        return TcpAction::None;
    };
    let mut w = Writer::new(rest);
    if body(&mut w).is_err() {
        return TcpAction::None;
    }
    let Ok(len) = u16::try_from(w.len()) else {
        return TcpAction::None;
    };
    if request.reply(status, len).emit(head).is_err() {
        return TcpAction::None;
    }
    TcpAction::Reply(HEADER_LEN + usize::from(len))
}

fn status_only(request: &Header, status: Status, out: &mut [u8]) -> TcpAction {
    reply(request, status, out, |_| Ok(()))
}

impl<'d, const SESSIONS: usize, const CONNECTIONS: usize> Adapter<'d, SESSIONS, CONNECTIONS> {
    /// An adapter for a device.
    pub fn new(device: &'d Device<'d>, config: Config) -> Self {
        Adapter {
            device,
            config,
            sessions: heapless::Vec::new(),
            conns: heapless::Vec::new(),
            io_missed: 0,
            rng: if config.seed == 0 {
                0x9E37_79B9
            } else {
                config.seed
            },
        }
    }

    /// The settings.
    pub fn config(&self) -> &Config {
        &self.config
    }

    /// The device description.
    pub fn device(&self) -> &'d Device<'d> {
        self.device
    }

    /// How many sessions are registered.
    pub fn session_count(&self) -> usize {
        self.sessions.len()
    }

    /// The open connections.
    pub fn connections(&self) -> impl Iterator<Item = ConnectionInfo> + '_ {
        self.conns.iter().map(Connection::info)
    }

    /// O->T datagrams missed since the adapter started, by every class 1
    /// connection (open or closed; wraps): each a datagram the originator
    /// produced at its RPI, as its sequence numbers count, that never came
    /// (a gap in the sequence). The open ones' own counts are in
    /// [`Adapter::connections`].
    pub fn io_missed(&self) -> u32 {
        self.io_missed
    }

    /// xorshift32: unpredictable enough for handles given a random seed,
    /// and a few bytes of code (no RNG crate on the board for this).
    fn next_random(&mut self) -> u32 {
        let mut x = self.rng;
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        self.rng = x;
        x
    }

    fn session_of(&self, link: LinkId) -> Option<&Session> {
        self.sessions.iter().find(|s| s.link == link)
    }

    /// Handles one packet of a TCP connection; `peer` is its remote address.
    /// The reply, if any, is written into `out` (600 bytes hold every reply
    /// to a request of the default sizes; a larger assembly needs more).
    pub fn handle_tcp<A: Application>(
        &mut self,
        link: LinkId,
        peer: Ipv4Addr,
        frame: Frame<'_>,
        now: Instant,
        app: &mut A,
        out: &mut [u8],
    ) -> TcpAction {
        let (header, data) = match frame {
            Frame::Complete { header, data } => (header, data),
            Frame::TooLong { header } => {
                // NOP's data is ignored whatever its length; every other
                // packet too long for the framer is refused.
                if header.options != 0 || header.command == Command::Nop {
                    return TcpAction::None;
                }
                return status_only(&header, Status::InvalidLength, out);
            }
        };
        // The specification: a packet with options set is discarded.
        if header.options != 0 {
            return TcpAction::None;
        }
        log_debug!(
            "enip: tcp command {:?} len {}",
            header.command,
            header.length
        );
        match header.command {
            Command::Nop => TcpAction::None,
            Command::ListIdentity | Command::ListServices | Command::ListInterfaces => {
                self.list(&header, data, app, out)
            }
            Command::RegisterSession => self.register(link, &header, data, out),
            Command::UnRegisterSession => {
                if self.session_of(link).map(|s| s.handle) != Some(header.session) {
                    return status_only(&header, Status::InvalidSessionHandle, out);
                }
                self.tcp_closed(link, now, app);
                TcpAction::Close
            }
            Command::SendRrData => {
                if self.session_of(link).map(|s| s.handle) != Some(header.session) {
                    return status_only(&header, Status::InvalidSessionHandle, out);
                }
                self.send_rr_data(link, peer, &header, data, now, app, out)
            }
            Command::SendUnitData => {
                if self.session_of(link).map(|s| s.handle) != Some(header.session) {
                    return status_only(&header, Status::InvalidSessionHandle, out);
                }
                self.send_unit_data(link, peer, &header, data, now, app, out)
            }
            Command::Unknown(_) => status_only(&header, Status::InvalidCommand, out),
        }
    }

    /// Handles a datagram on UDP port 44818 (discovery): ListIdentity,
    /// ListServices and ListInterfaces are answered into `out`; every other
    /// command is dropped without a reply, so that the port cannot be used
    /// to reflect errors at a forged source address.
    pub fn handle_udp<A: Application>(
        &mut self,
        datagram: &[u8],
        app: &mut A,
        out: &mut [u8],
    ) -> Option<usize> {
        let header = Header::parse(datagram).ok()?;
        if header.options != 0 {
            return None;
        }
        let data = datagram.get(HEADER_LEN..)?;
        if data.len() != usize::from(header.length) {
            return None;
        }
        match header.command {
            Command::ListIdentity | Command::ListServices | Command::ListInterfaces => {
                match self.list(&header, data, app, out) {
                    TcpAction::Reply(n) => Some(n),
                    _ => None,
                }
            }
            _ => None,
        }
    }

    fn list<A: Application>(
        &mut self,
        header: &Header,
        data: &[u8],
        app: &mut A,
        out: &mut [u8],
    ) -> TcpAction {
        // The List commands carry no data.
        if !data.is_empty() {
            return status_only(header, Status::InvalidLength, out);
        }
        let command = header.command;
        let status = self.identity_status(app.identity().status);
        let ip = app.tcp_ip().ip;
        let port = self.config.encap_port;
        reply(header, Status::Success, out, |w| {
            let mut cpf = CpfWriter::begin(w)?;
            match command {
                Command::ListIdentity => cpf.item_with(w, ItemType::CipIdentity, |w| {
                    let mut identity = app.identity();
                    identity.status = status;
                    IdentityItem {
                        version: PROTOCOL_VERSION,
                        socket: SocketAddrV4::new(ip, port),
                        identity,
                        state: STATE_OPERATIONAL,
                    }
                    .emit(w)
                }),
                Command::ListServices => cpf.item_with(w, ItemType::ListServices, |w| {
                    ServicesItem::communications().emit(w)
                }),
                // No non-CIP interfaces: an empty item list.
                _ => Ok(()),
            }
        })
    }

    fn register(
        &mut self,
        link: LinkId,
        header: &Header,
        data: &[u8],
        out: &mut [u8],
    ) -> TcpAction {
        let req = match RegisterRepr::parse(data) {
            Ok(r) => r,
            Err(_) => return status_only(header, Status::InvalidLength, out),
        };
        if req.version != PROTOCOL_VERSION {
            // The reply names the version this target speaks.
            let h = Header {
                session: 0,
                ..*header
            };
            return reply(&h, Status::UnsupportedProtocolRevision, out, |w| {
                RegisterRepr {
                    version: PROTOCOL_VERSION,
                    options: 0,
                }
                .emit(w)
            });
        }
        if self.session_of(link).is_some() {
            return reply(header, Status::InvalidCommand, out, |w| req.emit(w));
        }
        let mut handle = self.next_random();
        while handle == 0 || self.sessions.iter().any(|s| s.handle == handle) {
            handle = self.next_random();
        }
        if self.sessions.push(Session { handle, link }).is_err() {
            let h = Header {
                session: 0,
                ..*header
            };
            return reply(&h, Status::InsufficientMemory, out, |w| req.emit(w));
        }
        let h = Header {
            session: handle,
            ..*header
        };
        reply(&h, Status::Success, out, |w| req.emit(w))
    }

    /// The TCP connection `link` closed: its session ends and its class 3
    /// connections close (class 1 connections do not: they live on UDP and
    /// end by Forward_Close or their timeout).
    pub fn tcp_closed<A: Application>(&mut self, link: LinkId, _now: Instant, app: &mut A) {
        self.sessions.retain(|s| s.link != link);
        while let Some(i) = self.conns.iter().position(|c| c.link == Some(link)) {
            let c = self.conns.swap_remove(i);
            app.event(Event::Closed {
                connection: c.id(),
                kind: c.kind,
                reason: CloseReason::LinkClosed,
            });
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn send_rr_data<A: Application>(
        &mut self,
        link: LinkId,
        peer: Ipv4Addr,
        header: &Header,
        data: &[u8],
        now: Instant,
        app: &mut A,
        out: &mut [u8],
    ) -> TcpAction {
        let Ok(sd) = SendDataRepr::parse(data) else {
            return status_only(header, Status::InvalidLength, out);
        };
        let Ok(cpf) = Cpf::parse(sd.cpf) else {
            return status_only(header, Status::IncorrectData, out);
        };
        let (Some(addr), Some(msg)) = (cpf.get(0), cpf.get(1)) else {
            return status_only(header, Status::IncorrectData, out);
        };
        if addr.kind != ItemType::NullAddress
            || !addr.data.is_empty()
            || msg.kind != ItemType::UnconnectedData
        {
            return status_only(header, Status::IncorrectData, out);
        }
        // A Forward_Open may name where T->O data goes (a Sockaddr Info T->O item).
        let mut t_o_dest = None;
        for item in cpf.items().iter().skip(2) {
            match (item.kind, Sockaddr::parse(item.data)) {
                (ItemType::SockaddrTO, Ok(s)) => t_o_dest = Some(s.addr),
                (ItemType::SockaddrOT, Ok(_)) => {}
                _ => return status_only(header, Status::IncorrectData, out),
            }
        }
        let ctx = explicit::Context {
            link,
            peer,
            now,
            t_o_dest,
        };
        let request = msg.data;
        reply(header, Status::Success, out, |w| {
            SendDataRepr::emit_prefix(0, 0, w)?;
            let mut c = CpfWriter::begin(w)?;
            c.item(w, ItemType::NullAddress, &[])?;
            c.item_with(w, ItemType::UnconnectedData, |w| {
                self.explicit(&ctx, request, app, w)
            })
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn send_unit_data<A: Application>(
        &mut self,
        link: LinkId,
        peer: Ipv4Addr,
        header: &Header,
        data: &[u8],
        now: Instant,
        app: &mut A,
        out: &mut [u8],
    ) -> TcpAction {
        let Ok(sd) = SendDataRepr::parse(data) else {
            return status_only(header, Status::InvalidLength, out);
        };
        let Ok(cpf) = Cpf::parse(sd.cpf) else {
            return status_only(header, Status::IncorrectData, out);
        };
        let (Some(addr), Some(msg), 2) = (cpf.get(0), cpf.get(1), cpf.items().len()) else {
            return status_only(header, Status::IncorrectData, out);
        };
        if addr.kind != ItemType::ConnectedAddress
            || msg.kind != ItemType::ConnectedData
            || msg.data.len() < 2
        {
            return status_only(header, Status::IncorrectData, out);
        }
        let Ok(id) = parse_connected_address(addr.data) else {
            return status_only(header, Status::IncorrectData, out);
        };
        // A connected message for no connection of this TCP connection is
        // dropped: connected messages have no error reply of their own.
        let Some(t_o_id) = self.touch_explicit(link, id, now) else {
            return TcpAction::None;
        };
        let (seq, request) = msg.data.split_at(2);
        let ctx = explicit::Context {
            link,
            peer,
            now,
            t_o_dest: None,
        };
        reply(header, Status::Success, out, |w| {
            SendDataRepr::emit_prefix(0, 0, w)?;
            let mut c = CpfWriter::begin(w)?;
            c.item(w, ItemType::ConnectedAddress, &t_o_id.to_le_bytes())?;
            c.item_with(w, ItemType::ConnectedData, |w| {
                w.bytes(seq, "sequence count")?;
                self.explicit(&ctx, request, app, w)
            })
        })
    }

    /// The Identity status with the bits the adapter keeps: "owned" while an
    /// exclusive owner is connected, and the extended status (no I/O, I/O
    /// idle, I/O running).
    fn identity_status(&self, app_status: u16) -> u16 {
        use crate::device::status::*;
        use crate::device::ConnectionKind;
        let mut io = self
            .conns
            .iter()
            .filter(|c| c.kind != ConnectionKind::Explicit)
            .peekable();
        let ext = if io.peek().is_none() {
            EXT_NO_IO
        } else if self.conns.iter().any(|c| c.run == Some(true)) {
            EXT_IO_RUN
        } else {
            EXT_IO_IDLE
        };
        let owned = if self
            .conns
            .iter()
            .any(|c| c.kind == ConnectionKind::ExclusiveOwner)
        {
            OWNED
        } else {
            0
        };
        (app_status & !(OWNED | EXT_MASK)) | owned | ext
    }
}
