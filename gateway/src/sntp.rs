//! Wall time for the audit log on boards: an SNTP client (RFC 4330) that
//! asks the server of `network.ntp_server` (feature `sntp`, part of the
//! field-device firmwares; Linux takes the host's clock instead).
//!
//! ## What it does
//! One future, joined into [`crate::board::run`], asks the configured
//! server at start and then every [`PERIOD`] (an hour), waiting
//! [`TIMEOUT`] (2 s) for each answer. A valid answer sets the audit log's
//! wall clock (`Log::set_wall_time`, which records a `time` event when the
//! time was unknown or moved by more than a second); between answers the
//! log counts on from the uptime. After a failure the next query comes
//! [`RETRY_FIRST`] (15 s) later, twice as long after each further failure,
//! at most [`PERIOD`]. A kiss-o'-death `DENY` or `RSTR` means "stop asking
//! me" (RFC 4330 section 8): that server is not asked again until the
//! setting names another one (or the board restarts); `RATE` and other
//! codes count as failures (they back off). The setting is read every
//! [`CONFIG_CHECK`] (10 s): a changed server is asked at once, with the
//! schedule started afresh; `0.0.0.0` asks nobody.
//!
//! ## Which answers count
//! The exchange and its checks are the `sntpc` crate's: an answer must come
//! from the server's address and port 123, carry our request's transmit
//! time as its origin time, be a server answer (mode 4) of version 1-4 from
//! stratum 1-15 (stratum 0 is a kiss-o'-death), not say "unsynchronised"
//! (leap indicator 3), have a transmit time, a root distance below 16 s
//! and a reference time not after its transmit time. Answers from
//! elsewhere, with another origin time or too short are not ours (a late
//! answer to an earlier query, a forgery): up to [`STRAYS`] of them are
//! passed over within one query. Here we add: the time must lie between
//! [`EARLIEST`] (2026-01-01; a server whose clock is unset answers 1900,
//! 1970 or 2000) and 2106 (the log's 32-bit seconds).
//!
//! The request's transmit time is the uptime plus [`EARLIEST`] plus a
//! random offset of up to 71 minutes, new for each query (32 bits from the
//! board's seed), and the socket's port is random too: an attacker who
//! cannot see the traffic must guess both to forge an answer. (`EARLIEST`
//! is also the pivot for the NTP era of the server's 32-bit seconds:
//! right until about 2094.)
//!
//! The time of an answer is the server's transmit time plus half the
//! round trip (at most [`TIMEOUT`]), taken at the instant the answer was
//! read; the log is given the instant its second began, so that it counts
//! whole seconds from there.
//!
//! ## Bounds
//! One UDP socket (in `board::SOCKETS`) with room for two datagrams of
//! 96 bytes (`RX_MAX`) and one request of 48; one query in flight, at most
//! [`STRAYS`] + 1 datagrams read per query; a server is asked at most
//! once per [`RETRY_FIRST`] (a changed setting is asked at once).
//!
//! ## Tests
//! The schedule and the checks run on the host against a fake socket in
//! virtual time (the tests below). The board's adapter (an embassy-net
//! UDP socket) is not run under QEMU: the QEMU tests' user network
//! (slirp, `restrict=on`) forwards only TCP (`guestfwd`), so the board
//! cannot reach a time server on the host.

use core::convert::Infallible;
use core::net::{Ipv4Addr, SocketAddr, SocketAddrV4};

use embassy_time::{Duration, Instant};
use sha2::{Digest, Sha256};
use sntpc::{KissOfDeathCode, NtpContext, NtpResult, NtpTimestampGenerator, NtpUdpSocket};

use crate::clock::{with_timeout, Clock};
use crate::hub::Hub;

/// The server's port.
pub(crate) const PORT: u16 = 123;
/// How long a query waits for its answer.
pub(crate) const TIMEOUT: Duration = Duration::from_secs(2);
/// The time between two queries that were answered.
pub(crate) const PERIOD: Duration = Duration::from_secs(3600);
/// The wait after a failed query; it doubles with each further failure,
/// up to [`PERIOD`].
pub(crate) const RETRY_FIRST: Duration = Duration::from_secs(15);
/// How often the setting `network.ntp_server` is looked at.
pub(crate) const CONFIG_CHECK: Duration = Duration::from_secs(10);
/// Datagrams that are not the answer (from elsewhere, another origin time,
/// too short) passed over within one query; one more ends it.
pub(crate) const STRAYS: usize = 4;
/// The earliest time an answer may give: 2026-01-01T00:00:00Z, in Unix
/// seconds (also the base of the request's transmit time).
pub(crate) const EARLIEST: u64 = 1_767_225_600;
/// The latest: the audit log keeps 32-bit Unix seconds (2106-02-07).
const LATEST: u64 = u32::MAX as u64;
const MICROS: u64 = 1_000_000;

