//! HTTP bytes from a browser or a script, in reads of any size, through
//! the gateway's web server (the real gateway future, in virtual time):
//! request lines, headers (the Host, Origin, content type and framing
//! rules: seeds and `dicts/gateway_http.dict` name them), bodies, logins,
//! configuration posts, requests kept alive to the connection's limit. Never a
//! panic; memory is bounded by construction (fixed buffers, no heap in the
//! gateway); whatever comes back is an HTTP answer; the connection is
//! closed within the server's timeouts once the client stops sending; the
//! configuration in use stays in range; and the gateway still serves the
//! next client and its PLC.
//!
//! One world per process (`common.rs`): each input is a new web client of
//! it; what the input stored (settings, triggers, the accounts) is put
//! back before the next. The robot is not reachable (connects are
//! refused), which keeps the seconds of virtual time the timeouts take
//! cheap.
//!
//! Input: the first byte picks the chunk sizes (1-64 bytes); the rest is the
//! stream, sent chunk by chunk with 1 ms of virtual time between chunks.
#![no_main]

#[path = "common.rs"]
mod common;

use core::cell::RefCell;
use core::net::Ipv4Addr;

use embassy_time::Duration;
use hans_gateway::config::Config;
use hans_gateway::registers as r;
use hans_gateway::testkit::plc::{pdu, Answer};
use hans_gateway::testkit::world::{World, WorldConfig};
use libfuzzer_sys::fuzz_target;

thread_local! {
    static WORLD: RefCell<Option<(World, Config)>> = const { RefCell::new(None) };
}

fn make() -> World {
    let mut w = World::new(WorldConfig {
        web: true,
        config: Config {
            // Nobody listens there: the link stays down.
            robot_ip: Ipv4Addr::new(10, 0, 0, 99),
            ..Config::default()
        },
        ..WorldConfig::default()
    });
    w.run_for(Duration::from_millis(20));
    w
}

fuzz_target!(|data: &[u8]| {
    let Some((&seed, stream)) = data.split_first() else {
        return;
    };
    common::with_world(&WORLD, make, |w| {
        let Some(mut conn) = w.web_connect(Ipv4Addr::new(10, 0, 0, 60)) else {
            panic!("the web port is not served");
        };
        let mut got = Vec::new();
        let mut rest = stream;
        let mut k = usize::from(seed);
        while !rest.is_empty() && conn.is_open() {
            let n = (k % 64 + 1).min(rest.len());
            k = k.wrapping_mul(31).wrapping_add(7);
            let (chunk, tail) = rest.split_at(n);
            conn.write(chunk);
            w.run_for(Duration::from_millis(1));
            got.extend(conn.read());
            rest = tail;
        }
        // The client stops sending: within the limits (3 s without a
        // request, 2 s to read one, 3 s to write an answer) the server
        // closes the connection.
        w.run_until_cond(Duration::from_secs(12), |_| !conn.is_open());
        got.extend(conn.read());
        assert!(!conn.is_open(), "connection still open after the timeouts");
        drop(conn);
        if !got.is_empty() {
            assert!(
                got.starts_with(b"HTTP/1.1 "),
                "not an HTTP answer: {:?}",
                &got[..got.len().min(40)]
            );
        }
        // Whatever the page applied is in range.
        let active = w.model(|m| m.config.active);
        assert_eq!(active.check(), Ok(()), "configuration in use out of range");
        // The next client is served, and so is the PLC.
        let answer = w.http(
            Ipv4Addr::new(10, 0, 0, 61),
            b"GET /api/session HTTP/1.1\r\nHost: 10.0.0.1\r\nConnection: close\r\n\r\n",
            Duration::from_secs(5),
        );
        assert!(
            answer.starts_with(b"HTTP/1.1 200"),
            "{:?}",
            String::from_utf8_lossy(&answer)
        );
        match w.request(0, &pdu::read(r::STATUS_VERSION, 1)) {
            Answer::Pdu(p) => assert_eq!(pdu::registers(&p)[0], r::MAP_VERSION),
            Answer::Exception(e) => panic!("exception {e}"),
        }
    });
});
