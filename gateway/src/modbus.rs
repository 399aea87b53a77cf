//! The Modbus TCP server: sessions, function codes, exceptions.
//!
//! PDUs are decoded and responses encoded with `modbus-core`; this module
//! reads whole ADUs off the stream (the MBAP length says how many bytes),
//! checks what `modbus-core` leaves to the server (quantities, byte counts,
//! addresses), and maps the request onto the register map.
//!
//! | FC | what | limits (else exception 03) |
//! |---|---|---|
//! | 1, 2 | read coils / discrete inputs (bits of registers) | 1-2000 bits |
//! | 3, 4 | read holding / input registers (one address space) | 1-125 |
//! | 5 | write single coil | value 0x0000 or 0xFF00 |
//! | 6 | write single register | |
//! | 15 | write multiple coils | 1-1968 bits, byte count matches |
//! | 16 | write multiple registers | 1-123, byte count matches |
//! | 23 | read/write multiple registers (write first) | read 1-125, write 1-121 |
//!
//! Other function codes get exception 01; unmapped addresses, or writes to
//! read-only ones, exception 02 (nothing is written); a configuration
//! command that cannot be saved, exception 04. A frame longer than any
//! Modbus ADU (MBAP length > 254, e.g. FC 16 with 124 registers) is read
//! off the stream and answered with exception 03 (01 for a function code
//! not in the table), as the specification asks for a quantity out of range.
//! A frame whose MBAP header is not Modbus (protocol id ≠ 0, length < 2)
//! closes that client's connection only. Unit ids are not checked (the gateway answers all).
//! A client silent for [`IDLE_TIMEOUT`] is disconnected.
//!
//! Sessions ([`Slots`], by the rules of `crate::admission`): at most
//! [`MAX_CLIENTS`] clients are served at once, at most [`PER_ADDRESS`] of
//! them from one address; one more socket accepts a newcomer while all
//! are served. A frame must be whole within [`FRAME_DEADLINE`] of its
//! first byte, else the connection is closed (so a trickle of partial
//! headers holds a slot for at most that long). A session that has not
//! completed a request for [`EVICT_IDLE`] (and is not in the middle of
//! one) is *idle*: when all slots are taken, the newcomer, once the
//! allow-list admits it, takes the slot of the longest-idle one, which is
//! closed. With none idle, the newcomer waits at most [`CLAIM_WAIT`] for a
//! slot (in that time every session not completing requests became idle
//! or was closed), else it is closed. When the newcomer's address already
//! has its [`PER_ADDRESS`] sessions, the newest connection wins: the least
//! recently active of them (not in the middle of a frame) is closed for
//! it, at once; if all are mid-frame, the newcomer is closed at once
//! ([`LIMITS`]: no newcomer waits for its own address's sessions).
//! The allow-list is checked at accept and before each request; applying a
//! configuration closes at once the sessions it no longer permits
//! (`Slots::close_unless`). A session asked to close, for that or for a
//! newcomer, is served no further request.
//!
//! Authorization by role ([`Grant`]): a client whose socket knows its role
//! (Modbus/TCP Security on Linux: the role extension of its certificate,
//! the Linux platform's TLS hands the server its certificate's claim:
//! `net::PeerClaim`) may write only as an operator or administrator; a
//! viewer's write (FC 5, 6, 15, 16, 23) gets exception 01 (Illegal
//! Function, as the MB/TCP Security specification asks), nothing of it is
//! written, and `WRITES_REFUSED` counts it. A plain connection has no role:
//! it may write what the write protection lets it.

use core::convert::Infallible;
use core::net::SocketAddrV4;

use embassy_futures::select::{select, Either};
use embassy_time::{Duration, Instant};
use modbus_core::tcp::{server::encode_response, Header, ResponseAdu};
use modbus_core::{
    Data, Exception, ExceptionResponse, FunctionCode, Request, Response, ResponsePdu,
};

use crate::access::accounts::Role;
use crate::admission::{self, octets, Guard, Limits, Refusal, Session};
use crate::clock::{with_deadline, Clock};
use crate::net::{PeerClaim, Socket};
use crate::registers::{self as r, AccessError, WriteError};

/// What the server serves: a register map (the gateway's is
/// [`crate::hub::PlcPort`]; tests may serve another).
///
/// Requests are handled at once, without awaiting, except a write that
/// started something slow (a configuration save): its answer waits for
/// [`Registers::settle`]. So a session holds no request buffers across an
/// await but its frame and its reply.
// The futures are deliberately not `Send` (single-threaded executors).
#[allow(async_fn_in_trait)]
pub(crate) trait Registers {
    /// Reads `out.len()` registers from `start`.
    fn read(&self, start: u16, out: &mut [u16]) -> Result<(), AccessError>;
    /// Writes `values` from `start` for the client at `peer` (its address
    /// goes into the audit records the write causes): all or nothing.
    /// `Ok(Some(p))`: stored, but the answer waits for
    /// [`Self::settle`]`(p)`.
    fn write(
        &self,
        start: u16,
        values: &[u16],
        peer: Option<SocketAddrV4>,
    ) -> Result<Option<Pending>, WriteError>;
    /// Waits for what a write of the client at `peer` started, and gives
    /// the write's result.
    async fn settle(&self, pending: Pending, peer: Option<SocketAddrV4>) -> Result<(), WriteError>;
    /// A client at `peer` connected: `Some(n)` when it is admitted (`n`
    /// clients connected now), `None` when the allow-list refuses it (the
    /// server closes the connection at once, without a reply; the refusal
    /// is counted).
    fn admit(&self, peer: Option<SocketAddrV4>) -> Option<u16>;
    /// The admitted client at `peer` left; returns how many are connected.
    fn leave(&self, peer: Option<SocketAddrV4>) -> u16;
    /// The allow-list in use permits a client at `peer` (nothing counted):
    /// asked at accept and before each request.
    fn permits(&self, peer: Option<SocketAddrV4>) -> bool;
    /// The session table the sessions share (and whoever closes them).
    fn slots(&self) -> &Slots;
    /// Whether a slot is reserved for the PLC, and whether the client at
    /// `peer` is the PLC (asked at accept; `crate::admission`). None by
    /// default.
    fn guard(&self, peer: Option<SocketAddrV4>) -> Guard {
        let _ = peer;
        Guard::NONE
    }
    /// A write of the client at `peer` was refused by its role
    /// ([`Grant::ReadOnly`]): counted (`WRITES_REFUSED`).
    fn write_refused(&self, peer: Option<SocketAddrV4>) {
        let _ = peer;
    }
}

