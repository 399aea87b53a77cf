//! The field-device firmware under QEMU publishes Sparkplug B to a real
//! broker: Debian's Mosquitto, started here on 127.0.0.1 at a free port,
//! which the firmware reaches as 10.0.2.100:1883 through QEMU's `guestfwd`
//! (`MQTT_PORT` of `scripts/qemu-run.sh`, which hands the firmware the word
//! `mqtt=10.0.2.100:1883`: MQTT on in its factory settings). An
//! independent subscriber (rumqttc; the payloads decoded with prost
//! structs written here from the specification's field numbers, not the
//! gateway's) checks the contract of `gateway/SPARKPLUG.md`: the NBIRTH
//! with `bdSeq` and seq 0 under the default edge node id `hans-` + MAC,
//! the DBIRTH once the robot link is up, a command the PLC runs through
//! Modbus as one command event in an NDATA, the seq numbers one by one,
//! and the NDEATH (the Will, same `bdSeq`) once the firmware is gone.
//!
//! Printed, not asserted: the time from QEMU's start to the NBIRTH and
//! DBIRTH, and from the command's end to its event (host and firmware
//! clocks).
//!
//! Register addresses are the gateway's (`gateway/REGISTERS.md`), repeated
//! on purpose as in `gateway.rs`.

use std::path::PathBuf;
use std::sync::mpsc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use prost::Message as _;
use qemu_tests::{log_dir, must, request_line, Plc, Process, LOOPBACK};
use rumqttc::{AsyncClient, Event, MqttOptions, Outgoing, Packet, QoS};
use serde_json::Value;

mod common;
use common::{Rig, STEP};

// Command channel 0 (see gateway.rs).
const CH0: u16 = 200;
const CH_STATUS: u16 = 60;
const ST_DONE: u16 = 1 << 1;
const ST_ERROR: u16 = 1 << 2;
const CMD_POWER_ON: u16 = 1;

/// The Sparkplug group of the factory settings (`mqtt.group_id`).
const GROUP: &str = "cells";
/// The edge node id the firmware takes by default: `hans-` and its MAC in
/// hex. QEMU gives the first NIC 52:54:00:12:34:56 when not told another
/// (`scripts/qemu-run.sh` sets none).
const EDGE: &str = "hans-525400123456";
/// The device id of the robot (the factory setting).
const DEVICE: &str = "robot";

/// Sparkplug B `Payload`, the fields read here (specification, chapter
/// "Payloads"; proto2).
#[derive(Clone, PartialEq, prost::Message)]
struct PPayload {
    #[prost(uint64, optional, tag = "1")]
    timestamp: Option<u64>,
    #[prost(message, repeated, tag = "2")]
    metrics: Vec<PMetric>,
    #[prost(uint64, optional, tag = "3")]
    seq: Option<u64>,
}

/// Sparkplug B `Payload.Metric`: the value is a oneof (tags 10-16); as
/// separate optional fields here, at most one of them set.
#[derive(Clone, PartialEq, prost::Message)]
struct PMetric {
    #[prost(string, optional, tag = "1")]
    name: Option<String>,
    #[prost(uint64, optional, tag = "3")]
    timestamp: Option<u64>,
    #[prost(uint32, optional, tag = "4")]
    datatype: Option<u32>,
    #[prost(bool, optional, tag = "7")]
    is_null: Option<bool>,
    #[prost(uint32, optional, tag = "10")]
    int_value: Option<u32>,
    #[prost(uint64, optional, tag = "11")]
    long_value: Option<u64>,
    #[prost(float, optional, tag = "12")]
    float_value: Option<f32>,
    #[prost(double, optional, tag = "13")]
    double_value: Option<f64>,
    #[prost(bool, optional, tag = "14")]
    boolean_value: Option<bool>,
    #[prost(string, optional, tag = "15")]
    string_value: Option<String>,
}

