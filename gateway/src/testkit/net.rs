//! An in-memory TCP network for the gateway's `Net` interface.
//!
//! The gateway's sockets ([`SimSocket`]) connect, accept, read and write
//! as on a real stack; the test's side of a connection is a [`SimStream`]
//! it reads and writes without awaiting. Addresses are IPv4 endpoints;
//! nothing leaves the process.
//!
//! Semantics, as on a real stack: a connect to an endpoint nobody listens
//! on is refused at once, except on a [`SimNet::blackhole`] address, where
//! it never completes (the caller's timeout ends it); a connection the
//! gateway accepts waits in a backlog until a socket accepts it; closing
//! one end is an end-of-stream for the other after the data in flight; a
//! reset is an error for the other end at once.

use core::cell::RefCell;
use core::future::poll_fn;
use core::net::{Ipv4Addr, SocketAddrV4};
use core::task::{Poll, Waker};
use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::rc::Rc;
use std::vec::Vec;

use crate::net::{Net, NetError, Socket};

/// One direction of a connection.
#[derive(Default)]
struct Pipe {
    data: VecDeque<u8>,
    /// The writer closed its end: end of stream once the data is read.
    fin: bool,
    /// The reader is woken when data, a FIN or a reset arrives.
    waker: Option<Waker>,
}

impl Pipe {
    fn wake(&mut self) {
        if let Some(w) = self.waker.take() {
            w.wake();
        }
    }
}

struct Conn {
    /// Gateway end's address, and the test end's.
    gw: SocketAddrV4,
    peer: SocketAddrV4,
    to_gw: Pipe,
    to_peer: Pipe,
    reset: bool,
    gw_closed: bool,
    peer_closed: bool,
    /// The test's [`SimStream`] is gone: once the gateway closed its end
    /// too, nobody can see the connection and it is forgotten (a world
    /// that lives long, as a fuzz target's, does not grow).
    peer_dropped: bool,
}

#[derive(Default)]
struct State {
    conns: BTreeMap<u64, Conn>,
    next_conn: u64,
    next_port: u16,
    /// Ports the gateway listens on: the backlog of connections not yet
    /// accepted, and who waits for them.
    gw_listen: BTreeMap<u16, (VecDeque<u64>, BTreeMap<u64, Waker>)>,
    next_socket: u64,
    /// Endpoints the test listens on: connections the gateway opened.
    servers: BTreeMap<SocketAddrV4, VecDeque<u64>>,
    /// Addresses where a connect never completes.
    blackholes: BTreeSet<Ipv4Addr>,
    /// Connection attempts of the gateway, per endpoint.
    attempts: BTreeMap<SocketAddrV4, usize>,
    /// UDP ports the gateway bound: the datagrams waiting.
    #[cfg(feature = "udp")]
    udp_bound: BTreeMap<u16, UdpQueue>,
    /// Datagrams the gateway sent, per destination, until the test takes
    /// them.
    #[cfg(feature = "udp")]
    udp_sent: BTreeMap<SocketAddrV4, VecDeque<(SocketAddrV4, Vec<u8>)>>,
}

/// A bound UDP port of the gateway: at most `cap` datagrams wait (its
/// socket's packet slots), the rest are dropped, as on a board.
#[cfg(feature = "udp")]
#[derive(Default)]
struct UdpQueue {
    queue: VecDeque<(SocketAddrV4, Vec<u8>)>,
    cap: usize,
    waker: Option<Waker>,
    dropped: u64,
}

/// Datagrams kept per destination for the test to read; older ones are
/// dropped beyond this (a test that never reads does not grow without
/// bound).
#[cfg(feature = "udp")]
const UDP_SENT_KEPT: usize = 10_000;

/// The network. Cheap to clone (all clones are the same network).
#[derive(Clone)]
pub struct SimNet {
    state: Rc<RefCell<State>>,
    /// The gateway's own address.
    pub gateway_ip: Ipv4Addr,
}

impl SimNet {
    /// A network on which the gateway is `gateway_ip`.
    pub fn new(gateway_ip: Ipv4Addr) -> Self {
        SimNet {
            state: Rc::new(RefCell::new(State {
                next_port: 40000,
                ..State::default()
            })),
            gateway_ip,
        }
    }

    /// The test listens on `addr` (a robot controller, its DataSheet port).
    pub fn listen(&self, addr: SocketAddrV4) {
        self.state.borrow_mut().servers.entry(addr).or_default();
    }

