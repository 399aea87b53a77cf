//! The socket adapter for Linux: tokio streams and listeners.
//!
//! Listening ports are bound once and shared by every socket that accepts on
//! them ([`TokioNet::listen`] binds ahead, which lets a caller use port 0 and
//! learn the real port; `accept` on a port not yet bound binds it on
//! [`TokioNet::new`]'s address). Connections beyond the ones being accepted
//! wait in the kernel's backlog.
//!
//! A listener made with a TLS server (`TokioNet::listen_tls`) hands its sockets connections whose handshake starts at
//! their first read or write and must end within
//! `tls::HANDSHAKE_DEADLINE` (see the `tls` module); the address is
//! known at accept, so the servers' allow-lists and slots apply before
//! the handshake costs anything. A TLS listener may also serve beside
//! another port (`TokioNet::listen_tls_beside`): the sockets accepting
//! on that port take its connections too (Modbus/TCP Security's clients
//! share the Modbus sessions with the plain ones).
//!
//! Needs a tokio runtime with I/O enabled (current-thread is enough).

use core::cell::RefCell;
use core::future::Future;
use core::net::{Ipv4Addr, SocketAddr, SocketAddrV4};
use std::borrow::ToOwned;
use std::io;
use std::rc::Rc;
use std::string::ToString;
use std::vec::Vec;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};

use hans_gateway::net::{Net, NetError, PeerClaim, Socket, UdpBuffers, UdpSocket};

/// A bound listener: sockets accepting on `port` take its connections.
struct Listener {
    /// The port sockets accept on (its own, or the one it serves beside).
    port: u16,
    tcp: Rc<TcpListener>,
    /// Its connections start TLS as this server.
    tls: Option<Rc<crate::tls::TlsServer>>,
}

/// Tokio networking for the gateway.
pub struct TokioNet {
    bind_ip: core::net::Ipv4Addr,
    listeners: RefCell<Vec<Listener>>,
    /// UDP ports bound ahead ([`TokioNet::listen_udp`]), by the port the
    /// gateway asks for, until it takes them.
    udp_bound: RefCell<Vec<(u16, std::net::UdpSocket)>>,
    /// The PEM file of the CAs a TLS server must be signed by
    /// ([`Socket::connect_tls`]); read at each TLS connect.
    tls_ca: Option<std::path::PathBuf>,
}

impl TokioNet {
    /// A stack whose on-demand listeners bind to `bind_ip` (use
    /// `127.0.0.1` in tests).
    pub fn new(bind_ip: core::net::Ipv4Addr) -> Self {
        TokioNet {
            bind_ip,
            listeners: RefCell::new(Vec::new()),
            udp_bound: RefCell::new(Vec::new()),
            tls_ca: None,
        }
    }

    /// TLS clients of this stack trust the CAs of the PEM file `ca`.
    pub fn with_tls_ca(mut self, ca: std::path::PathBuf) -> Self {
        self.tls_ca = Some(ca);
        self
    }

    /// Binds `addr` now and returns the port bound (useful with port 0).
    /// Sockets then accept on that port.
    pub async fn listen(&self, addr: SocketAddrV4) -> io::Result<u16> {
        self.bind(addr, None, None).await
    }

    /// Binds the UDP port `addr` now and returns the port bound (useful
    /// with port 0); the gateway's `udp(port)` then takes this socket.
    pub fn listen_udp(&self, addr: SocketAddrV4) -> io::Result<u16> {
        let s = std::net::UdpSocket::bind(addr)?;
        let port = s.local_addr()?.port();
        self.udp_bound.borrow_mut().push((port, s));
        Ok(port)
    }

    /// Binds `addr` now for TLS as `server`; returns the port bound.
    /// Sockets accepting on that port start TLS with their clients.
    pub(crate) async fn listen_tls(
        &self,
        addr: SocketAddrV4,
        server: crate::tls::TlsServer,
    ) -> io::Result<u16> {
        self.bind(addr, None, Some(server)).await
    }