/// Why a query gave no time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Failure {
    /// No answer within [`TIMEOUT`].
    Timeout,
    /// The request could not be sent (no address or route yet).
    Network,
    /// More than [`STRAYS`] datagrams that were not the answer.
    Strays,
    /// A kiss-o'-death: `DENY` and `RSTR` stop the asking, others back off.
    Kiss(KissOfDeathCode),
    /// An answer that failed sntpc's checks (see the module docs).
    Invalid(sntpc::Error),
    /// A valid answer with a time outside [`EARLIEST`] to 2106.
    Implausible(u64),
}

impl Failure {
    /// A short text for the log.
    fn text(&self) -> &'static str {
        match self {
            Failure::Timeout => "no answer",
            Failure::Network => "not sent",
            Failure::Strays => "only answers that were not ours",
            Failure::Kiss(_) => "kiss-o'-death",
            Failure::Invalid(sntpc::Error::UnsynchronizedClock) => "server unsynchronised",
            Failure::Invalid(_) => "invalid answer",
            Failure::Implausible(_) => "implausible time",
        }
    }

    /// What it means for the schedule.
    fn outcome(&self) -> Outcome {
        match self {
            Failure::Kiss(KissOfDeathCode::Deny | KissOfDeathCode::Rstr) => Outcome::Refused,
            _ => Outcome::Failed,
        }
    }
}

/// How a query ended, for the schedule.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Outcome {
    /// Answered: the next in [`PERIOD`].
    Synced,
    /// No time: the next after the back-off.
    Failed,
    /// The server said stop (kiss-o'-death `DENY`, `RSTR`).
    Refused,
}

/// When to ask which server: the schedule, apart from the network.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Plan {
    /// The server the plan is for (the setting when last looked at).
    server: Ipv4Addr,
    /// When to ask it next; `None`: not at all (none set, or it refused).
    next: Option<Instant>,
    /// The wait after the next failure.
    retry: Duration,
}

impl Plan {
    /// No server yet.
    const fn new() -> Self {
        Plan {
            server: Ipv4Addr::UNSPECIFIED,
            next: None,
            retry: RETRY_FIRST,
        }
    }

    /// The server to ask at `now`, if any, with `configured` the setting:
    /// a changed setting starts the plan afresh (asked at once; `0.0.0.0`:
    /// nobody).
    fn due(&mut self, configured: Ipv4Addr, now: Instant) -> Option<Ipv4Addr> {
        if configured != self.server {
            *self = Plan {
                server: configured,
                next: (!configured.is_unspecified()).then_some(now),
                retry: RETRY_FIRST,
            };
        }
        self.next.filter(|at| *at <= now).map(|_| self.server)
    }

    /// When to look again: the next query, or the next look at the
    /// setting, whichever comes first.
    fn wake(&self, now: Instant) -> Instant {
        let check = now + CONFIG_CHECK;
        self.next.map_or(check, |at| at.min(check))
    }

    /// A query ended at `now` with `outcome`.
    fn done(&mut self, outcome: Outcome, now: Instant) {
        match outcome {
            Outcome::Synced => {
                self.next = Some(now + PERIOD);
                self.retry = RETRY_FIRST;
            }
            Outcome::Failed => {
                self.next = Some(now + self.retry);
                self.retry = (self.retry * 2).min(PERIOD);
            }
            Outcome::Refused => self.next = None,
        }
    }
}

/// Asks the server of `network.ntp_server` for the time, at start and on
/// the schedule of the module docs, over `socket`, and sets the audit
/// log's wall clock from its answers. `nonce` gives 32 random bits for
/// each query (the request's transmit time). Never returns.
pub(crate) async fn run<C: Clock, U: NtpUdpSocket>(
    hub: &Hub,
    clock: &C,
    socket: &U,
    mut nonce: impl FnMut() -> u32,
) -> Infallible {
    let mut plan = Plan::new();
    loop {
        let now = clock.now();
        let configured = hub.with(|m| m.config.active.ntp_server);
        let Some(server) = plan.due(configured, now) else {
            clock.sleep_until(plan.wake(now)).await;
            continue;
        };
        let outcome = match ask(clock, socket, server, nonce()).await {
            Ok((unix, at)) => {
                debug!("time: {} (Unix) from the time server", unix);
                hub.audit.set_wall_time(unix, at, Some(server));
                Outcome::Synced
            }
            Err(e) => {
                let [a, b, c, d] = server.octets();
                if let Failure::Kiss(code) = e {
                    warn!(
                        "time: the time server {}.{}.{}.{} sent kiss-o'-death {}",
                        a,
                        b,
                        c,
                        d,
                        code.as_str()
                    );
                } else {
                    warn!("time: no time from {}.{}.{}.{}: {}", a, b, c, d, e.text());
                }
                e.outcome()
            }
        };
        plan.done(outcome, clock.now());
        if outcome == Outcome::Refused {
            warn!("time: not asking that server again until network.ntp_server changes");
        }
    }
}