/// What a session may do with the registers, by its client's role.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Grant {
    /// Read, and write what the write protection lets it.
    ReadWrite,
    /// Read only: a write gets exception 01.
    ReadOnly,
}

impl Grant {
    /// The grant of a client whose transport says `claim` of it: a plain
    /// connection (which the allow-list alone admits) and a certificate
    /// naming the operator's or the administrator's role read and write;
    /// a certificate naming the viewer's role, another word or none reads
    /// only (the least role: unknown claims fail closed).
    pub(crate) fn of(claim: &PeerClaim) -> Grant {
        match claim {
            PeerClaim::None => Grant::ReadWrite,
            PeerClaim::Certificate(word) => match word.as_deref().and_then(Role::parse) {
                Some(Role::Operator | Role::Admin) => Grant::ReadWrite,
                Some(Role::Viewer) | None => Grant::ReadOnly,
            },
        }
    }
}

/// `true` for the function codes that write (FC 23 reads too: refused
/// whole).
fn writes(fc: u8) -> bool {
    matches!(fc, 5 | 6 | 15 | 16 | 23)
}

/// The answer to the request `adu` when `grant` does not let it through:
/// exception 01 for a write of a read-only client, written into `out`
/// (its length); `None` when the request may be served.
fn refuse(grant: Grant, adu: &[u8], out: &mut [u8]) -> Option<usize> {
    let (&[t0, t1, _, _, _, _, unit], Some(&fc)) = (adu.first_chunk::<7>()?, adu.get(7)) else {
        return None;
    };
    if grant == Grant::ReadWrite || !writes(fc) {
        return None;
    }
    let hdr = Header {
        transaction_id: u16::from_be_bytes([t0, t1]),
        unit_id: unit,
    };
    exception_reply(hdr, fc, Exception::IllegalFunction, out)
}

/// What a write started that its answer waits for (for the gateway: a
/// configuration command).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(crate) struct Pending(pub u16);

/// The answer to a write that waits for [`Registers::settle`]: what it
/// will be if the write succeeds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Deferred {
    hdr: Header,
    fc: u8,
    ok: DeferredOk,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum DeferredOk {
    /// FC 5 and 6: the request's address and value, echoed.
    Echo([u8; 4]),
    /// FC 15 and 16: address and quantity.
    Count(u16, u16),
    /// FC 23: the registers to read after the write.
    ReadBack(u16, u16),
}

/// How a request is answered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Answer {
    /// The reply is in the output buffer: its length.
    Now(usize),
    /// The reply waits for the write's pending work: see [`finish`].
    After(Pending, Deferred),
}

/// Longest ADU: 7-byte MBAP header + 253-byte PDU.
pub(crate) const MAX_ADU: usize = 260;
/// An exception reply: 7-byte MBAP header, function code, exception code.
const EXCEPTION_ADU: usize = 9;
/// A client that sends nothing for this long is disconnected.
pub(crate) const IDLE_TIMEOUT: Duration = Duration::from_secs(120);
/// A frame must be whole this long after its first byte, else the
/// connection is closed. A Modbus ADU is at most 260 bytes: one TCP
/// segment on Ethernet, a quarter of a second even through a 9600 baud
/// serial bridge, and a lost segment is sent again well within a second
/// (Linux's shortest retransmission timeout is 200 ms). Longer only helps
/// a client that holds a slot with a trickle of bytes.
pub(crate) const FRAME_DEADLINE: Duration = Duration::from_secs(1);
/// A session that has not completed a request for this long (and is not
/// in the middle of one) is idle: a newcomer may take its slot. Twice a
/// PLC's or HMI's usual slowest poll cycle (10 ms - 1 s), so that a
/// polling client is never taken for idle; a client idle longer is closed
/// only when a newcomer needs its slot.
pub(crate) const EVICT_IDLE: Duration = Duration::from_secs(2);
/// Clients served at once.
pub(crate) const MAX_CLIENTS: usize = crate::limits::MODBUS_CLIENTS;
/// Sockets (session futures) of the server: one more than the clients
/// served, so that one always accepts a newcomer, which may then take an
/// idle session's slot.
pub(crate) const SOCKETS: usize = crate::limits::MAX_SESSIONS;
/// Clients served at once from one address.
/// One fewer than all of them: one address (a scanner, a flood) always
/// leaves a slot for another, while a host running several clients (an
/// HMI and a diagnostics tool, or clients behind one NAT) is not turned
/// away at its second.
pub(crate) const PER_ADDRESS: usize = MAX_CLIENTS - 1;

