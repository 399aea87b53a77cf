//! The socket adapter for Linux: tokio streams and listeners.
//!
//! Listening ports are bound once and shared by every socket that accepts on
//! them ([`TokioNet::listen`] binds ahead, which lets a caller use port 0 and
//! learn the real port; `accept` on a port not yet bound binds it on
//! [`TokioNet::new`]'s address). Connections beyond the ones being accepted
//! wait in the kernel's backlog.
//!
//! Needs a tokio runtime with I/O enabled (current-thread is enough).

extern crate std;

use core::cell::RefCell;
use core::net::{Ipv4Addr, SocketAddr, SocketAddrV4};
use std::borrow::ToOwned;
use std::io;
use std::rc::Rc;
use std::vec::Vec;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};

use super::{Net, NetError, Socket};

/// Tokio networking for the gateway.
pub(crate) struct TokioNet {
    bind_ip: core::net::Ipv4Addr,
    listeners: RefCell<Vec<(u16, Rc<TcpListener>)>>,
    /// The PEM file of the CAs a TLS server must be signed by
    /// ([`Socket::connect_tls`]); read at each TLS connect.
    #[cfg(feature = "mqtt-tls")]
    tls_ca: Option<std::path::PathBuf>,
}

impl TokioNet {
    /// A stack whose on-demand listeners bind to `bind_ip` (use
    /// `127.0.0.1` in tests).
    pub(crate) fn new(bind_ip: core::net::Ipv4Addr) -> Self {
        TokioNet {
            bind_ip,
            listeners: RefCell::new(Vec::new()),
            #[cfg(feature = "mqtt-tls")]
            tls_ca: None,
        }
    }

    /// TLS clients of this stack trust the CAs of the PEM file `ca`.
    #[cfg(feature = "mqtt-tls")]
    pub(crate) fn with_tls_ca(mut self, ca: std::path::PathBuf) -> Self {
        self.tls_ca = Some(ca);
        self
    }

    /// Binds `addr` now and returns the port bound (useful with port 0).
    /// Sockets then accept on that port.
    pub(crate) async fn listen(&self, addr: SocketAddrV4) -> io::Result<u16> {
        let l = TcpListener::bind(addr).await?;
        let port = l.local_addr()?.port();
        self.listeners.borrow_mut().push((port, Rc::new(l)));
        Ok(port)
    }

    async fn listener(&self, port: u16) -> Result<Rc<TcpListener>, NetError> {
        if let Some((_, l)) = self.listeners.borrow().iter().find(|(p, _)| *p == port) {
            return Ok(l.clone());
        }
        self.listen(SocketAddrV4::new(self.bind_ip, port))
            .await
            .map_err(|_| NetError::ListenFailed)?;
        self.listeners
            .borrow()
            .iter()
            .find(|(p, _)| *p == port)
            .map(|(_, l)| l.clone())
            .ok_or(NetError::ListenFailed)
    }
}

/// A tokio TCP stream slot.
pub(crate) struct TokioSocket<'a> {
    net: &'a TokioNet,
    stream: Option<Stream>,
}

/// A connection: plain TCP, or TLS over it (a client's).
enum Stream {
    Plain(TcpStream),
    #[cfg(feature = "mqtt-tls")]
    Tls(std::boxed::Box<tokio_rustls::client::TlsStream<TcpStream>>),
}

impl Stream {
    async fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self {
            Stream::Plain(s) => s.read(buf).await,
            #[cfg(feature = "mqtt-tls")]
            Stream::Tls(s) => s.read(buf).await,
        }
    }

    async fn write_all(&mut self, buf: &[u8]) -> io::Result<()> {
        match self {
            Stream::Plain(s) => s.write_all(buf).await,
            #[cfg(feature = "mqtt-tls")]
            Stream::Tls(s) => {
                s.write_all(buf).await?;
                // rustls buffers: what was written goes out now.
                s.flush().await
            }
        }
    }

    async fn shutdown(&mut self) -> io::Result<()> {
        match self {
            Stream::Plain(s) => s.shutdown().await,
            #[cfg(feature = "mqtt-tls")]
            Stream::Tls(s) => s.shutdown().await,
        }
    }

    fn tcp(&self) -> &TcpStream {
        match self {
            Stream::Plain(s) => s,
            #[cfg(feature = "mqtt-tls")]
            Stream::Tls(s) => s.get_ref().0,
        }
    }
}

/// The TLS client configuration: the CAs of `ca` (PEM), else the system's
/// bundle; TLS 1.2 and 1.3 with rustls' safe defaults (ring).
#[cfg(feature = "mqtt-tls")]
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

    #[cfg(feature = "mqtt-tls")]
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
        let l = self.net.listener(port).await?;
        let (s, _) = l.accept().await.map_err(|_| NetError::ListenFailed)?;
        let _ = s.set_nodelay(true);
        self.stream = Some(Stream::Plain(s));
        Ok(())
    }

    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, NetError> {
        let s = self.stream.as_mut().ok_or(NetError::NotConnected)?;
        s.read(buf).await.map_err(|_| NetError::Reset)
    }

    async fn write_all(&mut self, buf: &[u8]) -> Result<(), NetError> {
        let s = self.stream.as_mut().ok_or(NetError::NotConnected)?;
        s.write_all(buf).await.map_err(|_| NetError::Reset)
    }

    async fn close(&mut self) {
        if let Some(mut s) = self.stream.take() {
            let _ = s.shutdown().await;
        }
    }

    fn remote(&self) -> Option<SocketAddrV4> {
        self.stream
            .as_ref()
            .and_then(|s| s.tcp().peer_addr().ok())
            .and_then(v4)
    }
}

impl Net for TokioNet {
    type Socket<'a> = TokioSocket<'a>;

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
