//! The robot link: one TCP connection to the controller's command port,
//! opened by the gateway (connect mode) or by the controller (listen mode,
//! the controller's client mode of chapter 3.1), with one request in flight.
//!
//! Replies are framed with the codec's [`Framer`]; anything the controller
//! sends while no request is in flight is dropped, and so is anything after
//! the reply (the controller answers one message with one message).
//!
//! In listen mode only the controller may connect ([`admits`]): the
//! configured `robot.address`, or, with none configured (0.0.0.0), the
//! first host that connects. A second socket keeps accepting while the link
//! is idle: a new connection from the live controller's address replaces
//! the old one (a controller reconnecting after a restart); one from any
//! other address is closed at once, before a byte is read or sent, and
//! never replaces the live link. The engine logs and counts both.
//!
//! The engine owns the link and decides about timeouts and backoff.

use core::net::{Ipv4Addr, SocketAddrV4};

use embassy_time::{Duration, Instant};

use crate::clock::{with_deadline, with_timeout, Clock, TimeoutError};
use hans_codec::{FrameError, Framer};

use crate::net::{NetError, Socket};

/// Longest reply accepted (longer replies end the command in Error
/// "bad reply"; the link stays up).
pub(crate) const REPLY_MAX: usize = 1024;
/// Bound of one connection attempt.
pub(crate) const CONNECT_TIMEOUT: Duration = Duration::from_secs(3);

/// Where the robot is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(crate) enum Target {
    /// Connect to the controller.
    Connect(SocketAddrV4),
    /// Wait for the controller on `port`; only from `controller` unless
    /// it is 0.0.0.0 (not configured: the first to connect).
    Listen {
        /// The port listened on.
        port: u16,
        /// The controller's address (`robot.address`), or 0.0.0.0.
        controller: Ipv4Addr,
    },
    /// No robot configured.
    None,
}

/// Why a request failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(crate) enum LinkError {
    /// No reply within the timeout.
    Timeout,
    /// The connection broke or was closed.
    Lost(NetError),
    /// The reply was too long or held invalid bytes (link still usable).
    BadFrame(FrameError),
}

/// What happened while the link was idle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(crate) enum IdleEvent {
    /// The connection was lost.
    Lost(NetError),
    /// The controller connected again (from the live link's address); the
    /// new connection, from this port, replaced the old.
    Replaced(SocketAddrV4),
    /// Another host connected to the listen port; its connection was
    /// closed, the live link stays (`None`: its address was unknown).
    Refused(Option<SocketAddrV4>),
}

/// What a listen-mode accept led to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(crate) enum Accepted {
    /// The link is up (connect mode: connected).
    Up,
    /// A host that is not the controller connected; its connection was
    /// closed, nothing is up (`None`: its address was unknown).
    Refused(Option<SocketAddrV4>),
}

/// Listen mode: may a connection from `peer` become the link? Only from
/// the configured `controller` (any address when it is 0.0.0.0), and while
/// a link from `live` is up only from that same address: another host
/// never replaces the live controller.
pub(crate) fn admits(controller: Ipv4Addr, live: Option<Ipv4Addr>, peer: Ipv4Addr) -> bool {
    if peer.is_unspecified() || (!controller.is_unspecified() && peer != controller) {
        return false;
    }
    live.is_none_or(|l| l == peer)
}

/// The link.
pub(crate) struct Link<S: Socket> {
    socks: [S; 2],
    cur: usize,
    up: bool,
    /// The address the live link came from (kept while it is up, even once
    /// the socket no longer knows it).
    live: Option<Ipv4Addr>,
    framer: Framer<REPLY_MAX>,
    rx: [u8; 256],
    reply: [u8; REPLY_MAX],
}

impl<S: Socket> Link<S> {
    /// A link over two sockets (the second serves listen-mode reconnects).
    pub(crate) fn new(a: S, b: S) -> Self {
        Link {
            socks: [a, b],
            cur: 0,
            up: false,
            live: None,
            framer: Framer::new(),
            rx: [0; 256],
            reply: [0; REPLY_MAX],
        }
    }

    /// `true` while connected.
    pub(crate) fn is_up(&self) -> bool {
        self.up
    }

