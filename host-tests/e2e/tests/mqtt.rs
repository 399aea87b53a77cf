//! Sparkplug B end to end: hans-sim (the robot) -> the gateway (on tokio,
//! as `hans-gateway --mqtt` runs it) -> Debian's Mosquitto on 127.0.0.1 at
//! a free port -> an independent consumer (rumqttc, payloads decoded with
//! prost from the specification's field numbers, not the gateway's code).
//! What SCADA relies on: births with every metric, bdSeq and seq, DDATA
//! soon after a robot change, one event per finished command, DDEATH when
//! the link drops, rebirths on request and after a broker restart, and
//! writes from MQTT refused.

use std::collections::{BTreeMap, BTreeSet};
use std::net::{Ipv4Addr, SocketAddr, SocketAddrV4};
use std::time::{Duration, Instant};

use hans_e2e::mqtt::{Metric, Mosquitto, Payload};
use hans_e2e::{code, Plc};
use hans_gateway::config::HostName;
use hans_gateway::MqttOverride;
use hans_gateway_linux::{HostOptions, RunningGateway};
use hans_sim::{Config, Sim};
use prost::Message as _;
use rumqttc::{AsyncClient, Event, MqttOptions, Packet, QoS};
use tokio::sync::mpsc;

/// One message the consumer received.
#[derive(Debug)]
struct Msg {
    topic: String,
    payload: Payload,
    at: Instant,
}

impl Msg {
    /// The message type (`NBIRTH`, `DDATA`, ...).
    fn ty(&self) -> &str {
        self.topic.split('/').nth(2).unwrap_or("")
    }

    fn metric(&self, name: &str) -> Option<&Metric> {
        self.payload.metrics.iter().find(|m| m.name() == name)
    }

    fn bd_seq(&self) -> Option<u64> {
        self.metric("bdSeq").and_then(|m| m.long)
    }
}

/// The consumer: everything under `spBv1.0/#`, in order.
struct Consumer {
    client: AsyncClient,
    rx: mpsc::UnboundedReceiver<Msg>,
    seen: Vec<Msg>,
}

impl Consumer {
    async fn start(port: u16, id: &str) -> Consumer {
        let mut opts = MqttOptions::new(id, "127.0.0.1", port);
        opts.set_keep_alive(Duration::from_secs(5));
        opts.set_max_packet_size(64 * 1024, 64 * 1024);
        let (client, mut events) = AsyncClient::new(opts, 64);
        client
            .subscribe("spBv1.0/#", QoS::AtLeastOnce)
            .await
            .unwrap();
        let (tx, rx) = mpsc::unbounded_channel();
        tokio::spawn(async move {
            // Ends when the test drops the receiver, or the broker stays away.
            let mut failures = 0;
            loop {
                match events.poll().await {
                    Ok(Event::Incoming(Packet::Publish(p))) => {
                        let payload = Payload::decode(&p.payload[..]).unwrap_or_else(|e| {
                            panic!("{}: not a Sparkplug payload: {e}", p.topic)
                        });
                        let msg = Msg {
                            topic: p.topic.clone(),
                            payload,
                            at: Instant::now(),
                        };
                        if tx.send(msg).is_err() {
                            return;
                        }
                        failures = 0;
                    }
                    Ok(_) => failures = 0,
                    Err(_) => {
                        failures += 1;
                        if failures > 100 || tx.is_closed() {
                            return;
                        }
                        tokio::time::sleep(Duration::from_millis(100)).await;
                    }
                }
            }
        });
        Consumer {
            client,
            rx,
            seen: Vec::new(),
        }
    }

