//! Benchmark (not a test): a plant's worth of cells into one broker on this
//! machine. `NODES` Linux gateways (`RunningGateway`, each on its own
//! thread and tokio runtime, as `hans-gateway --mqtt` runs), each with its
//! own hans-sim, publish Sparkplug B to one Debian Mosquitto on 127.0.0.1;
//! one independent consumer (rumqttc + prost) subscribes to the group.
//!
//! Figures printed:
//! 1. every birth seen (NBIRTH and DBIRTH of every node) and how long the
//!    fleet took to be born;
//! 2. robot change -> DDATA at the consumer, p50/p99 over every node (goal:
//!    p99 <= 100 ms): a box input of one simulator flips, the consumer
//!    timestamps the DDATA that carries it (the bound the gateway keeps,
//!    one poll period and one publish period, is asserted exactly in
//!    virtual time: `gateway/tests/mqtt.rs`);
//! 3. messages/s through the broker with every robot changing an input every
//!    `CHANGE_EVERY`, and the gateways' CPU per node (their threads' user +
//!    system time from /proc, over the same window), idle and loaded.
//!
//! `cargo bench -p hans-e2e --bench sparkplug_fleet` (release build;
//! `HANS_FLEET_NODES=N` for another size). Needs mosquitto
//! (`bash scripts/setup.sh`). Only 127.0.0.1; every wait is bounded and the
//! broker is killed on every exit path.

use std::collections::HashMap;
use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use hans_e2e::mqtt::{Mosquitto, Payload};
use hans_gateway::config::HostName;
use hans_gateway::MqttOverride;
use hans_gateway_linux::{HostOptions, RunningGateway};
use hans_sim::{Config, Sim};
use prost::Message as _;
use rumqttc::{AsyncClient, Event, MqttOptions, Packet, QoS};

const GROUP: &str = "cells";
/// Each robot changes an input this often in the loaded window.
const CHANGE_EVERY: Duration = Duration::from_millis(500);
const WINDOW: Duration = Duration::from_secs(10);
const ROUNDS: usize = 4;

/// What the consumer saw: per (message type, node) the arrival times, and
/// the box-input value of each DDATA with its arrival.
#[derive(Default)]
struct Seen {
    total: u64,
    births: HashMap<(String, String), Instant>,
    di: Vec<(String, u32, Instant)>,
}

/// The gateway threads' CPU time so far (user + system, in clock ticks).
fn gateway_ticks() -> u64 {
    let mut total = 0;
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return 0;
    };
    for t in tasks.flatten() {
        let comm = std::fs::read_to_string(t.path().join("comm")).unwrap_or_default();
        if comm.trim() != "hans-gateway" {
            continue;
        }
        let stat = std::fs::read_to_string(t.path().join("stat")).unwrap_or_default();
        // After the ")" closing the name: state is field 3; utime 14, stime 15.
        if let Some((_, rest)) = stat.rsplit_once(')') {
            let f: Vec<&str> = rest.split_whitespace().collect();
            let num = |i: usize| f.get(i).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0);
            total += num(11) + num(12);
        }
    }
    total
}

fn pct(sorted: &[Duration], p: f64) -> Duration {
    let i = ((sorted.len() as f64 - 1.0) * p).round() as usize;
    sorted[i.min(sorted.len() - 1)]
}

