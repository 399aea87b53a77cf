//! TLS on Linux, against the `hans-gateway` binary: the web page over
//! HTTPS (`--web-tls`, checked with `openssl s_client`) and Modbus/TCP
//! Security (`--modbus-tls-listen`, `--modbus-tls`, `--modbus-tls-ca`,
//! checked with a Rust client: tokio-rustls and hand-written Modbus
//! frames). The certificates are made here with the `openssl` command
//! line: a plant CA, the gateway's certificate for 127.0.0.1, client
//! certificates with the MB/TCP Security role extension, and another CA.
//! Everything on 127.0.0.1; every wait bounded; processes killed on drop.

use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Arc;
use std::time::{Duration, Instant};

mod common;

use common::{free_port, make_ca, make_cert, Killed};
use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, PrivateKeyDer, ServerName};
use tokio::io::{AsyncReadExt, AsyncWriteExt};

/// The handshake bound of the gateway (`tls::HANDSHAKE_DEADLINE`, tested
/// exactly in virtual time in src/net.rs), as its log gives it.
const HANDSHAKE_DEADLINE: Duration = Duration::from_secs(2);

/// The longest any wait here may take before the test fails (generous: a
/// loaded machine; never a figure the product is held to).
const WAIT: Duration = Duration::from_secs(10);

/// PLC_HEARTBEAT (RW) and WRITES_REFUSED (RO) of REGISTERS.md.
const PLC_HEARTBEAT: u16 = 140;
const WRITES_REFUSED: u16 = 53;

