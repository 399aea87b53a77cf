//! The client against a fake broker in virtual time: the broker is written
//! here (its framing and payload decoding are the test's own, not the
//! client's `packet` module nor femtopb).

use std::convert::Infallible;
use std::future::Future;
use std::net::{Ipv4Addr, SocketAddrV4};
use std::pin::Pin;
use std::rc::Rc;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::task::Waker;
use std::vec::Vec;

use embassy_time::{Duration, Instant};
use prost::Message as _;

use super::*;
use crate::config::Config;
use crate::net::NetError;
use crate::state::{LinkState, Model};
use crate::testkit::clock::VirtualClock;
use crate::testkit::net::{SimNet, SimStream};
use crate::testkit::world::{poll_until_waiting, Flag, GATEWAY_IP};

const BROKER: SocketAddrV4 = SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, 50), 1883);

#[derive(Clone, PartialEq, prost::Message)]
struct PPayload {
    #[prost(message, repeated, tag = "2")]
    metrics: Vec<PMetric>,
    #[prost(uint64, optional, tag = "3")]
    seq: Option<u64>,
}

#[derive(Clone, PartialEq, prost::Message)]
struct PMetric {
    #[prost(string, optional, tag = "1")]
    name: Option<String>,
    #[prost(uint64, optional, tag = "11")]
    long: Option<u64>,
    #[prost(bool, optional, tag = "14")]
    boolean: Option<bool>,
}

fn bd_seq(payload: &[u8]) -> Option<u64> {
    let p = PPayload::decode(payload).ok()?;
    p.metrics
        .iter()
        .find(|m| m.name.as_deref() == Some("bdSeq"))
        .and_then(|m| m.long)
}

/// A packet as the broker sees it.
#[derive(Debug)]
struct Pkt {
    first: u8,
    body: Vec<u8>,
}

fn mqtt_str(b: &[u8], at: usize) -> (String, usize) {
    let n = usize::from(u16::from_be_bytes([b[at], b[at + 1]]));
    (
        String::from_utf8(b[at + 2..at + 2 + n].to_vec()).unwrap(),
        at + 2 + n,
    )
}

impl Pkt {
    fn publish(&self) -> (String, Vec<u8>) {
        assert_eq!(self.first, 0x30, "PUBLISH QoS 0, not retained");
        let (t, k) = mqtt_str(&self.body, 0);
        (t, self.body[k..].to_vec())
    }
}

/// The fake broker: one connection at a time.
struct Broker {
    net: SimNet,
    conn: Option<SimStream>,
    inbox: Vec<u8>,
}

impl Broker {
    fn accept(&mut self) -> bool {
        self.conn = self.net.accept(BROKER);
        self.inbox.clear();
        self.conn.is_some()
    }

    fn packets(&mut self) -> Vec<Pkt> {
        if let Some(c) = self.conn.as_mut() {
            self.inbox.extend(c.read());
        }
        let mut out = Vec::new();
        loop {
            let (mut n, mut mult, mut i) = (0usize, 1usize, 1usize);
            let done = loop {
                let Some(&b) = self.inbox.get(i) else {
                    break false;
                };
                n += usize::from(b & 0x7f) * mult;
                mult *= 128;
                i += 1;
                if b & 0x80 == 0 {
                    break true;
                }
            };
            if !done || self.inbox.len() < i + n {
                return out;
            }
            out.push(Pkt {
                first: self.inbox[0],
                body: self.inbox[i..i + n].to_vec(),
            });
            self.inbox.drain(..i + n);
        }
    }

    fn send(&mut self, b: &[u8]) {
        self.conn.as_mut().unwrap().write(b);
    }

    fn publish(&mut self, topic: &str, payload: &[u8]) {
        let mut body = Vec::new();
        body.extend((topic.len() as u16).to_be_bytes());
        body.extend(topic.as_bytes());
        body.extend(payload);
        let mut p = vec![0x30];
        let mut n = body.len();
        loop {
            let b = (n % 128) as u8;
            n /= 128;
            p.push(if n > 0 { b | 0x80 } else { b });
            if n == 0 {
                break;
            }
        }
        p.extend(body);
        self.send(&p);
    }
}

struct T {
    clock: Rc<VirtualClock>,
    hub: Rc<Hub>,
    status: Rc<Status>,
    broker: Broker,
    fut: Pin<Box<dyn Future<Output = Infallible>>>,
    flag: Arc<Flag>,
    waker: Waker,
}