/// One query to `server`: the Unix time its answer gives and the instant
/// that second began, or why not.
async fn ask<C: Clock, U: NtpUdpSocket>(
    clock: &C,
    socket: &U,
    server: Ipv4Addr,
    nonce: u32,
) -> Result<(u64, Instant), Failure> {
    let addr = SocketAddr::V4(SocketAddrV4::new(server, PORT));
    let context = NtpContext::new(Stamps {
        clock,
        offset_us: u64::from(nonce),
        now: clock.now(),
    });
    let exchange = async {
        let sent = sntpc::sntp_send_request(addr, socket, context)
            .await
            .map_err(|_| Failure::Network)?;
        for _ in 0..=STRAYS {
            match sntpc::sntp_process_response(addr, socket, context, sent).await {
                Ok(r) => return Ok(r),
                // Not the answer to this request: read on.
                Err(
                    sntpc::Error::ResponseAddressMismatch
                    | sntpc::Error::IncorrectOriginTimestamp
                    | sntpc::Error::IncorrectPayload,
                ) => {}
                Err(sntpc::Error::KissOfDeath(code)) => return Err(Failure::Kiss(code)),
                Err(e) => return Err(Failure::Invalid(e)),
            }
        }
        Err(Failure::Strays)
    };
    let answer = with_timeout(clock, TIMEOUT, exchange)
        .await
        .map_err(|_| Failure::Timeout)??;
    wall_time(&answer, clock.now())
}

/// The Unix second an answer read at `at` gives, and the instant that
/// second began: the server's transmit time plus half the round trip.
fn wall_time(r: &NtpResult, at: Instant) -> Result<(u64, Instant), Failure> {
    let half = (r.roundtrip() / 2).min(TIMEOUT.as_micros());
    let micros = u64::from(sntpc::fraction_to_microseconds(r.sec_fraction())) + half;
    let unix = r.sec().saturating_add(micros / MICROS);
    if !(EARLIEST..=LATEST).contains(&unix) {
        return Err(Failure::Implausible(unix));
    }
    let into = Duration::from_micros(micros % MICROS);
    Ok((unix, at.checked_sub(into).unwrap_or(at)))
}

/// The client's clock as sntpc reads it (the request's transmit time, the
/// answer's arrival): [`EARLIEST`] plus the query's random offset plus the
/// uptime.
struct Stamps<'a, C> {
    clock: &'a C,
    offset_us: u64,
    /// The instant of the last `init`.
    now: Instant,
}

impl<C> Clone for Stamps<'_, C> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<C> Copy for Stamps<'_, C> {}

impl<C> Stamps<'_, C> {
    fn micros(&self) -> u64 {
        (EARLIEST * MICROS)
            .saturating_add(self.offset_us)
            .saturating_add(self.now.as_micros())
    }
}

impl<C: Clock> NtpTimestampGenerator for Stamps<'_, C> {
    fn init(&mut self) {
        self.now = self.clock.now();
    }

    fn timestamp_sec(&self) -> u64 {
        self.micros() / MICROS
    }

    fn timestamp_subsec_micros(&self) -> u32 {
        u32::try_from(self.micros() % MICROS).unwrap_or(0)
    }
}

/// What the seed is hashed with for the client's generator.
const DOMAIN: &[u8] = b"hans-gateway sntp nonces";

/// The port and the nonces: SplitMix64 from a hash of the board's seed.
///
/// Not a cryptographic generator, and it need not be: the nonces only
/// have to be unknown to an attacker who cannot see the requests (one
/// who sees them can answer them: SNTP has no authentication here).
/// The hash keeps the seed (also the web sessions') out of reach of
/// anyone who works the generator's state back from its output. The
/// sessions' ChaCha20 would cost a second copy of 2.6 KiB of flash.
pub(crate) struct Nonces(u64);

impl Nonces {
    pub(crate) fn new(seed: &[u8; 32]) -> Self {
        let hash = Sha256::new()
            .chain_update(DOMAIN)
            .chain_update(seed)
            .finalize();
        let mut state = [0u8; 8];
        for (s, h) in state.iter_mut().zip(hash.iter()) {
            *s = *h;
        }
        Nonces(u64::from_le_bytes(state))
    }

    pub(crate) fn next(&mut self) -> u32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 32) as u32
    }
}

/// The board's side: sntpc's socket over an embassy-net UDP socket, and the
/// client on a board's stack.
///
/// sntpc's own embassy adapter (`sntpc-net-embassy`) is for embassy-net
/// 0.8; ours is 0.9, hence this one.
#[cfg(feature = "sntp")]
mod board {
    use core::convert::Infallible;
    use core::net::SocketAddr;

