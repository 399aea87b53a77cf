//! Throughput benchmark (a report, not a test): N clients on loopback, each
//! one request in flight, sending `ReadCurFSM,0,;` for a fixed time.
//!
//! `cargo run --release -p hans-sim --example throughput [CLIENTS] [SECONDS]`

use std::time::{Duration, Instant};

use hans_sim::{Config, Sim};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

const USAGE: &str =
    "usage: throughput [CLIENTS] [SECONDS]  (whole numbers from 1; defaults 4 and 3)";

/// The optional argument `what`: `default` when absent, an error for
/// anything but a whole number from 1.
fn count(arg: Option<String>, what: &str, default: u64) -> Result<u64, String> {
    let Some(text) = arg else {
        return Ok(default);
    };
    match text.parse::<u64>() {
        Ok(0) => Err(format!("{what} must be at least 1, got 0")),
        Ok(v) => Ok(v),
        Err(_) => Err(format!("{what} must be a whole number, got {text:?}")),
    }
}

#[tokio::main]
async fn main() {
    let mut args = std::env::args().skip(1);
    let parsed = (|| {
        let clients = count(args.next(), "CLIENTS", 4)?;
        let secs = count(args.next(), "SECONDS", 3)?;
        match args.next() {
            Some(extra) => Err(format!("unexpected argument {extra:?}")),
            None => Ok((clients, secs)),
        }
    })();
    let (clients, secs) = match parsed {
        Ok(v) => v,
        Err(e) => {
            eprintln!("throughput: {e}\n{USAGE}");
            std::process::exit(2);
        }
    };
    let sim = Sim::start(Config {
        datasheet_ports: vec![],
        received_capacity: 1000,
        ..Config::ready()
    })
    .await
    .expect("start the simulator");
    let addr = sim.command_addr();
    let until = Instant::now() + Duration::from_secs(secs);
    let mut tasks = Vec::new();
    for _ in 0..clients {
        tasks.push(tokio::spawn(async move {
            let mut s = TcpStream::connect(addr).await.expect("connect");
            s.set_nodelay(true).expect("nodelay");
            let want = b"ReadCurFSM,OK,33,;";
            let mut buf = [0u8; 64];
            let mut n = 0u64;
            let mut lat = Vec::new();
            while Instant::now() < until {
                let t = Instant::now();
                s.write_all(b"ReadCurFSM,0,;").await.expect("write");
                let mut got = 0;
                while got < want.len() {
                    let r = tokio::time::timeout(Duration::from_secs(5), s.read(&mut buf[got..]))
                        .await
                        .expect("reply within 5 s")
                        .expect("read");
                    assert!(r > 0, "closed");
                    got += r;
                }
                assert_eq!(&buf[..got], want);
                lat.push(t.elapsed());
                n += 1;
            }
            (n, lat)
        }));
    }
    let mut total = 0;
    let mut lat = Vec::new();
    for t in tasks {
        let (n, l) = t.await.expect("client task");
        total += n;
        lat.extend(l);
    }
    lat.sort();
    // The sample at quantile `p` of a non-empty, sorted list.
    let pct = |p: f64| {
        let i = (lat.len().saturating_sub(1) as f64 * p) as usize;
        lat.get(i).copied().unwrap_or_default()
    };
    if lat.is_empty() {
        println!("{clients} clients, {secs} s: no request completed");
    } else {
        println!(
            "{clients} clients, {secs} s: {total} requests, {:.0} requests/s, latency p50 {:?} p99 {:?}",
            total as f64 / secs as f64,
            pct(0.5),
            pct(0.99)
        );
    }
    sim.shutdown().await;
}