/// The longest a newcomer waits for a slot: by then every session that
/// is not completing requests was idle for [`EVICT_IDLE`] or closed at
/// its [`FRAME_DEADLINE`].
pub(crate) const CLAIM_WAIT: Duration =
    Duration::from_millis(EVICT_IDLE.as_millis() + FRAME_DEADLINE.as_millis());
/// The sessions' table: who is served, since when idle, who is asked to
/// close. Shared by the session futures (and the hub, which closes the
/// sessions an allow-list no longer permits).
pub(crate) type Slots = admission::Slots<SOCKETS, MAX_CLIENTS, PER_ADDRESS>;
/// The sessions' times. A newcomer whose address has its [`PER_ADDRESS`]
/// sessions, all in the middle of a frame, is closed at once: none waits
/// for its own address's sessions (a client that reconnects finds its old
/// session quiet, and takes its place).
pub(crate) const LIMITS: Limits = Limits {
    evict_idle: EVICT_IDLE,
    claim_wait: CLAIM_WAIT,
    waiting_per_address: 0,
};
/// The server's name in log lines.
pub(crate) const NAME: &str = "modbus";

/// Serves Modbus clients on `port`, one after the other, forever, as
/// socket `i` of the [`SOCKETS`] (its entry in [`Registers::slots`]).
pub(crate) async fn session<S: Socket, C: Clock, R: Registers>(
    regs: &R,
    clock: &C,
    mut sock: S,
    port: u16,
    i: usize,
) -> Infallible {
    let slots = regs.slots();
    loop {
        if sock.accept(port).await.is_err() {
            clock.sleep(Duration::from_millis(500)).await;
            continue;
        }
        let peer = sock.remote();
        let [a, b, c, d] = octets(peer);
        // The allow-list before anything else: a client it refuses takes
        // no slot and closes nobody's.
        if !regs.permits(peer) {
            // Refused: `admit` counts it in MODBUS_REFUSED.
            let _ = regs.admit(peer);
            slots.refused(Refusal::NotAllowed, peer);
            sock.close().await;
            continue;
        }
        if let Err(why) = slots.claim(i, peer, regs.guard(peer), clock).await {
            slots.refused(why, peer);
            sock.close().await;
            continue;
        }
        let Some(n) = regs.admit(peer) else {
            slots.release(i);
            slots.refused(Refusal::NotAllowed, peer);
            sock.close().await;
            continue;
        };
        info!(
            "modbus: client {}.{}.{}.{}:{} connected ({} now)",
            a,
            b,
            c,
            d,
            peer.map_or(0, |p| p.port()),
            n
        );
        serve(regs, clock, &mut sock, i, peer).await;
        sock.close().await;
        slots.release(i);
        let n = regs.leave(peer);
        info!("modbus: client disconnected ({} left)", n);
    }
}

/// Serves one client (socket `i`, at `peer`) until it leaves, falls
/// silent, is too slow with a frame, sends what is not Modbus TCP, or is
/// asked to close ([`Slots`]).
pub(crate) async fn serve<S: Socket, C: Clock, R: Registers>(
    regs: &R,
    clock: &C,
    sock: &mut S,
    i: usize,
    peer: Option<SocketAddrV4>,
) {
    let session = regs.slots().session(i);
    let mut buf = [0u8; MAX_ADU];
    let mut out = [0u8; MAX_ADU];
    let mut len = 0usize;
    // When the first byte of the frame in `buf` came.
    let mut started: Option<Instant> = None;
    loop {
        // Header first, then as many bytes as its length field says.
        let need = match buf.get(..7) {
            Some(&[_, _, p0, p1, l0, l1, _]) if len >= 7 => {
                let proto = u16::from_be_bytes([p0, p1]);
                let length = usize::from(u16::from_be_bytes([l0, l1]));
                if proto != 0 || length < 2 {
                    info!(
                        "modbus: not a Modbus frame (protocol {}, length {}), closing",
                        proto, length
                    );
                    return;
                }
                if length > MAX_ADU - 6 {
                    // Longer than any Modbus ADU: too many values (e.g.
                    // FC 16 with 124 registers). Read it off the stream and
                    // answer as for any quantity out of range.
                    if len < 8 {
                        8
                    } else {
                        let deadline = started.unwrap_or_else(|| clock.now()) + FRAME_DEADLINE;
                        let Some(n) =
                            oversized(clock, sock, &buf, len, 6 + length, &mut out, deadline).await
                        else {
                            return;
                        };
                        if !may_serve(regs, session, peer)
                            || !reply(session, sock, out.get(..n)).await
                        {
                            return;
                        }
                        session.answered(clock.now());
                        len = 0;
                        started = None;
                        continue;
                    }
                } else {
                    6 + length
                }
            }
            _ => 7,
        };
        if len < need {
            let Some(free) = buf.get_mut(len..) else {
                return;
            };
            let deadline = match started {
                Some(t) => t + FRAME_DEADLINE,
                None => clock.now() + IDLE_TIMEOUT,
            };
            let read = select(sock.read(free), session.closing());
            match with_deadline(clock, deadline, read).await {
                Ok(Either::First(Ok(0) | Err(_))) => return,
                Ok(Either::First(Ok(n))) => {
                    if started.is_none() {
                        let now = clock.now();
                        started = Some(now);
                        session.started();
                    }
                    len += n;
                }
                Ok(Either::Second(why)) => {
                    regs.slots().closed(why, peer);
                    return;
                }
                Err(_) if started.is_some() => {
                    info!(
                        "modbus: frame not whole {} ms after its first byte, closing",
                        FRAME_DEADLINE.as_millis()
                    );
                    return;
                }
                Err(_) => {
                    info!("modbus: client idle, closing");
                    return;
                }
            }
            continue;
        }
        let Some(adu) = buf.get(..need) else {
            return;
        };
        if !may_serve(regs, session, peer) {
            return;
        }
        // The role as it is now: known once the TLS handshake ended.
        let answer = if let Some(n) = refuse(Grant::of(&sock.peer_claim()), adu, &mut out) {
            regs.write_refused(peer);
            let [a, b, c, d] = octets(peer);
            warn!(
                "modbus: write (fc {}) of client {}.{}.{}.{} refused: its certificate's role may only read",
                adu.get(7).copied().unwrap_or(0),
                a,
                b,
                c,
                d
            );
            Some(n)
        } else {
            match handle(regs, adu, &mut out, peer) {
                Some(Answer::Now(n)) => Some(n),
                Some(Answer::After(p, d)) => finish(regs, p, d, &mut out, peer).await,
                None => None,
            }
        };
        if let Some(n) = answer {
            if !reply(session, sock, out.get(..n)).await {
                return;
            }
        }
        buf.copy_within(need..len, 0);
        len -= need;
        let now = clock.now();
        session.answered(now);
        // What is left is the start of the next frame.
        started = (len > 0).then_some(now);
        if started.is_some() {
            session.started();
        }
    }
}