    /// The controller's address while connected.
    pub(crate) fn peer(&self) -> Option<SocketAddrV4> {
        self.socks.get(self.cur).and_then(|s| s.remote())
    }

    fn sock(&mut self) -> &mut S {
        let [a, b] = &mut self.socks;
        if self.cur.is_multiple_of(2) {
            a
        } else {
            b
        }
    }

    /// One attempt to bring the link up: a connect bounded by
    /// [`CONNECT_TIMEOUT`], or an accept that waits as long as it is polled
    /// and takes one connection: the controller's ([`Accepted::Up`]), or
    /// another host's, closed at once ([`Accepted::Refused`]).
    pub(crate) async fn establish<C: Clock>(
        &mut self,
        target: Target,
        clock: &C,
    ) -> Result<Accepted, NetError> {
        match target {
            Target::None => core::future::pending().await,
            Target::Connect(addr) => {
                match with_timeout(clock, CONNECT_TIMEOUT, self.sock().connect(addr)).await {
                    Ok(Ok(())) => {}
                    Ok(Err(e)) => return Err(e),
                    Err(TimeoutError) => {
                        self.sock().close().await;
                        return Err(NetError::ConnectFailed);
                    }
                }
            }
            Target::Listen { port, controller } => {
                // Either socket may get the controller's connection (one of
                // them may still be listening from an earlier idle period).
                let (a, b) = self.socks.split_at_mut(1);
                let (Some(a), Some(b)) = (a.first_mut(), b.first_mut()) else {
                    return Err(NetError::ListenFailed);
                };
                match embassy_futures::select::select(a.accept(port), b.accept(port)).await {
                    embassy_futures::select::Either::First(r) => {
                        r?;
                        self.cur = 0;
                    }
                    embassy_futures::select::Either::Second(r) => {
                        r?;
                        self.cur = 1;
                    }
                }
                let peer = self.sock().remote();
                if !peer.is_some_and(|p| admits(controller, None, *p.ip())) {
                    self.sock().close().await;
                    return Ok(Accepted::Refused(peer));
                }
            }
        }
        self.up = true;
        self.live = self.sock().remote().map(|p| *p.ip());
        self.framer.reset();
        Ok(Accepted::Up)
    }

    /// Closes the connection (the socket can be used again).
    pub(crate) async fn close(&mut self) {
        self.up = false;
        self.live = None;
        self.framer.reset();
        self.sock().close().await;
    }

    /// Closes both sockets, also one still listening (the target changed).
    pub(crate) async fn close_all(&mut self) {
        self.up = false;
        self.live = None;
        self.framer.reset();
        for s in self.socks.iter_mut() {
            s.close().await;
        }
    }

    /// Sends one request and waits for its reply until `deadline`. The
    /// reply text (with its `;`) is valid until the next call.
    pub(crate) async fn transact<C: Clock>(
        &mut self,
        request: &[u8],
        deadline: Instant,
        clock: &C,
    ) -> Result<&str, LinkError> {
        if !self.up {
            return Err(LinkError::Lost(NetError::NotConnected));
        }
        self.framer.reset();
        if let Err(e) = self.sock().write_all(request).await {
            return Err(LinkError::Lost(e));
        }
        let len = self.read_reply(deadline, clock).await?;
        self.reply
            .get(..len)
            .and_then(|b| core::str::from_utf8(b).ok())
            .ok_or(LinkError::BadFrame(FrameError::InvalidByte {
                byte: 0,
                offset: 0,
            }))
    }

    async fn read_reply<C: Clock>(
        &mut self,
        deadline: Instant,
        clock: &C,
    ) -> Result<usize, LinkError> {
        loop {
            let i = self.cur % 2;
            let Some(sock) = self.socks.get_mut(i) else {
                return Err(LinkError::Lost(NetError::NotConnected));
            };
            let n = match with_deadline(clock, deadline, sock.read(&mut self.rx)).await {
                Err(TimeoutError) => return Err(LinkError::Timeout),
                Ok(Err(e)) => return Err(LinkError::Lost(e)),
                Ok(Ok(0)) => return Err(LinkError::Lost(NetError::Reset)),
                Ok(Ok(n)) => n,
            };
            let mut input = self.rx.get(..n).unwrap_or(&[]);
            while !input.is_empty() {
                let (used, item) = self.framer.push(input);
                input = input.get(used..).unwrap_or(&[]);
                match item {
                    None => {}
                    Some(Err(e)) => return Err(LinkError::BadFrame(e)),
                    Some(Ok(msg)) => {
                        let b = msg.as_bytes();
                        let dst = self.reply.get_mut(..b.len());
                        // The framer never yields more than REPLY_MAX bytes.
                        if let Some(dst) = dst {
                            dst.copy_from_slice(b);
                            return Ok(b.len());
                        }
                        return Err(LinkError::BadFrame(FrameError::TooLong { len: b.len() }));
                    }
                }
            }
        }
    }