    /// The test stops listening on `addr` (later connects are refused).
    pub fn unlisten(&self, addr: SocketAddrV4) {
        self.state.borrow_mut().servers.remove(&addr);
    }

    /// Connects to `ip` never complete (a host that does not answer).
    pub fn blackhole(&self, ip: Ipv4Addr, on: bool) {
        let mut s = self.state.borrow_mut();
        if on {
            s.blackholes.insert(ip);
        } else {
            s.blackholes.remove(&ip);
        }
    }

    /// How often the gateway tried to connect to `addr`.
    pub fn attempts(&self, addr: SocketAddrV4) -> usize {
        self.with(|s| s.attempts.get(&addr).copied().unwrap_or(0))
    }

    /// A connection the gateway opened to `addr`, if one waits.
    pub fn accept(&self, addr: SocketAddrV4) -> Option<SimStream> {
        let id = self
            .state
            .borrow_mut()
            .servers
            .get_mut(&addr)?
            .pop_front()?;
        Some(SimStream {
            net: self.clone(),
            id,
        })
    }

    /// Connects from `from` to the gateway's `port`; `None` if the gateway
    /// does not listen there.
    pub fn connect(&self, from: SocketAddrV4, port: u16) -> Option<SimStream> {
        let mut s = self.state.borrow_mut();
        let gw = SocketAddrV4::new(self.gateway_ip, port);
        let id = s.next_conn;
        let (backlog, wakers) = s.gw_listen.get_mut(&port)?;
        backlog.push_back(id);
        for (_, w) in core::mem::take(wakers) {
            w.wake();
        }
        s.next_conn += 1;
        s.conns.insert(id, Conn::new(gw, from));
        Some(SimStream {
            net: self.clone(),
            id,
        })
    }

    fn with<R>(&self, f: impl FnOnce(&mut State) -> R) -> R {
        f(&mut self.state.borrow_mut())
    }

    /// Sends a datagram from `from` to the gateway's UDP `port`: `false`
    /// if nobody is bound there or its queue is full (dropped, as a stack
    /// drops).
    #[cfg(feature = "udp")]
    pub fn send_udp(&self, from: SocketAddrV4, port: u16, bytes: &[u8]) -> bool {
        self.with(|s| {
            let Some(q) = s.udp_bound.get_mut(&port) else {
                return false;
            };
            if q.queue.len() >= q.cap {
                q.dropped += 1;
                return false;
            }
            q.queue.push_back((from, bytes.to_vec()));
            if let Some(w) = q.waker.take() {
                w.wake();
            }
            true
        })
    }

    /// The datagrams the gateway sent to `to` since the last call: sender
    /// and bytes, oldest first.
    #[cfg(feature = "udp")]
    pub fn recv_udp(&self, to: SocketAddrV4) -> Vec<(SocketAddrV4, Vec<u8>)> {
        self.with(|s| {
            s.udp_sent
                .get_mut(&to)
                .map(|q| q.drain(..).collect())
                .unwrap_or_default()
        })
    }

    /// Datagrams dropped at the gateway's UDP `port` because its queue was
    /// full.
    #[cfg(feature = "udp")]
    pub fn udp_dropped(&self, port: u16) -> u64 {
        self.with(|s| s.udp_bound.get(&port).map_or(0, |q| q.dropped))
    }
}

/// A gateway UDP socket on the simulated network.
#[cfg(feature = "udp")]
pub struct SimUdp {
    net: SimNet,
    port: u16,
}

#[cfg(feature = "udp")]
impl crate::net::UdpSocket for SimUdp {
    async fn recv_from(&mut self, buf: &mut [u8]) -> Result<(usize, SocketAddrV4), NetError> {
        let net = self.net.clone();
        let port = self.port;
        poll_fn(|cx| {
            net.with(|s| {
                let Some(q) = s.udp_bound.get_mut(&port) else {
                    return Poll::Ready(Err(NetError::NotConnected));
                };
                while let Some((from, d)) = q.queue.pop_front() {
                    if let Some(dst) = buf.get_mut(..d.len()) {
                        dst.copy_from_slice(&d);
                        return Poll::Ready(Ok((d.len(), from)));
                    }
                    // Longer than the reader's buffer: dropped whole.
                }
                q.waker = Some(cx.waker().clone());
                Poll::Pending
            })
        })
        .await
    }

