//! The allow-lists by client address, from loopback addresses only: a
//! Modbus or web client from 127.0.0.2 is refused (closed at once, counted)
//! while the lists hold 127.0.0.1 only, and served once 127.0.0.2 is
//! allowed.
//!
//! This runs on the host, where the gateway sees the client's real address.
//! Under QEMU it cannot: QEMU's user-mode network presents every forwarded
//! loopback client as 10.0.2.2 (see `firmware/qemu-tests/tests/field_device.rs`,
//! which tests the allow-list on the board by that address instead).

use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4};
use std::time::Duration;

use hans_e2e::Plc;
use hans_gateway::config::{AllowEntry, AllowList};
use hans_gateway::registers as r;
use hans_gateway_linux::{HostOptions, RunningGateway};
use hans_sim::{Config, Sim};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpSocket, TcpStream};

const SECOND: Ipv4Addr = Ipv4Addr::new(127, 0, 0, 2);
/// How long a refused client may wait for the close (it comes at once).
const LIMIT: Duration = Duration::from_secs(5);

/// A connection to `to` from `from`.
async fn connect_from(from: Ipv4Addr, to: SocketAddrV4) -> TcpStream {
    let s = TcpSocket::new_v4().expect("socket");
    s.bind(SocketAddr::from((from, 0))).expect("bind 127.0.0.2");
    tokio::time::timeout(LIMIT, s.connect(SocketAddr::V4(to)))
        .await
        .expect("connect in time")
        .expect("connect")
}

/// One Modbus read from `from`: `true` if it was answered.
async fn modbus_served(from: Ipv4Addr, to: SocketAddrV4) -> bool {
    use tokio_modbus::client::Reader;
    let mut ctx = tokio_modbus::client::tcp::attach(connect_from(from, to).await);
    let answer = tokio::time::timeout(LIMIT, ctx.read_holding_registers(r::STATUS_VERSION, 1))
        .await
        .expect("an answer or a close in time");
    matches!(answer, Ok(Ok(_)))
}

/// `GET /api/session` from `from`: the answer's first line, or "" if the
/// connection was closed without one.
async fn web_answer(from: Ipv4Addr, to: SocketAddrV4) -> String {
    let mut s = connect_from(from, to).await;
    // A refused client may find the connection closed before it writes.
    // The device is named by its address (another name gets 421).
    let request = format!("GET /api/session HTTP/1.1\r\nHost: {to}\r\nConnection: close\r\n\r\n");
    let _ = s.write_all(request.as_bytes()).await;
    let mut got = Vec::new();
    let _ = tokio::time::timeout(LIMIT, s.read_to_end(&mut got))
        .await
        .expect("an answer or a close in time");
    String::from_utf8_lossy(&got).to_string()
}

/// `POST path` with a JSON body from 127.0.0.1, as the device's page
/// sends it, with a session cookie (`hgw_session=...`) if given: the
/// answer's status line.
async fn web_post_as(to: SocketAddrV4, path: &str, body: &str, cookie: Option<&str>) -> String {
    web_post_full(to, path, body, cookie)
        .await
        .lines()
        .next()
        .unwrap_or("")
        .to_string()
}

/// The whole answer to a POST (head and body).
async fn web_post_full(to: SocketAddrV4, path: &str, body: &str, cookie: Option<&str>) -> String {
    let mut s = connect_from(Ipv4Addr::LOCALHOST, to).await;
    let cookie = cookie.map_or(String::new(), |c| format!("Cookie: {c}\r\n"));
    let request = format!(
        "POST {path} HTTP/1.1\r\nHost: {to}\r\nOrigin: http://{to}\r\n{cookie}\
         Content-Type: application/json\r\nConnection: close\r\nContent-Length: {}\r\n\r\n{body}",
        body.len()
    );
    s.write_all(request.as_bytes()).await.expect("send");
    let mut got = Vec::new();
    // Not LIMIT: a setup hashes a password (10,000 PBKDF2 rounds), which
    // an unoptimized build on a loaded machine takes seconds for.
    let _ = tokio::time::timeout(hans_e2e::WAIT, s.read_to_end(&mut got))
        .await
        .expect("an answer in time");
    String::from_utf8_lossy(&got).to_string()
}

/// The setup code handed to the gateway, as `hans-gateway` prints one.
const SETUP_CODE: &str = "ABCD-EFGH-JKMN";