// DataType numbers of the specification.
const UINT8: u32 = 5;
const UINT16: u32 = 6;
const INT32: u32 = 3;
const INT64: u32 = 4;
const STRING: u32 = 12;

impl PPayload {
    /// The metrics named `name` (a data message may hold several command
    /// events, each with the same names).
    fn all(&self, name: &str) -> Vec<&PMetric> {
        self.metrics
            .iter()
            .filter(|m| m.name.as_deref() == Some(name))
            .collect()
    }

    /// The first metric named `name`.
    fn get(&self, name: &str) -> Option<&PMetric> {
        self.metrics
            .iter()
            .find(|m| m.name.as_deref() == Some(name))
    }

    /// The one metric named `name` (a command event's: once per event).
    fn one(&self, name: &str) -> &PMetric {
        let all = self.all(name);
        assert_eq!(
            all.len(),
            1,
            "{name} once in the message: {:?}",
            self.names()
        );
        all[0]
    }

    fn names(&self) -> Vec<&str> {
        self.metrics
            .iter()
            .filter_map(|m| m.name.as_deref())
            .collect()
    }
}

/// One PUBLISH the subscriber received, and when.
#[derive(Clone, Debug)]
struct Received {
    topic: String,
    /// The payload, if it decoded (NDEATH, DBIRTH ... all should).
    payload: Option<PPayload>,
    at: Instant,
}

/// Debian's Mosquitto on 127.0.0.1 at a free port, with a configuration of
/// its own in a temporary directory; run under `timeout(1)` and stopped by
/// its PID when dropped (the directory removed).
struct Broker {
    process: Process,
    port: u16,
    dir: PathBuf,
}

impl Broker {
    fn start() -> Broker {
        let bin = ["/usr/sbin/mosquitto", "/usr/bin/mosquitto"]
            .into_iter()
            .map(PathBuf::from)
            .find(|p| p.exists())
            .unwrap_or_else(|| {
                panic!("mosquitto is not installed: `bash scripts/setup.sh` installs it (Debian's package)")
            });
        let start = Instant::now();
        loop {
            let port = qemu_tests::free_port();
            let dir = std::env::temp_dir()
                .join(format!("hans-qemu-mosquitto-{}-{port}", std::process::id()));
            std::fs::create_dir_all(&dir).expect("broker directory");
            let conf = dir.join("mosquitto.conf");
            std::fs::write(
                &conf,
                format!(
                    "listener {port} 127.0.0.1\nallow_anonymous true\npersistence false\n\
                     log_dest stderr\nlog_type error\nlog_type warning\nlog_type notice\n\
                     connection_messages true\n"
                ),
            )
            .expect("broker configuration");
            let process = Process::start(
                "mosquitto",
                Duration::from_secs(300),
                &bin,
                &["-c", conf.to_str().expect("utf-8 path")],
                &[],
                &log_dir().join("mqtt-sparkplug.mosquitto.log"),
            )
            .expect("start mosquitto");
            let mut broker = Broker { process, port, dir };
            // Listening within 10 s; a port taken in the meantime makes it
            // exit: another port then.
            while start.elapsed() < Duration::from_secs(10) {
                if std::net::TcpStream::connect((LOOPBACK, port)).is_ok() {
                    return broker;
                }
                if !broker.process.running() {
                    break;
                }
                std::thread::sleep(Duration::from_millis(20));
            }
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "mosquitto did not listen within 10 s (log: {})",
                log_dir().join("mqtt-sparkplug.mosquitto.log").display()
            );
        }
    }
}