    use embassy_net::udp::{PacketMetadata, RecvError, UdpSocket};
    use embassy_net::Stack;
    use sntpc::NtpUdpSocket;

    use super::{run, Nonces};
    use crate::clock::Clock;
    use crate::hub::Hub;

    /// Bytes of a datagram the socket takes: an answer is 48, 68 with a
    /// MAC (a server answers so only to a request with one; ours has
    /// none); longer ones are dropped.
    const RX_MAX: usize = 96;
    /// The first port of the dynamic range (RFC 6335): the socket binds
    /// to a random one from here on.
    const DYNAMIC_PORTS: u16 = 49152;

    /// sntpc's UDP socket over embassy-net's.
    struct EmbassyUdp<'a>(UdpSocket<'a>);

    impl NtpUdpSocket for EmbassyUdp<'_> {
        async fn send_to(&self, buf: &[u8], addr: SocketAddr) -> sntpc::Result<usize> {
            // IPv4 only (the stack's protocol).
            let SocketAddr::V4(to) = addr else {
                return Err(sntpc::Error::Network);
            };
            match self.0.send_to(buf, to).await {
                Ok(()) => Ok(buf.len()),
                Err(_) => Err(sntpc::Error::Network),
            }
        }

        async fn recv_from(&self, buf: &mut [u8]) -> sntpc::Result<(usize, SocketAddr)> {
            let mut rx = [0u8; RX_MAX];
            loop {
                match self.0.recv_from(&mut rx).await {
                    Ok((n, meta)) => {
                        let mut len = 0;
                        for (d, s) in buf.iter_mut().zip(rx.iter().take(n)) {
                            *d = *s;
                            len += 1;
                        }
                        return Ok((len, meta.endpoint.into()));
                    }
                    // Longer than any answer (dropped by the stack): the
                    // query's deadline bounds this loop.
                    Err(RecvError::Truncated) => {}
                }
            }
        }
    }

    /// Runs the client on `stack` (one socket of `board::SOCKETS`), its
    /// port and nonces from `seed`.
    pub(crate) async fn on_stack<C: Clock>(
        stack: Stack<'_>,
        hub: &Hub,
        clock: &C,
        seed: [u8; 32],
    ) -> Infallible {
        let mut rng = Nonces::new(&seed);
        let mut rx_meta = [PacketMetadata::EMPTY; 2];
        let mut tx_meta = [PacketMetadata::EMPTY; 1];
        let mut rx = [0u8; 2 * RX_MAX];
        let mut tx = [0u8; 48];
        let mut socket = UdpSocket::new(stack, &mut rx_meta, &mut rx, &mut tx_meta, &mut tx);
        let port = DYNAMIC_PORTS + (rng.next() % 16384) as u16;
        if socket.bind(port).is_err() {
            warn!("time: no UDP port for the SNTP client");
            return core::future::pending().await;
        }
        let socket = EmbassyUdp(socket);
        // An address first (DHCP may take a while): no failed queries at
        // every start.
        stack.wait_config_up().await;
        run(hub, clock, &socket, || rng.next()).await
    }
}

#[cfg(feature = "sntp")]
pub(crate) use board::on_stack;

#[cfg(test)]
mod tests {
    use core::cell::RefCell;
    use core::future::{poll_fn, Future};
    use core::pin::Pin;
    use core::task::{Poll, Waker};
    use std::boxed::Box;
    use std::collections::VecDeque;
    use std::rc::Rc;
    use std::string::{String, ToString};
    use std::sync::atomic::AtomicBool;
    use std::sync::Arc;
    use std::vec::Vec;

    use super::*;
    use crate::audit::Kind;
    use crate::config::Config;
    use crate::state::Model;
    use crate::testkit::clock::VirtualClock;
    use crate::testkit::world::{poll_until_waiting, Flag};