    async fn send_to(&mut self, buf: &[u8], to: SocketAddrV4) -> Result<(), NetError> {
        let from = SocketAddrV4::new(self.net.gateway_ip, self.port);
        self.net.with(|s| {
            let q = s.udp_sent.entry(to).or_default();
            if q.len() >= UDP_SENT_KEPT {
                q.pop_front();
            }
            q.push_back((from, buf.to_vec()));
        });
        Ok(())
    }
}

#[cfg(feature = "udp")]
impl Drop for SimUdp {
    fn drop(&mut self) {
        self.net.with(|s| s.udp_bound.remove(&self.port));
    }
}

impl Conn {
    fn new(gw: SocketAddrV4, peer: SocketAddrV4) -> Self {
        Conn {
            gw,
            peer,
            to_gw: Pipe::default(),
            to_peer: Pipe::default(),
            reset: false,
            gw_closed: false,
            peer_closed: false,
            peer_dropped: false,
        }
    }
}

/// The test's end of a connection.
pub struct SimStream {
    net: SimNet,
    id: u64,
}

impl SimStream {
    /// Everything received so far (taken).
    pub fn read(&mut self) -> Vec<u8> {
        self.net.with(|s| match s.conns.get_mut(&self.id) {
            Some(c) => {
                // Whole slices, not byte by byte: fuzz targets read a lot.
                let (a, b) = c.to_peer.data.as_slices();
                let mut out = Vec::with_capacity(a.len() + b.len());
                out.extend_from_slice(a);
                out.extend_from_slice(b);
                c.to_peer.data.clear();
                out
            }
            None => Vec::new(),
        })
    }

    /// Sends `bytes` to the gateway (dropped if the connection is gone).
    pub fn write(&mut self, bytes: &[u8]) {
        self.net.with(|s| {
            if let Some(c) = s.conns.get_mut(&self.id) {
                if !c.reset && !c.gw_closed && !c.peer_closed {
                    c.to_gw.data.extend(bytes);
                    c.to_gw.wake();
                }
            }
        });
    }

    /// Closes this end (the gateway reads the end of the stream).
    pub fn close(&mut self) {
        self.net.with(|s| {
            if let Some(c) = s.conns.get_mut(&self.id) {
                c.peer_closed = true;
                c.to_gw.fin = true;
                c.to_gw.wake();
            }
        });
    }

    /// Resets the connection (the gateway's next read fails).
    pub fn reset(&mut self) {
        self.net.with(|s| {
            if let Some(c) = s.conns.get_mut(&self.id) {
                c.reset = true;
                c.to_gw.wake();
            }
        });
    }

    /// `true` while neither end closed it and it was not reset.
    pub fn is_open(&self) -> bool {
        self.net.with(|s| {
            s.conns
                .get(&self.id)
                .is_some_and(|c| !c.reset && !c.gw_closed && !c.peer_closed)
        })
    }

    /// The gateway's address on this connection.
    pub fn gateway_addr(&self) -> Option<SocketAddrV4> {
        self.net.with(|s| s.conns.get(&self.id).map(|c| c.gw))
    }
}

impl Drop for SimStream {
    fn drop(&mut self) {
        self.close();
        self.net.with(|s| {
            if let Some(c) = s.conns.get_mut(&self.id) {
                c.peer_dropped = true;
                if c.gw_closed {
                    s.conns.remove(&self.id);
                }
            }
        });
    }
}

/// A gateway socket on the simulated network.
pub struct SimSocket {
    net: SimNet,
    /// Its id (one waker per socket waiting to accept).
    sid: u64,
    conn: Option<u64>,
}

impl SimSocket {
    fn conn_state<R>(&self, f: impl FnOnce(&mut Conn) -> R) -> Option<R> {
        let id = self.conn?;
        self.net.with(|s| s.conns.get_mut(&id).map(f))
    }
}

impl Socket for SimSocket {
    async fn connect(&mut self, remote: SocketAddrV4) -> Result<(), NetError> {
        self.close().await;
        let net = self.net.clone();
        let result = net.with(|s| {
            *s.attempts.entry(remote).or_default() += 1;
            if s.blackholes.contains(remote.ip()) {
                return None;
            }
            if !s.servers.contains_key(&remote) {
                return Some(Err(NetError::ConnectFailed));
            }
            let port = s.next_port;
            s.next_port = s.next_port.wrapping_add(1).max(40000);
            let id = s.next_conn;
            s.next_conn += 1;
            let gw = SocketAddrV4::new(net.gateway_ip, port);
            s.conns.insert(id, Conn::new(gw, remote));
            if let Some(q) = s.servers.get_mut(&remote) {
                q.push_back(id);
            }
            Some(Ok(id))
        });
        match result {
            Some(Ok(id)) => {
                self.conn = Some(id);
                Ok(())
            }
            Some(Err(e)) => Err(e),
            // A host that does not answer: only a timeout ends it.
            None => core::future::pending().await,
        }
    }

