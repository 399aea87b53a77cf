//! The small socket interface the gateway logic runs on: the platform API
//! a network stack implements.
//!
//! The logic needs only TCP streams it can connect, accept, read, write and
//! close, and it reuses each socket for many connections in turn (a board
//! has a fixed number of sockets with fixed buffers). Two adapters exist:
//!
//! * `embassy` (feature `embassy-net`): boards, and the two-stacks host
//!   test.
//! * tokio, in the Linux crate (`hans-gateway-linux`), which also serves
//!   TLS behind the same interface (HTTPS, Modbus/TCP Security): the
//!   servers above do not change; a Modbus session asks its socket what
//!   the client's certificate claims ([`Socket::peer_claim`]) and decides
//!   what that grants.
//!
//! The futures are not `Send`: the whole gateway runs as one task on a
//! single-threaded executor (embassy's, or tokio's current-thread runtime).
//!
//! ## UDP (feature `udp`)
//! A listener that takes datagrams (EtherNet/IP's discovery on 44818 and
//! its class 1 I/O on 2222) binds a [`UdpSocket`] with [`Net::udp`] and
//! fixed buffers ([`UdpBuffers`]): at most as many datagrams as it has
//! packet slots, and as many bytes as its receive buffer holds, wait to be
//! read; the stack drops what arrives beyond that (embassy-net's queue; on
//! Linux the kernel's socket buffer). So a flood of datagrams costs the
//! gateway the reading of what fits in the queue, and otherwise nothing but
//! a drop: no allocation, no growing queue, no socket taken from another
//! listener. A datagram longer than the reader's buffer is dropped whole,
//! never handed over cut.

use core::net::{Ipv4Addr, SocketAddrV4};

#[cfg(feature = "embassy-net")]
pub(crate) mod embassy;

/// The longest role word a [`PeerClaim`] carries.
pub const CLAIM_MAX: usize = 16;

/// What a transport that authenticates its clients says of the peer (TLS
/// with client certificates: Modbus/TCP Security on Linux); the server
/// decides what it grants. The socket layer knows no roles.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum PeerClaim {
    /// The transport does not authenticate clients (plain TCP, HTTPS).
    None,
    /// The client is authenticated by a certificate (or its handshake has
    /// not ended yet): the role word it claims (the Modbus/TCP Security
    /// role extension's text), or `None` where it claims none, an
    /// unreadable one, one longer than [`CLAIM_MAX`], or has not finished
    /// its handshake.
    Certificate(Option<heapless::String<CLAIM_MAX>>),
}

/// Why a socket operation failed. Every failure ends the connection.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NetError {
    /// The peer refused or did not answer the connection attempt.
    ConnectFailed,
    /// The local port cannot be listened on.
    ListenFailed,
    /// The connection was reset or broke.
    Reset,
    /// The operation needs a connected socket.
    NotConnected,
    /// This platform has no TLS client (boards).
    TlsUnavailable,
    /// The TLS handshake failed (the server's certificate is not signed by
    /// a trusted CA or names another host, no common protocol version,
    /// the trusted CAs could not be read).
    TlsFailed,
}

impl NetError {
    /// A short text for logs.
    pub fn as_str(self) -> &'static str {
        match self {
            NetError::ConnectFailed => "connect failed",
            NetError::ListenFailed => "listen failed",
            NetError::Reset => "connection reset",
            NetError::NotConnected => "not connected",
            NetError::TlsUnavailable => "TLS not available on this device",
            NetError::TlsFailed => "TLS handshake failed",
        }
    }
}

/// One reusable TCP socket: connect or accept, talk, close, start again.
// The futures are deliberately not `Send` (single-threaded executors).
#[allow(async_fn_in_trait)]
pub trait Socket {
    /// Connects to `remote`. The socket must be closed.
    async fn connect(&mut self, remote: SocketAddrV4) -> Result<(), NetError>;

    /// Connects to `remote` and starts TLS, checking that the server's
    /// certificate names `server_name` (a host name or an address) and is
    /// signed by a trusted CA. The socket must be closed. Platforms
    /// without a TLS client answer [`NetError::TlsUnavailable`].
    async fn connect_tls(
        &mut self,
        remote: SocketAddrV4,
        server_name: &str,
    ) -> Result<(), NetError> {
        let _ = (remote, server_name);
        Err(NetError::TlsUnavailable)
    }

    /// Waits for a peer to connect to local `port`. Cancel-safe: if the
    /// future is dropped and `accept` is called again, a connection that
    /// arrived in between is returned.
    async fn accept(&mut self, port: u16) -> Result<(), NetError>;

    /// Reads what is available (at least one byte); `Ok(0)` when the peer
    /// closed its side. Cancel-safe.
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, NetError>;

    /// Writes all of `buf`.
    async fn write_all(&mut self, buf: &[u8]) -> Result<(), NetError>;