    /// Binds `addr` now for TLS as `server`, its connections accepted by
    /// the sockets accepting on `beside` (bound before); returns the port
    /// bound.
    pub(crate) async fn listen_tls_beside(
        &self,
        beside: u16,
        addr: SocketAddrV4,
        server: crate::tls::TlsServer,
    ) -> io::Result<u16> {
        self.bind(addr, Some(beside), Some(server)).await
    }

    /// Binds `addr` for the sockets accepting on `beside` (else on the
    /// port bound), with TLS as `server` if given; returns the port bound.
    async fn bind(
        &self,
        addr: SocketAddrV4,
        beside: Option<u16>,
        server: Option<crate::tls::TlsServer>,
    ) -> io::Result<u16> {
        let l = TcpListener::bind(addr).await?;
        let port = l.local_addr()?.port();
        self.listeners.borrow_mut().push(Listener {
            port: beside.unwrap_or(port),
            tcp: Rc::new(l),
            tls: server.map(Rc::new),
        });
        Ok(port)
    }

    /// The listeners whose connections sockets accepting on `port` take
    /// (`port` bound now on [`Self::new`]'s address if none is).
    async fn listeners(&self, port: u16) -> Result<Vec<Accepting>, NetError> {
        let found = |ls: &Vec<Listener>| -> Vec<Accepting> {
            ls.iter()
                .filter(|l| l.port == port)
                .map(|l| Accepting {
                    tcp: l.tcp.clone(),
                    tls: l.tls.clone(),
                })
                .collect()
        };
        let ls = found(&self.listeners.borrow());
        if !ls.is_empty() {
            return Ok(ls);
        }
        self.listen(SocketAddrV4::new(self.bind_ip, port))
            .await
            .map_err(|_| NetError::ListenFailed)?;
        let ls = found(&self.listeners.borrow());
        if ls.is_empty() {
            return Err(NetError::ListenFailed);
        }
        Ok(ls)
    }
}

/// A listener a socket accepts from.
struct Accepting {
    tcp: Rc<TcpListener>,
    tls: Option<Rc<crate::tls::TlsServer>>,
}

impl Accepting {
    /// The next connection, as this listener hands it out. Cancel-safe
    /// (tokio's `accept` is).
    async fn accept(&self) -> io::Result<Stream> {
        let (s, _) = self.tcp.accept().await?;
        // Small request/reply messages: send each at once.
        let _ = s.set_nodelay(true);
        if let Some(server) = &self.tls {
            return Ok(Stream::Handshake(std::boxed::Box::new(Handshake {
                accept: server.acceptor.accept(s),
                server: server.clone(),
                until: None,
            })));
        }
        Ok(Stream::Plain(s))
    }
}

/// A TLS server's connection whose handshake has not ended: it runs at
/// the first read or write ([`Stream::ready`]).
struct Handshake {
    accept: tokio_rustls::Accept<TcpStream>,
    server: Rc<crate::tls::TlsServer>,
    /// When it must have ended (set when it starts).
    until: Option<tokio::time::Instant>,
}

/// A tokio TCP stream slot.
pub struct TokioSocket<'a> {
    net: &'a TokioNet,
    stream: Option<Stream>,
}

/// A connection: plain TCP, or TLS over it (a client's, or a server's
/// before and after its handshake).
enum Stream {
    Plain(TcpStream),
    Tls(std::boxed::Box<tokio_rustls::client::TlsStream<TcpStream>>),
    Handshake(std::boxed::Box<Handshake>),
    /// A TLS server's connection, and what its client's certificate claims
    /// when the server asked for one.
    Served(
        std::boxed::Box<tokio_rustls::server::TlsStream<TcpStream>>,
        Option<PeerClaim>,
    ),
}