/// The session may be served another request: it was not asked to close
/// (for a newcomer, or by an allow-list applied since), and the allow-list
/// in use, not only the one at accept, permits its client. Logs why not.
fn may_serve<R: Registers>(regs: &R, session: Session<'_>, peer: Option<SocketAddrV4>) -> bool {
    let Some(why) = session.check(regs.permits(peer)) else {
        return true;
    };
    regs.slots().closed(why, peer);
    false
}

/// Writes `bytes` unless the session is asked to close first; `false`
/// when the session ends.
async fn reply<S: Socket>(session: Session<'_>, sock: &mut S, bytes: Option<&[u8]>) -> bool {
    match select(sock.write_all(bytes.unwrap_or(&[])), session.closing()).await {
        Either::First(r) => r.is_ok(),
        Either::Second(_) => false,
    }
}

/// A frame of `total` bytes that cannot fit [`MAX_ADU`], of which `head`
/// holds the first `have` (header and function code): reads the rest off
/// the stream without keeping it and writes the exception reply into
/// `out` (03, or 01 for a function code not [`served`]). `None` when the client
/// went away or the frame was not whole by `deadline`.
async fn oversized<S: Socket, C: Clock>(
    clock: &C,
    sock: &mut S,
    head: &[u8; MAX_ADU],
    have: usize,
    total: usize,
    out: &mut [u8; MAX_ADU],
    deadline: Instant,
) -> Option<usize> {
    let fc = head[7];
    debug!("modbus: fc {} frame of {} bytes, too long", fc, total);
    let mut sink = [0u8; 64];
    let mut left = total.saturating_sub(have);
    while left > 0 {
        let room = sink.get_mut(..left.min(64))?;
        match with_deadline(clock, deadline, sock.read(room)).await {
            Ok(Ok(n)) if n > 0 => left = left.saturating_sub(n),
            _ => return None,
        }
    }
    let code = if served(FunctionCode::new(fc & 0x7F)) {
        Exception::IllegalDataValue
    } else {
        Exception::IllegalFunction
    };
    let hdr = Header {
        transaction_id: u16::from_be_bytes([head[0], head[1]]),
        unit_id: head[6],
    };
    exception_reply(hdr, fc, code, out)
}

/// `true` for the function codes [`execute`] answers.
fn served(fc: FunctionCode) -> bool {
    matches!(
        fc,
        FunctionCode::ReadCoils
            | FunctionCode::ReadDiscreteInputs
            | FunctionCode::ReadHoldingRegisters
            | FunctionCode::ReadInputRegisters
            | FunctionCode::WriteSingleCoil
            | FunctionCode::WriteSingleRegister
            | FunctionCode::WriteMultipleCoils
            | FunctionCode::WriteMultipleRegisters
            | FunctionCode::ReadWriteMultipleRegisters
    )
}

/// Writes exception `e` to a request of function code `fc` into `out`;
/// returns its length. Function codes of 0x80 and above are malformed
/// requests: answered as for their low 7 bits (modbus-core adds 0x80).
fn exception_reply(hdr: Header, fc: u8, e: Exception, out: &mut [u8]) -> Option<usize> {
    // The reply is 9 bytes; modbus-core 0.2 would index past a buffer with
    // room for only one byte of the PDU.
    if out.len() < EXCEPTION_ADU {
        return None;
    }
    debug!("modbus: fc {} -> exception {}", fc, e as u8);
    let pdu = ResponsePdu(Err(ExceptionResponse {
        function: FunctionCode::new(fc & 0x7F),
        exception: e,
    }));
    encode_response(ResponseAdu { hdr, pdu }, out).ok()
}