    async fn accept(&mut self, port: u16) -> Result<(), NetError> {
        if self.conn.is_some() && self.conn_state(|c| !c.gw_closed).unwrap_or(false) {
            return Ok(());
        }
        let net = self.net.clone();
        let sid = self.sid;
        let id = poll_fn(|cx| {
            net.with(|s| {
                let (backlog, wakers) = s.gw_listen.entry(port).or_default();
                match backlog.pop_front() {
                    Some(id) => {
                        wakers.remove(&sid);
                        Poll::Ready(id)
                    }
                    None => {
                        wakers.insert(sid, cx.waker().clone());
                        Poll::Pending
                    }
                }
            })
        })
        .await;
        self.conn = Some(id);
        Ok(())
    }

    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, NetError> {
        let id = self.conn.ok_or(NetError::NotConnected)?;
        let net = self.net.clone();
        poll_fn(|cx| {
            net.with(|s| {
                let Some(c) = s.conns.get_mut(&id) else {
                    return Poll::Ready(Err(NetError::NotConnected));
                };
                if c.reset {
                    return Poll::Ready(Err(NetError::Reset));
                }
                if !c.to_gw.data.is_empty() {
                    let n = buf.len().min(c.to_gw.data.len());
                    // Whole slices, not byte by byte.
                    let (a, b) = c.to_gw.data.as_slices();
                    let from_a = n.min(a.len());
                    buf[..from_a].copy_from_slice(&a[..from_a]);
                    buf[from_a..n].copy_from_slice(&b[..n - from_a]);
                    c.to_gw.data.drain(..n);
                    return Poll::Ready(Ok(n));
                }
                if c.to_gw.fin || c.gw_closed {
                    return Poll::Ready(Ok(0));
                }
                c.to_gw.waker = Some(cx.waker().clone());
                Poll::Pending
            })
        })
        .await
    }

    async fn write_all(&mut self, buf: &[u8]) -> Result<(), NetError> {
        let r = self.conn_state(|c| {
            if c.reset {
                return Err(NetError::Reset);
            }
            if c.gw_closed {
                return Err(NetError::NotConnected);
            }
            if !c.peer_closed {
                c.to_peer.data.extend(buf);
            }
            Ok(())
        });
        r.unwrap_or(Err(NetError::NotConnected))
    }

    async fn close(&mut self) {
        if let Some(id) = self.conn.take() {
            self.net.with(|s| {
                if let Some(c) = s.conns.get_mut(&id) {
                    c.gw_closed = true;
                    c.to_peer.fin = true;
                    c.to_gw.wake();
                    if c.peer_dropped {
                        s.conns.remove(&id);
                    }
                }
            });
        }
    }

    fn remote(&self) -> Option<SocketAddrV4> {
        let id = self.conn?;
        self.net
            .with(|s| s.conns.get(&id).filter(|c| !c.gw_closed).map(|c| c.peer))
    }
}

impl Net for SimNet {
    type Socket<'a> = SimSocket;
    #[cfg(feature = "udp")]
    type Udp<'a> = SimUdp;

    #[cfg(feature = "udp")]
    fn udp<'a>(&'a self, port: u16, bufs: crate::net::UdpBuffers<'a>) -> Result<SimUdp, NetError> {
        self.with(|s| {
            if s.udp_bound.contains_key(&port) {
                return Err(NetError::ListenFailed);
            }
            s.udp_bound.insert(
                port,
                UdpQueue {
                    cap: bufs.rx_meta.len(),
                    ..UdpQueue::default()
                },
            );
            Ok(())
        })?;
        Ok(SimUdp {
            net: self.clone(),
            port,
        })
    }

    fn socket<'a>(&'a self, _rx: &'a mut [u8], _tx: &'a mut [u8]) -> SimSocket {
        let sid = self.with(|s| {
            s.next_socket += 1;
            s.next_socket
        });
        SimSocket {
            net: self.clone(),
            sid,
            conn: None,
        }
    }
}