impl Stream {
    /// Ends a TLS server's handshake if it has not ended (within its
    /// deadline from the first call); else nothing. Cancel-safe: the
    /// handshake goes on at the next call, with the same deadline.
    async fn ready(&mut self) -> io::Result<()> {
        let Stream::Handshake(h) = self else {
            return Ok(());
        };
        let peer = h
            .accept
            .get_ref()
            .and_then(|s| s.peer_addr().ok())
            .map_or_else(|| "(unknown)".to_owned(), |a| a.to_string());
        let deadline = crate::tls::HANDSHAKE_DEADLINE;
        let until = *h.until.get_or_insert_with(|| {
            tokio::time::Instant::now() + std::time::Duration::from_millis(deadline.as_millis())
        });
        let what = h.server.what;
        let tls = match tokio::time::timeout_at(until, &mut h.accept).await {
            Ok(Ok(tls)) => tls,
            Ok(Err(e)) => {
                log::warn!("{what}: TLS handshake with {peer} refused: {e}");
                return Err(e);
            }
            Err(_) => {
                log::warn!(
                    "{what}: TLS handshake with {peer} not done within {} ms, closing",
                    deadline.as_millis()
                );
                return Err(io::ErrorKind::TimedOut.into());
            }
        };
        let role = if h.server.clients {
            let cert = tls
                .get_ref()
                .1
                .peer_certificates()
                .and_then(|c| c.first())
                .map(|c| crate::tls::client_cert(c));
            match &cert {
                Some(c) => log::info!(
                    "{what}: TLS client {peer} authenticated as {:?}, role extension {:?}",
                    c.subject,
                    c.role,
                ),
                None => log::warn!("{what}: TLS client {peer} without a certificate: no role"),
            }
            Some(cert.map_or(PeerClaim::Certificate(None), |c| c.role.claim()))
        } else {
            None
        };
        *self = Stream::Served(std::boxed::Box::new(tls), role);
        Ok(())
    }

    async fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self {
            Stream::Plain(s) => s.read(buf).await,
            Stream::Tls(s) => s.read(buf).await,
            Stream::Served(s, _) => s.read(buf).await,
            Stream::Handshake(_) => Err(io::ErrorKind::NotConnected.into()),
        }
    }

    async fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        match self {
            Stream::Plain(s) => s.write_all(buf).await,
            Stream::Tls(s) => {
                s.write_all(buf).await?;
                // rustls buffers: what was written goes out now.
                s.flush().await
            }
            Stream::Served(s, _) => {
                s.write_all(buf).await?;
                s.flush().await
            }
            Stream::Handshake(_) => Err(io::ErrorKind::NotConnected.into()),
        }
    }

    async fn shutdown(&mut self) -> io::Result<()> {
        match self {
            Stream::Plain(s) => s.shutdown().await,
            Stream::Tls(s) => s.shutdown().await,
            Stream::Served(s, _) => s.shutdown().await,
            // No TLS yet: dropping the stream closes the connection.
            Stream::Handshake(_) => Ok(()),
        }
    }

    fn tcp(&self) -> Option<&TcpStream> {
        match self {
            Stream::Plain(s) => Some(s),
            Stream::Tls(s) => Some(s.get_ref().0),
            Stream::Served(s, _) => Some(s.get_ref().0),
            Stream::Handshake(h) => h.accept.get_ref(),
        }
    }

    /// What a TLS client's certificate claims (see
    /// [`Socket::peer_claim`]).
    fn peer_claim(&self) -> PeerClaim {
        match self {
            Stream::Served(_, Some(claim)) => claim.clone(),
            // Not authenticated yet: no claim (the least).
            Stream::Handshake(h) if h.server.clients => PeerClaim::Certificate(None),
            _ => PeerClaim::None,
        }
    }
}

/// The TLS client configuration: the CAs of `ca` (PEM), else the system's
/// bundle; TLS 1.2 and 1.3 with rustls' safe defaults (ring).
fn tls_config(
    ca: Option<&std::path::Path>,
) -> Result<std::sync::Arc<rustls::ClientConfig>, NetError> {
    use rustls::pki_types::pem::PemObject;
    use rustls::pki_types::CertificateDer;
    const SYSTEM: &str = "/etc/ssl/certs/ca-certificates.crt";
    let path = ca.unwrap_or(std::path::Path::new(SYSTEM));
    let mut roots = rustls::RootCertStore::empty();
    let certs = CertificateDer::pem_file_iter(path).map_err(|e| {
        log::warn!("tls: cannot read the CA file {}: {e}", path.display());
        NetError::TlsFailed
    })?;
    for cert in certs {
        let cert = cert.map_err(|_| NetError::TlsFailed)?;
        roots.add(cert).map_err(|_| NetError::TlsFailed)?;
    }
    if roots.is_empty() {
        log::warn!("tls: no CA certificate in {}", path.display());
        return Err(NetError::TlsFailed);
    }
    let provider = std::sync::Arc::new(rustls::crypto::ring::default_provider());
    let config = rustls::ClientConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .map_err(|_| NetError::TlsFailed)?
        .with_root_certificates(roots)
        .with_no_client_auth();
    Ok(std::sync::Arc::new(config))
}