fn exception(e: WriteError) -> Exception {
    match e {
        WriteError::Address => Exception::IllegalDataAddress,
        WriteError::Value => Exception::IllegalDataValue,
        WriteError::Device => Exception::ServerDeviceFailure,
        WriteError::Protected => Exception::IllegalFunction,
    }
}

/// Answers one complete ADU of the client at `peer`; `None` if nothing can
/// be answered.
pub(crate) fn handle<R: Registers>(
    regs: &R,
    adu: &[u8],
    out: &mut [u8],
    peer: Option<SocketAddrV4>,
) -> Option<Answer> {
    let pdu_len = adu.len().checked_sub(7)?;
    let frame = modbus_core::tcp::extract_frame(adu, pdu_len).ok()??;
    let hdr = Header {
        transaction_id: frame.transaction_id,
        unit_id: frame.unit_id,
    };
    let pdu = frame.pdu;
    let fc = *pdu.first()?;
    let mut data = [0u8; 252];
    let result = match Request::try_from(pdu) {
        Ok(Request::Custom(..)) | Err(modbus_core::Error::FnCode(_)) => {
            Err(Exception::IllegalFunction)
        }
        Err(_) => Err(Exception::IllegalDataValue),
        Ok(req) => execute(regs, req, pdu, &mut data, peer),
    };
    match result {
        Ok(Executed::Done(resp)) => encode_response(
            ResponseAdu {
                hdr,
                pdu: ResponsePdu(Ok(resp)),
            },
            out,
        )
        .ok()
        .map(Answer::Now),
        Ok(Executed::Pending(p, ok)) => Some(Answer::After(p, Deferred { hdr, fc, ok })),
        Err(e) => exception_reply(hdr, fc, e, out).map(Answer::Now),
    }
}

/// Waits for a write's pending work (of the client at `peer`), then
/// writes its answer into `out`.
pub(crate) async fn finish<R: Registers>(
    regs: &R,
    p: Pending,
    d: Deferred,
    out: &mut [u8],
    peer: Option<SocketAddrV4>,
) -> Option<usize> {
    if let Err(e) = regs.settle(p, peer).await {
        return exception_reply(d.hdr, d.fc, exception(e), out);
    }
    let mut data = [0u8; 252];
    let mut words = [0u16; 125];
    let resp = match d.ok {
        DeferredOk::Echo(echo) => {
            let dst = data.get_mut(..4)?;
            dst.copy_from_slice(&echo);
            match d.fc {
                5 => Response::Custom(FunctionCode::WriteSingleCoil, dst),
                _ => Response::WriteSingleRegister(be16(&echo, 0), be16(&echo, 2)),
            }
        }
        DeferredOk::Count(addr, qty) => match d.fc {
            15 => Response::WriteMultipleCoils(addr, qty),
            _ => Response::WriteMultipleRegisters(addr, qty),
        },
        DeferredOk::ReadBack(addr, qty) => {
            let w = words.get_mut(..usize::from(qty))?;
            if regs.read(addr, w).is_err() {
                return exception_reply(d.hdr, d.fc, Exception::IllegalDataAddress, out);
            }
            Response::ReadWriteMultipleRegisters(Data::from_words(w, &mut data).ok()?)
        }
    };
    encode_response(
        ResponseAdu {
            hdr: d.hdr,
            pdu: ResponsePdu(Ok(resp)),
        },
        out,
    )
    .ok()
}

/// A request executed: its response, or the write's pending work and what
/// the response will be.
enum Executed<'d> {
    Done(Response<'d>),
    Pending(Pending, DeferredOk),
}

fn be16(b: &[u8], at: usize) -> u16 {
    u16::from_be_bytes([
        b.get(at).copied().unwrap_or(0),
        b.get(at + 1).copied().unwrap_or(0),
    ])
}

/// Reads `qty` bits from `addr` packed as the reply wants them (bit `i` in
/// bit `i % 8` of byte `i / 8`) into `packed`; returns the bytes used.
/// Packs straight from the registers: no array of 2000 `bool`s.
fn read_bits<R: Registers>(
    regs: &R,
    addr: u16,
    qty: u16,
    packed: &mut [u8],
) -> Result<usize, Exception> {
    if !(1..=2000).contains(&qty) {
        return Err(Exception::IllegalDataValue);
    }
    let last = u32::from(addr) + u32::from(qty) - 1;
    if last > 0xFFFF {
        return Err(Exception::IllegalDataAddress);
    }
    let first_reg = addr / 16;
    let count = (last / 16) as u16 - first_reg + 1;
    let mut words = [0u16; 126];
    let w = words
        .get_mut(..usize::from(count))
        .ok_or(Exception::IllegalDataAddress)?;
    regs.read(first_reg, w)
        .map_err(|_| Exception::IllegalDataAddress)?;
    let bytes = usize::from(qty).div_ceil(8);
    let out = packed
        .get_mut(..bytes)
        .ok_or(Exception::ServerDeviceFailure)?;
    out.fill(0);
    for i in 0..usize::from(qty) {
        let bit = usize::from(addr) + i;
        let word = w
            .get(bit / 16 - usize::from(first_reg))
            .copied()
            .unwrap_or(0);
        if word & (1 << (bit % 16)) != 0 {
            if let Some(b) = out.get_mut(i / 8) {
                *b |= 1 << (i % 8);
            }
        }
    }
    Ok(bytes)
}

