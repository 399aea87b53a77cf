//! The board path on the host: the gateway's `board::run` on one
//! embassy-net stack, a PLC and a robot on a second stack, the two joined
//! by embassy-net-driver-channel devices and a frame-copying bridge. No TAP
//! device, no root; real TCP through the embassy-net adapter.
//!
//! As on a board, the gateway's stack starts without an address and
//! `board::run` applies the configuration's network settings
//! (`network_managed`): the address, and the Modbus port (5020 here, to
//! show it is the configuration's). The web page is served on the same
//! stack (port 80), so the stack's resources are sized by
//! `board::SOCKETS` with every part of the gateway in use.

// The gateway's board future, nested in this test's blocks, is 130 queries
// deep when the codec has its `v6` feature (which hans-sim, a dependency of
// this package, turns on): one over the default limit of 128.
#![recursion_limit = "256"]

use core::net::Ipv4Addr;
use std::cell::RefCell;

use embassy_futures::join::{join, join5};
use embassy_futures::select::{select, Either};
use embassy_net::tcp::TcpSocket;
use embassy_net::{Config, Ipv4Cidr, Stack, StackResources, StaticConfigV4};
use embassy_net_driver_channel as ch;
use embassy_time::{with_timeout, Timer};
use hans_e2e::{code, words_of_f32, CannedRobot};
use hans_gateway::config::NetConfig;
use hans_gateway::registers as r;

const MTU: usize = 1514;
const GW_IP: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 1);
const PEER_IP: Ipv4Addr = Ipv4Addr::new(10, 0, 0, 2);
/// The gateway's Modbus port, from its configuration (`NET_MODBUS_PORT`).
const MODBUS_PORT: u16 = 5020;

fn config(ip: Ipv4Addr) -> Config {
    Config::ipv4_static(StaticConfigV4 {
        address: Ipv4Cidr::new(ip, 24),
        gateway: None,
        dns_servers: Default::default(),
    })
}

/// Copies every frame one device sends into the other device.
async fn bridge(mut tx: ch::TxRunner<'_, MTU>, mut rx: ch::RxRunner<'_, MTU>) {
    loop {
        let frame = tx.tx_buf().await;
        let dst = rx.rx_buf().await;
        let n = frame.len().min(dst.len());
        dst[..n].copy_from_slice(&frame[..n]);
        rx.rx_done(n);
        tx.tx_done();
    }
}

/// A robot controller on the peer stack: answers everything, records what
/// it received.
async fn robot(stack: Stack<'_>, received: &RefCell<Vec<String>>) {
    let (mut rxb, mut txb) = ([0u8; 2048], [0u8; 2048]);
    let mut s = TcpSocket::new(stack, &mut rxb, &mut txb);
    loop {
        if s.accept(10003).await.is_err() {
            Timer::after_millis(10).await;
            continue;
        }
        let mut canned = CannedRobot::new();
        let mut buf = [0u8; 512];
        loop {
            let n = match s.read(&mut buf).await {
                Ok(0) | Err(_) => break,
                Ok(n) => n,
            };
            for (msg, reply) in canned.feed(&buf[..n]) {
                received.borrow_mut().push(msg);
                let mut out = reply.as_bytes();
                while !out.is_empty() {
                    match s.write(out).await {
                        Ok(k) if k > 0 => out = &out[k..],
                        _ => break,
                    }
                }
            }
        }
        s.abort();
        let _ = s.flush().await;
    }
}

/// One Modbus request/response over an embassy-net socket.
async fn modbus(s: &mut TcpSocket<'_>, tid: u16, pdu: &[u8]) -> Vec<u8> {
    let mut adu = tid.to_be_bytes().to_vec();
    adu.extend([0, 0]);
    adu.extend(((pdu.len() + 1) as u16).to_be_bytes());
    adu.push(1);
    adu.extend(pdu);
    let mut out: &[u8] = &adu;
    while !out.is_empty() {
        let k = s.write(out).await.expect("write");
        out = &out[k..];
    }
    let mut got = Vec::new();
    let mut buf = [0u8; 300];
    loop {
        if got.len() >= 7 {
            let len = usize::from(u16::from_be_bytes([got[4], got[5]]));
            if got.len() >= 6 + len {
                assert_eq!(&got[..2], &tid.to_be_bytes());
                return got[7..6 + len].to_vec();
            }
        }
        let n = s.read(&mut buf).await.expect("read");
        assert!(n > 0, "gateway closed the connection");
        got.extend(&buf[..n]);
    }
}

async fn read_reg(s: &mut TcpSocket<'_>, tid: u16, addr: u16) -> u16 {
    let a = addr.to_be_bytes();
    let resp = modbus(s, tid, &[3, a[0], a[1], 0, 1]).await;
    assert_eq!(&resp[..2], &[3, 2], "read {addr}: {resp:?}");
    u16::from_be_bytes([resp[2], resp[3]])
}

