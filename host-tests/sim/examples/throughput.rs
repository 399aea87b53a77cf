//! Throughput benchmark (a report, not a test): N clients on loopback, each
//! one request in flight, sending `ReadCurFSM,0,;` for a fixed time.
//!
//! `cargo run --release -p hans-sim --example throughput [CLIENTS] [SECONDS]`

use std::time::{Duration, Instant};

use hans_sim::{Config, Sim};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;

#[tokio::main]
async fn main() {
    let mut args = std::env::args().skip(1);
    let clients: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(4);
    let secs: u64 = args.next().and_then(|a| a.parse().ok()).unwrap_or(3);
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
    let pct = |p: f64| lat[((lat.len() as f64 - 1.0) * p) as usize];
    println!(
        "{clients} clients, {secs} s: {total} requests, {:.0} requests/s, latency p50 {:?} p99 {:?}",
        total as f64 / secs as f64,
        pct(0.5),
        pct(0.99)
    );
    sim.shutdown().await;
}
