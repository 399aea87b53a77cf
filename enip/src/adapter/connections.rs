//! The Connection Manager's services and the connections they open: class 1
//! I/O (consumed O->T datagrams, produced T->O datagrams, the inactivity
//! watchdog) and class 3 explicit connections.

use core::net::{Ipv4Addr, SocketAddrV4};

use super::explicit::Context;
use super::{Adapter, LinkId};
use crate::app::{Application, CloseReason, ConnectionId, Event, WriteOrigin};
use crate::device::{AssemblyKind, ConnectionKind};
use crate::objects::{class, Failure, Outcome};
use crate::time::Instant;
use crate::wire::cip::{AppPath, GeneralStatus, Request, Service};
use crate::wire::conn_mgr::{
    emit_close_reply, emit_failure, ConnectionType, ExtendedStatus, ForwardClose, ForwardOpen,
    ForwardOpenReply, Triad,
};
use crate::wire::cpf::{CpfWriter, ItemType};
use crate::wire::epath::{segments, KeyMismatch, LogicalType, Segment};
use crate::wire::io::{split_run_idle, IoPacket, RUN};
use crate::wire::Writer;

/// The size of the CIP sequence count in front of class 1 data.
const SEQ_COUNT_LEN: u16 = 2;
/// The size of the run/idle header of O->T data.
const RUN_IDLE_LEN: u16 = 4;

/// An open connection.
#[derive(Debug, Clone)]
pub(super) struct Connection {
    pub(super) kind: ConnectionKind,
    triad: Triad,
    o_t_id: u32,
    t_o_id: u32,
    o_t_rpi: u32,
    t_o_rpi: u32,
    /// RPI x the timeout multiplier, in microseconds.
    timeout: u64,
    /// When the watchdog expires.
    deadline: Instant,
    /// The output assembly an exclusive owner writes.
    pub(super) output: Option<u16>,
    /// The input assembly a class 1 connection reads.
    input: Option<u16>,
    /// The input assembly's size.
    input_size: u16,
    originator: Ipv4Addr,
    /// Where T->O datagrams go (class 1).
    dest: SocketAddrV4,
    /// The TCP connection of a class 3 connection.
    pub(super) link: Option<LinkId>,
    next_production: Instant,
    t_o_sequence: u32,
    t_o_count: u16,
    last_sequence: Option<u32>,
    last_count: Option<u16>,
    pub(super) run: Option<bool>,
    received: u32,
    missed: u32,
    produced: u32,
}

/// What the adapter knows of an open connection (for diagnostics and tests).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConnectionInfo {
    /// The connection (its O->T id).
    pub id: ConnectionId,
    /// Its kind.
    pub kind: ConnectionKind,
    /// The T->O connection id.
    pub t_o_id: u32,
    /// The triad.
    pub triad: Triad,
    /// The O->T RPI in microseconds.
    pub o_t_rpi_us: u32,
    /// The T->O RPI in microseconds.
    pub t_o_rpi_us: u32,
    /// The inactivity timeout in microseconds.
    pub timeout_us: u64,
    /// The originator.
    pub originator: Ipv4Addr,
    /// Where T->O datagrams go.
    pub destination: SocketAddrV4,
    /// O->T datagrams (or class 3 requests) taken.
    pub received: u32,
    /// O->T datagrams missing by their sequence numbers.
    pub missed: u32,
    /// T->O datagrams produced.
    pub produced: u32,
    /// The last run/idle state seen.
    pub run: Option<bool>,
}

impl Connection {
    pub(super) fn id(&self) -> ConnectionId {
        ConnectionId(self.o_t_id)
    }

    pub(super) fn info(&self) -> ConnectionInfo {
        ConnectionInfo {
            id: self.id(),
            kind: self.kind,
            t_o_id: self.t_o_id,
            triad: self.triad,
            o_t_rpi_us: self.o_t_rpi,
            t_o_rpi_us: self.t_o_rpi,
            timeout_us: self.timeout,
            originator: self.originator,
            destination: self.dest,
            received: self.received,
            missed: self.missed,
            produced: self.produced,
            run: self.run,
        }
    }

