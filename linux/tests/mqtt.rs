//! The MQTT client against a real broker: Debian's Mosquitto, started here
//! on 127.0.0.1 at a free port, and an independent subscriber (rumqttc,
//! payloads decoded with prost from the specification's field numbers).
//! `cargo test -p hans-gateway-linux --test mqtt`.

use std::net::{Ipv4Addr, SocketAddrV4, TcpStream};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

mod common;

use common::{free_port, make_ca, make_cert, Killed};
use hans_gateway::mqtt::sparkplug::NodeConfig;
use hans_gateway::mqtt::{Settings, Status};
use hans_gateway::{Gateway, Options};
use hans_gateway_linux::mqtt::run_host;
use prost::Message as _;
use rumqttc::{AsyncClient, Event, MqttOptions, Packet, QoS};

#[derive(Clone, PartialEq, prost::Message)]
struct PPayload {
    #[prost(uint64, optional, tag = "1")]
    timestamp: Option<u64>,
    #[prost(message, repeated, tag = "2")]
    metrics: Vec<PMetric>,
    #[prost(uint64, optional, tag = "3")]
    seq: Option<u64>,
}

#[derive(Clone, PartialEq, prost::Message)]
struct PMetric {
    #[prost(string, optional, tag = "1")]
    name: Option<String>,
    #[prost(uint32, optional, tag = "4")]
    datatype: Option<u32>,
    #[prost(uint64, optional, tag = "11")]
    long: Option<u64>,
}

/// The broker, killed when dropped.
struct Mosquitto {
    child: Child,
    port: u16,
    _dir: PathBuf,
}

impl Drop for Mosquitto {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self._dir);
    }
}

fn mosquitto() -> Mosquitto {
    let bin = ["/usr/sbin/mosquitto", "/usr/bin/mosquitto"]
        .into_iter()
        .map(PathBuf::from)
        .find(|p| p.exists())
        .unwrap_or_else(|| {
            panic!("mosquitto is not installed: `bash scripts/setup.sh` installs it (Debian's package)")
        });
    let port = free_port();
    let dir = std::env::temp_dir().join(format!("hans-mqtt-{}-{port}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let conf = dir.join("mosquitto.conf");
    std::fs::write(
        &conf,
        format!("listener {port} 127.0.0.1\nallow_anonymous true\npersistence false\n"),
    )
    .unwrap();
    let child = Command::new(bin)
        .arg("-c")
        .arg(&conf)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let m = Mosquitto {
        child,
        port,
        _dir: dir,
    };
    let end = Instant::now() + Duration::from_secs(5);
    while TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(Instant::now() < end, "mosquitto did not listen on {port}");
        std::thread::sleep(Duration::from_millis(20));
    }
    m
}

/// `hans-gateway` with a configuration file in `dir` (robot absent, edge
/// id `edge`, then `mqtt_toml` in its `[mqtt]` table) and `args`, its
/// stderr in `dir/EDGE.log`; killed when dropped.
fn gateway_process(
    dir: &std::path::Path,
    edge: &str,
    mqtt_toml: &str,
    args: &[&std::ffi::OsStr],
) -> Killed {
    let cfg = dir.join(format!("{edge}.toml"));
    std::fs::write(
        &cfg,
        format!(
            "[robot]\naddress = \"127.0.0.1\"\nport = 1\n[mqtt]\nedge_id = \"{edge}\"\n{mqtt_toml}"
        ),
    )
    .unwrap();
    Killed(
        Command::new(env!("CARGO_BIN_EXE_hans-gateway"))
            .args(["--modbus-listen", "127.0.0.1:0", "--config"])
            .arg(&cfg)
            .arg("--setup-code-file")
            .arg(dir.join(format!("{edge}.code")))
            .args(args)
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(dir.join(format!("{edge}.log"))).unwrap())
            .spawn()
            .unwrap(),
    )
}