fn v4(addr: SocketAddr) -> Option<SocketAddrV4> {
    match addr {
        SocketAddr::V4(a) => Some(a),
        SocketAddr::V6(a) => a
            .ip()
            .to_ipv4_mapped()
            .map(|ip| SocketAddrV4::new(ip, a.port())),
    }
}

impl TokioSocket<'_> {
    /// Ends a TLS server's handshake first (see [`Stream::ready`]); one
    /// that failed or timed out ends the connection (it cannot go on).
    async fn ready(&mut self) -> Result<(), NetError> {
        if let Some(s) = self.stream.as_mut() {
            if s.ready().await.is_err() {
                self.stream = None;
                return Err(NetError::Reset);
            }
        }
        Ok(())
    }
}

impl Socket for TokioSocket<'_> {
    async fn connect(&mut self, remote: SocketAddrV4) -> Result<(), NetError> {
        let s = TcpStream::connect(remote)
            .await
            .map_err(|_| NetError::ConnectFailed)?;
        // Small request/reply messages: send each at once.
        let _ = s.set_nodelay(true);
        self.stream = Some(Stream::Plain(s));
        Ok(())
    }

    async fn connect_tls(
        &mut self,
        remote: SocketAddrV4,
        server_name: &str,
    ) -> Result<(), NetError> {
        let name = rustls::pki_types::ServerName::try_from(server_name.to_owned())
            .map_err(|_| NetError::TlsFailed)?;
        let config = tls_config(self.net.tls_ca.as_deref())?;
        let s = TcpStream::connect(remote)
            .await
            .map_err(|_| NetError::ConnectFailed)?;
        let _ = s.set_nodelay(true);
        let tls = tokio_rustls::TlsConnector::from(config)
            .connect(name, s)
            .await
            .map_err(|e| {
                log::warn!("tls: handshake with {remote} ({server_name}) failed: {e}");
                NetError::TlsFailed
            })?;
        self.stream = Some(Stream::Tls(std::boxed::Box::new(tls)));
        Ok(())
    }

    async fn accept(&mut self, port: u16) -> Result<(), NetError> {
        let ls = self.net.listeners(port).await?;
        let stream = match ls.as_slice() {
            [one] => one.accept().await,
            // Several listeners (one beside the other): the first
            // connection of any.
            _ => {
                let mut accepts: Vec<_> = ls
                    .iter()
                    .map(|l| std::boxed::Box::pin(l.accept()))
                    .collect();
                core::future::poll_fn(|cx| {
                    accepts
                        .iter_mut()
                        .find_map(|a| match a.as_mut().poll(cx) {
                            core::task::Poll::Ready(r) => Some(r),
                            core::task::Poll::Pending => None,
                        })
                        .map_or(core::task::Poll::Pending, core::task::Poll::Ready)
                })
                .await
            }
        };
        self.stream = Some(stream.map_err(|_| NetError::ListenFailed)?);
        Ok(())
    }

    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, NetError> {
        self.ready().await?;
        let s = self.stream.as_mut().ok_or(NetError::NotConnected)?;
        s.read(buf).await.map_err(|_| NetError::Reset)
    }

    async fn write_all(&mut self, buf: &[u8]) -> Result<(), NetError> {
        self.ready().await?;
        let s = self.stream.as_mut().ok_or(NetError::NotConnected)?;
        s.write_all(buf).await.map_err(|_| NetError::Reset)
    }

    fn peer_claim(&self) -> PeerClaim {
        self.stream
            .as_ref()
            .map_or(PeerClaim::None, Stream::peer_claim)
    }

    async fn close(&mut self) {
        if let Some(mut s) = self.stream.take() {
            let _ = s.shutdown().await;
        }
    }

    fn encrypted(&self) -> bool {
        if let Some(Stream::Handshake(_) | Stream::Served(..)) = &self.stream {
            return true;
        }
        false
    }

    fn remote(&self) -> Option<SocketAddrV4> {
        self.stream
            .as_ref()
            .and_then(Stream::tcp)
            .and_then(|s| s.peer_addr().ok())
            .and_then(v4)
    }
}

