//! The socket adapter for boards: embassy-net TCP sockets.
//!
//! embassy-net has no listener type: every socket that serves a port calls
//! `accept(port)` itself, so the gateway keeps one socket per Modbus session
//! (and two for the robot link in listen mode). When all of them are busy,
//! further connection attempts are refused (RST) by the stack. A SYN that
//! took a listening socket must complete its handshake within
//! [`HANDSHAKE`], else the socket listens again (a SYN flood from forged
//! addresses holds each socket that long, not for the socket's timeout).
//! That deadline is the socket's own timeout while it listens: the stack
//! schedules it and closes the half-open socket itself (and wakes the
//! waiting task), so a listening socket costs no wake-ups until a client
//! comes (no polling: the board sleeps).

use core::net::SocketAddrV4;

use embassy_net::tcp::{State, TcpSocket};
use embassy_net::{IpAddress, IpEndpoint, Stack};
use embassy_time::Duration;

use super::{Net, NetError, Socket};

/// How long a connection may take to complete its handshake once its SYN
/// has taken a listening socket. The socket's own timeout (20 s, below)
/// would let a SYN from a forged address, whose SYN-ACKs nobody answers,
/// hold the socket that long: a SYN flood then took every listening socket
/// of Modbus and the page for 20 s after it ended (found by the robustness
/// rig, host-tests/robustness). A real client completes it in one round
/// trip; this leaves room for one SYN-ACK retransmission (the stack's first
/// retransmission timeout is 1 s).
const HANDSHAKE: Duration = Duration::from_millis(1500);

/// A connection's timeout once established: a peer that vanished without
/// FIN/RST is found within it (with the keep-alive, [`KEEP_ALIVE`]).
const TIMEOUT: Duration = Duration::from_secs(20);

/// The keep-alive's period on an established connection.
const KEEP_ALIVE: Duration = Duration::from_secs(5);

/// An embassy-net stack as the gateway's network.
#[derive(Clone, Copy)]
pub(crate) struct EmbassyNet<'d> {
    stack: Stack<'d>,
}

impl<'d> EmbassyNet<'d> {
    /// Wraps the board's stack.
    pub(crate) fn new(stack: Stack<'d>) -> Self {
        EmbassyNet { stack }
    }
}

/// An embassy-net TCP socket.
pub(crate) struct EmbassySocket<'a> {
    socket: TcpSocket<'a>,
}

impl Socket for EmbassySocket<'_> {
    async fn connect(&mut self, remote: SocketAddrV4) -> Result<(), NetError> {
        if self.socket.state() != State::Closed {
            self.close().await;
        }
        self.socket.set_timeout(Some(TIMEOUT));
        let ep = IpEndpoint::new(IpAddress::Ipv4(*remote.ip()), remote.port());
        self.socket
            .connect(ep)
            .await
            .map_err(|_| NetError::ConnectFailed)
    }

    async fn accept(&mut self, port: u16) -> Result<(), NetError> {
        loop {
            match self.socket.state() {
                State::Established | State::CloseWait => {
                    self.socket.set_timeout(Some(TIMEOUT));
                    return Ok(());
                }
                State::Closed | State::Listen => {
                    // While listening the socket's timeout is the handshake's
                    // deadline: a SYN whose sender never completes the
                    // handshake (a forged source) is reset by the stack
                    // HANDSHAKE after it came, and `accept` returns with the
                    // socket closed: it listens again (the next round).
                    self.socket.set_timeout(Some(HANDSHAKE));
                    self.socket
                        .accept(port)
                        .await
                        .map_err(|_| NetError::ListenFailed)?;
                }
                // Only after an earlier `accept` was dropped mid-handshake:
                // its deadline still runs; look again once it is past.
                State::SynReceived => embassy_time::Timer::after(HANDSHAKE).await,
                // Closing states of an earlier connection: end it, listen again.
                _ => self.close().await,
            }
        }
    }

    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, NetError> {
        self.socket.read(buf).await.map_err(|_| NetError::Reset)
    }

    async fn write_all(&mut self, mut buf: &[u8]) -> Result<(), NetError> {
        while !buf.is_empty() {
            let n = self.socket.write(buf).await.map_err(|_| NetError::Reset)?;
            if n == 0 {
                return Err(NetError::Reset);
            }
            buf = buf.get(n..).unwrap_or(&[]);
        }
        self.socket.flush().await.map_err(|_| NetError::Reset)
    }

    async fn close(&mut self) {
        self.socket.close();
        self.socket.abort();
        // Let the stack send the RST before the socket is reused; bounded
        // because a dead peer must not keep us here.
        let _ = embassy_time::with_timeout(Duration::from_millis(200), self.socket.flush()).await;
    }

    fn remote(&self) -> Option<SocketAddrV4> {
        match self.socket.remote_endpoint() {
            Some(IpEndpoint {
                addr: IpAddress::Ipv4(ip),
                port,
            }) => Some(SocketAddrV4::new(ip, port)),
            #[allow(unreachable_patterns)]
            _ => None,
        }
    }
}