fn model() -> Model {
    let mut m = Model::new(Config::default(), Config::default());
    m.link.state = LinkState::Connected;
    m.robot.joints = Some([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    m
}

fn settings(keep_alive: Duration) -> Settings {
    let mut settings = Settings::new(BROKER, NodeConfig::new("Plant A", "cell-7").unwrap());
    settings.keep_alive = keep_alive;
    settings
}

impl T {
    fn new(keep_alive: Duration) -> T {
        T::with(settings(keep_alive))
    }

    /// The client with `settings`.
    fn with(settings: Settings) -> T {
        T::build(model(), move |h, c, n, s| {
            Box::pin(async move { run(&h, &*c, &n, &settings, &s).await })
        })
    }

    /// The gateway's telemetry task ([`serve`]) for a hub with `config`.
    fn serve(config: Config, own_id: &'static str) -> T {
        let mut m = model();
        m.config.active = config;
        T::build(m, move |h, c, n, _| {
            Box::pin(async move { serve(&h, &*c, &n, own_id, "0.1.0-test", None, None).await })
        })
    }

    fn build(
        model: Model,
        fut: impl FnOnce(
            Rc<Hub>,
            Rc<VirtualClock>,
            SimNet,
            Rc<Status>,
        ) -> Pin<Box<dyn Future<Output = Infallible>>>,
    ) -> T {
        let clock = Rc::new(VirtualClock::new());
        let net = SimNet::new(GATEWAY_IP);
        net.listen(BROKER);
        let hub = Rc::new(Hub::new(model));
        let status = Rc::new(Status::new());
        let fut = fut(hub.clone(), clock.clone(), net.clone(), status.clone());
        let flag = Arc::new(Flag(AtomicBool::new(true)));
        let waker = Waker::from(flag.clone());
        T {
            clock,
            hub,
            status,
            broker: Broker {
                net,
                conn: None,
                inbox: Vec::new(),
            },
            fut,
            flag,
            waker,
        }
    }

    fn now(&self) -> Instant {
        crate::clock::Clock::now(&*self.clock)
    }

    /// Runs until `cond` holds, at most `limit`; `true` if it held.
    fn run_until(&mut self, limit: Duration, mut cond: impl FnMut(&mut T) -> bool) -> bool {
        let end = self.now() + limit;
        loop {
            let now = self.now();
            poll_until_waiting(&self.flag, &self.waker, &mut self.fut, 10_000, now);
            if cond(self) {
                return true;
            }
            if now >= end {
                return false;
            }
            let next = self
                .clock
                .next_deadline()
                .filter(|t| *t > now)
                .unwrap_or(end);
            self.clock.advance_to(next.min(end));
        }
    }

    /// Waits for `n` packets from the gateway (within `limit`).
    fn expect(&mut self, n: usize, limit: Duration) -> Vec<Pkt> {
        let mut got = Vec::new();
        let ok = self.run_until(limit, |t| {
            got.extend(t.broker.packets());
            got.len() >= n
        });
        assert!(ok, "{n} packets within {limit:?}, got {got:?}");
        got
    }

    /// Accepts the gateway's connection, checks its CONNECT, answers
    /// CONNACK, reads the SUBSCRIBE and the births; returns the births.
    fn session(&mut self, limit: Duration) -> (u64, Vec<(String, Vec<u8>)>) {
        assert!(
            self.run_until(limit, |t| t.broker.accept()),
            "the gateway connects within {limit:?}"
        );
        let c = self.expect(1, Duration::from_secs(1));
        assert_eq!(c[0].first, 0x10, "CONNECT");
        let b = &c[0].body;
        assert_eq!(&b[..7], b"\0\x04MQTT\x04", "MQTT 3.1.1");
        assert_eq!(b[7], 0x0E, "clean session, a Will of QoS 1, not retained");
        let (id, k) = mqtt_str(b, 10);
        assert_eq!(id, "cell-7");
        let (will_topic, k) = mqtt_str(b, k);
        assert_eq!(will_topic, "spBv1.0/Plant A/NDEATH/cell-7");
        let n = usize::from(u16::from_be_bytes([b[k], b[k + 1]]));
        assert_eq!(k + 2 + n, b.len(), "no user name");
        let will_bd = bd_seq(&b[k + 2..]).expect("the Will is an NDEATH with bdSeq");
        self.broker.send(&[0x20, 2, 0, 0]);
        let p = self.expect(3, Duration::from_secs(1));
        assert_eq!(p[0].first, 0x82, "SUBSCRIBE");
        let (t1, k) = mqtt_str(&p[0].body, 2);
        let (t2, _) = mqtt_str(&p[0].body, k + 1);
        assert_eq!(t1, "spBv1.0/Plant A/NCMD/cell-7");
        assert_eq!(t2, "spBv1.0/Plant A/DCMD/cell-7/robot");
        self.broker.send(&[0x90, 4, 0, 1, 0, 0]);
        let births: Vec<_> = p[1..].iter().map(Pkt::publish).collect();
        assert_eq!(births[0].0, "spBv1.0/Plant A/NBIRTH/cell-7");
        assert_eq!(
            bd_seq(&births[0].1),
            Some(will_bd),
            "the NBIRTH's bdSeq is the Will's"
        );
        assert_eq!(births[1].0, "spBv1.0/Plant A/DBIRTH/cell-7/robot");
        (will_bd, births)
    }
}

const KA: Duration = Duration::from_secs(30);

#[test]
fn connects_with_the_will_publishes_births_then_data_and_answers_a_rebirth() {
    let mut t = T::new(KA);
    let (bd, _) = t.session(Duration::from_secs(1));
    assert_eq!(bd, 0);
    assert!(t.status.get().connected);
    // A robot change: DDATA within 200 ms.
    t.run_until(Duration::from_millis(500), |_| false);
    assert!(
        t.broker.packets().is_empty(),
        "nothing changed, nothing sent"
    );
    t.hub
        .with(|m| m.robot.joints = Some([9.0, 2.0, 3.0, 4.0, 5.0, 6.0]));
    let p = t.expect(1, Duration::from_millis(200));
    let (topic, payload) = p[0].publish();
    assert_eq!(topic, "spBv1.0/Plant A/DDATA/cell-7/robot");
    let names: Vec<_> = PPayload::decode(&payload[..])
        .unwrap()
        .metrics
        .into_iter()
        .filter_map(|m| m.name)
        .collect();
    assert!(names.iter().any(|n| n.contains("J1")), "{names:?}");
    // NCMD rebirth: the births again, same bdSeq.
    let rebirth = PPayload {
        metrics: vec![PMetric {
            name: Some("Node Control/Rebirth".into()),
            long: None,
            boolean: Some(true),
        }],
        seq: None,
    }
    .encode_to_vec();
    t.broker.publish("spBv1.0/Plant A/NCMD/cell-7", &rebirth);
    // Within a second of the births: answered when the second has passed
    // (one birth a second at most).
    let p = t.expect(2, Duration::from_millis(1200));
    let (topic, payload) = p[0].publish();
    assert_eq!(topic, "spBv1.0/Plant A/NBIRTH/cell-7");
    assert_eq!(bd_seq(&payload), Some(0));
    assert_eq!(PPayload::decode(&payload[..]).unwrap().seq, Some(0));
    assert_eq!(p[1].publish().0, "spBv1.0/Plant A/DBIRTH/cell-7/robot");
    assert_eq!(t.status.get().node.rebirths, 1);
    // Another node's NCMD is not ours.
    t.broker.publish("spBv1.0/Plant A/NCMD/cell-8", &rebirth);
    t.run_until(Duration::from_millis(300), |_| false);
    assert!(t.broker.packets().is_empty());
}

#[test]
fn a_packet_longer_than_the_buffer_is_skipped_and_the_connection_stays() {
    let mut t = T::new(KA);
    t.session(Duration::from_secs(1));
    let rebirth = PPayload {
        metrics: vec![PMetric {
            name: Some("Node Control/Rebirth".into()),
            long: None,
            boolean: Some(true),
        }],
        seq: None,
    }
    .encode_to_vec();
    // A long one, in pieces, then a rebirth right behind it.
    let mut big = rebirth.clone();
    big.resize(3 * RX_BUF, 0);
    t.broker.publish("spBv1.0/Plant A/NCMD/cell-7", &big);
    t.broker.publish("spBv1.0/Plant A/NCMD/cell-7", &rebirth);
    let p = t.expect(2, Duration::from_millis(1200));
    assert_eq!(p[0].publish().0, "spBv1.0/Plant A/NBIRTH/cell-7");
    let s = t.status.get();
    assert_eq!((s.skipped, s.connects, s.node.rebirths), (1, 1, 1), "{s:?}");
    assert!(s.connected);
}

#[test]
fn a_closed_connection_reconnects_with_backoff_and_a_new_bd_seq() {
    let mut t = T::new(KA);
    t.session(Duration::from_secs(1));
    // The broker goes away: closed, then refusing.
    t.broker.conn.as_mut().unwrap().close();
    t.broker.net.unlisten(BROKER);
    let lost = t.now();
    let mut tries = Vec::new();
    let mut seen = t.broker.net.attempts(BROKER);
    t.run_until(Duration::from_secs(70), |t| {
        let n = t.broker.net.attempts(BROKER);
        if n > seen {
            seen = n;
            tries.push((t.now() - lost).as_millis());
        }
        false
    });
    assert!(!t.status.get().connected);
    assert_eq!(
        t.status.get().last_error,
        Some(Error::Net(NetError::ConnectFailed))
    );
    // Waits of 1, 2, 4, 8, 16, then 30 s.
    let gaps: Vec<_> = tries.windows(2).map(|w| w[1] - w[0]).collect();
    assert_eq!(tries[0], 1000, "{tries:?}");
    assert_eq!(gaps, [2000, 4000, 8000, 16000, 30000], "{tries:?}");
    // Back: a new session, a new bdSeq, new births.
    t.broker.net.listen(BROKER);
    let (bd, _) = t.session(Duration::from_secs(31));
    assert_eq!(bd, 1);
    assert_eq!(t.status.get().connects, 2);
}

#[test]
fn pings_at_the_keep_alive_and_a_silent_broker_ends_the_connection() {
    let mut t = T::new(Duration::from_secs(4));
    t.session(Duration::from_secs(1));
    let start = t.now();
    let p = t.expect(1, Duration::from_secs(3));
    assert_eq!(p[0].first, 0xC0, "PINGREQ");
    assert_eq!((t.now() - start).as_millis(), 2000, "half the keep-alive");
    t.broker.send(&[0xD0, 0]);
    let p = t.expect(1, Duration::from_secs(3));
    assert_eq!(p[0].first, 0xC0, "PINGREQ again");
    // No PINGRESP: the connection ends within one keep-alive.
    let ok = t.run_until(Duration::from_secs(5), |t| !t.status.get().connected);
    assert!(ok);
    assert_eq!(t.status.get().last_error, Some(Error::Timeout));
    // A refused CONNECT (bad password) is an error too, and backs off.
    assert!(t.run_until(Duration::from_secs(2), |t| t.broker.accept()));
    t.expect(1, Duration::from_secs(1));
    t.broker.send(&[0x20, 2, 0, 5]);
    t.run_until(Duration::from_millis(10), |_| false);
    assert_eq!(t.status.get().last_error, Some(Error::Refused(5)));
}

/// What the broker does in [`plc_view`].
#[derive(Clone, Copy, Debug, PartialEq)]
enum Down {
    /// No MQTT client at all (the reference).
    NoClient,
    /// The broker refuses connections.
    Refusing,
    /// The broker's host never answers.
    Blackhole,
    /// The broker accepts, answers CONNACK, takes the births and closes
    /// after 700 ms, again and again.
    Flapping,
}

/// A gateway, a robot, a PLC and (unless `NoClient`) the MQTT client with
/// a broker that is `down`: what the PLC reads every 100 ms for 60 s (the
/// time of the answer after the request, and the registers).
fn plc_view(down: Down) -> (Vec<(u64, Vec<u16>)>, Stats) {
    use crate::gateway::{Gateway, Options};
    use crate::testkit::plc::{pdu, Answer, Plc};
    use crate::testkit::robot::SimRobot;
    use crate::testkit::world::{MemStorage, MODBUS_PORT, ROBOT_IP, ROBOT_PORT};

    let clock = Rc::new(VirtualClock::new());
    let net = SimNet::new(GATEWAY_IP);
    let mut robot = SimRobot::new(&net, SocketAddrV4::new(ROBOT_IP, ROBOT_PORT), 1);
    let defaults = Config {
        robot_ip: ROBOT_IP,
        robot_port: ROBOT_PORT,
        ..Config::default()
    };
    let gateway = Rc::new(Gateway::new(Options {
        modbus_port: MODBUS_PORT,
        defaults,
        seed: [1; 32],
        ..Default::default()
    }));
    match down {
        Down::Blackhole => net.blackhole(*BROKER.ip(), true),
        Down::Flapping => net.listen(BROKER),
        Down::NoClient | Down::Refusing => {}
    }
    let status = Rc::new(Status::new());
    let settings = Settings::new(BROKER, NodeConfig::new("Plant A", "cell-7").unwrap());
    let (c, n, g, s) = (clock.clone(), net.clone(), gateway.clone(), status.clone());
    let mut fut: Pin<Box<dyn Future<Output = Infallible>>> = Box::pin(async move {
        let client = async {
            if down == Down::NoClient {
                core::future::pending().await
            } else {
                run(g.hub(), &*c, &n, &settings, &s).await
            }
        };
        let (never, _) =
            embassy_futures::join::join(g.run(&n, &*c, MemStorage::default()), client).await;
        never
    });
    let flag = Arc::new(Flag(AtomicBool::new(true)));
    let waker = Waker::from(flag.clone());
    let mut broker = Broker {
        net: net.clone(),
        conn: None,
        inbox: Vec::new(),
    };
    let mut since = Instant::from_ticks(0);
    let mut plc: Option<Plc> = None;
    let mut seen = Vec::new();
    let mut pending: Option<(u16, Instant)> = None;
    let mut next_read = Instant::from_millis(1000);
    let end = Instant::from_secs(60);
    loop {
        let now = crate::clock::Clock::now(&*clock);
        loop {
            poll_until_waiting(&flag, &waker, &mut fut, 100_000, now);
            if !robot.step(now) {
                break;
            }
        }
        if down == Down::Flapping {
            if broker.conn.is_none() && broker.accept() {
                since = now;
            }
            if broker.conn.is_some() {
                for p in broker.packets() {
                    if p.first == 0x10 {
                        broker.send(&[0x20, 2, 0, 0]);
                    }
                }
                if now >= since + Duration::from_millis(700) {
                    broker.conn = None;
                }
            }
        }
        if plc.is_none() {
            plc = net
                .connect(
                    SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, 10), 50000),
                    MODBUS_PORT,
                )
                .map(Plc::new);
        }
        if let (Some(p), Some((tid, sent))) = (plc.as_mut(), pending) {
            if let Some(a) = p.answer(tid) {
                let Answer::Pdu(pdu) = a else {
                    panic!("exception {a:?}");
                };
                seen.push(((now - sent).as_millis(), pdu::registers(&pdu)));
                pending = None;
            }
        }
        if pending.is_none() && now >= next_read {
            if let Some(p) = plc.as_mut() {
                pending = Some((p.send(&pdu::read(0, 32)), now));
                next_read += Duration::from_millis(100);
                flag.0.store(true, std::sync::atomic::Ordering::Relaxed);
                continue;
            }
        }
        if now >= end {
            return (seen, status.get());
        }
        let next = [clock.next_deadline(), robot.next_wakeup(), Some(next_read)]
            .into_iter()
            .flatten()
            .filter(|t| *t > now)
            .min()
            .unwrap_or(end)
            .min(end);
        clock.advance_to(next);
    }
}

