//! TLS servers on Linux: the web page over HTTPS and Modbus/TCP Security,
//! with rustls (ring) through tokio-rustls.
//!
//! The gateway's servers (the page, Modbus) do not know about TLS: a
//! listener of [`crate::net::TokioNet`] made with a [`TlsServer`]
//! hands its sockets TCP connections whose handshake has not started yet.
//! The servers check the allow-list and give a slot as for a plain
//! connection; the handshake runs at the connection's first read, bounded
//! by [`HANDSHAKE_DEADLINE`], so that a client nobody admitted costs no
//! handshake and a client that never finishes one holds its slot no
//! longer than a web request may take.
//!
//! # Modbus/TCP Security
//!
//! The Modbus Organization's "MB/TCP Security" protocol (port 802): TLS 1.2
//! or later, the client's certificate required and verified against the
//! CAs given (`--modbus-tls-ca`), and the client's role in the certificate's
//! role extension ([`ROLE_OID`], an ASN.1 UTF8String). The socket hands the
//! extension's word to the Modbus server as the client's claim
//! ([`hans_gateway::net::PeerClaim`]), which maps it to the accounts' roles:
//!
//! | role extension | role | Modbus |
//! |---|---|---|
//! | `admin` | admin | reads and writes |
//! | `operator` | operator | reads and writes |
//! | `viewer` | viewer | reads; writes get exception 01 |
//! | anything else, or none | viewer (the least) | reads; writes get exception 01 |
//!
//! A refused write is answered with exception 01 (Illegal Function), as the
//! specification asks for an authorization failure, logged and counted in
//! `WRITES_REFUSED`.

use std::io;
use std::path::Path;
use std::string::{String, ToString};
use std::sync::Arc;

use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, PrivateKeyDer};
use x509_cert::der::asn1::Utf8StringRef;
use x509_cert::der::oid::ObjectIdentifier;
use x509_cert::der::Decode;

use hans_gateway::net::PeerClaim;

/// The longest a TLS handshake may take, from the connection's first read
/// (at once after it was given its slot): then the connection is closed.
/// No longer than a web request may take once started
/// ([`hans_gateway::limits::WEB_REQUEST_DEADLINE`], checked below); for
/// Modbus, as long as a session may stay silent before a newcomer may take
/// its slot. A handshake on a plant network takes milliseconds.
pub(crate) const HANDSHAKE_DEADLINE: embassy_time::Duration = embassy_time::Duration::from_secs(2);

const _: () = assert!(
    HANDSHAKE_DEADLINE.as_millis() <= hans_gateway::limits::WEB_REQUEST_DEADLINE.as_millis(),
    "a handshake holds a web slot no longer than a request"
);

/// The role extension of Modbus/TCP Security (its "Role" OID under the
/// Modbus Organization's enterprise number 50316).
pub(crate) const ROLE_OID: ObjectIdentifier =
    ObjectIdentifier::new_unwrap("1.3.6.1.4.1.50316.802.1");

/// What a client's certificate's role extension says.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum CertRole {
    /// It names this role (its word, as written).
    Named(String),
    /// The certificate has no role extension.
    Missing,
    /// The extension is not one UTF8String, appears twice, or the
    /// certificate cannot be read.
    Malformed,
}

impl CertRole {
    /// The claim the socket hands the server: the word named (one longer
    /// than [`hans_gateway::net::CLAIM_MAX`] names no role the gateway
    /// knows: none), else none. The server grants the least to none.
    pub(crate) fn claim(&self) -> PeerClaim {
        match self {
            CertRole::Named(word) => PeerClaim::Certificate(word.as_str().try_into().ok()),
            CertRole::Missing | CertRole::Malformed => PeerClaim::Certificate(None),
        }
    }
}

/// A verified client certificate, as the log and the servers see it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct ClientCert {
    /// Its subject (RFC 4514), for the log.
    pub(crate) subject: String,
    /// Its role extension.
    pub(crate) role: CertRole,
}