/// A tokio UDP socket. Its receive queue is the kernel's socket buffer
/// (what a flood brings beyond it is dropped by the kernel); datagrams are
/// read one at a time into a buffer of the largest UDP payload, so that
/// one longer than the caller's buffer is recognized and dropped whole.
pub struct TokioUdp {
    socket: tokio::net::UdpSocket,
    scratch: Vec<u8>,
}

/// The largest UDP payload over IPv4.
const UDP_MAX: usize = 65_507;

impl UdpSocket for TokioUdp {
    async fn recv_from(&mut self, buf: &mut [u8]) -> Result<(usize, SocketAddrV4), NetError> {
        loop {
            let (n, from) = self
                .socket
                .recv_from(&mut self.scratch)
                .await
                .map_err(|_| NetError::Reset)?;
            let (Some(from), Some(dst), Some(src)) =
                (v4(from), buf.get_mut(..n), self.scratch.get(..n))
            else {
                // IPv6, or longer than `buf`: dropped.
                continue;
            };
            dst.copy_from_slice(src);
            return Ok((n, from));
        }
    }

    async fn send_to(&mut self, buf: &[u8], to: SocketAddrV4) -> Result<(), NetError> {
        match self.socket.send_to(buf, to).await {
            Ok(n) if n == buf.len() => Ok(()),
            _ => Err(NetError::Reset),
        }
    }
}

impl Net for TokioNet {
    type Socket<'a> = TokioSocket<'a>;
    type Udp<'a> = TokioUdp;

    /// Binds `port` on the address of [`TokioNet::new`] (or the address a
    /// caller bound ahead with [`TokioNet::listen_udp`]).
    fn udp<'a>(&'a self, port: u16, _bufs: UdpBuffers<'a>) -> Result<TokioUdp, NetError> {
        let bound = self
            .udp_bound
            .borrow_mut()
            .iter()
            .position(|(p, _)| *p == port);
        let std_socket = match bound {
            Some(i) => self.udp_bound.borrow_mut().swap_remove(i).1,
            None => std::net::UdpSocket::bind(SocketAddrV4::new(self.bind_ip, port))
                .map_err(|_| NetError::ListenFailed)?,
        };
        std_socket
            .set_nonblocking(true)
            .map_err(|_| NetError::ListenFailed)?;
        let socket =
            tokio::net::UdpSocket::from_std(std_socket).map_err(|_| NetError::ListenFailed)?;
        Ok(TokioUdp {
            socket,
            scratch: std::vec![0; UDP_MAX],
        })
    }

    fn socket<'a>(&'a self, _rx: &'a mut [u8], _tx: &'a mut [u8]) -> TokioSocket<'a> {
        TokioSocket {
            net: self,
            stream: None,
        }
    }

    async fn resolve(&self, name: &str) -> Option<Ipv4Addr> {
        // The system's resolver (getaddrinfo, on tokio's blocking pool);
        // the first IPv4 address.
        tokio::net::lookup_host((name, 0))
            .await
            .ok()?
            .find_map(|a| match a.ip() {
                std::net::IpAddr::V4(ip) => Some(ip),
                std::net::IpAddr::V6(_) => None,
            })
    }
}

#[cfg(test)]
mod tests {
    //! The TLS handshake's deadline in virtual time: tokio's clock paused,
    //! it moves to the next timer whenever nothing else can run, so the
    //! instant a connection is closed is exact, whatever the machine's
    //! load. (The servers' use of it, and a handshake that ends, are tested
    //! against the `hans-gateway` binary: tests/tls.rs.)

    use super::*;
    use std::path::{Path, PathBuf};
    use std::time::Duration;