/// A subscriber (`id`) to `topic` on the broker at `port`, its SUBACK
/// received (within 15 s).
async fn subscriber(id: &str, port: u16, topic: &str) -> (AsyncClient, rumqttc::EventLoop) {
    let mut opts = MqttOptions::new(id, "127.0.0.1", port);
    opts.set_keep_alive(Duration::from_secs(5));
    let (client, mut events) = AsyncClient::new(opts, 10);
    client.subscribe(topic, QoS::AtLeastOnce).await.unwrap();
    // 15 s: the broker was just started, beside other test processes on
    // a loaded 2-core machine (5 s once ran out there).
    let deadline = tokio::time::Instant::now() + Duration::from_secs(15);
    loop {
        let ev = tokio::time::timeout_at(deadline, events.poll())
            .await
            .expect("SUBACK within 15 s")
            .unwrap();
        if let Event::Incoming(Packet::SubAck(_)) = ev {
            return (client, events);
        }
    }
}

/// The next PUBLISH whose topic contains `what`, within `limit` (else a
/// failure saying `expect`).
async fn published(
    events: &mut rumqttc::EventLoop,
    limit: Duration,
    what: &str,
    expect: &str,
) -> rumqttc::Publish {
    let deadline = tokio::time::Instant::now() + limit;
    loop {
        match tokio::time::timeout_at(deadline, events.poll())
            .await
            .expect(expect)
            .unwrap()
        {
            Event::Incoming(Packet::Publish(p)) if p.topic.contains(what) => return p,
            _ => continue,
        }
    }
}

/// Reads what `events` brings until the log file `log` says `why` (within
/// 15 s), failing if anything of the node `edge` is published meanwhile:
/// a gateway the broker refused (the log says so once it was refused)
/// publishes nothing.
async fn nothing_published_until_logged(
    events: &mut rumqttc::EventLoop,
    edge: &str,
    log: &std::path::Path,
    why: &str,
) {
    let deadline = tokio::time::Instant::now() + Duration::from_secs(15);
    loop {
        let text = std::fs::read_to_string(log).unwrap_or_default();
        if text.contains(why) {
            return;
        }
        assert!(
            tokio::time::Instant::now() < deadline,
            "the log does not say {why:?} within 15 s: {text}"
        );
        // What the broker forwarded meanwhile (or 20 ms of nothing).
        let next = tokio::time::timeout(Duration::from_millis(20), events.poll()).await;
        if let Ok(Ok(Event::Incoming(Packet::Publish(p)))) = next {
            assert!(
                !p.topic.contains(edge),
                "published though refused: {}",
                p.topic
            );
        }
    }
}

#[tokio::test(flavor = "current_thread")]
async fn mosquitto_passes_the_nbirth_and_then_the_will_as_ndeath_to_an_independent_subscriber() {
    let broker = mosquitto();
    // Subscribed before the gateway connects.
    let (_client, mut events) = subscriber("checker", broker.port, "spBv1.0/Plant A/#").await;

    let gateway = Gateway::new(Options::default());
    let settings = Settings::new(
        SocketAddrV4::new(Ipv4Addr::LOCALHOST, broker.port),
        NodeConfig::new("Plant A", "cell-7").unwrap(),
    );
    let status = Status::new();
    let mut run = Box::pin(run_host(gateway.hub(), &settings, &status));
    let deadline = tokio::time::Instant::now() + Duration::from_secs(5);
    let nbirth = loop {
        tokio::select! {
            never = &mut run => match never {},
            ev = tokio::time::timeout_at(deadline, events.poll()) => {
                match ev.expect("an NBIRTH within 5 s").unwrap() {
                    Event::Incoming(Packet::Publish(p)) => break p,
                    _ => continue,
                }
            }
        }
    };
    assert_eq!(nbirth.topic, "spBv1.0/Plant A/NBIRTH/cell-7");
    assert_eq!(nbirth.qos, QoS::AtMostOnce);
    assert!(!nbirth.retain);
    let p = PPayload::decode(&nbirth.payload[..]).unwrap();
    assert_eq!(p.seq, Some(0));
    let utc = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .as_millis() as u64;
    let ts = p.timestamp.expect("a timestamp");
    assert!(utc.abs_diff(ts) < 10_000, "wall time: {ts} vs {utc}");
    let bd = p
        .metrics
        .iter()
        .find(|m| m.name.as_deref() == Some("bdSeq"))
        .expect("bdSeq in the NBIRTH");
    assert_eq!(
        (bd.long, bd.datatype),
        (Some(0), Some(4)),
        "bdSeq 0, Int64 (Sparkplug 3.0's bdSeq rule; SPARKPLUG.md)"
    );
    assert!(
        p.metrics.len() > 20,
        "every node metric: {}",
        p.metrics.len()
    );
    let s = status.get();
    assert!(s.connected && s.connects == 1 && s.sent >= 1, "{s:?}");

    // The gateway gone without a DISCONNECT (its socket closed): the broker
    // publishes the Will, the NDEATH of the same bdSeq.
    drop(run);
    let ndeath = published(
        &mut events,
        Duration::from_secs(5),
        "/NDEATH/",
        "the NDEATH within 5 s",
    )
    .await;
    assert_eq!(ndeath.topic, "spBv1.0/Plant A/NDEATH/cell-7");
    let p = PPayload::decode(&ndeath.payload[..]).unwrap();
    let bd = p
        .metrics
        .iter()
        .find(|m| m.name.as_deref() == Some("bdSeq"));
    assert_eq!(bd.and_then(|m| m.long), Some(0));
    assert_eq!(p.seq, None, "an NDEATH has no seq");
}