/// Reads the subject and the role extension of the DER certificate `der`.
///
/// With x509-cert (RustCrypto's X.509 types over `der`): rustls-webpki,
/// which verified the chain, does not expose a certificate's extensions;
/// x509-parser would do as well, with nom and more dependencies.
pub(crate) fn client_cert(der: &[u8]) -> ClientCert {
    let Ok(cert) = x509_cert::Certificate::from_der(der) else {
        return ClientCert {
            subject: String::new(),
            role: CertRole::Malformed,
        };
    };
    let tbs = cert.tbs_certificate();
    let mut roles = tbs
        .extensions()
        .into_iter()
        .flatten()
        .filter(|e| e.extn_id == ROLE_OID);
    let role = match (roles.next(), roles.next()) {
        (None, _) => CertRole::Missing,
        (Some(ext), None) => match Utf8StringRef::from_der(ext.extn_value.as_bytes()) {
            Ok(text) => CertRole::Named(text.as_str().to_string()),
            Err(_) => CertRole::Malformed,
        },
        // RFC 5280: an extension appears at most once.
        (Some(_), Some(_)) => CertRole::Malformed,
    };
    ClientCert {
        subject: tbs.subject().to_string(),
        role,
    }
}

/// A server's certificate chain and private key, from PEM files.
fn identity(
    cert: &Path,
    key: &Path,
) -> io::Result<(
    std::vec::Vec<CertificateDer<'static>>,
    PrivateKeyDer<'static>,
)> {
    let bad = |path: &Path, why: &dyn core::fmt::Display| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            std::format!("{}: {why}", path.display()),
        )
    };
    let certs = CertificateDer::pem_file_iter(cert)
        .map_err(|e| bad(cert, &e))?
        .collect::<Result<std::vec::Vec<_>, _>>()
        .map_err(|e| bad(cert, &e))?;
    if certs.is_empty() {
        return Err(bad(cert, &"no certificate (PEM) in it"));
    }
    let key_der = PrivateKeyDer::from_pem_file(key).map_err(|e| bad(key, &e))?;
    Ok((certs, key_der))
}

/// What a TLS listener does with the connections it accepts.
pub(crate) struct TlsServer {
    pub(crate) acceptor: tokio_rustls::TlsAcceptor,
    /// Client certificates are required (Modbus/TCP Security): the
    /// connection's role comes from its certificate.
    pub(crate) clients: bool,
    /// What is served, for the log (`web`, `modbus`).
    pub(crate) what: &'static str,
}

impl TlsServer {
    /// The web page's: the certificate chain `cert` and its key `key`
    /// (PEM), TLS 1.2 and 1.3, no client certificate.
    pub(crate) fn web(cert: &Path, key: &Path) -> io::Result<TlsServer> {
        let (certs, key_der) = identity(cert, key)?;
        let config = rustls::ServerConfig::builder_with_provider(provider())
            .with_safe_default_protocol_versions()
            .map_err(io::Error::other)?
            .with_no_client_auth()
            .with_single_cert(certs, key_der)
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
        Ok(TlsServer {
            acceptor: Arc::new(config).into(),
            clients: false,
            what: "web",
        })
    }

    /// Modbus/TCP Security's: as [`Self::web`], and a client certificate
    /// signed by a CA of `client_ca` (PEM) is required.
    pub(crate) fn modbus(cert: &Path, key: &Path, client_ca: &Path) -> io::Result<TlsServer> {
        let (certs, key_der) = identity(cert, key)?;
        let bad = |why: &dyn core::fmt::Display| {
            io::Error::new(
                io::ErrorKind::InvalidInput,
                std::format!("{}: {why}", client_ca.display()),
            )
        };
        let mut roots = rustls::RootCertStore::empty();
        for ca in CertificateDer::pem_file_iter(client_ca).map_err(|e| bad(&e))? {
            roots.add(ca.map_err(|e| bad(&e))?).map_err(|e| bad(&e))?;
        }
        if roots.is_empty() {
            return Err(bad(&"no CA certificate (PEM) in it"));
        }
        let verifier = rustls::server::WebPkiClientVerifier::builder_with_provider(
            Arc::new(roots),
            provider(),
        )
        .build()
        .map_err(|e| bad(&e))?;
        let config = rustls::ServerConfig::builder_with_provider(provider())
            .with_safe_default_protocol_versions()
            .map_err(io::Error::other)?
            .with_client_cert_verifier(verifier)
            .with_single_cert(certs, key_der)
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e))?;
        Ok(TlsServer {
            acceptor: Arc::new(config).into(),
            clients: true,
            what: "modbus",
        })
    }
}

