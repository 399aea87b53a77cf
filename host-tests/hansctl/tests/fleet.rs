//! `hansctl fleet` as a program against a real broker: Debian's Mosquitto,
//! started here on 127.0.0.1 at a free port and killed at the end. The
//! test publishes Sparkplug B messages it encodes itself (prost, field
//! numbers from the specification, written apart from hansctl's reader)
//! and reads what the built binary prints. Every wait is bounded.

use std::io::{BufRead, BufReader, Read};
use std::net::{TcpListener, TcpStream};
use std::path::PathBuf;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use prost::Message as _;
use rumqttc::{AsyncClient, Event, MqttOptions, Packet, QoS};
use serde_json::Value;

const BIN: &str = env!("CARGO_BIN_EXE_hansctl");
/// Every wait of the test, but the run of hansctl itself.
const WAIT: Duration = Duration::from_secs(20);
/// How long hansctl runs (`--for`): time to start, subscribe and receive
/// the few messages, with room for a loaded machine.
const RUN: &str = "6";

/// Sparkplug B payload as this test writes it.
#[derive(Clone, PartialEq, prost::Message)]
struct SpPayload {
    #[prost(uint64, optional, tag = "1")]
    timestamp: Option<u64>,
    #[prost(message, repeated, tag = "2")]
    metrics: Vec<SpMetric>,
    #[prost(uint64, optional, tag = "3")]
    seq: Option<u64>,
}

/// The metric's value fields written as separate optionals (the
/// specification's oneof), one set at a time.
#[derive(Clone, PartialEq, prost::Message)]
struct SpMetric {
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
    #[prost(bool, optional, tag = "14")]
    boolean_value: Option<bool>,
    #[prost(string, optional, tag = "15")]
    string_value: Option<String>,
}

const TS: u64 = 1_767_225_600_000;

fn m(name: &str, datatype: u32) -> SpMetric {
    SpMetric {
        name: Some(name.into()),
        timestamp: Some(TS),
        datatype: Some(datatype),
        ..Default::default()
    }
}
fn uint64(name: &str, v: u64) -> SpMetric {
    SpMetric {
        long_value: Some(v),
        ..m(name, 8)
    }
}
/// Int32 (3), UInt8 (5), UInt16 (6), UInt32 (7): `int_value`, signed as
/// two's complement.
fn int(name: &str, datatype: u32, v: i64) -> SpMetric {
    SpMetric {
        int_value: Some(v as u32),
        ..m(name, datatype)
    }
}
fn text(name: &str, v: &str) -> SpMetric {
    SpMetric {
        string_value: Some(v.into()),
        ..m(name, 12)
    }
}
fn null(name: &str, datatype: u32) -> SpMetric {
    SpMetric {
        is_null: Some(true),
        ..m(name, datatype)
    }
}

fn payload(seq: Option<u64>, metrics: Vec<SpMetric>) -> Vec<u8> {
    SpPayload {
        timestamp: Some(TS),
        metrics,
        seq,
    }
    .encode_to_vec()
}

fn nbirth(bd_seq: u64) -> Vec<u8> {
    payload(
        Some(0),
        vec![
            uint64("bdSeq", bd_seq),
            text("Gateway/Version", "0.1.0"),
            text("Link/State", "connected"),
            null("Last Command/Source", 12),
            null("Last Command/Result", 12),
        ],
    )
}

fn dbirth() -> Vec<u8> {
    payload(
        Some(1),
        vec![
            int("FSM/Code", 3, 33),
            text("FSM/Name", "StandBy"),
            int("Error/Code", 3, 0),
            null("Error/Text", 12),
            SpMetric {
                float_value: Some(0.5),
                ..m("Override", 9)
            },
        ],
    )
}

/// One command event: the seven `Last Command/*` metrics.
fn command_event(seq: u64, result: &str, error_id: i64) -> Vec<u8> {
    payload(
        Some(seq),
        vec![
            text("Last Command/Source", "Channel 0"),
            int("Last Command/Code", 6, 2),
            text("Last Command/Text", "MoveJ,0,10,20,30,0,90,0,;"),
            text("Last Command/Result", result),
            int("Last Command/Error Id", 3, error_id),
            int("Last Command/Error Source", 5, 1),
            int("Last Command/Duration", 7, 250),
        ],
    )
}

fn ndeath(bd_seq: u64) -> Vec<u8> {
    payload(None, vec![uint64("bdSeq", bd_seq)])
}