    /// Ends the connection (if any) so that the socket can be reused.
    async fn close(&mut self);

    /// The peer's address while connected.
    fn remote(&self) -> Option<SocketAddrV4>;

    /// The connection is encrypted (a TLS server's, Linux `--web-tls`):
    /// the web page's session cookie is then marked `Secure`.
    fn encrypted(&self) -> bool {
        false
    }

    /// What the client's certificate claims, where the connection was
    /// accepted by a TLS server that requires client certificates
    /// (Modbus/TCP Security on Linux). [`PeerClaim::None`]: no client
    /// authentication (plain TCP, HTTPS), the allow-list alone decides.
    fn peer_claim(&self) -> PeerClaim {
        PeerClaim::None
    }
}

/// The bookkeeping of one queued datagram of a UDP socket (its length and
/// sender): embassy-net's on boards; nothing elsewhere (tokio's sockets and
/// the test network keep their own). A [`UdpBuffers`] has one per datagram
/// that may wait.
#[cfg(all(feature = "udp", feature = "embassy-net"))]
pub type PacketMeta = embassy_net::udp::PacketMetadata;
/// The bookkeeping of one queued datagram of a UDP socket (its length and
/// sender): embassy-net's on boards; nothing elsewhere (tokio's sockets and
/// the test network keep their own). A [`UdpBuffers`] has one per datagram
/// that may wait.
#[cfg(all(feature = "udp", not(feature = "embassy-net")))]
#[derive(Clone, Copy, Debug)]
pub struct PacketMeta;

/// An empty [`PacketMeta`], to fill arrays with.
#[cfg(all(feature = "udp", feature = "embassy-net"))]
pub const PACKET_META: PacketMeta = embassy_net::udp::PacketMetadata::EMPTY;
/// An empty [`PacketMeta`], to fill arrays with.
#[cfg(all(feature = "udp", not(feature = "embassy-net")))]
pub const PACKET_META: PacketMeta = PacketMeta;

/// The buffers of a UDP socket: `rx_meta.len()` datagrams of `rx.len()`
/// bytes in all may wait to be read (more are dropped by the stack), and
/// `tx_meta.len()` datagrams of `tx.len()` bytes to be sent. Adapters with
/// their own buffering (tokio's) use none of it; the bound is then the
/// kernel's socket buffer.
#[cfg(feature = "udp")]
pub struct UdpBuffers<'a> {
    /// A slot per received datagram that may wait.
    pub rx_meta: &'a mut [PacketMeta],
    /// The received datagrams' bytes.
    pub rx: &'a mut [u8],
    /// A slot per datagram waiting to be sent.
    pub tx_meta: &'a mut [PacketMeta],
    /// The bytes waiting to be sent.
    pub tx: &'a mut [u8],
}

/// A bound UDP socket.
#[cfg(feature = "udp")]
#[allow(async_fn_in_trait)]
pub trait UdpSocket {
    /// The next datagram: its length in `buf` and its sender. A datagram
    /// longer than `buf` is dropped (and the next one waited for), never
    /// handed over cut. Cancel-safe: a datagram not yet returned stays
    /// queued.
    async fn recv_from(&mut self, buf: &mut [u8]) -> Result<(usize, SocketAddrV4), NetError>;

    /// Sends `buf` to `to` as one datagram (waits for room in the socket's
    /// send buffer; one larger than that buffer is an error).
    async fn send_to(&mut self, buf: &[u8], to: SocketAddrV4) -> Result<(), NetError>;
}

/// A network stack that makes sockets.
#[allow(async_fn_in_trait)]
pub trait Net {
    /// The socket type, borrowing the stack and its buffers.
    type Socket<'a>: Socket
    where
        Self: 'a;

    /// A new, closed socket using `rx` and `tx` as its buffers (adapters with
    /// their own buffering, like tokio's, ignore them).
    fn socket<'a>(&'a self, rx: &'a mut [u8], tx: &'a mut [u8]) -> Self::Socket<'a>;

    /// The UDP socket type (feature `udp`).
    #[cfg(feature = "udp")]
    type Udp<'a>: UdpSocket
    where
        Self: 'a;

    /// A UDP socket bound to local `port` with `bufs` (feature `udp`);
    /// [`NetError::ListenFailed`] if the port cannot be bound.
    #[cfg(feature = "udp")]
    fn udp<'a>(&'a self, port: u16, bufs: UdpBuffers<'a>) -> Result<Self::Udp<'a>, NetError>;

    /// The IPv4 address of the host `name`, where the platform resolves
    /// names (Linux: the system's resolver); `None` where it does not
    /// (boards: their settings take addresses) or when the name has none.
    async fn resolve(&self, name: &str) -> Option<Ipv4Addr> {
        let _ = name;
        None
    }
}