/// rustls' ring provider (no aws-lc: see Cargo.toml).
fn provider() -> Arc<rustls::crypto::CryptoProvider> {
    Arc::new(rustls::crypto::ring::default_provider())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A DER certificate with the extensions `exts` (OID, DER value),
    /// built by hand: only what [`client_cert`] reads has to be right.
    fn cert_with(exts: &[(&[u8], &[u8])]) -> std::vec::Vec<u8> {
        fn tlv(tag: u8, body: &[u8]) -> std::vec::Vec<u8> {
            let mut v = std::vec![tag];
            let n = body.len();
            // DER: the shortest length form.
            if n < 128 {
                v.push(n as u8);
            } else if n < 256 {
                v.extend_from_slice(&[0x81, n as u8]);
            } else {
                v.extend_from_slice(&[0x82, (n >> 8) as u8, n as u8]);
            }
            v.extend_from_slice(body);
            v
        }
        let name = tlv(
            0x30,
            &tlv(
                0x31,
                &tlv(
                    0x30,
                    &[&tlv(0x06, &[0x55, 4, 3])[..], &tlv(0x0C, b"plc")[..]].concat(),
                ),
            ),
        );
        let alg = tlv(0x30, &tlv(0x06, &[0x2A, 0x86, 0x48, 0xCE, 0x3D, 4, 3, 2]));
        let time = tlv(0x17, b"250101000000Z");
        let spki = tlv(
            0x30,
            &[
                &tlv(0x30, &tlv(0x06, &[0x2A, 0x86, 0x48, 0xCE, 0x3D, 2, 1]))[..],
                &tlv(0x03, &[0, 4, 1, 2])[..],
            ]
            .concat(),
        );
        let mut ext_list = std::vec::Vec::new();
        for (oid, value) in exts {
            ext_list.extend(tlv(
                0x30,
                &[&tlv(0x06, oid)[..], &tlv(0x04, value)[..]].concat(),
            ));
        }
        let tbs = tlv(
            0x30,
            &[
                &tlv(0xA0, &tlv(0x02, &[2]))[..],
                &tlv(0x02, &[1])[..],
                &alg[..],
                &name[..],
                &tlv(0x30, &[&time[..], &time[..]].concat())[..],
                &name[..],
                &spki[..],
                &tlv(0xA3, &tlv(0x30, &ext_list))[..],
            ]
            .concat(),
        );
        tlv(
            0x30,
            &[&tbs[..], &alg[..], &tlv(0x03, &[0, 0])[..]].concat(),
        )
    }

    /// 1.3.6.1.4.1.50316.802.1 in DER.
    const ROLE: &[u8] = &[0x2B, 6, 1, 4, 1, 0x83, 0x89, 0x0C, 0x86, 0x22, 1];

    #[test]
    fn the_role_oid_is_the_specifications() {
        assert_eq!(ROLE_OID.as_bytes(), ROLE);
    }

    #[test]
    fn the_role_extension_names_a_role_or_the_least_applies() {
        let read = |exts: &[(&[u8], &[u8])]| client_cert(&cert_with(exts)).role;
        assert_eq!(
            read(&[(ROLE, b"\x0C\x08operator")]),
            CertRole::Named("operator".into())
        );
        assert_eq!(
            read(&[(ROLE, b"\x0C\x08Operator")]),
            CertRole::Named("Operator".into())
        );
        assert_eq!(read(&[]), CertRole::Missing);
        // Another extension (subjectKeyIdentifier) is not a role.
        assert_eq!(
            read(&[(&[0x55, 29, 14], b"\x04\x01\x00")]),
            CertRole::Missing
        );
        // A PrintableString, not a UTF8String.
        assert_eq!(read(&[(ROLE, b"\x13\x08operator")]), CertRole::Malformed);
        // Twice.
        assert_eq!(
            read(&[(ROLE, b"\x0C\x05admin"), (ROLE, b"\x0C\x05admin")]),
            CertRole::Malformed
        );
        // The word goes to the server as it is; none where there is none
        // or it is longer than any role's.
        let word = |w: &str| PeerClaim::Certificate(Some(w.try_into().unwrap()));
        assert_eq!(CertRole::Named("admin".into()).claim(), word("admin"));
        assert_eq!(CertRole::Named("x".into()).claim(), word("x"));
        for role in [
            CertRole::Named("a-role-word-longer-than-any".into()),
            CertRole::Missing,
            CertRole::Malformed,
        ] {
            assert_eq!(role.claim(), PeerClaim::Certificate(None), "{role:?}");
        }
        assert_eq!(client_cert(b"\x30\x00").role, CertRole::Malformed);
        assert_eq!(client_cert(&cert_with(&[])).subject, "CN=plc");
    }
}
