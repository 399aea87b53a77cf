//! The socket adapter for boards: embassy-net TCP sockets.
//!
//! embassy-net has no listener type: every socket that serves a port calls
//! `accept(port)` itself, so the gateway keeps one socket per Modbus session
//! (and two for the robot link in listen mode). When all of them are busy,
//! further connection attempts are refused (RST) by the stack.

use core::net::SocketAddrV4;

use embassy_net::tcp::{State, TcpSocket};
use embassy_net::{IpAddress, IpEndpoint, Stack};
use embassy_time::Duration;

use super::{Net, NetError, Socket};

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
        let ep = IpEndpoint::new(IpAddress::Ipv4(*remote.ip()), remote.port());
        self.socket
            .connect(ep)
            .await
            .map_err(|_| NetError::ConnectFailed)
    }

    async fn accept(&mut self, port: u16) -> Result<(), NetError> {
        match self.socket.state() {
            State::Closed => self
                .socket
                .accept(port)
                .await
                .map_err(|_| NetError::ListenFailed),
            // A former `accept` was cancelled with the socket listening: the
            // handshake goes on in the stack; wait until it completes.
            State::Listen | State::SynReceived => {
                self.socket.wait_write_ready().await;
                match self.socket.state() {
                    State::Established => Ok(()),
                    _ => Err(NetError::Reset),
                }
            }
            State::Established => Ok(()),
            _ => {
                self.close().await;
                self.socket
                    .accept(port)
                    .await
                    .map_err(|_| NetError::ListenFailed)
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

impl<'d> Net for EmbassyNet<'d> {
    type Socket<'a>
        = EmbassySocket<'a>
    where
        Self: 'a;

    fn socket<'a>(&'a self, rx: &'a mut [u8], tx: &'a mut [u8]) -> EmbassySocket<'a> {
        let mut socket = TcpSocket::new(self.stack, rx, tx);
        // A peer that vanished without FIN/RST is found within ~20 s.
        socket.set_keep_alive(Some(Duration::from_secs(5)));
        socket.set_timeout(Some(Duration::from_secs(20)));
        socket.set_nagle_enabled(false);
        EmbassySocket { socket }
    }
}