/// A directory of its own, removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(name: &str) -> TempDir {
        let dir = std::env::temp_dir().join(format!("hans-tls-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        TempDir(dir)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A client certificate of `ca` whose role extension (MB/TCP Security,
/// OID 1.3.6.1.4.1.50316.802.1, a UTF8String) says `role` (none: `None`).
fn client_cert(dir: &Path, ca: &str, name: &str, role: Option<&str>) {
    let mut ext = String::from(
        "basicConstraints=CA:FALSE\nkeyUsage=critical,digitalSignature\nextendedKeyUsage=clientAuth\n",
    );
    if let Some(role) = role {
        ext.push_str(&format!("1.3.6.1.4.1.50316.802.1=ASN1:UTF8String:{role}\n"));
    }
    make_cert(dir, ca, name, &ext);
}

/// The test PKI in `dir`: `plant-ca` with the gateway's `server` (for
/// 127.0.0.1) and clients `operator`, `admin`, `viewer`, `engineer` (a
/// role the gateway does not know) and `anonymous` (no role); `other-ca`
/// with its `intruder` (role operator).
fn pki(dir: &Path) {
    make_ca(dir, "plant-ca");
    make_ca(dir, "other-ca");
    make_cert(
        dir,
        "plant-ca",
        "server",
        "basicConstraints=CA:FALSE\nkeyUsage=critical,digitalSignature\nextendedKeyUsage=serverAuth\nsubjectAltName=IP:127.0.0.1\n",
    );
    for (name, role) in [
        ("operator", Some("operator")),
        ("admin", Some("admin")),
        ("viewer", Some("viewer")),
        ("engineer", Some("engineer")),
        ("anonymous", None),
    ] {
        client_cert(dir, "plant-ca", name, role);
    }
    client_cert(dir, "other-ca", "intruder", Some("operator"));
}

/// A running `hans-gateway` with the page over HTTPS and Modbus/TCP
/// Security beside plain Modbus, its log in `dir/gateway.log`.
struct Gateway {
    _child: Killed,
    modbus: u16,
    web: u16,
    secure: u16,
    log: PathBuf,
}

impl Gateway {
    fn start(dir: &Path) -> Gateway {
        Gateway::start_logging(dir, "info")
    }

    /// Started with `RUST_LOG` = `filter`.
    fn start_logging(dir: &Path, filter: &str) -> Gateway {
        let (modbus, web, secure) = (free_port(), free_port(), free_port());
        let at = |port: u16| format!("127.0.0.1:{port}");
        let log = dir.join("gateway.log");
        let child = Command::new(env!("CARGO_BIN_EXE_hans-gateway"))
            .current_dir(dir)
            .args(["--robot", "127.0.0.1:1", "--modbus-listen", &at(modbus)])
            .args([
                "--web-listen",
                &at(web),
                "--web-tls",
                "server.crt",
                "server.key",
            ])
            .args(["--modbus-tls-listen", &at(secure)])
            .args(["--modbus-tls", "server.crt", "server.key"])
            .args([
                "--modbus-tls-ca",
                "plant-ca.crt",
                "--setup-code-file",
                "code",
            ])
            .env("RUST_LOG", filter)
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .unwrap();
        let child = Killed(child);
        let end = Instant::now() + WAIT;
        // The log says so once every port is bound.
        while !std::fs::read_to_string(&log)
            .unwrap_or_default()
            .contains("modbus/tcp security")
        {
            assert!(
                Instant::now() < end,
                "hans-gateway did not start: {}",
                std::fs::read_to_string(&log).unwrap_or_default()
            );
            std::thread::sleep(Duration::from_millis(20));
        }
        Gateway {
            _child: child,
            modbus,
            web,
            secure,
            log,
        }
    }

    fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// The log once it says `what` (within [`WAIT`]; else the test
    /// fails). Called once what it looks for has happened: the gateway
    /// logs it before it answers or closes.
    fn log_says(&self, what: &str) -> String {
        self.log_until(what, |log| log.contains(what))
    }

    /// The log once `done` holds for it (within [`WAIT`]; else the test
    /// fails, saying it was waiting for `what`).
    fn log_until(&self, what: &str, done: impl Fn(&str) -> bool) -> String {
        let end = Instant::now() + WAIT;
        loop {
            let log = self.log();
            if done(&log) {
                return log;
            }
            assert!(Instant::now() < end, "the log does not say {what}: {log}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

/// A TLS client configuration trusting `plant-ca`, presenting the
/// certificate `cert` of `dir` (none: `None`).
fn client_config(dir: &Path, cert: Option<&str>) -> Arc<rustls::ClientConfig> {
    let mut roots = rustls::RootCertStore::empty();
    roots
        .add(CertificateDer::from_pem_file(dir.join("plant-ca.crt")).unwrap())
        .unwrap();
    let builder = rustls::ClientConfig::builder_with_provider(Arc::new(
        rustls::crypto::ring::default_provider(),
    ))
    .with_safe_default_protocol_versions()
    .unwrap()
    .with_root_certificates(roots);
    let config = match cert {
        Some(name) => {
            let chain =
                vec![CertificateDer::from_pem_file(dir.join(format!("{name}.crt"))).unwrap()];
            let key = PrivateKeyDer::from_pem_file(dir.join(format!("{name}.key"))).unwrap();
            builder.with_client_auth_cert(chain, key).unwrap()
        }
        None => builder.with_no_client_auth(),
    };
    Arc::new(config)
}

/// A Modbus/TCP Security client: TLS to 127.0.0.1:`port` with the
/// certificate `cert`, then hand-written Modbus TCP frames.
struct SecureClient {
    tls: tokio_rustls::client::TlsStream<tokio::net::TcpStream>,
    tid: u16,
}

impl SecureClient {
    async fn connect(dir: &Path, port: u16, cert: Option<&str>) -> Result<SecureClient, String> {
        let tcp = tokio::net::TcpStream::connect(("127.0.0.1", port))
            .await
            .map_err(|e| e.to_string())?;
        let name = ServerName::try_from("127.0.0.1").unwrap();
        let connect = tokio_rustls::TlsConnector::from(client_config(dir, cert)).connect(name, tcp);
        let tls = tokio::time::timeout(Duration::from_secs(5), connect)
            .await
            .map_err(|_| "handshake timed out".to_string())?
            .map_err(|e| e.to_string())?;
        Ok(SecureClient { tls, tid: 0 })
    }

    /// Sends the PDU `pdu` (unit 1), returns the answer's PDU. With TLS
    /// 1.3 a server refuses a client's certificate after the client
    /// finished its handshake: the refusal shows here.
    async fn request(&mut self, pdu: &[u8]) -> Result<Vec<u8>, String> {
        self.tid = self.tid.wrapping_add(1);
        let len = (pdu.len() + 1) as u16;
        let mut adu = vec![];
        adu.extend_from_slice(&self.tid.to_be_bytes());
        adu.extend_from_slice(&[0, 0]);
        adu.extend_from_slice(&len.to_be_bytes());
        adu.push(1);
        adu.extend_from_slice(pdu);
        let exchange = async {
            self.tls.write_all(&adu).await?;
            self.tls.flush().await?;
            let mut head = [0u8; 7];
            self.tls.read_exact(&mut head).await?;
            let n = u16::from_be_bytes([head[4], head[5]]) as usize;
            let mut body = vec![0u8; n.saturating_sub(1)];
            self.tls.read_exact(&mut body).await?;
            std::io::Result::Ok((head, body))
        };
        let (head, body) = tokio::time::timeout(Duration::from_secs(5), exchange)
            .await
            .map_err(|_| "no answer within 5 s".to_string())?
            .map_err(|e| e.to_string())?;
        assert_eq!(
            u16::from_be_bytes([head[0], head[1]]),
            self.tid,
            "transaction id"
        );
        Ok(body)
    }

    async fn read(&mut self, addr: u16) -> Result<Vec<u8>, String> {
        let [a0, a1] = addr.to_be_bytes();
        self.request(&[3, a0, a1, 0, 1]).await
    }

    async fn write(&mut self, addr: u16, value: u16) -> Result<Vec<u8>, String> {
        let [a0, a1] = addr.to_be_bytes();
        let [v0, v1] = value.to_be_bytes();
        self.request(&[6, a0, a1, v0, v1]).await
    }
}

/// The answer to FC 3 of one register holding `value`.
fn one_register(value: u16) -> Vec<u8> {
    let [v0, v1] = value.to_be_bytes();
    vec![3, 2, v0, v1]
}

/// One request over `openssl s_client` (the gateway's certificate verified
/// against the plant CA for 127.0.0.1): its stdout (the answer) and
/// stderr.
fn s_client(dir: &Path, host: &str, request: &[u8]) -> (String, String) {
    let mut child = Killed(
        Command::new("openssl")
            .args(["s_client", "-connect", host, "-CAfile", "plant-ca.crt"])
            .args([
                "-verify_return_error",
                "-verify_ip",
                "127.0.0.1",
                "-quiet",
                "-ign_eof",
            ])
            .current_dir(dir)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap(),
    );
    child.0.stdin.take().unwrap().write_all(request).unwrap();
    let end = Instant::now() + Duration::from_secs(10);
    while child.0.try_wait().unwrap().is_none() {
        assert!(Instant::now() < end, "s_client did not end within 10 s");
        std::thread::sleep(Duration::from_millis(20));
    }
    let mut out = Vec::new();
    child
        .0
        .stdout
        .take()
        .unwrap()
        .read_to_end(&mut out)
        .unwrap();
    let mut err = String::new();
    child
        .0
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    (String::from_utf8_lossy(&out).into_owned(), err)
}

/// The page over HTTPS with `openssl s_client` (the gateway's certificate
/// verified against the plant CA for 127.0.0.1): 200 and the page. A
/// plain HTTP request on that port gets no HTTP answer.
#[test]
fn the_page_is_served_over_https_and_not_over_plain_http_on_that_port() {
    let dir = TempDir::new("https");
    pki(&dir.0);
    let gw = Gateway::start(&dir.0);
    let host = format!("127.0.0.1:{}", gw.web);
    let request = format!("GET / HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n");
    let (out, err) = s_client(&dir.0, &host, request.as_bytes());
    assert!(
        out.starts_with("HTTP/1.1 200"),
        "stdout: {out}\nstderr: {err}"
    );
    assert!(err.contains("verify return:1"), "{err}");

    let mut plain = TcpStream::connect(("127.0.0.1", gw.web)).unwrap();
    plain
        .set_read_timeout(Some(Duration::from_secs(5)))
        .unwrap();
    plain.write_all(request.as_bytes()).unwrap();
    let mut answer = Vec::new();
    let _ = plain.read_to_end(&mut answer);
    assert!(
        !answer.starts_with(b"HTTP/"),
        "{}",
        String::from_utf8_lossy(&answer)
    );
    gw.log_says("web: TLS handshake with 127.0.0.1:");
}

/// Issue 25, finding 5: HTTPS sent no `Strict-Transport-Security`, so a
/// browser could be sent to the plain-HTTP address of the device by
/// whoever sits on the way. Every answer over HTTPS (the page, the API,
/// an error) now carries it for a year.
#[test]
fn answers_over_https_carry_strict_transport_security() {
    let dir = TempDir::new("https-hsts");
    pki(&dir.0);
    let gw = Gateway::start(&dir.0);
    let host = format!("127.0.0.1:{}", gw.web);
    for path in ["/", "/api/status", "/api/nope"] {
        let request = format!("GET {path} HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n");
        let (out, err) = s_client(&dir.0, &host, request.as_bytes());
        let head = out.split("\r\n\r\n").next().unwrap_or("");
        assert!(
            head.lines()
                .any(|l| l.eq_ignore_ascii_case("strict-transport-security: max-age=31536000")),
            "{path}: {head}\nstderr: {err}"
        );
    }
}

/// A session opened over HTTPS has its cookie marked `Secure`: a browser
/// never sends it over plain HTTP (where it could be read on the wire).
#[test]
fn a_session_opened_over_https_has_a_secure_cookie() {
    let dir = TempDir::new("https-cookie");
    pki(&dir.0);
    let gw = Gateway::start(&dir.0);
    let host = format!("127.0.0.1:{}", gw.web);
    // Written just after the ports are bound (what `start` waits for).
    let end = Instant::now() + Duration::from_secs(10);
    let code = loop {
        match std::fs::read_to_string(dir.0.join("code")) {
            Ok(c) if !c.trim().is_empty() => break c,
            _ if Instant::now() < end => std::thread::sleep(Duration::from_millis(20)),
            other => panic!("no setup code file within 10 s: {other:?}"),
        }
    };
    let body = format!(
        r#"{{"code":"{}","name":"admin","password":"correct horse"}}"#,
        code.trim()
    );
    let request = format!(
        "POST /api/setup HTTP/1.1\r\nHost: {host}\r\nOrigin: https://{host}\r\nContent-Type: application/json\r\nContent-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    );
    let (out, err) = s_client(&dir.0, &host, request.as_bytes());
    assert!(
        out.starts_with("HTTP/1.1 200"),
        "stdout: {out}\nstderr: {err}"
    );
    let cookie = out
        .lines()
        .find(|l| l.to_ascii_lowercase().starts_with("set-cookie:"))
        .unwrap_or_else(|| panic!("no cookie: {out}"));
    assert!(
        cookie.contains("HttpOnly") && cookie.ends_with("; Secure"),
        "{cookie}"
    );
}

/// A client that opens TCP to `port`, sends `hello` (nothing, or the
/// start of a ClientHello) and then nothing more: its connection and its
/// local port (the gateway's log names it).
fn attacker(port: u16, hello: &[u8]) -> (TcpStream, u16) {
    let mut s = TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.write_all(hello).unwrap();
    let local = s.local_addr().unwrap().port();
    (s, local)
}

/// Reads `s` until the server closes it (an alert may come first):
/// `Err` if it is still open after [`WAIT`] (without the handshake's
/// deadline the page closes a silent connection after its 3 s idle
/// timeout, Modbus after 120 s).
fn closed_by_server(mut s: TcpStream) -> Result<(), String> {
    s.set_read_timeout(Some(WAIT)).unwrap();
    let mut sink = [0u8; 512];
    loop {
        match s.read(&mut sink) {
            Ok(0) => return Ok(()),
            Ok(_) => continue,
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                return Err(format!("still open after {WAIT:?}"))
            }
            // Reset: closed with what it sent unread.
            Err(_) => return Ok(()),
        }
    }
}

/// The attack: clients that open TCP and never finish (or never start)
/// their handshake, on the page and on Modbus/TCP Security, all at once.
/// Once the gateway has given each a slot, an operator is served; each
/// attacker is closed by the gateway, and its log says the handshake's
/// deadline did it (not the page's idle timeout, 3 s, nor Modbus's,
/// 120 s). How soon is tested exactly in virtual time (src/net.rs).
#[tokio::test(flavor = "current_thread")]
async fn a_client_that_never_finishes_its_handshake_is_closed_within_the_deadline() {
    let dir = TempDir::new("hello");
    pki(&dir.0);
    // The page logs each connection it serves at debug level (Modbus its
    // clients at info, with their port).
    let gw = Gateway::start_logging(&dir.0, "info,hans_gateway::web=debug");
    // A TLS record header for a 512-byte handshake message, and 4 bytes.
    let partial: &[u8] = &[0x16, 0x03, 0x01, 0x02, 0x00, 0x01, 0x00, 0x01, 0xFC];
    let attacks = [
        ("web", "silent", attacker(gw.web, &[])),
        ("web", "partial ClientHello", attacker(gw.web, partial)),
        ("modbus", "silent", attacker(gw.secure, &[])),
        (
            "modbus",
            "partial ClientHello",
            attacker(gw.secure, partial),
        ),
    ];
    let modbus_ports: Vec<u16> = attacks
        .iter()
        .filter(|(what, _, _)| *what == "modbus")
        .map(|(_, _, (_, port))| *port)
        .collect();
    gw.log_until("that every attacker has its slot", |log| {
        let web = log.matches("web: client 127.0.0.1 served in slot").count();
        web >= 2
            && modbus_ports
                .iter()
                .all(|p| log.contains(&format!("modbus: client 127.0.0.1:{p} connected")))
    });
    // Meanwhile an operator is served.
    let mut op = SecureClient::connect(&dir.0, gw.secure, Some("operator"))
        .await
        .unwrap();
    assert_eq!(op.read(PLC_HEARTBEAT).await, Ok(one_register(0)));
    for (what, how, (stream, port)) in attacks {
        assert_eq!(closed_by_server(stream), Ok(()), "{what}, {how}");
        gw.log_says(&format!(
            "{what}: TLS handshake with 127.0.0.1:{port} not done within {} ms, closing",
            HANDSHAKE_DEADLINE.as_millis()
        ));
    }
}

/// An operator's and an administrator's certificates read and write; a
/// viewer's, an unknown role's and a certificate without a role read, and
/// their writes get exception 01 (nothing written, WRITES_REFUSED counts
/// them, the log says so). The plain Modbus listener serves unchanged.
#[tokio::test(flavor = "current_thread")]
async fn the_certificates_role_decides_whether_a_client_may_write() {
    let dir = TempDir::new("roles");
    pki(&dir.0);
    let gw = Gateway::start(&dir.0);
    let mut value: u16 = 0x1200;
    for cert in ["operator", "admin"] {
        let mut c = SecureClient::connect(&dir.0, gw.secure, Some(cert))
            .await
            .unwrap();
        value += 1;
        let [v0, v1] = value.to_be_bytes();
        assert_eq!(
            c.write(PLC_HEARTBEAT, value).await,
            Ok(vec![6, 0, PLC_HEARTBEAT as u8, v0, v1]),
            "{cert}"
        );
        assert_eq!(
            c.read(PLC_HEARTBEAT).await,
            Ok(one_register(value)),
            "{cert}"
        );
    }
    let mut refused = 0;
    for cert in ["viewer", "engineer", "anonymous"] {
        let mut c = SecureClient::connect(&dir.0, gw.secure, Some(cert))
            .await
            .unwrap();
        assert_eq!(
            c.write(PLC_HEARTBEAT, 0x7777).await,
            Ok(vec![0x86, 1]),
            "{cert}"
        );
        // FC 16 too.
        assert_eq!(
            c.request(&[16, 0, PLC_HEARTBEAT as u8, 0, 1, 2, 0x77, 0x77])
                .await,
            Ok(vec![0x90, 1]),
            "{cert}"
        );
        refused += 2;
        assert_eq!(
            c.read(PLC_HEARTBEAT).await,
            Ok(one_register(value)),
            "{cert}: unchanged"
        );
        assert_eq!(
            c.read(WRITES_REFUSED).await,
            Ok(one_register(refused)),
            "{cert}"
        );
    }
    let log = gw.log_says("refused: its certificate's role may only read");
    assert!(log.contains("Named(\"engineer\")"), "{log}");

    // Plain Modbus TCP, as before: writes and reads.
    let mut plain = tokio::net::TcpStream::connect(("127.0.0.1", gw.modbus))
        .await
        .unwrap();
    plain
        .write_all(&[0, 9, 0, 0, 0, 6, 1, 6, 0, PLC_HEARTBEAT as u8, 0x42, 0x42])
        .await
        .unwrap();
    let mut answer = [0u8; 12];
    tokio::time::timeout(Duration::from_secs(5), plain.read_exact(&mut answer))
        .await
        .unwrap()
        .unwrap();
    assert_eq!(
        answer,
        [0, 9, 0, 0, 0, 6, 1, 6, 0, PLC_HEARTBEAT as u8, 0x42, 0x42]
    );
}

/// Without a client certificate, or with one of another CA, the handshake
/// is refused: no Modbus request is ever answered, and the log says why.
#[tokio::test(flavor = "current_thread")]
async fn without_a_certificate_or_with_another_cas_the_handshake_is_refused() {
    let dir = TempDir::new("refused");
    pki(&dir.0);
    let gw = Gateway::start(&dir.0);
    for cert in [None, Some("intruder")] {
        // TLS 1.3: the client may think it finished before the server
        // refuses; TLS 1.2 fails in the handshake. Either way, no answer.
        let answered = match SecureClient::connect(&dir.0, gw.secure, cert).await {
            Ok(mut c) => c.read(PLC_HEARTBEAT).await,
            Err(e) => Err(e),
        };
        assert!(answered.is_err(), "{cert:?}: {answered:?}");
    }
    gw.log_says("modbus: TLS handshake with 127.0.0.1:");
    gw.log_says("refused: ");
}

/// TLS files that cannot be read stop the start (status 1, the file
/// named); `--web-tls` without `--web-listen` is a bad command line
/// (status 2).
#[test]
fn unreadable_tls_files_stop_the_start() {
    let dir = TempDir::new("files");
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_hans-gateway"))
            .current_dir(&dir.0)
            .args(["--robot", "127.0.0.1:1", "--modbus-listen", "127.0.0.1:0"])
            .args(["--setup-code-file", "code"])
            .args(args)
            .output()
            .unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (code, err) = run(&[
        "--web-listen",
        "127.0.0.1:0",
        "--web-tls",
        "no.crt",
        "no.key",
    ]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("no.crt"), "{err}");
    let (code, err) = run(&["--web-tls", "a.crt", "a.key"]);
    assert_eq!(code, Some(2), "{err}");
    let (code, err) = run(&["--modbus-tls-listen", "127.0.0.1:0"]);
    assert_eq!(code, Some(2), "{err}");
}