async fn plc(stack: Stack<'_>, received: &RefCell<Vec<String>>) {
    let (mut rxb, mut txb) = ([0u8; 1024], [0u8; 1024]);
    let mut s = TcpSocket::new(stack, &mut rxb, &mut txb);
    s.connect((GW_IP, MODBUS_PORT))
        .await
        .expect("connect to the gateway's Modbus port");
    assert_eq!(
        read_reg(&mut s, 1, r::STATUS_VERSION).await,
        hans_gateway::registers::MAP_VERSION
    );
    let mut tid = 2;
    while read_reg(&mut s, tid, r::STATUS_LINK_STATE).await != 3 {
        tid += 1;
        Timer::after_millis(20).await;
    }
    // SetBoxDO bit 2 = 1 on channel 0, sequence 3: inputs, then Execute.
    let b = r::channel_base(0);
    let a = (b + 1).to_be_bytes();
    let ([p0_hi, p0_lo], [p1_hi, p1_lo]) = (words_of_f32(2.0), words_of_f32(1.0));
    // Command, sequence, reserved, P0, P1.
    let regs: [u16; 7] = [code::SET_BOX_DO, 3, 0, p0_hi, p0_lo, p1_hi, p1_lo];
    let mut pdu = vec![0x10, a[0], a[1], 0, 7, 14];
    for v in regs {
        pdu.extend(v.to_be_bytes());
    }
    assert_eq!(modbus(&mut s, 100, &pdu).await, [0x10, a[0], a[1], 0, 7]);
    let c = b.to_be_bytes();
    assert_eq!(
        modbus(&mut s, 101, &[6, c[0], c[1], 0, 1]).await,
        [6, c[0], c[1], 0, 1]
    );
    let mut tid = 200;
    let status = loop {
        let st = read_reg(&mut s, tid, b + r::CH_STATUS).await;
        if st & (r::ST_DONE | r::ST_ERROR) != 0 {
            break st;
        }
        tid += 1;
        Timer::after_millis(10).await;
    };
    assert_eq!(status & (r::ST_DONE | r::ST_ERROR | r::ST_BUSY), r::ST_DONE);
    assert_eq!(read_reg(&mut s, tid + 1, b + r::CH_SEQ_ECHO).await, 3);
    assert!(
        received.borrow().iter().any(|m| m == "SetBoxDO,2,1,;"),
        "{:?}",
        received.borrow()
    );
    s.close();
    let _ = s.flush().await;
    web_status(stack).await;
}

/// `GET /api/status` from the web page on port 80: answered, and it shows
/// the robot link up.
async fn web_status(stack: Stack<'_>) {
    let (mut rxb, mut txb) = ([0u8; 4096], [0u8; 1024]);
    let mut s = TcpSocket::new(stack, &mut rxb, &mut txb);
    s.connect((GW_IP, 80))
        .await
        .expect("connect to the web page");
    let mut out: &[u8] = b"GET /api/status HTTP/1.1\r\nHost: 10.0.0.1\r\nConnection: close\r\n\r\n";
    while !out.is_empty() {
        let k = s.write(out).await.expect("write");
        out = &out[k..];
    }
    let mut got = Vec::new();
    let mut buf = [0u8; 1024];
    loop {
        match s.read(&mut buf).await {
            Ok(0) | Err(_) => break,
            Ok(n) => got.extend(&buf[..n]),
        }
    }
    let text = String::from_utf8_lossy(&got);
    assert!(text.starts_with("HTTP/1.1 200"), "{text}");
    assert!(text.contains(r#""state":"connected""#), "{text}");
}

#[test]
fn gateway_over_two_embassy_net_stacks() {
    let rt = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .expect("runtime");
    rt.block_on(async {
        let mut state_a = ch::State::<MTU, 4, 4>::new();
        let mut state_b = ch::State::<MTU, 4, 4>::new();
        let mac = |n| ch::driver::HardwareAddress::Ethernet([2, 0, 0, 0, 0, n]);
        let (runner_a, dev_a) = ch::new(&mut state_a, mac(1));
        let (runner_b, dev_b) = ch::new(&mut state_b, mac(2));
        let (state_ra, rx_a, tx_a) = runner_a.split();
        let (state_rb, rx_b, tx_b) = runner_b.split();
        state_ra.set_link_state(ch::driver::LinkState::Up);
        state_rb.set_link_state(ch::driver::LinkState::Up);
        let mut res_a = StackResources::<{ hans_gateway::board::SOCKETS }>::new();
        let mut res_b = StackResources::<4>::new();
        // No address: the gateway applies its configuration's.
        let (stack_a, mut net_a) = embassy_net::new(dev_a, Config::default(), &mut res_a, 1);
        let (stack_b, mut net_b) = embassy_net::new(dev_b, config(PEER_IP), &mut res_b, 2);

        let storage = hans_gateway::storage::NoStorage;
        let options = hans_gateway::Options {
            defaults: hans_gateway::Config {
                robot_ip: PEER_IP,
                robot_port: 10003,
                net: NetConfig {
                    ip: GW_IP,
                    mask: Ipv4Addr::new(255, 255, 255, 0),
                    gateway: Ipv4Addr::UNSPECIFIED,
                    modbus_port: MODBUS_PORT,
                    ..NetConfig::DEFAULT
                },
                ..hans_gateway::Config::default()
            },
            network_managed: true,
            ..Default::default()
        };
        let received = RefCell::new(Vec::new());
        let infra = join5(
            net_a.run(),
            net_b.run(),
            join(bridge(tx_a, rx_b), bridge(tx_b, rx_a)),
            robot(stack_b, &received),
            hans_gateway::board::run(stack_a, storage, options),
        );
        let test = with_timeout(
            embassy_time::Duration::from_secs(30),
            plc(stack_b, &received),
        );
        match select(infra, test).await {
            Either::First(_) => panic!("the network stopped"),
            Either::Second(r) => r.expect("the PLC finished within 30 s"),
        }
    });
}