    fn is_io(&self) -> bool {
        self.kind != ConnectionKind::Explicit
    }
}

/// What became of a datagram on the I/O port.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum IoOutcome {
    /// Taken: the watchdog restarted and any new data went to the application.
    Consumed,
    /// Not a class 1 datagram.
    Malformed,
    /// No open connection has this O->T id.
    UnknownConnection,
    /// It came from an address other than the connection's originator.
    WrongSource,
    /// Its sequence number is not newer than the last one taken.
    Stale,
    /// Its data is not the size the connection was opened with.
    WrongSize,
}

/// A Forward_Open failure with its extended status (and a second word for
/// the size errors: the size that would be accepted).
fn refuse(triad: &Triad, ext: ExtendedStatus, extra: Option<u16>) -> Failure {
    let mut f = Failure::from(GeneralStatus::ConnectionFailure);
    // Capacity 2: cannot fail.
    let _ = f.additional.push(ext.into());
    if let Some(e) = extra {
        let _ = f.additional.push(e);
    }
    let mut buf = [0u8; 10];
    let mut w = Writer::new(&mut buf);
    if emit_failure(triad, &mut w).is_ok() {
        let _ = f.data.extend_from_slice(&buf);
    }
    f
}

/// What a Forward_Open's connection path names.
struct OpenPath {
    class: u32,
    config: Option<u32>,
    points: heapless::Vec<u32, 2>,
    data: Option<usize>,
}

fn parse_open_path<A: Application>(
    fo: &ForwardOpen<'_>,
    app: &A,
) -> Result<OpenPath, ExtendedStatus> {
    let mut p = OpenPath {
        class: 0,
        config: None,
        points: heapless::Vec::new(),
        data: None,
    };
    let mut seen_class = false;
    for seg in segments(fo.path) {
        match seg.map_err(|_| ExtendedStatus::InvalidSegment)? {
            Segment::ElectronicKey(key) if !seen_class => {
                key.check(&app.identity()).map_err(|m| match m {
                    KeyMismatch::VendorOrProduct => ExtendedStatus::VendorOrProductMismatch,
                    KeyMismatch::DeviceType => ExtendedStatus::DeviceTypeMismatch,
                    KeyMismatch::Revision => ExtendedStatus::RevisionMismatch,
                })?
            }
            Segment::Logical {
                kind: LogicalType::Class,
                value,
            } if !seen_class => {
                seen_class = true;
                p.class = value;
            }
            Segment::Logical {
                kind: LogicalType::Instance,
                value,
            } if seen_class && p.config.is_none() => p.config = Some(value),
            Segment::Logical {
                kind: LogicalType::ConnectionPoint,
                value,
            } if seen_class => p
                .points
                .push(value)
                .map_err(|_| ExtendedStatus::InvalidSegment)?,
            Segment::Data(d) if seen_class && p.data.is_none() => p.data = Some(d.len()),
            _ => return Err(ExtendedStatus::InvalidSegment),
        }
    }
    if !seen_class {
        return Err(ExtendedStatus::InvalidSegment);
    }
    Ok(p)
}