/// Runs `hans-gateway --mqtt` as a plant does (keep-alive `keep_alive_s`),
/// then ends it `how` (a signal, as `kill -SIG`): the time until the broker
/// publishes its NDEATH (at most 15 s), checked to carry the bdSeq of the
/// NBIRTH seen.
async fn declared_dead(how: &str, keep_alive_s: u64) -> Duration {
    let broker = mosquitto();
    let (_client, mut events) = subscriber("scada-kill", broker.port, "spBv1.0/#").await;
    // One directory per test: the two run at once, each its own file.
    let dir = std::env::temp_dir().join(format!("hans-mqtt-kill-{}-{how}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // The robot is absent (its port refuses): the node lives without its
    // device.
    let mqtt = format!("127.0.0.1:{}", broker.port);
    let gw = gateway_process(
        &dir,
        "gw-kill",
        &format!("keep_alive_s = {keep_alive_s}\ngroup_id = \"kill\"\n"),
        &["--mqtt".as_ref(), mqtt.as_ref()],
    );
    let nbirth = published(
        &mut events,
        Duration::from_secs(10),
        "/NBIRTH/",
        "the NBIRTH within 10 s",
    )
    .await;
    assert_eq!(nbirth.topic, "spBv1.0/kill/NBIRTH/gw-kill");
    let bd_of = |payload: &[u8]| {
        PPayload::decode(payload)
            .unwrap()
            .metrics
            .iter()
            .find(|m| m.name.as_deref() == Some("bdSeq"))
            .and_then(|m| m.long)
    };
    let bd = bd_of(&nbirth.payload);
    assert!(bd.is_some());
    let status = Command::new("kill")
        .arg(format!("-{how}"))
        .arg(gw.0.id().to_string())
        .status()
        .unwrap();
    assert!(status.success());
    let killed = Instant::now();
    let ndeath = published(
        &mut events,
        Duration::from_secs(15),
        "/NDEATH/",
        "the NDEATH within 15 s",
    )
    .await;
    let took = killed.elapsed();
    println!("SIG{how} -> NDEATH at the consumer: {took:?}");
    assert_eq!(ndeath.topic, "spBv1.0/kill/NDEATH/gw-kill");
    assert_eq!(bd_of(&ndeath.payload), bd, "the NDEATH of the session born");
    let _ = std::fs::remove_dir_all(&dir);
    took
}

/// Killed (SIGKILL: no DISCONNECT; the kernel closes the socket, which the
/// broker takes as the end): the NDEATH (in practice at once). With a
/// keep-alive of 60 s, an NDEATH within the wait (15 s) cannot be the
/// keep-alive's (1.5 times it, 90 s): the close told the broker.
#[tokio::test(flavor = "current_thread")]
async fn a_killed_hans_gateway_is_declared_dead_by_the_broker() {
    declared_dead("KILL", 60).await;
}

/// Frozen (SIGSTOP: the socket stays open and silent, as when the cable is
/// pulled or the power goes): only the keep-alive we registered tells the
/// broker. The MQTT rule is 1.5 times it (7.5 s) after the last packet;
/// Debian 12's Mosquitto 2.0.11 checks keep-alives on a coarse timer and
/// was measured at 11 s here, so the wait is 3 times (the broker's, not
/// the gateway's figure; the README gives it). The gateway pings after
/// half a keep-alive of silence, so the NDEATH comes at least one
/// keep-alive (5 s) after it froze; the bound is half that, for a ping a
/// loaded machine made late: a close would be at once.
#[tokio::test(flavor = "current_thread")]
async fn a_silent_hans_gateway_is_declared_dead_by_the_keep_alive() {
    let took = declared_dead("STOP", 5).await;
    assert!(
        took >= Duration::from_millis(2_500),
        "by the keep-alive, not a close: {took:?}"
    );
}

/// Mosquitto configured as `global`, then a plain listener on `plain`
/// (for the test's subscriber), then `after` (its settings and a second
/// listener on `second`); waits until both listen.
fn two_listeners(
    dir: &std::path::Path,
    global: &str,
    plain: u16,
    after: &str,
    second: u16,
) -> Mosquitto {
    let conf = dir.join("mosquitto.conf");
    std::fs::write(
        &conf,
        format!("{global}persistence false\nlistener {plain} 127.0.0.1\n{after}"),
    )
    .unwrap();
    let bin = ["/usr/sbin/mosquitto", "/usr/bin/mosquitto"]
        .into_iter()
        .find(|p| std::path::Path::new(p).exists())
        .expect("mosquitto");
    let broker = Mosquitto {
        child: Command::new(bin)
            .arg("-c")
            .arg(&conf)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
        port: plain,
        _dir: dir.join("broker-run"),
    };
    let end = Instant::now() + Duration::from_secs(5);
    while TcpStream::connect(("127.0.0.1", second)).is_err()
        || TcpStream::connect(("127.0.0.1", plain)).is_err()
    {
        assert!(Instant::now() < end, "mosquitto did not listen");
        std::thread::sleep(Duration::from_millis(20));
    }
    broker
}

/// `hans-gateway --mqtt mqtts://127.0.0.1:PORT --mqtt-ca CA` against a
/// Mosquitto TLS listener whose certificate (for 127.0.0.1) a test CA
/// signed: the NBIRTH arrives (seen on the broker's second, plain
/// listener); with another CA the handshake fails, nothing is published,
/// and the log says why.
#[tokio::test(flavor = "current_thread")]
async fn over_tls_the_broker_is_trusted_by_its_ca_only() {
    let dir = std::env::temp_dir().join(format!("hans-mqtt-tls-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    make_ca(&dir, "plant-ca");
    make_ca(&dir, "other-ca");
    make_cert(
        &dir,
        "plant-ca",
        "broker",
        "subjectAltName=IP:127.0.0.1\nextendedKeyUsage=serverAuth\n",
    );
    // Mosquitto started as root reads its files as the user `mosquitto`:
    // the throwaway test key is made readable to it.
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(
            dir.join("broker.key"),
            std::fs::Permissions::from_mode(0o644),
        )
        .unwrap();
    }
    let (tls_port, plain_port) = (free_port(), free_port());
    let _broker = two_listeners(
        &dir,
        "per_listener_settings false\nallow_anonymous true\n",
        plain_port,
        &format!(
            "listener {tls_port} 127.0.0.1\ncafile {0}/plant-ca.crt\ncertfile {0}/broker.crt\nkeyfile {0}/broker.key\n",
            dir.display()
        ),
        tls_port,
    );
    let (_client, mut events) = subscriber("scada-tls", plain_port, "spBv1.0/#").await;
    let mqtt = format!("mqtts://127.0.0.1:{tls_port}");
    let start = |ca: &str, edge: &str| {
        let ca = dir.join(ca);
        gateway_process(
            &dir,
            edge,
            "",
            &[
                "--mqtt".as_ref(),
                mqtt.as_ref(),
                "--mqtt-ca".as_ref(),
                ca.as_os_str(),
            ],
        )
    };
    // Signed by the CA it trusts: born over TLS.
    let _good = start("plant-ca.crt", "gw-tls");
    let nbirth = published(
        &mut events,
        Duration::from_secs(10),
        "/NBIRTH/",
        "an NBIRTH over TLS within 10 s",
    )
    .await;
    assert_eq!(nbirth.topic, "spBv1.0/cells/NBIRTH/gw-tls");
    // Trusting another CA: refused at the handshake, nothing published.
    let _bad = start("other-ca.crt", "gw-wrong-ca");
    // Until its log says why it was refused, nothing of it is published.
    nothing_published_until_logged(
        &mut events,
        "gw-wrong-ca",
        &dir.join("gw-wrong-ca.log"),
        "TLS handshake failed",
    )
    .await;
    let _ = std::fs::remove_dir_all(&dir);
}

/// A broker that wants a user name and password: `hans-gateway
/// --mqtt-user U --mqtt-password-file F` logs in and is born; with a wrong
/// password the broker refuses it, nothing is published and the log says
/// so; a password file others may read is refused at start (status 1).
#[tokio::test(flavor = "current_thread")]
async fn a_broker_with_accounts_admits_the_gateway_with_its_password_only() {
    use std::os::unix::fs::PermissionsExt;
    let dir = std::env::temp_dir().join(format!("hans-mqtt-login-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let passwd = dir.join("passwd");
    let ok = Command::new("mosquitto_passwd")
        .args(["-b", "-c"])
        .arg(&passwd)
        .args(["cell-login", "a long broker secret"])
        .status()
        .expect("mosquitto_passwd (Debian's mosquitto package)");
    assert!(ok.success());
    // Read by the broker as the user `mosquitto`.
    std::fs::set_permissions(&passwd, std::fs::Permissions::from_mode(0o644)).unwrap();
    let (auth_port, plain_port) = (free_port(), free_port());
    let _broker = two_listeners(
        &dir,
        "per_listener_settings true\n",
        plain_port,
        &format!(
            "allow_anonymous true\nlistener {auth_port} 127.0.0.1\nallow_anonymous false\npassword_file {}\n",
            passwd.display()
        ),
        auth_port,
    );
    let (_client, mut events) = subscriber("scada-login", plain_port, "spBv1.0/#").await;
    let mqtt = format!("127.0.0.1:{auth_port}");
    let start = |edge: &str, password: &str, mode: u32| {
        let pw = dir.join(format!("{edge}.password"));
        std::fs::write(&pw, format!("{password}\n")).unwrap();
        std::fs::set_permissions(&pw, std::fs::Permissions::from_mode(mode)).unwrap();
        let args = [
            "--mqtt".as_ref(),
            mqtt.as_ref(),
            "--mqtt-user".as_ref(),
            "cell-login".as_ref(),
            "--mqtt-password-file".as_ref(),
            pw.as_os_str(),
        ];
        (
            gateway_process(&dir, edge, "", &args),
            dir.join(format!("{edge}.log")),
        )
    };
    let (_good, _) = start("gw-login", "a long broker secret", 0o600);
    let nbirth = published(
        &mut events,
        Duration::from_secs(10),
        "/NBIRTH/",
        "an NBIRTH after login",
    )
    .await;
    assert_eq!(nbirth.topic, "spBv1.0/cells/NBIRTH/gw-login");

    let (_bad, log) = start("gw-bad-login", "not the secret", 0o600);
    nothing_published_until_logged(&mut events, "gw-bad-login", &log, "refused by the broker")
        .await;

    let (mut open, log) = start("gw-open-file", "a long broker secret", 0o644);
    let status = {
        let end = Instant::now() + Duration::from_secs(10);
        loop {
            if let Some(s) = open.0.try_wait().unwrap() {
                break s;
            }
            assert!(
                Instant::now() < end,
                "a readable password file stops the start"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    };
    assert_eq!(status.code(), Some(1));
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(text.contains("readable by others"), "{text}");
    let _ = std::fs::remove_dir_all(&dir);
}