    const SERVER: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 123);
    const OTHER: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 124);
    /// The server's Unix time at virtual instant 0, in µs: 0.6 s into a
    /// second.
    const UNIX0_US: u64 = 1_800_000_000 * MICROS + 600_000;
    const UNIX0: u64 = UNIX0_US / MICROS;
    /// Seconds from 1900 (NTP) to 1970 (Unix).
    const NTP_UNIX: u64 = 2_208_988_800;

    /// How the fake server answers a request.
    #[derive(Clone, Copy, Debug)]
    enum Mode {
        /// At once, with its time.
        Good,
        /// Not at all.
        Silent,
        /// Its answer arrives this late.
        Late(Duration),
        /// First datagrams that are not the answer (from another address,
        /// from another port, with another origin time, 20 bytes long;
        /// each with a time 1000 s off), then the answer.
        StraysFirst,
        /// Only the datagrams of `StraysFirst`, no answer.
        OnlyStrays,
        /// A kiss-o'-death with this code (stratum 0).
        Kiss(&'static [u8; 4]),
        /// Leap indicator 3: its clock is unsynchronised.
        Unsynchronised,
        /// Stratum 16.
        Stratum16,
        /// Its clock was never set: it answers 1970 (plus the uptime).
        Unset,
    }

    /// A datagram on its way to the client.
    struct Datagram {
        arrives: Instant,
        from: SocketAddr,
        bytes: Vec<u8>,
    }

    /// The network and the time server, as the client's socket sees them.
    struct Fake {
        clock: Rc<VirtualClock>,
        mode: RefCell<Mode>,
        /// The server's clock minus the true time, in µs.
        skew_us: RefCell<i64>,
        /// Requests: when, to whom, what.
        sent: RefCell<Vec<(Instant, SocketAddr, Vec<u8>)>>,
        inbox: RefCell<VecDeque<Datagram>>,
        waker: RefCell<Option<Waker>>,
    }

    /// An NTP timestamp (32.32 fixed point seconds since 1900) of `unix_us`.
    fn ntp(unix_us: u64) -> u64 {
        let secs = unix_us / MICROS + NTP_UNIX;
        let frac = ((unix_us % MICROS) << 32) / MICROS;
        (secs << 32) | frac
    }

    /// A server's answer to `request` with its time `unix_us`.
    fn answer(request: &[u8], unix_us: u64, li: u8, stratum: u8, ref_id: [u8; 4]) -> Vec<u8> {
        let mut p = std::vec![0u8; 48];
        p[0] = (li << 6) | (request[0] & 0x38) | 4;
        p[1] = stratum;
        p[2] = 6;
        p[3] = (-20i8) as u8;
        p[12..16].copy_from_slice(&ref_id);
        p[16..24].copy_from_slice(&ntp(unix_us - 10 * MICROS).to_be_bytes());
        p[24..32].copy_from_slice(&request[40..48]);
        p[32..40].copy_from_slice(&ntp(unix_us).to_be_bytes());
        p[40..48].copy_from_slice(&ntp(unix_us).to_be_bytes());
        p
    }

    impl Fake {
        fn new(clock: Rc<VirtualClock>, mode: Mode) -> Self {
            Fake {
                clock,
                mode: RefCell::new(mode),
                skew_us: RefCell::new(0),
                sent: RefCell::new(Vec::new()),
                inbox: RefCell::new(VecDeque::new()),
                waker: RefCell::new(None),
            }
        }

        /// The server's time now.
        fn server_us(&self) -> u64 {
            let t = UNIX0_US + self.clock.now().as_micros();
            t.checked_add_signed(*self.skew_us.borrow()).unwrap()
        }

        fn deliver(&self, from: SocketAddr, bytes: Vec<u8>, after: Duration) {
            let arrives = self.clock.now() + after;
            self.inbox.borrow_mut().push_back(Datagram {
                arrives,
                from,
                bytes,
            });
        }

        /// What the server (and the others) send back to `request` to `to`.
        fn respond(&self, to: SocketAddr, request: &[u8]) {
            let now = self.server_us();
            let sync = [0, 2, b'G', b'P'];
            let mode = *self.mode.borrow();
            let strays = |f: &Fake| {
                let wrong = answer(request, now + 1000 * MICROS, 0, 2, sync);
                let other = SocketAddr::V4(SocketAddrV4::new(OTHER, PORT));
                let port = SocketAddr::V4(SocketAddrV4::new(SERVER, PORT + 1));
                f.deliver(other, wrong.clone(), Duration::from_ticks(0));
                f.deliver(port, wrong.clone(), Duration::from_ticks(0));
                let mut forged = wrong.clone();
                forged[31] ^= 1;
                f.deliver(to, forged, Duration::from_ticks(0));
                f.deliver(to, wrong[..20].to_vec(), Duration::from_ticks(0));
            };
            let now0 = Duration::from_ticks(0);
            match mode {
                Mode::Good => self.deliver(to, answer(request, now, 0, 2, sync), now0),
                Mode::Silent => {}
                Mode::Late(d) => self.deliver(to, answer(request, now, 0, 2, sync), d),
                Mode::StraysFirst => {
                    strays(self);
                    self.deliver(to, answer(request, now, 0, 2, sync), now0);
                }
                Mode::OnlyStrays => strays(self),
                Mode::Kiss(code) => self.deliver(to, answer(request, now, 3, 0, *code), now0),
                Mode::Unsynchronised => self.deliver(to, answer(request, now, 3, 2, sync), now0),
                Mode::Stratum16 => self.deliver(to, answer(request, now, 0, 16, sync), now0),
                Mode::Unset => {
                    let uptime = self.clock.now().as_micros();
                    self.deliver(to, answer(request, uptime, 0, 2, sync), now0)
                }
            }
        }

        /// When the next datagram in flight arrives.
        fn next_arrival(&self) -> Option<Instant> {
            let now = self.clock.now();
            let inbox = self.inbox.borrow();
            inbox.iter().map(|d| d.arrives).filter(|t| *t > now).min()
        }

        /// Wakes the reader if a datagram has arrived.
        fn wake_if_arrived(&self) {
            let now = self.clock.now();
            if self.inbox.borrow().iter().any(|d| d.arrives <= now) {
                if let Some(w) = self.waker.borrow_mut().take() {
                    w.wake();
                }
            }
        }
    }

    impl NtpUdpSocket for Fake {
        async fn send_to(&self, buf: &[u8], addr: SocketAddr) -> sntpc::Result<usize> {
            let now = self.clock.now();
            self.sent.borrow_mut().push((now, addr, buf.to_vec()));
            self.respond(addr, buf);
            self.wake_if_arrived();
            Ok(buf.len())
        }

        async fn recv_from(&self, buf: &mut [u8]) -> sntpc::Result<(usize, SocketAddr)> {
            poll_fn(|cx| {
                let now = self.clock.now();
                let mut inbox = self.inbox.borrow_mut();
                match inbox.iter().position(|d| d.arrives <= now) {
                    Some(i) => {
                        let d = inbox.remove(i).unwrap();
                        let n = d.bytes.len().min(buf.len());
                        buf[..n].copy_from_slice(&d.bytes[..n]);
                        Poll::Ready(Ok((n, d.from)))
                    }
                    None => {
                        *self.waker.borrow_mut() = Some(cx.waker().clone());
                        Poll::Pending
                    }
                }
            })
            .await
        }
    }

    /// The client in virtual time, with a hub and a fake network.
    struct Rig {
        clock: Rc<VirtualClock>,
        hub: Rc<Hub>,
        fake: Rc<Fake>,
        fut: Pin<Box<dyn Future<Output = Infallible>>>,
        flag: Arc<Flag>,
        waker: Waker,
    }

    impl Rig {
        /// The client with `server` set, the server answering as `mode`;
        /// started at 10 s of uptime.
        fn new(server: Ipv4Addr, mode: Mode) -> Rig {
            let config = Config {
                ntp_server: server,
                ..Config::DEFAULT
            };
            let clock = Rc::new(VirtualClock::new());
            clock.advance_to(Instant::from_secs(10));
            let hub = Rc::new(Hub::new(Model::new(config, config)));
            let fake = Rc::new(Fake::new(clock.clone(), mode));
            let (c, h, f) = (clock.clone(), hub.clone(), fake.clone());
            let fut = Box::pin(async move {
                let mut n = 0u32;
                let nonce = move || {
                    n = n.wrapping_add(1);
                    n.wrapping_mul(2_654_435_761)
                };
                run(&h, &*c, &*f, nonce).await
            });
            let flag = Arc::new(Flag(AtomicBool::new(true)));
            let waker = Waker::from(flag.clone());
            let mut rig = Rig {
                clock,
                hub,
                fake,
                fut,
                flag,
                waker,
            };
            rig.settle();
            rig
        }

        fn now(&self) -> Instant {
            self.clock.now()
        }

        fn settle(&mut self) {
            let at = self.now();
            self.fake.wake_if_arrived();
            poll_until_waiting(&self.flag, &self.waker, &mut self.fut, 1000, at);
        }

        /// Runs until `end`.
        fn run_until(&mut self, end: Instant) {
            loop {
                self.settle();
                let next = [self.clock.next_deadline(), self.fake.next_arrival()]
                    .into_iter()
                    .flatten()
                    .min();
                match next {
                    Some(t) if t <= end => self.clock.advance_to(t),
                    _ => {
                        self.clock.advance_to(end);
                        self.settle();
                        return;
                    }
                }
            }
        }

        fn run_for(&mut self, d: Duration) {
            let end = self.now() + d;
            self.run_until(end);
        }

        fn set_mode(&self, mode: Mode) {
            *self.fake.mode.borrow_mut() = mode;
        }

        fn set_server(&self, server: Ipv4Addr) {
            self.hub.with(|m| m.config.active.ntp_server = server);
        }

        /// The queries so far: when (ms of uptime), to whom.
        fn queries(&self) -> Vec<(u64, SocketAddr)> {
            let sent = self.fake.sent.borrow();
            sent.iter().map(|(t, a, _)| (t.as_millis(), *a)).collect()
        }

        /// When the queries were sent (s of uptime).
        fn query_secs(&self) -> Vec<u64> {
            let sent = self.fake.sent.borrow();
            sent.iter().map(|(t, _, _)| t.as_secs()).collect()
        }

        /// The audit log's wall time now.
        fn wall(&self) -> Option<u32> {
            self.hub.audit.wall_at(self.now())
        }

        /// The `time` records: detail and source.
        fn time_records(&self) -> Vec<(String, Option<Ipv4Addr>)> {
            let log = &self.hub.audit;
            log.stamp(self.now());
            let mut v = Vec::new();
            let (Some(last), _, _) = log.summary() else {
                return v;
            };
            let mut next = 0;
            while let Some(r) = log.copy(next, last) {
                if r.kind == Kind::Time {
                    v.push((r.detail.as_str().to_string(), r.from));
                }
                if r.seq >= last {
                    break;
                }
                next = r.seq + 1;
            }
            v
        }
    }

    fn server(ip: Ipv4Addr) -> SocketAddr {
        SocketAddr::V4(SocketAddrV4::new(ip, PORT))
    }

    fn secs(s: u64) -> Duration {
        Duration::from_secs(s)
    }

    #[test]
    fn an_answer_at_start_sets_the_wall_time_to_the_second() {
        let mut w = Rig::new(SERVER, Mode::Good);
        assert_eq!(w.queries(), [(10_000, server(SERVER))], "asked at start");
        let sent = w.fake.sent.borrow()[0].2.clone();
        assert_eq!(sent.len(), 48);
        assert_eq!(sent[0], 0x23, "SNTP version 4, client");
        // The server's clock read 10.6 s into UNIX0's minute when it
        // answered: the second UNIX0 + 10 began at 9.4 s of uptime.
        assert_eq!(w.wall(), Some(UNIX0 as u32 + 10));
        w.run_until(Instant::from_millis(10_399));
        assert_eq!(w.wall(), Some(UNIX0 as u32 + 10));
        w.run_until(Instant::from_millis(10_401));
        assert_eq!(w.wall(), Some(UNIX0 as u32 + 11));
        assert_eq!(
            w.time_records(),
            [(
                "set by a time server (was unknown)".to_string(),
                Some(SERVER)
            )]
        );
    }

    #[test]
    fn the_server_is_asked_again_hourly() {
        let mut w = Rig::new(SERVER, Mode::Good);
        w.run_for(secs(5400));
        // The server's clock jumps ahead by 100 s.
        *w.fake.skew_us.borrow_mut() = 100 * MICROS as i64;
        w.run_for(secs(3 * 3600 - 5400));
        assert_eq!(w.query_secs(), [10, 3610, 7210, 10810]);
        assert_eq!(w.wall(), Some((UNIX0 + 10810 + 100) as u32));
        let records = w.time_records();
        let details: Vec<&str> = records.iter().map(|(d, _)| d.as_str()).collect();
        assert_eq!(
            details,
            [
                "set by a time server (was unknown)",
                "set by a time server, moved by 100 s"
            ]
        );
    }

    #[test]
    fn silence_times_out_and_the_retries_back_off_to_hourly() {
        let mut w = Rig::new(SERVER, Mode::Silent);
        w.run_for(secs(12 * 3600));
        assert_eq!(w.wall(), None);
        let at = w.query_secs();
        // Each waits 2 s, then 15, 30, 60, ... s until the next.
        assert_eq!(at[..6], [10, 27, 59, 121, 243, 485]);
        let gaps: Vec<u64> = at.windows(2).map(|p| p[1] - p[0]).collect();
        assert!(gaps.iter().all(|g| *g <= 3602), "{gaps:?}");
        assert_eq!(gaps[gaps.len() - 3..], [3602; 3], "at most hourly");
        // The server answers again: the next query syncs and the
        // schedule is hourly again, the back-off forgotten.
        w.set_mode(Mode::Good);
        let n = at.len();
        w.run_for(secs(4 * 3600 + 10));
        let at = w.query_secs();
        assert!(w.wall().is_some());
        let after: Vec<u64> = at[n..].windows(2).map(|p| p[1] - p[0]).collect();
        assert!(
            after.len() >= 3 && after.iter().all(|g| *g == 3600),
            "{after:?}"
        );
        // Then silence again: the first retry is 15 s after the failure.
        w.set_mode(Mode::Silent);
        let n = at.len();
        w.run_for(secs(3600 + 20));
        let at = w.query_secs();
        assert_eq!(at[n + 1] - at[n], 2 + 15);
    }

    #[test]
    fn answers_from_elsewhere_or_to_other_requests_are_passed_over() {
        let mut w = Rig::new(SERVER, Mode::StraysFirst);
        assert_eq!(w.wall(), Some(UNIX0 as u32 + 10), "the real answer's time");
        w.run_for(secs(60));
        assert_eq!(w.query_secs(), [10], "one query, answered");
    }

    #[test]
    fn only_strays_is_a_failure() {
        let mut w = Rig::new(SERVER, Mode::OnlyStrays);
        w.run_for(secs(30));
        assert_eq!(w.wall(), None);
        assert_eq!(w.query_secs(), [10, 27], "backed off as for silence");
    }

    #[test]
    fn a_late_answer_does_not_spoil_the_next_query() {
        let mut w = Rig::new(SERVER, Mode::Late(secs(3)));
        w.run_for(secs(5));
        assert_eq!(w.wall(), None, "too late: 2 s is the limit");
        w.set_mode(Mode::Good);
        // The retry reads the late answer first (another origin time),
        // then its own.
        w.run_for(secs(20));
        assert_eq!(w.query_secs(), [10, 27]);
        assert_eq!(w.wall(), Some((UNIX0 + 35) as u32));
    }

    #[test]
    fn deny_and_rstr_stop_the_asking_until_the_server_changes() {
        for code in [b"DENY", b"RSTR"] {
            let mut w = Rig::new(SERVER, Mode::Kiss(code));
            w.run_for(secs(5 * 3600));
            assert_eq!(w.query_secs(), [10], "{code:?}: asked once");
            assert_eq!(w.wall(), None);
            w.set_mode(Mode::Good);
            w.set_server(OTHER);
            w.run_for(CONFIG_CHECK);
            let q = w.queries();
            assert_eq!(q.len(), 2, "{code:?}: the new server is asked");
            assert_eq!(q[1].1, server(OTHER));
            assert!(w.wall().is_some());
            assert_eq!(w.time_records()[0].1, Some(OTHER));
        }
    }

    #[test]
    fn rate_and_other_kisses_back_off() {
        for code in [b"RATE", b"INIT", b"XFOO"] {
            let mut w = Rig::new(SERVER, Mode::Kiss(code));
            w.run_for(secs(60));
            // Refused at once: 15 s, then 30 s later.
            assert_eq!(w.query_secs(), [10, 25, 55], "{code:?}");
            assert_eq!(w.wall(), None);
        }
    }

    #[test]
    fn unsynchronised_or_implausible_answers_are_refused() {
        for mode in [Mode::Unsynchronised, Mode::Stratum16, Mode::Unset] {
            let mut w = Rig::new(SERVER, mode);
            w.run_for(secs(30));
            assert_eq!(w.wall(), None, "{mode:?}");
            assert_eq!(w.query_secs(), [10, 25], "{mode:?}: backed off");
        }
    }

    #[test]
    fn a_changed_server_is_asked_at_once_and_none_is_asked_nothing() {
        let mut w = Rig::new(SERVER, Mode::Good);
        w.run_for(secs(100));
        w.set_server(OTHER);
        w.run_for(CONFIG_CHECK);
        let q = w.queries();
        assert_eq!(q.len(), 2);
        assert_eq!(q[1].1, server(OTHER));
        assert!(q[1].0 <= 110_000 + CONFIG_CHECK.as_millis());
        w.set_server(Ipv4Addr::UNSPECIFIED);
        w.run_for(secs(3 * 3600));
        assert_eq!(w.queries().len(), 2, "0.0.0.0: nobody is asked");
        assert!(w.wall().is_some(), "the wall time goes on from the uptime");
    }

    #[test]
    fn without_a_server_the_client_only_looks_at_the_setting() {
        let mut w = Rig::new(Ipv4Addr::UNSPECIFIED, Mode::Good);
        let sleeps = w.clock.sleeps();
        w.run_for(secs(3600));
        assert!(w.queries().is_empty());
        let woke = w.clock.sleeps() - sleeps;
        assert!(woke <= 3600 / CONFIG_CHECK.as_secs() + 1, "{woke} wakes");
        w.set_server(SERVER);
        w.run_for(CONFIG_CHECK);
        assert_eq!(w.queries().len(), 1);
    }

    #[test]
    fn the_nonces_are_splitmix64_of_a_hash_of_the_seed() {
        // SplitMix64's first output from state 0 (its reference code).
        assert_eq!(Nonces(0).next(), 0xe220_a839);
        let mut a = Nonces::new(&[1; 32]);
        let mut b = Nonces::new(&[2; 32]);
        let (a1, a2, b1) = (a.next(), a.next(), b.next());
        assert!(a1 != a2 && a1 != b1, "{a1} {a2} {b1}");
        assert_ne!(Nonces::new(&[0; 32]).0, 0, "the state is the seed's hash");
    }

    #[test]
    fn each_request_carries_a_new_random_transmit_time() {
        let mut w = Rig::new(SERVER, Mode::Silent);
        w.run_for(secs(20));
        let sent = w.fake.sent.borrow();
        let tx: Vec<u64> = sent
            .iter()
            .map(|(_, _, b)| u64::from_be_bytes(b[40..48].try_into().unwrap()))
            .collect();
        assert_eq!(tx.len(), 2);
        // Uptime 10 s and 27 s plus EARLIEST plus the nonce (µs).
        for (t, (up, nonce)) in tx.iter().zip([(10u64, 1u32), (27, 2)]) {
            let us = EARLIEST * MICROS + u64::from(nonce.wrapping_mul(2_654_435_761)) + up * MICROS;
            assert_eq!(*t >> 32, us / MICROS + NTP_UNIX);
        }
    }
}