/// An embassy-net UDP socket (feature `udp`): its queues are the buffers
/// it was made with, and the stack drops what does not fit them.
#[cfg(feature = "udp")]
pub(crate) struct EmbassyUdp<'a> {
    socket: embassy_net::udp::UdpSocket<'a>,
}

#[cfg(feature = "udp")]
impl super::UdpSocket for EmbassyUdp<'_> {
    async fn recv_from(&mut self, buf: &mut [u8]) -> Result<(usize, SocketAddrV4), NetError> {
        use embassy_net::udp::RecvError;
        loop {
            match self.socket.recv_from(buf).await {
                Ok((
                    n,
                    embassy_net::udp::UdpMetadata {
                        endpoint:
                            IpEndpoint {
                                addr: IpAddress::Ipv4(ip),
                                port,
                            },
                        ..
                    },
                )) => return Ok((n, SocketAddrV4::new(ip, port))),
                // Longer than `buf` (dropped by the stack's read), or not
                // IPv4 (with IPv6 in the stack): the next one.
                #[allow(unreachable_patterns)]
                Ok(_) | Err(RecvError::Truncated) => continue,
            }
        }
    }

    async fn send_to(&mut self, buf: &[u8], to: SocketAddrV4) -> Result<(), NetError> {
        let ep = IpEndpoint::new(IpAddress::Ipv4(*to.ip()), to.port());
        self.socket
            .send_to(buf, ep)
            .await
            .map_err(|_| NetError::Reset)
    }
}

impl<'d> Net for EmbassyNet<'d> {
    type Socket<'a>
        = EmbassySocket<'a>
    where
        Self: 'a;

    #[cfg(feature = "udp")]
    type Udp<'a>
        = EmbassyUdp<'a>
    where
        Self: 'a;

    #[cfg(feature = "udp")]
    fn udp<'a>(
        &'a self,
        port: u16,
        bufs: super::UdpBuffers<'a>,
    ) -> Result<EmbassyUdp<'a>, NetError> {
        let mut socket = embassy_net::udp::UdpSocket::new(
            self.stack,
            bufs.rx_meta,
            bufs.rx,
            bufs.tx_meta,
            bufs.tx,
        );
        socket.bind(port).map_err(|_| NetError::ListenFailed)?;
        Ok(EmbassyUdp { socket })
    }

    fn socket<'a>(&'a self, rx: &'a mut [u8], tx: &'a mut [u8]) -> EmbassySocket<'a> {
        let mut socket = TcpSocket::new(self.stack, rx, tx);
        // A peer that vanished without FIN/RST is found within ~20 s.
        socket.set_keep_alive(Some(KEEP_ALIVE));
        socket.set_timeout(Some(TIMEOUT));
        socket.set_nagle_enabled(false);
        EmbassySocket { socket }
    }
}
