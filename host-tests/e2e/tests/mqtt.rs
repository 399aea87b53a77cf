//! Sparkplug B end to end: hans-sim (the robot) -> the gateway (on tokio,
//! as `hans-gateway --mqtt` runs it) -> Debian's Mosquitto on 127.0.0.1 at
//! a free port -> an independent consumer (rumqttc, payloads decoded with
//! prost from the specification's field numbers, not the gateway's code).
//! What SCADA relies on: births with every metric, bdSeq and seq, DDATA
//! after a robot change, one event per finished command, DDEATH when the
//! link drops, rebirths on request and after a broker restart, and writes
//! from MQTT refused.
//!
//! Every wait is for a message or an acknowledgement, bounded. How soon
//! a change is published is asserted in virtual time
//! (`gateway/tests/mqtt.rs`) and measured on a real machine by the fleet
//! benchmark (`benches/sparkplug_fleet.rs`); this test prints what it saw.

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
use tokio::sync::{mpsc, watch};

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
    /// The number of the connection (1, 2, ... for each CONNACK) whose
    /// subscription the broker last acknowledged (SUBACK).
    subscribed: watch::Receiver<u32>,
    seen: Vec<Msg>,
}

/// Everything the consumer reads.
const TOPICS: &str = "spBv1.0/#";

impl Consumer {
    /// Connects and subscribes; returns once the broker acknowledged the
    /// subscription (`subscribe` only queues it).
    async fn start(port: u16, id: &str) -> Consumer {
        let mut opts = MqttOptions::new(id, "127.0.0.1", port);
        opts.set_keep_alive(Duration::from_secs(5));
        opts.set_max_packet_size(64 * 1024, 64 * 1024);
        let (client, mut events) = AsyncClient::new(opts, 64);
        let (tx, rx) = mpsc::unbounded_channel();
        let (subscribed_tx, subscribed) = watch::channel(0);
        let again = client.clone();
        tokio::spawn(async move {
            // Ends when the test drops the receiver, or the broker stays away.
            let mut failures = 0;
            let mut connection = 0;
            loop {
                match events.poll().await {
                    // A new connection, with a clean session: subscribe in
                    // it (after a broker restart too).
                    Ok(Event::Incoming(Packet::ConnAck(_))) => {
                        connection += 1;
                        failures = 0;
                        if again.try_subscribe(TOPICS, QoS::AtLeastOnce).is_err() {
                            return;
                        }
                    }
                    Ok(Event::Incoming(Packet::SubAck(_))) => {
                        failures = 0;
                        subscribed_tx.send_replace(connection);
                    }
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
        let mut consumer = Consumer {
            client,
            rx,
            subscribed,
            seen: Vec::new(),
        };
        consumer.subscribed_in(1).await;
        consumer
    }

    /// Waits (at most 20 s) until the broker acknowledged the subscription
    /// of the consumer's `connection`th connection (or a later one's).
    async fn subscribed_in(&mut self, connection: u32) {
        let acked = self.subscribed.wait_for(|c| *c >= connection);
        match tokio::time::timeout(Duration::from_secs(20), acked).await {
            Ok(Ok(_)) => {}
            other => panic!("no SUBACK in connection {connection} within 20 s: {other:?}"),
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
    // Subscribed (acknowledged) before the gateway exists: its first
    // births are seen.
    let mut scada = Consumer::start(broker.port, "scada-e2e").await;
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

    // A robot change: a DDATA with it (within 200 ms in virtual time; here
    // only printed).
    let mut lat = Vec::new();
    for k in 0..5u8 {
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

    // One event per finished command, with its result, in order: three
    // Done, then a fourth command the robot refuses, whose event (an
    // error) closes the list (events go out in the order the commands
    // started).
    let from = scada.seen.len();
    for seq in 1..=3u16 {
        let e = c.plc.run(0, code::SET_OVERRIDE, &[0.5], seq).await;
        assert!(e.done(), "{e:?}");
    }
    let e = c.plc.run(0, code::SET_BOX_DO, &[9.0, 1.0], 4).await;
    assert!(!e.done(), "no box output 9: {e:?}");
    let results = |seen: &[Msg]| -> Vec<String> {
        seen.iter()
            .filter(|m| m.topic == topic("NDATA"))
            .flat_map(|m| m.payload.metrics.iter())
            .filter(|m| m.name() == "Last Command/Result")
            .map(|m| m.string.clone().unwrap_or_default())
            .collect()
    };
    let i = scada
        .wait(Duration::from_secs(5), "the fourth command's event", |m| {
            // Several events in one NDATA when they finished within a
            // publish period.
            results(std::slice::from_ref(m))
                .iter()
                .any(|r| r == "error")
        })
        .await;
    assert_eq!(
        results(&scada.seen[from..=i]),
        ["done", "done", "done", "error"],
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
    let c = cell(port).await;
    let i = scada
        .wait(Duration::from_secs(5), "NBIRTH", |m| {
            m.topic == topic("NBIRTH")
        })
        .await;
    let bd = scada.seen[i].bd_seq().unwrap();
    drop(broker);
    let _broker = Mosquitto::start(Some(port), "");
    // The consumer connects again and subscribes in its new (clean)
    // session. The gateway's new session may have published its NBIRTH
    // before that subscription: then ask for its births again (an NCMD
    // rebirth keeps the session's bdSeq). One request is enough: if the
    // NBIRTH went out before the subscription, the gateway's own
    // subscription to its NCMD (which it sends before its births) was in
    // place before this request; if not, the NBIRTH comes after it.
    scada.subscribed_in(2).await;
    scada
        .client
        .publish(topic("NCMD"), QoS::AtLeastOnce, false, rebirth_request())
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