/// Writes `qty` bits from `addr`, taking bit `i` from `bit(i)`, for the
/// client at `peer`.
fn write_bits<R: Registers>(
    regs: &R,
    addr: u16,
    qty: u16,
    bit: impl Fn(usize) -> bool,
    peer: Option<SocketAddrV4>,
) -> Result<Option<Pending>, Exception> {
    let last = u32::from(addr) + u32::from(qty) - 1;
    if last > 0xFFFF {
        return Err(Exception::IllegalDataAddress);
    }
    let first_reg = addr / 16;
    let count = (last / 16) as u16 - first_reg + 1;
    r::check(first_reg, count, true).map_err(|_| Exception::IllegalDataAddress)?;
    let mut words = [0u16; 124];
    let w = words
        .get_mut(..usize::from(count))
        .ok_or(Exception::IllegalDataAddress)?;
    regs.read(first_reg, w)
        .map_err(|_| Exception::IllegalDataAddress)?;
    for i in 0..usize::from(qty) {
        let b = usize::from(addr) + i;
        if let Some(word) = w.get_mut(b / 16 - usize::from(first_reg)) {
            if bit(i) {
                *word |= 1 << (b % 16);
            } else {
                *word &= !(1 << (b % 16));
            }
        }
    }
    regs.write(first_reg, w, peer).map_err(exception)
}