/// Mosquitto on 127.0.0.1, killed (and its directory removed) when
/// dropped.
struct Broker {
    process: Child,
    port: u16,
    dir: PathBuf,
}

impl Drop for Broker {
    fn drop(&mut self) {
        let _ = self.process.kill();
        let _ = self.process.wait();
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// A port nothing listens on (now).
fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port on 127.0.0.1")
        .port()
}

fn start_broker() -> Broker {
    let exe = ["/usr/sbin/mosquitto", "/usr/bin/mosquitto"]
        .iter()
        .map(PathBuf::from)
        .find(|p| p.is_file())
        .expect("mosquitto (Debian's package; `bash scripts/setup.sh` installs it)");
    let port = free_port();
    let dir = std::env::temp_dir().join(format!("hansctl-fleet-{}-{port}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a temporary directory");
    let conf = dir.join("broker.conf");
    std::fs::write(
        &conf,
        format!(
            "listener {port} 127.0.0.1\nallow_anonymous true\npersistence false\nlog_dest none\n"
        ),
    )
    .expect("the broker's configuration");
    let process = Command::new(exe)
        .arg("-c")
        .arg(&conf)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start mosquitto");
    let broker = Broker { process, port, dir };
    let until = Instant::now() + WAIT;
    while TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(
            Instant::now() < until,
            "mosquitto not listening on {port} within {WAIT:?}"
        );
        std::thread::sleep(Duration::from_millis(25));
    }
    broker
}

/// hansctl running, its stderr read line by line, its stdout to the end.
struct Running {
    child: Child,
    stderr: mpsc::Receiver<String>,
    stdout: Option<std::thread::JoinHandle<String>>,
}

impl Drop for Running {
    fn drop(&mut self) {
        // A failed assertion must not leave it running.
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn spawn_fleet(args: &[&str]) -> Running {
    let mut child = Command::new(BIN)
        .arg("fleet")
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("run hansctl");
    let err = child.stderr.take().expect("stderr");
    let (tx, stderr) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(err).lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let mut out = child.stdout.take().expect("stdout");
    let stdout = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = out.read_to_string(&mut s);
        s
    });
    Running {
        child,
        stderr,
        stdout: Some(stdout),
    }
}

impl Running {
    /// Waits for the line saying hansctl is subscribed.
    fn wait_subscribed(&self) {
        let until = Instant::now() + WAIT;
        let mut seen = Vec::new();
        loop {
            let left = until.saturating_duration_since(Instant::now());
            match self.stderr.recv_timeout(left) {
                Ok(l) if l.contains("subscribed to spBv1.0/") => return,
                Ok(l) => seen.push(l),
                Err(e) => {
                    panic!("hansctl did not subscribe within {WAIT:?} ({e}); stderr: {seen:?}")
                }
            }
        }
    }