    /// Waits (at most `limit`) for a message `want` accepts; returns its
    /// index in `seen`.
    async fn wait(&mut self, limit: Duration, what: &str, want: impl Fn(&Msg) -> bool) -> usize {
        let end = Instant::now() + limit;
        let from = self.seen.len();
        if let Some(i) = self.seen.iter().skip(from).position(&want) {
            return from + i;
        }
        loop {
            let left = end.saturating_duration_since(Instant::now());
            match tokio::time::timeout(left, self.rx.recv()).await {
                Ok(Some(m)) => {
                    let hit = want(&m);
                    self.seen.push(m);
                    if hit {
                        return self.seen.len() - 1;
                    }
                }
                _ => panic!(
                    "{what} within {limit:?}; got {:?}",
                    self.seen
                        .iter()
                        .skip(from)
                        .map(|m| m.topic.as_str())
                        .collect::<Vec<_>>()
                ),
            }
        }
    }

    /// Collects what arrives during `d`.
    async fn collect(&mut self, d: Duration) -> Vec<usize> {
        let end = Instant::now() + d;
        let from = self.seen.len();
        while let Ok(Some(m)) = tokio::time::timeout(
            end.saturating_duration_since(Instant::now()),
            self.rx.recv(),
        )
        .await
        {
            self.seen.push(m);
        }
        (from..self.seen.len()).collect()
    }
}

const GROUP: &str = "cells";
const EDGE: &str = "cell-e2e";

fn topic(ty: &str) -> String {
    match ty {
        "DBIRTH" | "DDATA" | "DDEATH" | "DCMD" => format!("spBv1.0/{GROUP}/{ty}/{EDGE}/robot"),
        _ => format!("spBv1.0/{GROUP}/{ty}/{EDGE}"),
    }
}

/// Simulator, gateway (publishing to `broker_port`) and a PLC.
struct Cell {
    sim: Sim,
    gw: RunningGateway,
    plc: Plc,
}

async fn cell(broker_port: u16) -> Cell {
    let sim = Sim::start(Config::ready())
        .await
        .expect("start the simulator");
    let robot = match sim.command_addr() {
        SocketAddr::V4(a) => a,
        SocketAddr::V6(_) => panic!("simulator not on IPv4"),
    };
    let mut opts = HostOptions::new(SocketAddrV4::new(Ipv4Addr::LOCALHOST, 0), robot);
    opts.mqtt = Some(MqttOverride {
        broker: HostName::new("127.0.0.1").unwrap(),
        port: broker_port,
        tls: false,
    });
    opts.node_name = HostName::new(EDGE).unwrap();
    let gw = RunningGateway::start(opts).expect("start the gateway");
    let mut plc = Plc::connect(gw.modbus_addr()).await;
    plc.wait_link().await;
    Cell { sim, gw, plc }
}