impl Drop for Broker {
    fn drop(&mut self) {
        self.process.stop();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The independent subscriber: rumqttc on a thread of its own (with its
/// own runtime), subscribed to `spBv1.0/#`, handing each PUBLISH with the
/// moment it arrived to the test. Disconnects and ends when dropped; its
/// thread lives at most `LIFE` in any case.
struct Subscriber {
    client: AsyncClient,
    rx: mpsc::Receiver<Result<Received, String>>,
    thread: Option<JoinHandle<()>>,
    /// Everything received so far, in order.
    seen: Vec<Received>,
}

impl Subscriber {
    const LIFE: Duration = Duration::from_secs(300);

    /// Connects to the broker on 127.0.0.1:`port` and subscribes; returns
    /// once the broker granted the subscription (10 s at most).
    fn start(port: u16) -> Subscriber {
        let mut opts = MqttOptions::new("qemu-test-subscriber", LOOPBACK.to_string(), port);
        opts.set_keep_alive(Duration::from_secs(30));
        // A birth is a few KiB; leave room.
        opts.set_max_packet_size(256 * 1024, 16 * 1024);
        let (client, mut events) = AsyncClient::new(opts, 10);
        let (tx, rx) = mpsc::channel();
        let (ready_tx, ready_rx) = mpsc::channel();
        let sub = client.clone();
        let thread = std::thread::spawn(move || {
            let rt = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
                .expect("subscriber runtime");
            let run = async move {
                if let Err(e) = sub.subscribe("spBv1.0/#", QoS::AtMostOnce).await {
                    let _ = ready_tx.send(Err(format!("subscribe: {e}")));
                    return;
                }
                loop {
                    match events.poll().await {
                        Ok(Event::Incoming(Packet::SubAck(_))) => {
                            let _ = ready_tx.send(Ok(()));
                        }
                        Ok(Event::Incoming(Packet::Publish(p))) => {
                            let at = Instant::now();
                            let r = Received {
                                topic: p.topic.clone(),
                                payload: PPayload::decode(&p.payload[..]).ok(),
                                at,
                            };
                            if tx.send(Ok(r)).is_err() {
                                return;
                            }
                        }
                        Ok(Event::Outgoing(Outgoing::Disconnect)) => return,
                        Ok(_) => {}
                        Err(e) => {
                            let _ = ready_tx.send(Err(format!("{e}")));
                            let _ = tx.send(Err(format!("subscriber: {e}")));
                            return;
                        }
                    }
                }
            };
            // Bounded whatever the test does.
            let _ = rt.block_on(async { tokio::time::timeout(Self::LIFE, run).await });
        });
        let mut s = Subscriber {
            client,
            rx,
            thread: Some(thread),
            seen: Vec::new(),
        };
        match ready_rx.recv_timeout(Duration::from_secs(10)) {
            Ok(Ok(())) => s,
            Ok(Err(e)) => panic!("subscriber: {e}"),
            Err(_) => {
                s.stop();
                panic!("subscriber: no SUBACK within 10 s");
            }
        }
    }

    /// The next message whose topic is `topic` and for which `check`
    /// holds, waiting until `deadline`; every message received on the way
    /// is kept in `seen`.
    fn wait(
        &mut self,
        what: &str,
        deadline: Instant,
        topic: &str,
        mut check: impl FnMut(&Received) -> bool,
    ) -> Received {
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            match self.rx.recv_timeout(left) {
                Ok(Ok(r)) => {
                    self.seen.push(r.clone());
                    if r.topic == topic && check(&r) {
                        return r;
                    }
                }
                Ok(Err(e)) => panic!("waiting for {what}: {e}"),
                Err(_) => panic!(
                    "no {what} ({topic}) in time; received: {:?}",
                    self.seen.iter().map(|r| &r.topic).collect::<Vec<_>>()
                ),
            }
        }
    }

    /// Disconnects and waits (5 s at most) for the thread to end.
    fn stop(&mut self) {
        let _ = self.client.try_disconnect();
        if let Some(thread) = self.thread.take() {
            let start = Instant::now();
            while !thread.is_finished() && start.elapsed() < Duration::from_secs(5) {
                std::thread::sleep(Duration::from_millis(20));
            }
            if thread.is_finished() {
                let _ = thread.join();
            }
            // Else it ends by itself within LIFE.
        }
    }
}

impl Drop for Subscriber {
    fn drop(&mut self) {
        self.stop();
    }
}

fn topic(kind: &str) -> String {
    match kind {
        "DBIRTH" | "DDATA" | "DDEATH" => format!("spBv1.0/{GROUP}/{kind}/{EDGE}/{DEVICE}"),
        _ => format!("spBv1.0/{GROUP}/{kind}/{EDGE}"),
    }
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1000.0
}

/// `a - b` in ms, negative when `a` came first.
fn signed_ms(a: Instant, b: Instant) -> f64 {
    ms(a.saturating_duration_since(b)) - ms(b.saturating_duration_since(a))
}

/// A string metric's value.
fn text(m: &PMetric) -> Option<&str> {
    m.string_value.as_deref()
}

/// Channel 0 runs `code` (no parameters) with sequence `seq`, the status
/// polled without pause. Returns its status bits at the end, when the
/// rising edge was written and when the PLC saw the end.
fn execute_timed(plc: &mut Plc, code: u16, seq: u16) -> (u16, Instant, Instant) {
    must(plc.write_single_register(CH0, 0), "Execute low");
    must(
        plc.write_multiple_registers(CH0 + 1, &[code, seq]),
        "command and sequence",
    );
    must(plc.write_single_register(CH0, 1), "Execute");
    let edge = Instant::now();
    let (st, done) = loop {
        let r = must(
            plc.read_holding_registers(CH0 + CH_STATUS, 2),
            "channel status",
        );
        if r[1] == seq && r[0] & (ST_DONE | ST_ERROR) != 0 {
            break (r[0], Instant::now());
        }
        assert!(
            edge.elapsed() < STEP,
            "command {code}: no end within {STEP:?}"
        );
    };
    must(plc.write_single_register(CH0, 0), "Execute low");
    (st, edge, done)
}

/// The firmware's `/api/status` `mqtt` object (diagnostics), or why not.
fn mqtt_status(rig: &Rig) -> String {
    match qemu_tests::http_get(rig.qemu.ports.web, "/api/status", Duration::from_secs(10)) {
        Ok(r) => serde_json::from_slice::<Value>(&r.body)
            .map(|v| v["mqtt"].to_string())
            .unwrap_or_else(|_| r.text()),
        Err(e) => format!("(GET /api/status: {e})"),
    }
}

#[test]
fn the_field_device_publishes_sparkplug_b_to_mosquitto_births_and_a_command_event() {
    let name = "mqtt-sparkplug";
    let broker = Broker::start();
    let mut sub = Subscriber::start(broker.port);

    // The firmware with the broker handed in (MQTT on in its factory
    // settings), and the simulator.
    let boot = Instant::now();
    let mut rig = Rig::start_with_env(
        "field-device",
        name,
        "",
        &[("MQTT_PORT", broker.port.to_string())],
    );

    // NBIRTH: the default edge node id, seq 0, bdSeq (UInt64, 0-255).
    let nbirth_topic = topic("NBIRTH");
    let nbirth = sub.wait("NBIRTH", boot + STEP, &nbirth_topic, |_| true);
    let t_nbirth = nbirth.at - boot;
    let nb = nbirth
        .payload
        .clone()
        .expect("the NBIRTH is a Sparkplug B payload");
    assert_eq!(nb.seq, Some(0), "NBIRTH seq");
    let bd = nb.get("bdSeq").expect("bdSeq in the NBIRTH");
    assert_eq!(bd.datatype, Some(INT64), "bdSeq is Int64 (SPARKPLUG.md)");
    let bd_seq = bd.long_value.expect("bdSeq has a value");
    assert!(bd_seq <= 255, "bdSeq {bd_seq}");
    for m in [
        "Node Control/Rebirth",
        "Gateway/Version",
        "Link/State",
        "Last Command/Result",
        "Channel 0/Phase",
    ] {
        assert!(nb.get(m).is_some(), "{m} in the NBIRTH: {:?}", nb.names());
    }
    let nb_ts = nb.timestamp.expect("NBIRTH timestamp");
    println!(
        "{name}: NBIRTH on {nbirth_topic}: bdSeq {bd_seq}, {} metrics, {:.0} ms after QEMU's start (host); firmware clock at the NBIRTH {nb_ts} ms",
        nb.metrics.len(),
        ms(t_nbirth)
    );

    // DBIRTH once the robot link is up (the simulator runs from the start).
    let dbirth_topic = topic("DBIRTH");
    let dbirth = sub.wait("DBIRTH", boot + STEP, &dbirth_topic, |_| true);
    let db = dbirth
        .payload
        .clone()
        .expect("the DBIRTH is a Sparkplug B payload");
    assert!(db.seq.is_some(), "DBIRTH has a seq");
    for m in [
        "FSM/Code",
        "FSM/Name",
        "Flags/Powered",
        "Flags/Enabled",
        "Error/Code",
        "Override",
        "Joints/J1",
        "Joints/J6",
        "Pose/X",
        "Pose/Rz",
        "IO/Box DO",
        "IO/Tool DO",
    ] {
        assert!(db.get(m).is_some(), "{m} in the DBIRTH: {:?}", db.names());
    }
    let fsm = db.get("FSM/Code").and_then(|m| m.int_value);
    assert!(fsm.is_some(), "the robot's FSM known at the DBIRTH: {db:?}");
    println!(
        "{name}: DBIRTH on {dbirth_topic}: seq {:?}, {} metrics, FSM {:?} ({:?}), {:.0} ms after QEMU's start",
        db.seq,
        db.metrics.len(),
        fsm,
        db.get("FSM/Name").and_then(text),
        ms(dbirth.at - boot)
    );

    // One command through the gateway: the PLC powers the robot on
    // (channel 0), and its event comes in an NDATA.
    let mut plc = rig.modbus();
    let (st, edge, done) = execute_timed(&mut plc, CMD_POWER_ON, 1);
    assert_eq!(st & (ST_DONE | ST_ERROR), ST_DONE, "power-on: {st:#06x}");
    let is_event = |r: &Received| {
        r.payload.as_ref().is_some_and(|p| {
            p.all("Last Command/Source")
                .iter()
                .any(|m| text(m) == Some("Channel 0"))
        })
    };
    let ndata_topic = topic("NDATA");
    let ndata = sub.wait("the command event", done + STEP, &ndata_topic, is_event);
    let nd = ndata.payload.clone().expect("NDATA payload");
    // The event's seven metrics, once each in this message.
    let event = |name: &str| nd.one(name);
    let code = event("Last Command/Code");
    assert_eq!(
        (code.datatype, code.int_value),
        (Some(UINT16), Some(u32::from(CMD_POWER_ON))),
        "Last Command/Code"
    );
    let result = event("Last Command/Result");
    assert_eq!(
        (result.datatype, text(result)),
        (Some(STRING), Some("done")),
        "Last Command/Result"
    );
    let error_id = event("Last Command/Error Id");
    assert_eq!(
        (error_id.datatype, error_id.int_value),
        (Some(INT32), Some(0)),
        "Last Command/Error Id"
    );
    let error_source = event("Last Command/Error Source");
    assert_eq!(
        (error_source.datatype, error_source.int_value),
        (Some(UINT8), Some(0)),
        "Last Command/Error Source"
    );
    let duration = event("Last Command/Duration");
    assert_eq!(
        duration.datatype,
        Some(INT32),
        "Last Command/Duration (Int32: no UInt32 metric, SPARKPLUG.md)"
    );
    let duration_ms = duration.int_value.expect("a duration");
    let sent = text(event("Last Command/Text"))
        .expect("Last Command/Text")
        .to_string();
    let received = rig.sim().received();
    assert!(
        received.iter().any(|m| m.trim() == sent.trim()),
        "Last Command/Text {sent:?} is what the robot received: {received:?}"
    );
    // Firmware clock: the command's end (the event's metric timestamp) to
    // the NDATA's publication (its payload timestamp).
    let ended = code.timestamp.expect("the event's timestamp");
    let published = nd.timestamp.expect("NDATA timestamp");
    assert!(
        published >= ended,
        "published {published} before the end {ended}"
    );
    let host_lag = signed_ms(ndata.at, done);
    println!(
        "{name}: command event (power-on, channel 0) in NDATA seq {:?}: result done, duration {duration_ms} ms (host: rising edge to Done seen {:.0} ms), text {sent:?}; \
         command's end to its event: {} ms on the firmware's clock (end to publication), {host_lag:+.0} ms on the host (Done seen by the PLC to NDATA received)",
        nd.seq,
        ms(done - edge),
        published - ended,
    );
    drop(plc);

    // seq: 0 in the NBIRTH, then one more in every message of the node
    // (NDATA, DBIRTH, DDATA, DDEATH), 255 followed by 0.
    let node_prefix = format!("spBv1.0/{GROUP}/");
    let mut expected = 0u64;
    let mut counted = 0;
    let start = sub
        .seen
        .iter()
        .position(|r| r.topic == nbirth_topic)
        .expect("the NBIRTH among those seen");
    for r in &sub.seen[start..] {
        if !r.topic.starts_with(&node_prefix) || r.topic.contains("/NDEATH/") {
            continue;
        }
        let seq = r.payload.as_ref().and_then(|p| p.seq);
        assert_eq!(
            seq,
            Some(expected),
            "seq of {} (messages: {:?})",
            r.topic,
            sub.seen[start..]
                .iter()
                .map(|r| (&r.topic, r.payload.as_ref().and_then(|p| p.seq)))
                .collect::<Vec<_>>()
        );
        expected = (expected + 1) % 256;
        counted += 1;
    }
    // What came, when (the firmware's clock: ms since its start), with the
    // command's end: a data round follows the previous one by at least the
    // period (100 ms), so the event waits for that.
    let timeline: Vec<String> = sub.seen[start..]
        .iter()
        .map(|r| {
            let kind = r.topic.split('/').nth(2).unwrap_or("?");
            match &r.payload {
                Some(p) => format!(
                    "{kind} seq {} at {} ms ({} metrics)",
                    p.seq.map_or("-".to_string(), |s| s.to_string()),
                    p.timestamp.unwrap_or(0),
                    p.metrics.len()
                ),
                None => format!("{kind} (not Sparkplug B)"),
            }
        })
        .collect();
    println!(
        "{name}: {counted} messages from the NBIRTH to the event, seq 0 to {}: {}; the command ended at {ended} ms; broker connection: {}",
        (expected + 255) % 256,
        timeline.join(", "),
        mqtt_status(&rig)
    );

    // The firmware ends (diagnostics port): the broker publishes its Will,
    // the NDEATH of the same bdSeq.
    let report = request_line(rig.qemu.ports.admin, "exit\n", Duration::from_secs(30))
        .expect("diagnostics report");
    println!("{name}: {}", report.trim());
    let exit = Instant::now();
    let (status, _log) = rig.wait_end();
    assert!(report.starts_with("stack_used="), "report: {report}");
    assert_eq!(status.and_then(|s| s.code()), Some(0), "exit status");
    rig.check_stack(&report);
    let ndeath = sub.wait(
        "NDEATH",
        exit + Duration::from_secs(20),
        &topic("NDEATH"),
        |_| true,
    );
    let p = ndeath.payload.clone().expect("NDEATH payload");
    assert_eq!(
        p.get("bdSeq").and_then(|m| m.long_value),
        Some(bd_seq),
        "the NDEATH's bdSeq is the NBIRTH's"
    );
    assert_eq!(p.seq, None, "an NDEATH has no seq");
    println!(
        "{name}: NDEATH (the Will, bdSeq {bd_seq}) {:.0} ms after the exit command",
        ms(ndeath.at - exit)
    );
    drop(sub);
    drop(broker);
}