    /// The address the live link came from (`None` while down).
    pub(crate) fn live(&self) -> Option<Ipv4Addr> {
        self.live
    }

    /// Waits while no request is in flight: returns when the connection is
    /// lost or, in listen mode (`Target::Listen`), when another connection
    /// came: it replaced the old one if [`admits`] lets it, else it was
    /// closed. Cancel-safe.
    pub(crate) async fn idle<C: Clock>(&mut self, target: Target, clock: &C) -> IdleEvent {
        let listen = match target {
            Target::Listen { port, controller } => Some((port, controller)),
            _ => None,
        };
        // A link without a known address is replaced by nobody.
        let live = self.live.unwrap_or(Ipv4Addr::UNSPECIFIED);
        let cur = self.cur % 2;
        let (a, b) = self.socks.split_at_mut(1);
        let (current, spare) = match (a.first_mut(), b.first_mut()) {
            (Some(a), Some(b)) if cur == 0 => (a, b),
            (Some(a), Some(b)) => (b, a),
            // Two sockets always exist.
            _ => return core::future::pending().await,
        };
        let rx = &mut self.rx;
        let watch = async {
            loop {
                match current.read(rx).await {
                    Ok(0) => return IdleEvent::Lost(NetError::Reset),
                    Err(e) => return IdleEvent::Lost(e),
                    // Unsolicited bytes: nothing is in flight, drop them.
                    Ok(_) => {}
                }
            }
        };
        let accept = async {
            match listen {
                Some((port, _)) => loop {
                    if spare.accept(port).await.is_ok() {
                        return;
                    }
                    clock.sleep(Duration::from_millis(100)).await;
                },
                None => core::future::pending().await,
            }
        };
        match embassy_futures::select::select(watch, accept).await {
            embassy_futures::select::Either::First(ev) => ev,
            embassy_futures::select::Either::Second(()) => {
                let controller = listen.map_or(Ipv4Addr::UNSPECIFIED, |(_, c)| c);
                let Some(new) = self.socks.get_mut(1 - cur) else {
                    return IdleEvent::Refused(None);
                };
                let peer = new.remote();
                match peer {
                    Some(p) if admits(controller, Some(live), *p.ip()) => {
                        if let Some(old) = self.socks.get_mut(cur) {
                            old.close().await;
                        }
                        self.cur = 1 - cur;
                        self.framer.reset();
                        IdleEvent::Replaced(p)
                    }
                    _ => {
                        new.close().await;
                        IdleEvent::Refused(peer)
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ROBOT: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 2);
    const OTHER: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 66);
    const ANY: Ipv4Addr = Ipv4Addr::UNSPECIFIED;

    #[test]
    fn a_configured_controller_address_is_the_only_one_admitted() {
        assert!(admits(ROBOT, None, ROBOT));
        assert!(!admits(ROBOT, None, OTHER));
        // Its reconnect replaces its live link; nobody else's does.
        assert!(admits(ROBOT, Some(ROBOT), ROBOT));
        assert!(!admits(ROBOT, Some(ROBOT), OTHER));
    }

    #[test]
    fn without_an_address_the_first_controller_keeps_the_link() {
        assert!(admits(ANY, None, OTHER));
        assert!(admits(ANY, Some(ROBOT), ROBOT));
        assert!(!admits(ANY, Some(ROBOT), OTHER));
        // A link whose address is unknown is replaced by nobody, and no
        // connection without an address is admitted.
        assert!(!admits(ANY, Some(ANY), ROBOT));
        assert!(!admits(ANY, None, ANY));
    }
}