/// The registers of an allow-list holding `entries` (`ip/prefix`).
fn allow_words(entries: &[(Ipv4Addr, u16)]) -> Vec<u16> {
    let mut w = vec![0u16; 12];
    for (i, (ip, prefix)) in entries.iter().enumerate() {
        let [a, b, c, d] = ip.octets();
        w[3 * i] = u16::from_be_bytes([a, b]);
        w[3 * i + 1] = u16::from_be_bytes([c, d]);
        w[3 * i + 2] = *prefix;
    }
    w
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_client_from_127_0_0_2_is_refused_until_allowed() {
    let sim = Sim::start(Config::ready()).await.expect("simulator");
    let robot = match sim.command_addr() {
        SocketAddr::V4(a) => a,
        SocketAddr::V6(_) => panic!("simulator not on IPv4"),
    };
    let only_first = AllowList([
        AllowEntry {
            ip: Ipv4Addr::LOCALHOST,
            prefix: 32,
        },
        AllowEntry::UNUSED,
        AllowEntry::UNUSED,
        AllowEntry::UNUSED,
    ]);
    let mut opts = HostOptions::new(SocketAddrV4::new(Ipv4Addr::LOCALHOST, 0), robot);
    opts.defaults.modbus_allow = only_first;
    opts.defaults.web_allow = only_first;
    opts.web_listen = Some(SocketAddrV4::new(Ipv4Addr::LOCALHOST, 0));
    opts.setup_code = hans_gateway::SetupCode::parse(SETUP_CODE.as_bytes());
    let gw = RunningGateway::start(opts).expect("gateway");
    let modbus = gw.modbus_addr();
    let web = gw.web_addr().expect("web page");

    // 127.0.0.1 is served; 127.0.0.2 is closed at once and counted.
    let mut plc = Plc::connect(modbus).await;
    assert!(modbus_served(Ipv4Addr::LOCALHOST, modbus).await);
    assert!(
        !modbus_served(SECOND, modbus).await,
        "Modbus from 127.0.0.2"
    );
    assert_eq!(plc.read1(r::STATUS_MODBUS_REFUSED).await, 1);
    assert!(web_answer(Ipv4Addr::LOCALHOST, web)
        .await
        .starts_with("HTTP/1.1 200"));
    assert_eq!(web_answer(SECOND, web).await, "", "web from 127.0.0.2");
    assert_eq!(plc.read1(r::STATUS_WEB_REFUSED).await, 1);

    // Allowed (as a PLC would: the registers, then CONFIG_COMMAND 1): not
    // before an administrator exists (CONFIG_RESULT 4), then served.
    let both = allow_words(&[(Ipv4Addr::LOCALHOST, 32), (SECOND, 32)]);
    plc.write(r::MODBUS_ALLOW, &both).await;
    plc.write(r::WEB_ALLOW, &both).await;
    assert!(plc
        .try_write(r::CONTROL_CONFIG_COMMAND, &[1])
        .await
        .is_err());
    assert_eq!(plc.read1(r::CONTROL_CONFIG_RESULT).await, 4, "locked");
    let setup = format!(r#"{{"code":"{SETUP_CODE}","name":"admin","password":"commission-2026"}}"#);
    let answer = web_post_full(web, "/api/setup", &setup, None).await;
    assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
    // Still locked with an administrator (the allow-lists are protected
    // settings), until it allows configuration over Modbus.
    assert!(plc
        .try_write(r::CONTROL_CONFIG_COMMAND, &[1])
        .await
        .is_err());
    let cookie = answer
        .lines()
        .find(|l| l.to_ascii_lowercase().starts_with("set-cookie:"))
        .and_then(|l| l.split_once(':'))
        .map(|(_, v)| v.trim())
        .and_then(|c| c.split(';').next())
        .unwrap_or_else(|| panic!("a session cookie: {answer}"))
        .to_string();
    let allow = r#"{"settings":{"access.modbus_config":"true"}}"#;
    let answer = web_post_as(web, "/api/config", allow, Some(&cookie)).await;
    assert!(answer.starts_with("HTTP/1.1 200"), "{answer}");
    // (The page's apply ended the Modbus edit: written again.)
    plc.write(r::MODBUS_ALLOW, &both).await;
    plc.write(r::WEB_ALLOW, &both).await;
    plc.write(r::CONTROL_CONFIG_COMMAND, &[1]).await;
    assert_eq!(plc.read1(r::CONTROL_CONFIG_RESULT).await, 3, "applied");
    assert!(modbus_served(SECOND, modbus).await, "Modbus from 127.0.0.2");
    assert!(web_answer(SECOND, web).await.starts_with("HTTP/1.1 200"));
    assert_eq!(plc.read1(r::STATUS_MODBUS_REFUSED).await, 1);
    assert_eq!(plc.read1(r::STATUS_WEB_REFUSED).await, 1);

    drop(plc);
    gw.stop();
    sim.shutdown().await;
}