#[test]
fn the_plc_sees_the_same_gateway_with_the_broker_down_silent_or_flapping() {
    let (reference, _) = plc_view(Down::NoClient);
    assert!(reference.len() > 500, "{} answers", reference.len());
    for down in [Down::Refusing, Down::Blackhole, Down::Flapping] {
        let (seen, stats) = plc_view(down);
        if down == Down::Flapping {
            assert!(stats.connects >= 3, "{stats:?}");
            assert!(stats.sent >= 6, "births published: {stats:?}");
        } else {
            assert_eq!(stats.connects, 0);
            assert!(stats.failures >= 3, "{stats:?}");
        }
        assert_eq!(seen.len(), reference.len(), "{down:?}");
        for (i, (a, b)) in seen.iter().zip(&reference).enumerate() {
            assert_eq!(a, b, "{down:?}: answer {i} differs");
        }
    }
}

#[test]
fn the_clients_future_is_small_enough_for_a_board() {
    let net = SimNet::new(GATEWAY_IP);
    let clock = VirtualClock::new();
    let hub = Hub::new(model());
    let status = Status::new();
    let settings = Settings::new(BROKER, NodeConfig::new("g", "e").unwrap());
    let fut = run(&hub, &clock, &net, &settings, &status);
    let size = core::mem::size_of_val(&fut);
    std::println!("mqtt::run future: {size} bytes");
    // The buffers (payload, packet, receive, the socket's two) and the
    // edge node's record of what it published.
    assert!(size < 16 * 1024, "{size} bytes");
}