fn execute<'d, R: Registers>(
    regs: &R,
    req: Request<'_>,
    pdu: &[u8],
    data: &'d mut [u8; 252],
    peer: Option<SocketAddrV4>,
) -> Result<Executed<'d>, Exception> {
    use Executed::Done;
    let mut words = [0u16; 125];
    match req {
        Request::ReadCoils(addr, qty) | Request::ReadDiscreteInputs(addr, qty) => {
            // Byte count, then the packed bits (the standard reply, written
            // here so that no array of 2000 bools is needed).
            let (count, bits) = data.split_at_mut(1);
            let n = read_bits(regs, addr, qty, bits)?;
            if let Some(c) = count.first_mut() {
                *c = n as u8;
            }
            let fc = match req {
                Request::ReadCoils(..) => FunctionCode::ReadCoils,
                _ => FunctionCode::ReadDiscreteInputs,
            };
            let d = data.get(..1 + n).ok_or(Exception::ServerDeviceFailure)?;
            Ok(Done(Response::Custom(fc, d)))
        }
        Request::ReadHoldingRegisters(addr, qty) | Request::ReadInputRegisters(addr, qty) => {
            if !(1..=125).contains(&qty) {
                return Err(Exception::IllegalDataValue);
            }
            let w = words
                .get_mut(..usize::from(qty))
                .ok_or(Exception::IllegalDataValue)?;
            regs.read(addr, w)
                .map_err(|_| Exception::IllegalDataAddress)?;
            let d = Data::from_words(w, data).map_err(|_| Exception::ServerDeviceFailure)?;
            Ok(Done(match req {
                Request::ReadHoldingRegisters(..) => Response::ReadHoldingRegisters(d),
                _ => Response::ReadInputRegisters(d),
            }))
        }
        Request::WriteSingleCoil(addr, on) => {
            let pending = write_bits(regs, addr, 1, |_| on, peer)?;
            // modbus-core 0.2 encodes this response without the value; the
            // standard answer echoes the request.
            let echo = pdu.get(1..5).ok_or(Exception::IllegalDataValue)?;
            if let Some(p) = pending {
                let mut e = [0u8; 4];
                e.copy_from_slice(echo);
                return Ok(Executed::Pending(p, DeferredOk::Echo(e)));
            }
            let d = data.get_mut(..4).ok_or(Exception::ServerDeviceFailure)?;
            d.copy_from_slice(echo);
            Ok(Done(Response::Custom(FunctionCode::WriteSingleCoil, d)))
        }
        Request::WriteSingleRegister(addr, value) => {
            if let Some(p) = regs.write(addr, &[value], peer).map_err(exception)? {
                let [a, b] = addr.to_be_bytes();
                let [c, d] = value.to_be_bytes();
                return Ok(Executed::Pending(p, DeferredOk::Echo([a, b, c, d])));
            }
            Ok(Done(Response::WriteSingleRegister(addr, value)))
        }
        Request::WriteMultipleCoils(addr, coils) => {
            let qty = be16(pdu, 3);
            let count = usize::from(*pdu.get(5).ok_or(Exception::IllegalDataValue)?);
            if !(1..=1968).contains(&qty)
                || count != usize::from(qty).div_ceil(8)
                || pdu.len() != 6 + count
            {
                return Err(Exception::IllegalDataValue);
            }
            if let Some(p) = write_bits(regs, addr, qty, |i| coils.get(i).unwrap_or(false), peer)? {
                return Ok(Executed::Pending(p, DeferredOk::Count(addr, qty)));
            }
            Ok(Done(Response::WriteMultipleCoils(addr, qty)))
        }
        Request::WriteMultipleRegisters(addr, values) => {
            let qty = be16(pdu, 3);
            let count = usize::from(*pdu.get(5).ok_or(Exception::IllegalDataValue)?);
            if !(1..=123).contains(&qty) || count != 2 * usize::from(qty) || pdu.len() != 6 + count
            {
                return Err(Exception::IllegalDataValue);
            }
            let w = words
                .get_mut(..usize::from(qty))
                .ok_or(Exception::IllegalDataValue)?;
            for (i, slot) in w.iter_mut().enumerate() {
                *slot = values.get(i).ok_or(Exception::IllegalDataValue)?;
            }
            if let Some(p) = regs.write(addr, w, peer).map_err(exception)? {
                return Ok(Executed::Pending(p, DeferredOk::Count(addr, qty)));
            }
            Ok(Done(Response::WriteMultipleRegisters(addr, qty)))
        }
        Request::ReadWriteMultipleRegisters(raddr, rqty, waddr, values) => {
            let wqty = be16(pdu, 7);
            let count = usize::from(*pdu.get(9).ok_or(Exception::IllegalDataValue)?);
            if !(1..=125).contains(&rqty)
                || !(1..=121).contains(&wqty)
                || count != 2 * usize::from(wqty)
                || pdu.len() != 10 + count
            {
                return Err(Exception::IllegalDataValue);
            }
            r::check(raddr, rqty, false).map_err(|_| Exception::IllegalDataAddress)?;
            let mut wv = [0u16; 121];
            let wv = wv
                .get_mut(..usize::from(wqty))
                .ok_or(Exception::IllegalDataValue)?;
            for (i, slot) in wv.iter_mut().enumerate() {
                *slot = values.get(i).ok_or(Exception::IllegalDataValue)?;
            }
            if let Some(p) = regs.write(waddr, wv, peer).map_err(exception)? {
                return Ok(Executed::Pending(p, DeferredOk::ReadBack(raddr, rqty)));
            }
            let w = words
                .get_mut(..usize::from(rqty))
                .ok_or(Exception::IllegalDataValue)?;
            regs.read(raddr, w)
                .map_err(|_| Exception::IllegalDataAddress)?;
            let d = Data::from_words(w, data).map_err(|_| Exception::ServerDeviceFailure)?;
            Ok(Done(Response::ReadWriteMultipleRegisters(d)))
        }
        Request::Custom(..) => Err(Exception::IllegalFunction),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The register map of a fresh gateway, without its tasks: the hub
    /// behind the PLC's port, at instant 0.
    struct Map {
        hub: crate::hub::Hub,
        clock: crate::testkit::clock::VirtualClock,
        slots: Slots,
    }

    impl Map {
        fn fresh() -> Map {
            let config = crate::Config::default();
            Map {
                hub: crate::hub::Hub::new(crate::state::Model::new(config, config)),
                clock: crate::testkit::clock::VirtualClock::new(),
                slots: Slots::new(NAME, &LIMITS),
            }
        }

        fn port(&self) -> crate::plc::PlcPort<'_, crate::testkit::clock::VirtualClock> {
            crate::plc::PlcPort {
                hub: &self.hub,
                clock: &self.clock,
                slots: &self.slots,
            }
        }
    }

    impl Registers for Map {
        fn read(&self, start: u16, out: &mut [u16]) -> Result<(), AccessError> {
            self.port().read(start, out)
        }
        fn write(
            &self,
            start: u16,
            values: &[u16],
            peer: Option<SocketAddrV4>,
        ) -> Result<Option<Pending>, WriteError> {
            self.port().write(start, values, peer)
        }
        async fn settle(&self, p: Pending, peer: Option<SocketAddrV4>) -> Result<(), WriteError> {
            self.port().settle(p, peer).await
        }
        fn admit(&self, peer: Option<SocketAddrV4>) -> Option<u16> {
            self.port().admit(peer)
        }
        fn leave(&self, peer: Option<SocketAddrV4>) -> u16 {
            self.port().leave(peer)
        }
        fn permits(&self, peer: Option<SocketAddrV4>) -> bool {
            self.port().permits(peer)
        }
        fn slots(&self) -> &Slots {
            &self.slots
        }
    }

    crate::admission::tests::admission_suite!(Slots::new(NAME, &LIMITS));

    fn answer(map: &Map, adu: &[u8]) -> Vec<u8> {
        let mut out = [0u8; MAX_ADU];
        let n = match handle(map, adu, &mut out, None).expect("an answer") {
            Answer::Now(n) => n,
            Answer::After(..) => panic!("no configuration command here"),
        };
        out[..n].to_vec()
    }

    #[test]
    fn exceptions_for_bad_requests() {
        let ctx = Map::fresh();
        assert_eq!(
            answer(&ctx, &[0, 1, 0, 0, 0, 2, 1, 0x2B]),
            [0, 1, 0, 0, 0, 3, 1, 0xAB, 1]
        );
        assert_eq!(
            answer(&ctx, &[0, 1, 0, 0, 0, 2, 1, 0x90]),
            [0, 1, 0, 0, 0, 3, 1, 0x90, 1]
        );
        assert_eq!(
            answer(&ctx, &[0, 1, 0, 0, 0, 6, 1, 3, 0, 64, 0, 1]),
            [0, 1, 0, 0, 0, 3, 1, 0x83, 2]
        );
        assert_eq!(
            answer(&ctx, &[0, 1, 0, 0, 0, 6, 1, 3, 0, 0, 0, 1]),
            [0, 1, 0, 0, 0, 5, 1, 3, 2, 1, 5]
        );
        // FC 1: bits 0-11 of register 0 (version 0x0105: bits 0, 2 and
        // 8), packed.
        assert_eq!(
            answer(&ctx, &[0, 1, 0, 0, 0, 6, 1, 1, 0, 0, 0, 12]),
            [0, 1, 0, 0, 0, 5, 1, 1, 2, 0x05, 0x01]
        );
        // FC 2 from bit 4, 988 bits (up to register 61): 124 bytes; bit 4
        // of the reply is bit 8 of register 0.
        let r = answer(&ctx, &[0, 1, 0, 0, 0, 6, 1, 2, 0, 4, 0x03, 0xDC]);
        assert_eq!((r[7], r[8], r.len()), (2, 124, 9 + 124));
        assert_eq!(r[9], 1 << 4);
        // From bit 4 to the status block's end (register 63): 1020 bits;
        // one bit more reaches register 64, unmapped: 02.
        let r = answer(&ctx, &[0, 1, 0, 0, 0, 6, 1, 2, 0, 4, 0x03, 0xFC]);
        assert_eq!((r[7], r[8], r.len()), (2, 128, 9 + 128));
        let r = answer(&ctx, &[0, 1, 0, 0, 0, 6, 1, 2, 0, 4, 0x03, 0xFD]);
        assert_eq!(&r[7..], [0x82, 2]);
        // FC 16 shorter than its header says -> 03, never a panic.
        assert_eq!(
            answer(&ctx, &[0, 1, 0, 0, 0, 5, 1, 0x10, 0, 140, 0]),
            [0, 1, 0, 0, 0, 3, 1, 0x90, 3]
        );
        assert_eq!(
            answer(&ctx, &[0, 1, 0, 0, 0, 3, 1, 0x0F, 0]),
            [0, 1, 0, 0, 0, 3, 1, 0x8F, 3]
        );
    }

    /// A viewer's certificate reads; its writes (every writing function
    /// code, FC 23 too) get exception 01 with the request's transaction
    /// and unit; an operator, an administrator and a plain connection are
    /// not refused here.
    #[test]
    fn a_read_only_grant_refuses_every_write_with_exception_01() {
        let mut out = [0u8; MAX_ADU];
        let cert = |w: Option<&str>| PeerClaim::Certificate(w.map(|w| w.try_into().unwrap()));
        let viewer = Grant::of(&cert(Some("viewer")));
        assert_eq!(viewer, Grant::ReadOnly);
        // Unknown words, none, and a handshake not ended: the least.
        for c in [cert(Some("root")), cert(Some("Admin")), cert(None)] {
            assert_eq!(Grant::of(&c), Grant::ReadOnly, "{c:?}");
        }
        for c in [PeerClaim::None, cert(Some("operator")), cert(Some("admin"))] {
            assert_eq!(Grant::of(&c), Grant::ReadWrite, "{c:?}");
        }
        let write = [0x12, 0x34, 0, 0, 0, 6, 7, 6, 0, 140, 0, 1];
        let n = refuse(viewer, &write, &mut out).expect("refused");
        assert_eq!(out[..n], [0x12, 0x34, 0, 0, 0, 3, 7, 0x86, 1]);
        for fc in [5, 6, 15, 16, 23] {
            let adu = [0, 1, 0, 0, 0, 2, 1, fc];
            let n = refuse(viewer, &adu, &mut out).expect("refused");
            assert_eq!(out[..n], [0, 1, 0, 0, 0, 3, 1, 0x80 | fc, 1], "fc {fc}");
            assert_eq!(refuse(Grant::ReadWrite, &adu, &mut out), None);
        }
        for fc in [1, 2, 3, 4, 0x2B, 0x86] {
            assert_eq!(refuse(viewer, &[0, 1, 0, 0, 0, 2, 1, fc], &mut out), None);
        }
        // Too short to be a request: left to the decoder.
        assert_eq!(refuse(viewer, &[0, 1, 0, 0, 0, 2, 1], &mut out), None);
    }

    #[test]
    fn exception_replies_name_the_function_and_the_code() {
        let mut out = [0u8; MAX_ADU];
        let hdr = Header {
            transaction_id: 0x1234,
            unit_id: 9,
        };
        let n = exception_reply(hdr, 0x10, Exception::IllegalDataValue, &mut out).unwrap();
        assert_eq!(out[..n], [0x12, 0x34, 0, 0, 0, 3, 9, 0x90, 3]);
        // A malformed code (0x80 set) is answered as its low 7 bits.
        let n = exception_reply(hdr, 0xC1, Exception::IllegalFunction, &mut out).unwrap();
        assert_eq!(out[..n], [0x12, 0x34, 0, 0, 0, 3, 9, 0xC1, 1]);
        // Too small a buffer: no reply, no panic.
        assert_eq!(
            exception_reply(
                hdr,
                3,
                Exception::IllegalFunction,
                &mut out[..EXCEPTION_ADU - 1]
            ),
            None
        );
        // The codes an oversized frame gets 03 for (else 01): those of the
        // module table, not 22 (MaskWriteRegister, known to modbus-core).
        let served: Vec<u8> = (0..=0x7F)
            .filter(|&c| served(FunctionCode::new(c)))
            .collect();
        assert_eq!(served, [1, 2, 3, 4, 5, 6, 15, 16, 23]);
    }
}