    /// A directory of its own, removed when dropped.
    struct TempDir(PathBuf);

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    /// A self-signed certificate for 127.0.0.1 and its key, made with
    /// Debian's `openssl` (as tests/tls.rs makes its PKI) in `dir`.
    fn identity(dir: &Path) -> (PathBuf, PathBuf) {
        let (cert, key) = (dir.join("server.crt"), dir.join("server.key"));
        let out = std::process::Command::new("openssl")
            .args(["req", "-x509", "-newkey", "ec", "-pkeyopt"])
            .args(["ec_paramgen_curve:P-256", "-nodes", "-days", "2"])
            .args(["-subj", "/CN=127.0.0.1", "-keyout"])
            .arg(&key)
            .arg("-out")
            .arg(&cert)
            .output()
            .expect("openssl (Debian's package) is installed");
        assert!(
            out.status.success(),
            "openssl: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        (cert, key)
    }

    /// A TLS listener's connection whose client sends `hello` and then
    /// nothing: how long the server's first read (which runs the
    /// handshake) took to fail, and how long until the client saw the
    /// connection closed, both from that read's start.
    fn held(name: &str, hello: &'static [u8]) -> (Duration, Duration) {
        let dir = TempDir(
            std::env::temp_dir().join(format!("hans-net-deadline-{}-{name}", std::process::id())),
        );
        std::fs::create_dir_all(&dir.0).unwrap();
        let (cert, key) = identity(&dir.0);
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .start_paused(true)
            .build()
            .unwrap();
        let test = async {
            let net = TokioNet::new(Ipv4Addr::LOCALHOST);
            let server = crate::tls::TlsServer::web(&cert, &key).unwrap();
            let any = SocketAddrV4::new(Ipv4Addr::LOCALHOST, 0);
            let port = net.listen_tls(any, server).await.unwrap();
            let client = tokio::spawn(async move {
                let mut s = TcpStream::connect(("127.0.0.1", port)).await.unwrap();
                s.write_all(hello).await.unwrap();
                let mut sink = [0u8; 512];
                // Until the server closes it (an alert may come first).
                loop {
                    match s.read(&mut sink).await {
                        Ok(0) | Err(_) => return tokio::time::Instant::now(),
                        Ok(_) => {}
                    }
                }
            });
            let (mut rx, mut tx) = ([0u8; 0], [0u8; 0]);
            let mut sock = net.socket(&mut rx, &mut tx);
            sock.accept(port).await.unwrap();
            let start = tokio::time::Instant::now();
            let mut buf = [0u8; 64];
            assert_eq!(sock.read(&mut buf).await, Err(NetError::Reset));
            let failed = start.elapsed();
            let closed = client.await.unwrap() - start;
            (failed, closed)
        };
        // Without a deadline the read would wait for ever: this bound (in
        // virtual time too) fails the test instead.
        runtime
            .block_on(async { tokio::time::timeout(Duration::from_secs(60), test).await })
            .expect("the connection closed within 60 s")
    }

    /// The deadline, and tokio's timer resolution (a timer fires at the
    /// first millisecond tick at or after its deadline).
    fn deadline() -> (Duration, Duration) {
        let d = Duration::from_millis(crate::tls::HANDSHAKE_DEADLINE.as_millis());
        (d, d + Duration::from_millis(1))
    }

    #[test]
    fn a_client_that_never_starts_its_handshake_is_closed_at_the_deadline() {
        let (failed, closed) = held("silent", &[]);
        let (from, to) = deadline();
        assert!(
            failed >= from && failed <= to,
            "the read failed after {failed:?}"
        );
        assert!(closed >= from && closed <= to, "closed after {closed:?}");
    }

    #[test]
    fn a_client_that_never_finishes_its_client_hello_is_closed_at_the_deadline() {
        // A TLS record header for a 512-byte handshake message, and 4 bytes.
        let partial = &[0x16, 0x03, 0x01, 0x02, 0x00, 0x01, 0x00, 0x01, 0xFC];
        let (failed, closed) = held("partial", partial);
        let (from, to) = deadline();
        assert!(
            failed >= from && failed <= to,
            "the read failed after {failed:?}"
        );
        assert!(closed >= from && closed <= to, "closed after {closed:?}");
    }
}