#[test]
fn a_state_payload_says_online_or_offline() {
    assert_eq!(
        host_online_of(br#"{"online" : true, "timestamp" : 1668114759262}"#),
        Some(true)
    );
    assert_eq!(
        host_online_of(br#"{"timestamp":1,"online":false}"#),
        Some(false)
    );
    assert_eq!(host_online_of(br#"{"online":"yes"}"#), None);
    assert_eq!(
        host_online_of(b"ONLINE"),
        None,
        "Sparkplug 2.2's text is not 3.0's"
    );
    assert_eq!(host_online_of(br#"{"online""#), None);
    assert_eq!(host_online_of(b""), None);
}

#[test]
fn with_a_primary_host_the_births_wait_for_its_state_and_its_offline_ends_the_session() {
    let mut s = settings(KA);
    s.primary_host = Some(crate::mqtt::sparkplug::Id::new("scada-1").unwrap());
    let mut t = T::with(s);
    assert!(t.run_until(Duration::from_secs(1), |t| t.broker.accept()));
    let c = t.expect(1, Duration::from_secs(1));
    assert_eq!(c[0].first, 0x10, "CONNECT");
    t.broker.send(&[0x20, 2, 0, 0]);
    let p = t.expect(1, Duration::from_secs(1));
    assert_eq!(p[0].first, 0x82, "SUBSCRIBE");
    let (t1, k) = mqtt_str(&p[0].body, 2);
    let (t2, k) = mqtt_str(&p[0].body, k + 1);
    let (t3, _) = mqtt_str(&p[0].body, k + 1);
    assert_eq!(
        [t1.as_str(), t2.as_str(), t3.as_str()],
        [
            "spBv1.0/Plant A/NCMD/cell-7",
            "spBv1.0/Plant A/DCMD/cell-7/robot",
            "spBv1.0/STATE/scada-1"
        ]
    );
    // No births while the host is not known to be online.
    t.run_until(Duration::from_secs(5), |_| false);
    assert!(
        t.broker.packets().is_empty(),
        "nothing before the host's STATE"
    );
    assert!(t.status.get().waiting_for_host);
    // Another host's STATE is not ours.
    t.broker
        .publish("spBv1.0/STATE/scada-2", br#"{"online":true,"timestamp":1}"#);
    t.run_until(Duration::from_secs(1), |_| false);
    assert!(t.broker.packets().is_empty());
    t.broker
        .publish("spBv1.0/STATE/scada-1", br#"{"online":true,"timestamp":2}"#);
    let p = t.expect(2, Duration::from_millis(200));
    assert_eq!(p[0].publish().0, "spBv1.0/Plant A/NBIRTH/cell-7");
    assert_eq!(p[1].publish().0, "spBv1.0/Plant A/DBIRTH/cell-7/robot");
    assert!(!t.status.get().waiting_for_host);
    // The host goes offline: the session ends (the broker sends the Will).
    t.broker.publish(
        "spBv1.0/STATE/scada-1",
        br#"{"online":false,"timestamp":3}"#,
    );
    assert!(t.run_until(Duration::from_millis(100), |t| !t.status.get().connected));
    assert_eq!(t.status.get().last_error, Some(Error::HostOffline));
    assert!(!t.broker.conn.as_ref().unwrap().is_open());
    // And the next session waits again.
    assert!(t.run_until(Duration::from_secs(2), |t| t.broker.accept()));
    t.expect(1, Duration::from_secs(1));
    t.broker.send(&[0x20, 2, 0, 0]);
    let p = t.expect(1, Duration::from_secs(1));
    assert_eq!(p[0].first, 0x82, "SUBSCRIBE");
    t.run_until(Duration::from_secs(2), |_| false);
    assert!(t.broker.packets().is_empty());
}

fn mqtt_config(enabled: bool, broker: &str) -> Config {
    let mut c = Config::default();
    c.mqtt.enabled = enabled;
    c.mqtt.broker = crate::config::HostName::new(broker).unwrap();
    c.mqtt.port = BROKER.port();
    c.mqtt.group = crate::config::HostName::new("Line2").unwrap();
    c
}

#[test]
fn the_gateways_task_connects_as_the_configuration_says() {
    // Off in the factory state, and off without a broker: no connection.
    for c in [
        Config::default(),
        mqtt_config(false, "10.0.0.50"),
        mqtt_config(true, ""),
    ] {
        let mut t = T::serve(c, "hans-0a0b0c");
        t.run_until(Duration::from_secs(10), |_| false);
        assert_eq!(t.broker.net.attempts(BROKER), 0, "{c:?}");
        assert!(!t.hub.mqtt.get().on);
    }
    // On: the edge node id is the device's own name unless one is set.
    let mut t = T::serve(mqtt_config(true, "10.0.0.50"), "hans-0a0b0c");
    assert!(t.run_until(Duration::from_secs(1), |t| t.broker.accept()));
    let c = t.expect(1, Duration::from_secs(1));
    let (id, k) = mqtt_str(&c[0].body, 10);
    assert_eq!(id, "hans-0a0b0c");
    assert_eq!(
        mqtt_str(&c[0].body, k).0,
        "spBv1.0/Line2/NDEATH/hans-0a0b0c"
    );
    assert!(t.hub.mqtt.get().on);
    let mut c = mqtt_config(true, "10.0.0.50");
    c.mqtt.edge = crate::config::HostName::new("cell-9").unwrap();
    c.mqtt.keep_alive_s = 7;
    let mut t = T::serve(c, "hans-0a0b0c");
    assert!(t.run_until(Duration::from_secs(1), |t| t.broker.accept()));
    let p = t.expect(1, Duration::from_secs(1));
    assert_eq!(
        u16::from_be_bytes([p[0].body[8], p[0].body[9]]),
        7,
        "keep-alive"
    );
    assert_eq!(mqtt_str(&p[0].body, 10).0, "cell-9");
}

#[test]
fn a_broker_name_the_platform_cannot_resolve_is_an_error_retried_with_backoff() {
    // The test network resolves no names (as a board's).
    let mut t = T::serve(mqtt_config(true, "broker.plant"), "gw");
    t.run_until(Duration::from_secs(10), |_| false);
    let s = t.hub.mqtt.get();
    assert!(s.on && !s.connected);
    assert_eq!(s.last_error, Some(Error::Unresolved));
    assert_eq!(s.failures, 4, "tries at 0, 1, 3 and 7 s (then 15 s): {s:?}");
    assert_eq!(t.broker.net.attempts(BROKER), 0);
    // An id Sparkplug refuses is said, not run.
    let mut c = mqtt_config(true, "10.0.0.50");
    c.mqtt.group = crate::config::HostName::new(&"g".repeat(40)).unwrap();
    let mut t = T::serve(c, "gw");
    t.run_until(Duration::from_secs(5), |_| false);
    assert_eq!(t.hub.mqtt.get().last_error, Some(Error::BadId));
    assert_eq!(t.broker.net.attempts(BROKER), 0);
}

#[test]
fn a_change_after_a_quiet_period_goes_out_at_once_and_a_burst_at_most_once_per_period() {
    let mut t = T::new(KA);
    t.session(Duration::from_secs(1));
    t.run_until(Duration::from_millis(537), |_| false);
    assert!(t.broker.packets().is_empty());
    // Quiet for longer than the period: the change goes at the instant it
    // is made, not at the client's next look.
    let changed = t.now();
    t.hub
        .with(|m| m.robot.joints = Some([9.0, 2.0, 3.0, 4.0, 5.0, 6.0]));
    let p = t.expect(1, Duration::from_millis(200));
    assert_eq!(p[0].publish().0, "spBv1.0/Plant A/DDATA/cell-7/robot");
    assert_eq!(t.now(), changed, "published at the change");
    // A second change right after: held to the period (100 ms).
    t.hub
        .with(|m| m.robot.joints = Some([19.0, 2.0, 3.0, 4.0, 5.0, 6.0]));
    let p = t.expect(1, Duration::from_millis(200));
    assert_eq!(p[0].publish().0, "spBv1.0/Plant A/DDATA/cell-7/robot");
    assert_eq!((t.now() - changed).as_millis(), 100, "one round per period");
}