impl<const SESSIONS: usize, const CONNECTIONS: usize> Adapter<'_, SESSIONS, CONNECTIONS> {
    pub(super) fn connection_manager<A: Application>(
        &mut self,
        ctx: &Context,
        req: &Request<'_>,
        path: &AppPath,
        app: &mut A,
        w: &mut Writer<'_>,
    ) -> Outcome {
        if path.instance != 1 || path.attribute.is_some() {
            return Err(if path.instance == 0 || path.instance == 1 {
                GeneralStatus::ServiceNotSupported.into()
            } else {
                GeneralStatus::ObjectDoesNotExist.into()
            });
        }
        match req.service {
            Service::ForwardOpen | Service::LargeForwardOpen => {
                let fo = ForwardOpen::parse(req.data, req.service == Service::LargeForwardOpen)
                    .map_err(|_| GeneralStatus::NotEnoughData)?;
                let reply = self.forward_open(ctx, &fo, app)?;
                reply.emit(w)?;
                Ok(())
            }
            Service::ForwardClose => {
                let fc = ForwardClose::parse(req.data).map_err(|_| GeneralStatus::NotEnoughData)?;
                let found = self.conns.iter().position(|c| {
                    c.triad == fc.triad && (c.originator == ctx.peer || c.link == Some(ctx.link))
                });
                let Some(i) = found else {
                    return Err(refuse(&fc.triad, ExtendedStatus::ConnectionNotFound, None));
                };
                let c = self.conns.swap_remove(i);
                app.event(Event::Closed {
                    connection: c.id(),
                    kind: c.kind,
                    reason: CloseReason::ForwardClose,
                });
                emit_close_reply(&fc.triad, w)?;
                Ok(())
            }
            _ => Err(GeneralStatus::ServiceNotSupported.into()),
        }
    }

    fn fresh_id(&mut self) -> u32 {
        loop {
            let id = self.next_random();
            if id != 0 && !self.conns.iter().any(|c| c.o_t_id == id || c.t_o_id == id) {
                return id;
            }
        }
    }

    fn forward_open<A: Application>(
        &mut self,
        ctx: &Context,
        fo: &ForwardOpen<'_>,
        app: &mut A,
    ) -> Result<ForwardOpenReply, Failure> {
        let triad = fo.triad;
        let no = |ext| refuse(&triad, ext, None);
        let t = fo.transport;
        let explicit = match (t.class, t.trigger, t.server) {
            (1, 0, false) => false,
            (3, _, true) => true,
            _ => return Err(no(ExtendedStatus::TransportNotSupported)),
        };
        let p = parse_open_path(fo, app).map_err(no)?;
        // Only point-to-point in both directions: multicast T->O would need
        // a multicast group the caller joins, which this adapter does not ask
        // for (Studio 5000: set the connection to Unicast).
        if fo.o_t_params.kind != ConnectionType::PointToPoint
            || fo.t_o_params.kind != ConnectionType::PointToPoint
        {
            return Err(no(ExtendedStatus::InvalidConnectionType));
        }
        let rpi_ok = |r: u32| (self.config.min_rpi_us..=self.config.max_rpi_us).contains(&r);
        if !rpi_ok(fo.o_t_rpi) || !rpi_ok(fo.t_o_rpi) {
            return Err(no(ExtendedStatus::RpiNotSupported));
        }
        if fo.multiplier > 7 {
            return Err(no(ExtendedStatus::ParameterError));
        }
        if self.conns.iter().any(|c| c.triad == triad) {
            return Err(no(ExtendedStatus::ConnectionInUse));
        }

        let (kind, output, input, input_size) = if explicit {
            if p.class != class::MESSAGE_ROUTER
                || p.config != Some(1)
                || !p.points.is_empty()
                || p.data.is_some()
            {
                return Err(no(ExtendedStatus::InvalidApplicationPath));
            }
            let max = self.config.max_explicit_size;
            if fo.o_t_params.size > max || fo.t_o_params.size > max {
                return Err(refuse(
                    &triad,
                    ExtendedStatus::InvalidConnectionSize,
                    Some(max),
                ));
            }
            (ConnectionKind::Explicit, None, None, 0)
        } else {
            self.check_io_path(fo, &p, app)?
        };

        if kind == ConnectionKind::ExclusiveOwner
            && self
                .conns
                .iter()
                .any(|c| c.kind == ConnectionKind::ExclusiveOwner && c.output == output)
        {
            return Err(no(ExtendedStatus::OwnershipConflict));
        }
        if kind == ConnectionKind::ListenOnly
            && !self.conns.iter().any(|c| {
                matches!(
                    c.kind,
                    ConnectionKind::ExclusiveOwner | ConnectionKind::InputOnly
                ) && c.input == input
            })
        {
            return Err(no(ExtendedStatus::NonListenOnlyNotOpen));
        }
        if self.conns.is_full() {
            return Err(no(ExtendedStatus::OutOfConnections));
        }
        let held = self
            .conns
            .iter()
            .filter(|c| c.originator == ctx.peer)
            .count();
        app.admit_open(kind, ctx.peer, held).map_err(no)?;

        let o_t_id = self.fresh_id();
        // Point to point T->O: the originator consumes, so its proposed id
        // stands (a zero proposal gets one of ours).
        let t_o_id = if fo.t_o_id != 0 {
            fo.t_o_id
        } else {
            self.fresh_id()
        };
        let timeout = u64::from(fo.o_t_rpi) * (4u64 << fo.multiplier);
        let first = timeout.max(u64::from(self.config.first_packet_timeout_us));
        let dest_ip = match ctx.t_o_dest {
            Some(a) if !a.ip().is_unspecified() => *a.ip(),
            _ => ctx.peer,
        };
        let dest_port = ctx.t_o_dest.map_or(self.config.io_port, |a| a.port());
        let c = Connection {
            kind,
            triad,
            o_t_id,
            t_o_id,
            o_t_rpi: fo.o_t_rpi,
            t_o_rpi: fo.t_o_rpi,
            timeout,
            deadline: ctx.now.plus_micros(first),
            output,
            input,
            input_size,
            originator: ctx.peer,
            dest: SocketAddrV4::new(dest_ip, dest_port),
            link: if explicit { Some(ctx.link) } else { None },
            next_production: ctx.now,
            t_o_sequence: 0,
            t_o_count: 0,
            last_sequence: None,
            last_count: None,
            run: None,
            received: 0,
            missed: 0,
            produced: 0,
        };
        if self.conns.push(c).is_err() {
            return Err(no(ExtendedStatus::OutOfConnections));
        }
        app.event(Event::Opened {
            connection: ConnectionId(o_t_id),
            kind,
            output,
            input,
            originator: ctx.peer,
        });
        Ok(ForwardOpenReply {
            o_t_id,
            t_o_id,
            triad,
            o_t_api: fo.o_t_rpi,
            t_o_api: fo.t_o_rpi,
        })
    }

    /// Checks a class 1 path and sizes against the device's connections;
    /// returns the kind, the output and input assemblies and the input size.
    #[allow(clippy::type_complexity)]
    fn check_io_path<A: Application>(
        &self,
        fo: &ForwardOpen<'_>,
        p: &OpenPath,
        app: &mut A,
    ) -> Result<(ConnectionKind, Option<u16>, Option<u16>, u16), Failure> {
        let triad = fo.triad;
        let no = |ext| refuse(&triad, ext, None);
        if p.class != class::ASSEMBLY {
            return Err(no(ExtendedStatus::InvalidApplicationPath));
        }
        let [o_t, t_o] = p.points.as_slice() else {
            return Err(no(ExtendedStatus::InvalidApplicationPath));
        };
        let (Ok(o_t), Ok(t_o)) = (u16::try_from(*o_t), u16::try_from(*t_o)) else {
            return Err(no(ExtendedStatus::InvalidApplicationPath));
        };
        let conn = *self
            .device
            .connection(o_t, t_o)
            .ok_or_else(|| no(ExtendedStatus::InvalidApplicationPath))?;
        let input = self
            .device
            .assembly(t_o)
            .filter(|a| a.kind == AssemblyKind::Input)
            .ok_or_else(|| no(ExtendedStatus::InvalidApplicationPath))?;
        // Configuration data: only for a configuration assembly of that size.
        if let Some(n) = p.data {
            let cfg = p
                .config
                .and_then(|c| u16::try_from(c).ok())
                .and_then(|c| self.device.assembly(c))
                .filter(|a| a.kind == AssemblyKind::Config && usize::from(a.size) == n);
            if cfg.is_none() {
                return Err(no(ExtendedStatus::InvalidConfigurationPath));
            }
        }
        let output = match conn.kind {
            ConnectionKind::ExclusiveOwner => {
                let out = self
                    .device
                    .assembly(o_t)
                    .filter(|a| a.kind == AssemblyKind::Output)
                    .ok_or_else(|| no(ExtendedStatus::InvalidApplicationPath))?;
                let want = out.size.saturating_add(SEQ_COUNT_LEN + RUN_IDLE_LEN);
                if fo.o_t_params.size != want {
                    return Err(refuse(&triad, ExtendedStatus::InvalidOToTSize, Some(want)));
                }
                Some(out.instance)
            }
            // A heartbeat: the sequence count alone, or with a run/idle
            // header (scanners differ); a zero size is taken as the same.
            ConnectionKind::InputOnly | ConnectionKind::ListenOnly => {
                if ![0, SEQ_COUNT_LEN, SEQ_COUNT_LEN + RUN_IDLE_LEN].contains(&fo.o_t_params.size) {
                    return Err(refuse(
                        &triad,
                        ExtendedStatus::InvalidOToTSize,
                        Some(SEQ_COUNT_LEN),
                    ));
                }
                None
            }
            ConnectionKind::Explicit => return Err(no(ExtendedStatus::InvalidApplicationPath)),
        };
        let want = input.size.saturating_add(SEQ_COUNT_LEN);
        if fo.t_o_params.size != want {
            return Err(refuse(&triad, ExtendedStatus::InvalidTToOSize, Some(want)));
        }
        // Configuration data is written last, once everything else passed.
        if let (Some(data), Some(cfg)) = (
            config_data(fo.path),
            p.config.and_then(|c| u16::try_from(c).ok()),
        ) {
            if let Err(_status) = app.write_assembly(cfg, data, WriteOrigin::Explicit) {
                return Err(no(ExtendedStatus::InvalidConfigurationPath));
            }
        }
        Ok((conn.kind, output, Some(input.instance), input.size))
    }

    /// A class 3 request arrived on connection `o_t_id` of `link`: restarts
    /// its watchdog and returns its T->O id.
    pub(super) fn touch_explicit(
        &mut self,
        link: LinkId,
        o_t_id: u32,
        now: Instant,
    ) -> Option<u32> {
        let c = self.conns.iter_mut().find(|c| {
            c.kind == ConnectionKind::Explicit && c.o_t_id == o_t_id && c.link == Some(link)
        })?;
        c.deadline = now.plus_micros(c.timeout);
        c.received = c.received.wrapping_add(1);
        Some(c.t_o_id)
    }

    /// Takes a datagram from the I/O port (UDP 2222) sent from `from`.
    pub fn handle_io<A: Application>(
        &mut self,
        from: SocketAddrV4,
        datagram: &[u8],
        now: Instant,
        app: &mut A,
    ) -> IoOutcome {
        let Ok(pkt) = IoPacket::parse(datagram) else {
            return IoOutcome::Malformed;
        };
        let Some(c) = self
            .conns
            .iter_mut()
            .find(|c| c.is_io() && c.o_t_id == pkt.connection_id)
        else {
            return IoOutcome::UnknownConnection;
        };
        if *from.ip() != c.originator {
            return IoOutcome::WrongSource;
        }
        if let Some(last) = c.last_sequence {
            // Serial number arithmetic: newer when ahead by less than 2^31.
            let ahead = pkt.sequence.wrapping_sub(last);
            if ahead == 0 || ahead >= 0x8000_0000 {
                return IoOutcome::Stale;
            }
            c.missed = c.missed.wrapping_add(ahead - 1);
            self.io_missed = self.io_missed.wrapping_add(ahead - 1);
        }
        let mut write = None;
        if let Some(out) = c.output {
            let Ok((header, data)) = split_run_idle(pkt.data) else {
                return IoOutcome::WrongSize;
            };
            // The size was checked at Forward_Open against the assembly.
            let size = self.device.assembly(out).map_or(0, |a| usize::from(a.size));
            if data.len() != size {
                return IoOutcome::WrongSize;
            }
            let run = header & RUN != 0;
            if c.run != Some(run) {
                c.run = Some(run);
                app.event(Event::RunIdle {
                    connection: ConnectionId(c.o_t_id),
                    run,
                });
            }
            if c.last_count != Some(pkt.sequence_count) {
                write = Some((out, data, run));
            }
        }
        c.last_sequence = Some(pkt.sequence);
        c.last_count = Some(pkt.sequence_count);
        c.received = c.received.wrapping_add(1);
        c.deadline = now.plus_micros(c.timeout);
        let id = ConnectionId(c.o_t_id);
        if let Some((out, data, run)) = write {
            // A refusal drops the data; the connection stays open.
            let _ = app.write_assembly(
                out,
                data,
                WriteOrigin::Io {
                    connection: id,
                    run,
                },
            );
        }
        IoOutcome::Consumed
    }

    /// Closes the connections whose watchdog expired (telling the
    /// application), then returns the next T->O datagram that is due,
    /// written into `out`, and where to send it. Call it until it returns
    /// `None`. A datagram more than one RPI late is sent once, not once per
    /// missed interval.
    pub fn poll<A: Application>(
        &mut self,
        now: Instant,
        app: &mut A,
        out: &mut [u8],
    ) -> Option<(SocketAddrV4, usize)> {
        while let Some(i) = self.conns.iter().position(|c| c.deadline <= now) {
            let c = self.conns.swap_remove(i);
            log_debug!("enip: connection {=u32:#x} timed out", c.o_t_id);
            app.event(Event::Closed {
                connection: c.id(),
                kind: c.kind,
                reason: CloseReason::TimedOut,
            });
        }
        loop {
            let c = self
                .conns
                .iter_mut()
                .filter(|c| c.is_io() && c.next_production <= now)
                .min_by_key(|c| c.next_production)?;
            let rpi = u64::from(c.t_o_rpi);
            c.next_production = c.next_production.plus_micros(rpi);
            if c.next_production <= now {
                c.next_production = now.plus_micros(rpi);
            }
            c.t_o_sequence = c.t_o_sequence.wrapping_add(1);
            c.t_o_count = c.t_o_count.wrapping_add(1);
            let (id, seq, count, input, size, dest) = (
                c.t_o_id,
                c.t_o_sequence,
                c.t_o_count,
                c.input,
                c.input_size,
                c.dest,
            );
            let mut w = Writer::new(out);
            let written = (|| {
                let mut cpf = CpfWriter::begin(&mut w)?;
                let mut addr = [0u8; 8];
                addr[..4].copy_from_slice(&id.to_le_bytes());
                addr[4..].copy_from_slice(&seq.to_le_bytes());
                cpf.item(&mut w, ItemType::SequencedAddress, &addr)?;
                cpf.item_with(&mut w, ItemType::ConnectedData, |w| {
                    w.u16(count, "sequence count")?;
                    let buf = w.reserve(usize::from(size), "input data")?;
                    if let Some(i) = input {
                        app.read_assembly(i, buf);
                    }
                    Ok::<(), crate::wire::Error>(())
                })
            })();
            if written.is_ok() {
                c.produced = c.produced.wrapping_add(1);
                return Some((dest, w.len()));
            }
            // A buffer too small for this connection: the interval passes
            // without a datagram (the caller's buffer is the bound).
        }
    }

    /// When [`Adapter::poll`] next has something to do: a T->O datagram or a
    /// watchdog. `None` without connections.
    pub fn poll_at(&self) -> Option<Instant> {
        self.conns
            .iter()
            .map(|c| {
                if c.is_io() {
                    c.deadline.min(c.next_production)
                } else {
                    c.deadline
                }
            })
            .min()
    }
}

/// The data of the path's data segment, if any.
fn config_data(path: &[u8]) -> Option<&[u8]> {
    segments(path).find_map(|s| match s {
        Ok(Segment::Data(d)) if !d.is_empty() => Some(d),
        _ => None,
    })
}