    /// Waits for hansctl to end by itself (`--for`); its status, stdout
    /// and the rest of its stderr.
    fn finish(mut self) -> (ExitStatus, String, String) {
        let until = Instant::now() + WAIT + Duration::from_secs(10);
        let status = loop {
            if let Some(s) = self.child.try_wait().expect("wait for hansctl") {
                break s;
            }
            assert!(Instant::now() < until, "hansctl still running after --for");
            std::thread::sleep(Duration::from_millis(50));
        };
        let mut err = String::new();
        while let Ok(l) = self.stderr.recv_timeout(Duration::from_secs(1)) {
            err.push_str(&l);
            err.push('\n');
        }
        let out = self
            .stdout
            .take()
            .map(|h| h.join().expect("stdout reader"))
            .unwrap_or_default();
        (status, out, err)
    }
}

/// Publishes `messages` in order (QoS 1 for NDEATH, as the broker sends a
/// Will, QoS 0 for the rest) and returns once the broker has acknowledged
/// every QoS 1 one, so all were sent.
async fn publish(port: u16, messages: Vec<(String, Vec<u8>)>) {
    let mut opts = MqttOptions::new(format!("fleet-test-{port}"), "127.0.0.1", port);
    opts.set_keep_alive(Duration::from_secs(5));
    let (client, mut events) = AsyncClient::new(opts, 32);
    let mut acks_due = 0;
    for (topic, bytes) in messages {
        let qos = if topic.contains("/NDEATH/") {
            acks_due += 1;
            QoS::AtLeastOnce
        } else {
            QoS::AtMostOnce
        };
        client
            .publish(topic, qos, false, bytes)
            .await
            .expect("queue a publish");
    }
    let until = tokio::time::Instant::now() + WAIT;
    while acks_due > 0 {
        let ev = tokio::time::timeout_at(until, events.poll())
            .await
            .expect("the broker acknowledged within the wait")
            .expect("connected to the broker");
        if let Event::Incoming(Packet::PubAck(_)) = ev {
            acks_due -= 1;
        }
    }
    // Everything queued goes out before the DISCONNECT: poll until it has.
    let _ = client.disconnect().await;
    let until = tokio::time::Instant::now() + WAIT;
    while let Ok(Ok(ev)) = tokio::time::timeout_at(until, events.poll()).await {
        if let Event::Outgoing(rumqttc::Outgoing::Disconnect) = ev {
            break;
        }
    }
}

fn topic(group: &str, kind: &str, node: &str) -> String {
    format!("spBv1.0/{group}/{kind}/{node}")
}

#[tokio::test(flavor = "current_thread")]
async fn json_lines_follow_a_gateway_from_birth_to_death() {
    let broker = start_broker();
    let addr = format!("127.0.0.1:{}", broker.port);
    let fleet = spawn_fleet(&[
        "--broker",
        &addr,
        "--group",
        "Plant T",
        "--json",
        "--for",
        RUN,
        "--timeout",
        "20000",
    ]);
    fleet.wait_subscribed();
    let g = "Plant T";
    publish(
        broker.port,
        vec![
            (topic(g, "NBIRTH", "cell-1"), nbirth(4)),
            (topic(g, "DBIRTH", "cell-1") + "/robot", dbirth()),
            (
                topic(g, "NDATA", "cell-1"),
                command_event(2, "error", 20018),
            ),
            (
                topic(g, "NDATA", "cell-1"),
                b"\xff\x00 not protobuf".to_vec(),
            ),
            // Another group: not subscribed to.
            (topic("Other", "NBIRTH", "cell-9"), nbirth(0)),
            // The Will of an earlier session, then this session's.
            (topic(g, "NDEATH", "cell-1"), ndeath(3)),
            (topic(g, "NDEATH", "cell-1"), ndeath(4)),
        ],
    )
    .await;
    let (status, out, err) = fleet.finish();
    assert!(status.success(), "{status}: {err}");
    let lines: Vec<Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{l:?}: {e}")))
        .collect();
    let types: Vec<&str> = lines
        .iter()
        .map(|l| l["type"].as_str().unwrap_or("?"))
        .collect();
    assert_eq!(
        types,
        ["NBIRTH", "DBIRTH", "NDATA", "NDATA", "NDEATH", "NDEATH"],
        "{out}"
    );
    for l in &lines {
        assert_eq!(
            (l["group"].as_str(), l["node"].as_str()),
            (Some(g), Some("cell-1")),
            "{l}"
        );
    }

    let birth = &lines[0];
    assert_eq!(birth["seq"], 0);
    assert_eq!(birth["device"], Value::Null);
    assert_eq!(birth["timestamp"], TS);
    assert_eq!(birth["metrics"]["bdSeq"], 4);
    assert_eq!(birth["metrics"]["Link/State"], "connected");
    assert_eq!(birth["metrics"]["Last Command/Source"], Value::Null);

    let dbirth = &lines[1];
    assert_eq!(
        (dbirth["device"].as_str(), dbirth["seq"].as_u64()),
        (Some("robot"), Some(1))
    );
    assert_eq!(dbirth["metrics"]["FSM/Name"], "StandBy");
    assert_eq!(dbirth["metrics"]["FSM/Code"], 33);
    assert_eq!(dbirth["metrics"]["Override"], 0.5);
    assert_eq!(dbirth["metrics"]["Error/Text"], Value::Null);

    let data = &lines[2];
    assert_eq!(data["seq"], 2);
    assert_eq!(data["metrics"]["Last Command/Error Id"], 20018);
    let commands = data["commands"].as_array().expect("the command event");
    assert_eq!(commands.len(), 1, "{data}");
    let c = &commands[0];
    assert_eq!(c["Source"], "Channel 0");
    assert_eq!(c["Code"], 2);
    assert_eq!(c["Text"], "MoveJ,0,10,20,30,0,90,0,;");
    assert_eq!(c["Result"], "error");
    assert_eq!(c["Error Id"], 20018);
    assert_eq!(c["Error Source"], 1);
    assert_eq!(c["Duration"], 250);
    assert_eq!(c["timestamp"], TS);

    let bad = &lines[3];
    let e = bad["error"].as_str().expect("a malformed payload's error");
    assert!(e.contains("not a Sparkplug B payload"), "{bad}");

    let stale = &lines[4];
    assert_eq!(stale["stale"], true, "{stale}");
    assert_eq!(stale["metrics"]["bdSeq"], 3);
    assert_eq!(stale["seq"], Value::Null, "an NDEATH has no seq");
    let death = &lines[5];
    assert_eq!(death["metrics"]["bdSeq"], 4);
    assert_eq!(death.get("stale"), None, "{death}");
}

#[tokio::test(flavor = "current_thread")]
async fn the_final_table_shows_a_dead_node_and_one_a_stale_death_left_alive() {
    let broker = start_broker();
    let addr = format!("127.0.0.1:{}", broker.port);
    // Not a terminal: the table is printed in blocks, the last at the end.
    let fleet = spawn_fleet(&["--broker", &addr, "--for", RUN, "--timeout", "20000"]);
    fleet.wait_subscribed();
    let g = "Plant T";
    publish(
        broker.port,
        vec![
            (topic(g, "NBIRTH", "cell-1"), nbirth(7)),
            (topic(g, "DBIRTH", "cell-1") + "/robot", dbirth()),
            (topic(g, "NDATA", "cell-1"), command_event(2, "done", 0)),
            (topic("Line 2", "NBIRTH", "cell-2"), nbirth(2)),
            (topic("Line 2", "NDATA", "cell-2"), b"\x0a\x05".to_vec()),
            (topic("Line 2", "NDEATH", "cell-2"), ndeath(1)),
            (topic(g, "NDEATH", "cell-1"), ndeath(7)),
        ],
    )
    .await;
    let (status, out, err) = fleet.finish();
    assert!(status.success(), "{status}: {err}");
    assert!(
        !out.contains('\x1b'),
        "no terminal codes into a pipe: {out:?}"
    );
    let last = out
        .split("\n\n")
        .filter(|b| !b.trim().is_empty())
        .last()
        .unwrap_or_else(|| panic!("no table printed: {out:?} {err}"));
    let lines: Vec<&str> = last.lines().collect();
    assert!(
        lines[0].contains("2 node(s), 1 alive, 1 dead") && lines[0].contains("1 malformed"),
        "{last}"
    );
    assert!(lines[1].starts_with("GROUP"), "{last}");
    let row = |node: &str| -> Vec<String> {
        let line = lines
            .iter()
            .find(|l| l.split("  ").nth(1).map(str::trim) == Some(node))
            .unwrap_or_else(|| panic!("no row for {node}:\n{last}"));
        // Columns are two or more spaces apart; cells have single spaces.
        line.split("  ")
            .map(str::trim)
            .filter(|c| !c.is_empty())
            .map(str::to_string)
            .collect()
    };
    let dead = row("cell-1");
    assert_eq!(
        dead[..7],
        ["Plant T", "cell-1", "DEAD", "robot", "down", "StandBy", "-"],
        "{last}"
    );
    assert_eq!(dead[7], "Channel 0: MoveJ,0,10,20,30,0,90,0,;", "{last}");
    assert_eq!(dead[8], "done 250ms", "{last}");
    assert_eq!(dead[10], "0", "{last}");
    let alive = row("cell-2");
    assert_eq!(
        alive[..5],
        ["Line 2", "cell-2", "ALIVE", "-", "- (connected)"],
        "{last}"
    );
    assert_eq!(
        alive.last().map(String::as_str),
        Some("1"),
        "one malformed: {last}"
    );
}

#[test]
fn an_unreachable_broker_is_an_error_after_the_timeout() {
    let port = free_port();
    let started = Instant::now();
    let run = spawn_fleet(&[
        "--broker",
        &format!("127.0.0.1:{port}"),
        "--timeout",
        "1500",
    ]);
    let (status, out, err) = run.finish();
    let took = started.elapsed();
    assert_eq!(status.code(), Some(3), "{out} {err}");
    assert!(
        err.contains(&format!(
            "cannot connect to the broker 127.0.0.1:{port} within 1500 ms"
        )),
        "{err}"
    );
    assert!(out.is_empty(), "{out}");
    assert!(
        took >= Duration::from_millis(1400),
        "gave up too soon: {took:?}"
    );
    assert!(took < Duration::from_secs(15), "took {took:?}");
}

/// NCMD messages on `group` that reach a subscriber from `act` until
/// `fleet` ended (its `--for`), as (topic, rebirth requested) pairs, and
/// how `fleet` ended ([`Running::finish`]). What hansctl published went to
/// the broker before it ended; the subscriber collects until a marker it
/// publishes after that comes back through the broker.
async fn commands_until_it_ends(
    port: u16,
    group: &str,
    act: impl std::future::Future<Output = ()>,
    fleet: Running,
) -> (Vec<(String, bool)>, (ExitStatus, String, String)) {
    let mut opts = MqttOptions::new(format!("ncmd-watch-{port}"), "127.0.0.1", port);
    opts.set_keep_alive(Duration::from_secs(5));
    let (client, mut events) = AsyncClient::new(opts, 32);
    client
        .subscribe(format!("spBv1.0/{group}/NCMD/#"), QoS::AtMostOnce)
        .await
        .expect("subscribe");
    let until = tokio::time::Instant::now() + WAIT;
    loop {
        let ev = tokio::time::timeout_at(until, events.poll())
            .await
            .expect("SUBACK")
            .expect("connected");
        if let Event::Incoming(Packet::SubAck(_)) = ev {
            break;
        }
    }
    act.await;
    let mut got = Vec::new();
    let mut record = |ev: Event| -> Option<String> {
        let Event::Incoming(Packet::Publish(p)) = ev else {
            return None;
        };
        let rebirth = SpPayload::decode(&p.payload[..])
            .map(|pl| {
                pl.metrics.iter().any(|m| {
                    m.name.as_deref() == Some("Node Control/Rebirth")
                        && m.boolean_value == Some(true)
                })
            })
            .unwrap_or(false);
        got.push((p.topic.clone(), rebirth));
        Some(p.topic.clone())
    };
    // Until hansctl ends (bounded by `finish`).
    let mut finished = tokio::task::spawn_blocking(move || fleet.finish());
    let ended = loop {
        tokio::select! {
            ended = &mut finished => break ended.expect("hansctl's wait"),
            ev = events.poll() => {
                record(ev.expect("connected"));
            }
        }
    };
    // Then the marker.
    let marker = format!("spBv1.0/{group}/NCMD/zz-marker");
    client
        .publish(&marker, QoS::AtMostOnce, false, Vec::new())
        .await
        .expect("queue the marker");
    let until = tokio::time::Instant::now() + WAIT;
    loop {
        let ev = tokio::time::timeout_at(until, events.poll())
            .await
            .expect("the marker back within the wait")
            .expect("connected");
        if record(ev).is_some_and(|t| t == marker) {
            break;
        }
    }
    got.pop();
    (got, ended)
}

/// A gateway born before the view started (births are not retained) is
/// asked once for its birth when its data arrives; `--no-rebirth` keeps
/// the view silent.
#[tokio::test(flavor = "current_thread")]
async fn a_node_seen_without_its_birth_is_asked_once_for_one_unless_told_not_to() {
    let broker = start_broker();
    let addr = format!("127.0.0.1:{}", broker.port);
    let g = "Plant R";
    let data = || {
        vec![
            (topic(g, "NDATA", "late-1"), command_event(5, "done", 0)),
            (topic(g, "NDATA", "late-1"), command_event(6, "done", 0)),
        ]
    };
    let fleet = spawn_fleet(&[
        "--broker",
        &addr,
        "--group",
        g,
        "--for",
        RUN,
        "--timeout",
        "20000",
    ]);
    fleet.wait_subscribed();
    let (got, (status, _, err)) =
        commands_until_it_ends(broker.port, g, publish(broker.port, data()), fleet).await;
    assert_eq!(
        got,
        [(topic(g, "NCMD", "late-1"), true)],
        "one rebirth request: {err}"
    );
    assert!(status.success(), "{status}: {err}");
    assert!(err.contains("asked Plant R/late-1 for its birth"), "{err}");

    let fleet = spawn_fleet(&[
        "--broker",
        &addr,
        "--group",
        g,
        "--for",
        RUN,
        "--timeout",
        "20000",
        "--no-rebirth",
    ]);
    fleet.wait_subscribed();
    let (got, (status, _, err)) =
        commands_until_it_ends(broker.port, g, publish(broker.port, data()), fleet).await;
    assert!(got.is_empty(), "--no-rebirth publishes nothing: {got:?}");
    assert!(status.success(), "{status}: {err}");
}