fn rebirth_request() -> Vec<u8> {
    Payload {
        timestamp: Some(1),
        metrics: vec![Metric {
            name: Some("Node Control/Rebirth".into()),
            datatype: Some(11),
            boolean: Some(true),
            ..Metric::default()
        }],
        seq: None,
    }
    .encode_to_vec()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn scada_sees_births_changes_commands_and_link_loss_and_mqtt_cannot_write() {
    let broker = Mosquitto::start(None, "");
    let mut scada = Consumer::start(broker.port, "scada-e2e").await;
    // Subscribed before the gateway exists: its first births are seen.
    tokio::time::sleep(Duration::from_millis(300)).await;
    let mut c = cell(broker.port).await;

    // Births: bdSeq, seq 0, then the device's, together every metric the
    // contract lists (gateway/SPARKPLUG.md), each with a datatype.
    let nb = scada
        .wait(Duration::from_secs(5), "NBIRTH", |m| {
            m.topic == topic("NBIRTH")
        })
        .await;
    let db = scada
        .wait(Duration::from_secs(5), "DBIRTH", |m| {
            m.topic == topic("DBIRTH")
        })
        .await;
    let (nbirth, dbirth) = (&scada.seen[nb], &scada.seen[db]);
    let bd = nbirth.bd_seq().expect("the NBIRTH has bdSeq");
    assert_eq!(nbirth.payload.seq, Some(0));
    assert!(
        nbirth
            .payload
            .timestamp
            .is_some_and(|t| t > 1_600_000_000_000),
        "wall-clock timestamps"
    );
    let birth_names: BTreeSet<&str> = nbirth
        .payload
        .metrics
        .iter()
        .chain(&dbirth.payload.metrics)
        .map(|m| {
            assert!(m.datatype.is_some(), "{} has a datatype", m.name());
            m.name()
        })
        .collect();
    let doc = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../gateway/SPARKPLUG.md"
    ))
    .unwrap();
    let metrics = doc.split_once("## Metrics").map_or("", |(_, m)| m);
    let documented: BTreeSet<String> = metrics
        .lines()
        .filter_map(|l| l.strip_prefix("| `"))
        .filter_map(|l| l.split_once('`'))
        .map(|(name, _)| name.to_string())
        .filter(|n| !n.starts_with("SOURCE/"))
        .collect();
    assert!(
        documented.len() > 50,
        "the metric table read: {documented:?}"
    );
    for name in &documented {
        assert!(
            birth_names.contains(name.as_str()),
            "{name} is in no birth: {birth_names:?}"
        );
    }
    assert!(birth_names.contains("Channel 0/Phase") && birth_names.contains("Trigger 15/Phase"));
    assert_eq!(
        dbirth.metric("Link/State").map(|_| ()),
        None,
        "node metrics in the NBIRTH"
    );

    // A robot change: DDATA within 200 ms of it (the gateway polls every
    // 100 ms, and publishes at most every 100 ms).
    let mut lat = Vec::new();
    for k in 0..5u8 {
        tokio::time::sleep(Duration::from_millis(150 + 37 * u64::from(k))).await;
        let changed = Instant::now();
        let on = k % 2 == 0;
        c.sim.set_io(|io| io.di[1] = on);
        let i = scada
            .wait(Duration::from_secs(2), "DDATA with the box inputs", |m| {
                m.topic == topic("DDATA")
                    && m.metric("IO/Box DI")
                        .and_then(|v| v.int)
                        .is_some_and(|v| (v & 2 != 0) == on)
            })
            .await;
        lat.push(scada.seen[i].at - changed);
    }
    lat.sort();
    println!("robot change -> DDATA at the consumer: {lat:?}");
    assert!(
        lat[lat.len() - 1] <= Duration::from_millis(200),
        "DDATA within 200 ms of the change: {lat:?}"
    );

    // One event per finished command, with its result.
    let from = scada.seen.len();
    for seq in 1..=3u16 {
        let e = c.plc.run(0, code::SET_OVERRIDE, &[0.5], seq).await;
        assert!(e.done(), "{e:?}");
    }
    scada.collect(Duration::from_millis(600)).await;
    let results: Vec<String> = scada.seen[from..]
        .iter()
        .filter(|m| m.topic == topic("NDATA"))
        .flat_map(|m| m.payload.metrics.iter())
        .filter(|m| m.name() == "Last Command/Result")
        .map(|m| m.string.clone().unwrap_or_default())
        .collect();
    assert_eq!(
        results,
        ["done", "done", "done"],
        "one event per finished command"
    );

    // seq: every message after the NBIRTH one more than the last, mod 256.
    let mut expect = 0u64;
    for m in &scada.seen[nb..] {
        if m.topic.starts_with(&format!("spBv1.0/{GROUP}/")) && m.ty() != "NDEATH" {
            if m.ty() == "NBIRTH" {
                expect = 0;
            }
            assert_eq!(m.payload.seq, Some(expect), "{}", m.topic);
            expect = (expect + 1) % 256;
        }
    }

    // MQTT cannot write: a DCMD and an NCMD other than a rebirth change
    // nothing at the robot and are counted.
    c.sim.clear_received();
    let write = |name: &str| {
        Payload {
            timestamp: Some(1),
            metrics: vec![Metric {
                name: Some(name.into()),
                datatype: Some(9),
                float: Some(0.1),
                ..Metric::default()
            }],
            seq: None,
        }
        .encode_to_vec()
    };
    scada
        .client
        .publish(topic("DCMD"), QoS::AtMostOnce, false, write("Override"))
        .await
        .unwrap();
    scada
        .client
        .publish(topic("NCMD"), QoS::AtMostOnce, false, write("Queue/Used"))
        .await
        .unwrap();
    let i = scada
        .wait(Duration::from_secs(2), "the refusals counted", |m| {
            m.metric("MQTT/Writes Refused").and_then(|v| v.int) == Some(2)
        })
        .await;
    assert_eq!(scada.seen[i].topic, topic("NDATA"));
    let sent: Vec<String> = c
        .sim
        .received()
        .into_iter()
        .filter(|m| !m.starts_with("Read") && !m.starts_with("PackageVersion"))
        .collect();
    assert!(
        sent.is_empty(),
        "nothing from MQTT reaches the robot: {sent:?}"
    );

    // A rebirth on request: the births again, same bdSeq, seq from 0.
    scada
        .client
        .publish(topic("NCMD"), QoS::AtMostOnce, false, rebirth_request())
        .await
        .unwrap();
    let i = scada
        .wait(Duration::from_secs(2), "NBIRTH on request", |m| {
            m.topic == topic("NBIRTH")
        })
        .await;
    assert_eq!(scada.seen[i].bd_seq(), Some(bd));
    assert_eq!(scada.seen[i].payload.seq, Some(0));
    scada
        .wait(Duration::from_secs(2), "DBIRTH on request", |m| {
            m.topic == topic("DBIRTH")
        })
        .await;

    // The robot link drops: DDEATH, then a DBIRTH when it is back.
    c.sim.drop_connections();
    let lost = Instant::now();
    let i = scada
        .wait(Duration::from_secs(3), "DDEATH", |m| {
            m.topic == topic("DDEATH")
        })
        .await;
    println!("link loss -> DDEATH: {:?}", scada.seen[i].at - lost);
    scada
        .wait(
            Duration::from_secs(10),
            "DBIRTH after the link is back",
            |m| m.topic == topic("DBIRTH"),
        )
        .await;

    c.gw.stop();
    c.sim.shutdown().await;
    drop(c.plc);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn after_a_broker_restart_the_gateway_is_born_again_with_the_next_bd_seq() {
    let broker = Mosquitto::start(None, "");
    let port = broker.port;
    let mut scada = Consumer::start(port, "scada-restart").await;
    tokio::time::sleep(Duration::from_millis(300)).await;
    let c = cell(port).await;
    let i = scada
        .wait(Duration::from_secs(5), "NBIRTH", |m| {
            m.topic == topic("NBIRTH")
        })
        .await;
    let bd = scada.seen[i].bd_seq().unwrap();
    drop(broker);
    tokio::time::sleep(Duration::from_millis(500)).await;
    let _broker = Mosquitto::start(Some(port), "");
    // rumqttc reconnects and subscribes again (clean session).
    scada
        .client
        .subscribe("spBv1.0/#", QoS::AtLeastOnce)
        .await
        .unwrap();
    let i = scada
        .wait(Duration::from_secs(20), "a new NBIRTH", |m| {
            m.topic == topic("NBIRTH")
        })
        .await;
    assert_eq!(
        scada.seen[i].bd_seq(),
        Some((bd + 1) % 256),
        "a new session, the next bdSeq"
    );
    scada
        .wait(Duration::from_secs(2), "DBIRTH", |m| {
            m.topic == topic("DBIRTH")
        })
        .await;
    let by_type: BTreeMap<&str, usize> = scada.seen.iter().fold(BTreeMap::new(), |mut acc, m| {
        *acc.entry(m.ty()).or_default() += 1;
        acc
    });
    println!("messages by type: {by_type:?}");
    c.gw.stop();
    c.sim.shutdown().await;
}