#[tokio::main(flavor = "multi_thread", worker_threads = 2)]
async fn main() {
    let nodes: usize = std::env::var("HANS_FLEET_NODES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(50);
    let broker = Mosquitto::start(None, "max_queued_messages 100000\n");
    let port = broker.port;
    let seen = Arc::new(Mutex::new(Seen::default()));
    let mut opts = MqttOptions::new("fleet-bench", "127.0.0.1", port);
    opts.set_keep_alive(Duration::from_secs(30));
    opts.set_max_packet_size(64 * 1024, 64 * 1024);
    let (client, mut events) = AsyncClient::new(opts, 1000);
    client
        .subscribe(format!("spBv1.0/{GROUP}/#"), QoS::AtMostOnce)
        .await
        .unwrap();
    let s = seen.clone();
    // `subscribe` only queues the request: the births are seen once the
    // broker acknowledged it.
    let (subscribed_tx, subscribed) = tokio::sync::oneshot::channel();
    let mut subscribed_tx = Some(subscribed_tx);
    tokio::spawn(async move {
        loop {
            match events.poll().await {
                Ok(Event::Incoming(Packet::SubAck(_))) => {
                    if let Some(tx) = subscribed_tx.take() {
                        let _ = tx.send(());
                    }
                }
                Ok(Event::Incoming(Packet::Publish(p))) => {
                    let at = Instant::now();
                    let parts: Vec<&str> = p.topic.split('/').collect();
                    let (ty, node) = (
                        parts.get(2).copied().unwrap_or(""),
                        parts.get(3).copied().unwrap_or(""),
                    );
                    let mut s = s.lock().unwrap();
                    s.total += 1;
                    if ty.ends_with("BIRTH") {
                        s.births
                            .entry((ty.to_string(), node.to_string()))
                            .or_insert(at);
                    }
                    if ty == "DDATA" {
                        if let Ok(pl) = Payload::decode(&p.payload[..]) {
                            for m in pl.metrics {
                                if m.name.as_deref() == Some("IO/Box DI") {
                                    if let Some(v) = m.int {
                                        s.di.push((node.to_string(), v, at));
                                    }
                                }
                            }
                        }
                    }
                }
                Ok(_) => {}
                Err(_) => tokio::time::sleep(Duration::from_millis(50)).await,
            }
        }
    });
    tokio::time::timeout(Duration::from_secs(20), subscribed)
        .await
        .expect("the broker acknowledged the subscription within 20 s")
        .expect("the consumer runs");

    // The cells.
    let start = Instant::now();
    let mut cells = Vec::new();
    for i in 0..nodes {
        let sim = Sim::start(Config::ready())
            .await
            .expect("start a simulator");
        let robot = match sim.command_addr() {
            SocketAddr::V4(a) => a,
            SocketAddr::V6(_) => panic!("simulator not on IPv4"),
        };
        let mut o = HostOptions::new(SocketAddrV4::new(Ipv4Addr::LOCALHOST, 0), robot);
        o.mqtt = Some(MqttOverride {
            broker: HostName::new("127.0.0.1").unwrap(),
            port,
            tls: false,
        });
        o.node_name = HostName::new(&format!("cell-{i:03}")).unwrap();
        let gw = RunningGateway::start(o).expect("start a gateway");
        cells.push((Arc::new(sim), gw));
    }
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        let n = seen.lock().unwrap().births.len();
        if n >= 2 * nodes || Instant::now() > deadline {
            break;
        }
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    let born = {
        let s = seen.lock().unwrap();
        let nb = s.births.keys().filter(|(t, _)| t == "NBIRTH").count();
        let db = s.births.keys().filter(|(t, _)| t == "DBIRTH").count();
        let last = s.births.values().max().copied().unwrap_or(start);
        (nb, db, last - start)
    };
    println!(
        "{nodes} gateways, one Mosquitto, 2 cores: births seen {} NBIRTH + {} DBIRTH of {nodes} + {nodes}, all within {:?} of the first start",
        born.0, born.1, born.2
    );
    assert_eq!((born.0, born.1), (nodes, nodes), "every birth seen");

    // Idle: what the fleet costs with nothing changing.
    let (t0, m0, c0) = (Instant::now(), seen.lock().unwrap().total, gateway_ticks());
    tokio::time::sleep(WINDOW).await;
    let (t1, m1, c1) = (Instant::now(), seen.lock().unwrap().total, gateway_ticks());
    let hz = 100.0; // USER_HZ on Linux
    let idle_cpu = (c1 - c0) as f64 / hz / (t1 - t0).as_secs_f64() / nodes as f64 * 100.0;
    println!(
        "idle (robots still): {:.1} messages/s at the broker, gateway CPU {:.2} % of a core per node (robot polled every 100 ms)",
        (m1 - m0) as f64 / (t1 - t0).as_secs_f64(),
        idle_cpu
    );

    // Latency: one robot at a time changes, the consumer times the DDATA.
    let mut lat = Vec::new();
    for round in 0..ROUNDS {
        for (i, (sim, _)) in cells.iter().enumerate() {
            let node = format!("cell-{i:03}");
            let on = round % 2 == 0;
            let from = seen.lock().unwrap().di.len();
            let changed = Instant::now();
            sim.set_io(|io| io.di[2] = on);
            let deadline = changed + Duration::from_secs(5);
            let arrived = loop {
                let hit = {
                    let s = seen.lock().unwrap();
                    s.di[from..]
                        .iter()
                        .find(|(n, v, _)| *n == node && (v & 4 != 0) == on)
                        .map(|(_, _, at)| *at)
                };
                if let Some(at) = hit {
                    break at;
                }
                assert!(Instant::now() < deadline, "{node}: no DDATA within 5 s");
                tokio::time::sleep(Duration::from_millis(1)).await;
            };
            lat.push(arrived - changed);
            // Spread the changes over the poll period.
            tokio::time::sleep(Duration::from_millis(7)).await;
        }
    }
    lat.sort();
    println!(
        "robot change -> DDATA at the consumer ({} changes): p50 {:.1} ms, p99 {:.1} ms, max {:.1} ms (goal p99 <= 100 ms)",
        lat.len(),
        pct(&lat, 0.5).as_secs_f64() * 1e3,
        pct(&lat, 0.99).as_secs_f64() * 1e3,
        lat[lat.len() - 1].as_secs_f64() * 1e3
    );

    // Loaded: every robot changes an input every CHANGE_EVERY.
    let stop = Arc::new(std::sync::atomic::AtomicBool::new(false));
    let sims: Vec<Arc<Sim>> = cells.iter().map(|(s, _)| s.clone()).collect();
    let st = stop.clone();
    let changer = tokio::spawn(async move {
        let mut k = 0u32;
        while !st.load(std::sync::atomic::Ordering::Relaxed) {
            for s in &sims {
                s.set_io(|io| io.di[3] = k.is_multiple_of(2));
                tokio::time::sleep(CHANGE_EVERY / sims.len() as u32).await;
            }
            k += 1;
        }
    });
    let (t0, m0, c0) = (Instant::now(), seen.lock().unwrap().total, gateway_ticks());
    tokio::time::sleep(WINDOW).await;
    let (t1, m1, c1) = (Instant::now(), seen.lock().unwrap().total, gateway_ticks());
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let _ = changer.await;
    let rate = (m1 - m0) as f64 / (t1 - t0).as_secs_f64();
    let cpu = (c1 - c0) as f64 / hz / (t1 - t0).as_secs_f64() / nodes as f64 * 100.0;
    println!(
        "loaded (each robot changes every {} ms): {:.0} messages/s at the broker ({:.2} per node), gateway CPU {:.2} % of a core per node",
        CHANGE_EVERY.as_millis(),
        rate,
        rate / nodes as f64,
        cpu
    );
    for (sim, gw) in cells {
        gw.stop();
        if let Ok(sim) = Arc::try_unwrap(sim) {
            sim.shutdown().await;
        }
    }
}
