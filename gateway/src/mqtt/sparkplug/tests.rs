//! The publishing rules in virtual time, with every payload decoded by an
//! independent decoder: prost, with the Sparkplug B messages written here
//! from the specification (field numbers and types), not femtopb's structs.

use embassy_time::{Duration, Instant};
use prost::Message as _;

use super::metrics::{Val, ValueField};
use super::*;
use crate::config::Config;
use crate::error::{ErrorSource, GatewayError};
use crate::job::Source;
use crate::state::history::LOG_LEN;
use crate::state::{Io, LinkState, RobotFlags, TextSource};

/// `Payload`, from the specification.
#[derive(Clone, PartialEq, prost::Message)]
struct PPayload {
    #[prost(uint64, optional, tag = "1")]
    timestamp: Option<u64>,
    #[prost(message, repeated, tag = "2")]
    metrics: Vec<PMetric>,
    #[prost(uint64, optional, tag = "3")]
    seq: Option<u64>,
    #[prost(string, optional, tag = "4")]
    uuid: Option<String>,
    #[prost(bytes = "vec", optional, tag = "5")]
    body: Option<Vec<u8>>,
}

/// `Payload.Metric`, from the specification.
#[derive(Clone, PartialEq, prost::Message)]
struct PMetric {
    #[prost(string, optional, tag = "1")]
    name: Option<String>,
    #[prost(uint64, optional, tag = "2")]
    alias: Option<u64>,
    #[prost(uint64, optional, tag = "3")]
    timestamp: Option<u64>,
    #[prost(uint32, optional, tag = "4")]
    datatype: Option<u32>,
    #[prost(bool, optional, tag = "5")]
    is_historical: Option<bool>,
    #[prost(bool, optional, tag = "6")]
    is_transient: Option<bool>,
    #[prost(bool, optional, tag = "7")]
    is_null: Option<bool>,
    #[prost(oneof = "PValue", tags = "10, 11, 12, 13, 14, 15, 16")]
    value: Option<PValue>,
}

/// `Payload.Metric.value`.
#[derive(Clone, PartialEq, prost::Oneof)]
enum PValue {
    #[prost(uint32, tag = "10")]
    Int(u32),
    #[prost(uint64, tag = "11")]
    Long(u64),
    #[prost(float, tag = "12")]
    Float(f32),
    #[prost(double, tag = "13")]
    Double(f64),
    #[prost(bool, tag = "14")]
    Boolean(bool),
    #[prost(string, tag = "15")]
    String(String),
    #[prost(bytes = "vec", tag = "16")]
    Bytes(Vec<u8>),
}

fn t(ms: u64) -> Instant {
    Instant::from_millis(ms)
}

/// 2026-01-01 00:00:00 UTC.
const UTC: u64 = 1_767_225_600_000;

fn model() -> Model {
    let mut m = Model::new(Config::default(), Config::default());
    m.link.state = LinkState::Connected;
    m.link.connects = 1;
    m.robot.fsm = Some(hans_codec::FsmState::StandBy);
    m.robot.flags = Some(RobotFlags {
        enabled: true,
        powered: true,
        ..RobotFlags::default()
    });
    m.robot.joints = Some([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    m.robot.pose = Some([420.0, 0.0, 445.0, 180.0, 0.0, 180.0]);
    m.robot.io[Io::BoxDo as usize] = Some(0b1001);
    m
}

fn node() -> EdgeNode {
    let mut n = EdgeNode::new(NodeConfig::new("Plant A", "cell-7").unwrap());
    n.set_wall_time(t(0), UTC);
    n
}

struct Msg {
    ty: MessageType,
    topic: String,
    p: PPayload,
}

fn decode(p: Publish<'_>) -> Msg {
    Msg {
        ty: p.ty,
        topic: p.topic.as_str().to_string(),
        p: PPayload::decode(p.payload).expect("a Sparkplug payload"),
    }
}

/// Every message `poll` has at `now`.
fn drain(n: &mut EdgeNode, now: Instant, m: &Model) -> Vec<Msg> {
    drain_with(n, now, m, PAYLOAD_BUF)
}

fn drain_with(n: &mut EdgeNode, now: Instant, m: &Model, size: usize) -> Vec<Msg> {
    let mut out = Vec::new();
    let mut buf = vec![0u8; size];
    while let Some(p) = n.poll(now, m, &mut buf).unwrap() {
        out.push(decode(p));
        assert!(out.len() < 1000, "poll never ends");
    }
    out
}

/// Connected and born at `now`: the births.
fn born(n: &mut EdgeNode, now: Instant, m: &Model) -> Vec<Msg> {
    let mut buf = [0u8; 64];
    n.connect(now, &mut buf).unwrap();
    drain(n, now, m)
}

fn get<'a>(msg: &'a Msg, name: &str) -> &'a PMetric {
    msg.p
        .metrics
        .iter()
        .rev()
        .find(|x| x.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no {name} in {:?}", msg.ty))
}

fn names(msg: &Msg) -> Vec<&str> {
    msg.p
        .metrics
        .iter()
        .filter_map(|x| x.name.as_deref())
        .collect()
}

fn expected(scope: Scope) -> Vec<String> {
    metrics::all()
        .filter(|x| x.def.scope == scope)
        .map(|x| x.name().to_string())
        .collect()
}

/// The value field a datatype travels in (the specification's table).
fn fits(dt: u32, v: &PValue) -> bool {
    matches!(
        (dt, v),
        (1..=3 | 5..=7, PValue::Int(_))
            | (4 | 8 | 13, PValue::Long(_))
            | (9, PValue::Float(_))
            | (10, PValue::Double(_))
            | (11, PValue::Boolean(_))
            | (12 | 14, PValue::String(_))
    )
}

fn check_birth(msg: &Msg, scope: Scope, ts: u64) {
    assert_eq!(names(msg), expected(scope), "every metric, in table order");
    assert_eq!(msg.p.timestamp, Some(ts));
    let rows = metrics::all().filter(|x| x.def.scope == scope);
    for (x, row) in msg.p.metrics.iter().zip(rows) {
        let name = x.name.as_deref().unwrap();
        assert_eq!(x.datatype, Some(row.def.datatype.code()), "{name}");
        assert_eq!(x.timestamp, Some(ts), "{name}");
        assert_eq!(x.alias, None, "{name}");
        match (&x.value, x.is_null) {
            (Some(v), None) => assert!(fits(row.def.datatype.code(), v), "{name}: {v:?}"),
            (None, Some(true)) => {}
            other => panic!("{name}: value and null: {other:?}"),
        }
    }
}

#[test]
fn births_carry_every_metric_with_its_datatype_and_value() {
    let mut m = model();
    m.start(Source::Channel(0), 1, 12, t(10));
    m.note_send(Source::Channel(0), b"MoveL,0,1,2,3,;");
    m.finish(Source::Channel(0), Outcome::Done, t(260));
    let mut n = node();
    let mut buf = [0u8; 64];
    let will = decode(n.connect(t(1000), &mut buf).unwrap());
    assert_eq!(will.ty, MessageType::NDeath);
    assert_eq!(will.topic, "spBv1.0/Plant A/NDEATH/cell-7");
    assert_eq!(will.p.seq, None, "NDEATH has no seq");
    // tck-id-message-flow-edge-node-birth-publish-will-message-payload-bdSeq:
    // INT64.
    assert_eq!(get(&will, "bdSeq").value, Some(PValue::Long(0)));
    assert_eq!(get(&will, "bdSeq").datatype, Some(4));

    let msgs = drain(&mut n, t(1000), &m);
    assert_eq!(msgs.len(), 2, "NBIRTH, DBIRTH, nothing else");
    let (nb, db) = (&msgs[0], &msgs[1]);
    assert_eq!(
        (nb.ty, nb.topic.as_str()),
        (MessageType::NBirth, "spBv1.0/Plant A/NBIRTH/cell-7")
    );
    assert_eq!(
        (db.ty, db.topic.as_str()),
        (MessageType::DBirth, "spBv1.0/Plant A/DBIRTH/cell-7/robot")
    );
    assert_eq!((nb.p.seq, db.p.seq), (Some(0), Some(1)));
    check_birth(nb, Scope::Node, UTC + 1000);
    check_birth(db, Scope::Device, UTC + 1000);

    // Values read from the state.
    let v = |msg, name| get(msg, name).value.clone();
    assert_eq!(v(nb, "bdSeq"), Some(PValue::Long(0)));
    assert_eq!(get(nb, "bdSeq").datatype, Some(4), "INT64, as in the Will");
    assert_eq!(v(nb, "Node Control/Rebirth"), Some(PValue::Boolean(false)));
    assert_eq!(
        v(nb, "Gateway/Version"),
        Some(PValue::String(env!("CARGO_PKG_VERSION").into()))
    );
    assert_eq!(
        v(nb, "Gateway/Map Version"),
        Some(PValue::String("1.5".into()))
    );
    assert_eq!(v(nb, "Gateway/Uptime"), Some(PValue::Int(1)));
    assert_eq!(
        v(nb, "Link/State"),
        Some(PValue::String("connected".into()))
    );
    assert_eq!(get(nb, "Link/Last Error").is_null, Some(true));
    assert_eq!(
        v(nb, "Channel 0/Phase"),
        Some(PValue::String("done".into()))
    );
    assert_eq!(
        v(nb, "Channel 0/Last Outcome"),
        Some(PValue::String("done".into()))
    );
    assert_eq!(get(nb, "Trigger 15/Last Outcome").is_null, Some(true));
    assert_eq!(
        v(nb, "Last Command/Source"),
        Some(PValue::String("Channel 0".into()))
    );
    assert_eq!(v(nb, "Last Command/Code"), Some(PValue::Int(12)));
    assert_eq!(
        v(nb, "Last Command/Text"),
        Some(PValue::String("MoveL,0,1,2,3,;".into()))
    );
    assert_eq!(v(nb, "Last Command/Duration"), Some(PValue::Int(250)));
    assert_eq!(v(db, "FSM/Code"), Some(PValue::Int(33)));
    assert_eq!(v(db, "FSM/Name"), Some(PValue::String("StandBy".into())));
    assert_eq!(v(db, "Flags/Enabled"), Some(PValue::Boolean(true)));
    assert_eq!(v(db, "Flags/Moving"), Some(PValue::Boolean(false)));
    assert_eq!(v(db, "Joints/J3"), Some(PValue::Float(3.0)));
    assert_eq!(v(db, "Pose/Z"), Some(PValue::Float(445.0)));
    assert_eq!(v(db, "IO/Box DO"), Some(PValue::Int(0b1001)));
    assert_eq!(get(db, "IO/Box DI").is_null, Some(true));
    assert_eq!(get(db, "Override").is_null, Some(true));
    assert_eq!(get(db, "Error/Text").is_null, Some(true));
}

/// Issue 27: `Gateway/Version` was the software's also on a board whose
/// update had installed another image version (the page's Firmware said
/// 0.2.0, the metric 0.1.0). Where an image runs, it is the image's, the
/// longest one fits; without one, the software's (above).
#[test]
fn the_version_metric_is_the_running_images_where_one_runs() {
    for (running, text) in [
        (
            crate::state::firmware::Version {
                major: 0,
                minor: 2,
                patch: 0,
            },
            "0.2.0",
        ),
        (
            crate::state::firmware::Version {
                major: 65535,
                minor: 65535,
                patch: 65535,
            },
            "65535.65535.65535",
        ),
    ] {
        let mut m = model();
        m.firmware.running = Some(running);
        let msgs = born(&mut node(), t(1000), &m);
        assert_eq!(
            get(&msgs[0], "Gateway/Version").value,
            Some(PValue::String(text.into()))
        );
    }
}

#[test]
fn signed_values_and_errors_travel_as_the_specification_says() {
    let mut m = model();
    m.robot.error_code = 10001;
    m.error_text
        .set(10001, TextSource::Controller, b"joint 3 over limit");
    m.link.last_error = Some(GatewayError::ReplyTimeout);
    m.start(Source::Trigger(3), 2, 0, t(0));
    m.finish(
        Source::Trigger(3),
        Outcome::Error(ErrorSource::Gateway, -5),
        t(5),
    );
    let mut n = node();
    let msgs = born(&mut n, t(100), &m);
    let (nb, db) = (&msgs[0], &msgs[1]);
    // Int32 -5 in int_value: its two's complement.
    assert_eq!(
        get(nb, "Trigger 3/Last Error Id").value,
        Some(PValue::Int(-5i32 as u32))
    );
    assert_eq!(
        get(nb, "Last Command/Error Source").value,
        Some(PValue::Int(3))
    );
    assert_eq!(
        get(nb, "Last Command/Result").value,
        Some(PValue::String("error".into()))
    );
    assert_eq!(
        get(nb, "Link/Last Error Code").value,
        Some(PValue::Int(39503))
    );
    assert_eq!(
        get(nb, "Link/Last Error").value,
        Some(PValue::String("reply timeout".into()))
    );
    assert_eq!(get(db, "Error/Code").value, Some(PValue::Int(10001)));
    assert_eq!(
        get(db, "Error/Text").value,
        Some(PValue::String("joint 3 over limit".into()))
    );
}

#[test]
fn data_is_published_by_exception_with_deadbands() {
    let mut m = model();
    let mut cfg = NodeConfig::new("g", "e").unwrap();
    cfg.pose_deadband = 1.0;
    let mut n = EdgeNode::new(cfg);
    born(&mut n, t(0), &m);
    assert!(drain(&mut n, t(0), &m).is_empty(), "nothing changed");

    // Below the joints' default deadband (0.1): nothing.
    m.robot.joints = Some([1.05, 2.0, 3.0, 4.0, 5.0, 6.0]);
    assert!(drain(&mut n, t(1000), &m).is_empty());
    // 0.1 from the value last published (1.0), not from the last seen.
    m.robot.joints = Some([1.1, 2.0, 3.0, 4.0, 5.0, 5.95]);
    let msgs = drain(&mut n, t(2000), &m);
    assert_eq!(msgs.len(), 1);
    assert_eq!(msgs[0].ty, MessageType::DData);
    assert_eq!(msgs[0].topic, "spBv1.0/g/DDATA/e/robot");
    assert_eq!(names(&msgs[0]), ["Joints/J1"]);
    assert_eq!(get(&msgs[0], "Joints/J1").value, Some(PValue::Float(1.1)));
    assert_eq!(get(&msgs[0], "Joints/J1").timestamp, Some(2000));

    // The pose's deadband is configured to 1 mm.
    m.robot.pose = Some([420.9, 0.0, 445.0, 180.0, 0.0, 180.0]);
    assert!(drain(&mut n, t(3000), &m).is_empty());
    m.robot.pose = Some([421.0, 0.0, 445.0, 180.0, 0.0, 180.0]);
    assert_eq!(names(&drain(&mut n, t(4000), &m)[0]), ["Pose/X"]);

    // Any change of a boolean, an integer, a string; null and back.
    m.robot.flags = Some(RobotFlags {
        moving: true,
        ..m.robot.flags.unwrap()
    });
    m.robot.io[Io::BoxDi as usize] = Some(1);
    m.robot.fsm = None;
    let msgs = drain(&mut n, t(5000), &m);
    assert_eq!(
        names(&msgs[0]),
        ["FSM/Code", "FSM/Name", "Flags/Moving", "IO/Box DI"]
    );
    assert_eq!(get(&msgs[0], "FSM/Code").is_null, Some(true));
    assert_eq!(get(&msgs[0], "FSM/Code").value, None);
    assert_eq!(get(&msgs[0], "FSM/Code").datatype, Some(3));

    // Node metrics go in NDATA; the uptime every 10 s.
    m.sessions = 2;
    let msgs = drain(&mut n, t(9_000), &m);
    assert_eq!(msgs.len(), 1);
    assert_eq!(
        (msgs[0].ty, names(&msgs[0])),
        (MessageType::NData, vec!["Modbus/Sessions"])
    );
    assert_eq!(msgs[0].topic, "spBv1.0/g/NDATA/e");
    let msgs = drain(&mut n, t(10_000), &m);
    assert_eq!(names(&msgs[0]), ["Gateway/Uptime"]);
    assert_eq!(get(&msgs[0], "Gateway/Uptime").value, Some(PValue::Int(10)));
}

#[test]
fn data_goes_at_most_once_per_period() {
    let mut m = model();
    let mut n = node();
    born(&mut n, t(0), &m);
    // A change after a quiet time goes at once.
    m.sessions = 1;
    assert_eq!(drain(&mut n, t(1000), &m).len(), 1);
    // The next one waits for the period (100 ms) from that round.
    m.sessions = 2;
    assert!(drain(&mut n, t(1050), &m).is_empty());
    assert!(drain(&mut n, t(1099), &m).is_empty());
    assert_eq!(n.next_round(), t(1100));
    let msgs = drain(&mut n, t(1100), &m);
    assert_eq!(get(&msgs[0], "Modbus/Sessions").value, Some(PValue::Int(2)));
    // A round with node and robot changes: NDATA then DDATA, one round.
    m.sessions = 3;
    m.robot.error_axis = 4;
    let msgs = drain(&mut n, t(1200), &m);
    let tys: Vec<_> = msgs.iter().map(|x| x.ty).collect();
    assert_eq!(tys, [MessageType::NData, MessageType::DData]);
    // With a period of 1 s.
    let mut cfg = NodeConfig::new("g", "e").unwrap();
    cfg.period = Duration::from_secs(1);
    let mut n = EdgeNode::new(cfg);
    born(&mut n, t(0), &m);
    m.sessions = 4;
    assert_eq!(drain(&mut n, t(10), &m).len(), 1);
    m.sessions = 5;
    assert!(drain(&mut n, t(1009), &m).is_empty());
    assert_eq!(drain(&mut n, t(1010), &m).len(), 1);
}

#[test]
fn seq_counts_every_message_and_wraps_after_255() {
    let mut m = model();
    let mut n = node();
    let mut seqs: Vec<u64> = born(&mut n, t(0), &m)
        .iter()
        .map(|x| x.p.seq.unwrap())
        .collect();
    let mut now = 0;
    for i in 0..600u16 {
        now += 100;
        m.sessions = i;
        // Now and then the link drops and comes back: DDEATH, DBIRTH.
        if i % 97 == 0 {
            m.link.state = LinkState::Down;
        } else {
            m.link.state = LinkState::Connected;
        }
        for msg in drain(&mut n, t(now), &m) {
            seqs.push(msg.p.seq.expect("every message after NBIRTH has a seq"));
        }
    }
    assert!(seqs.len() > 600);
    for (k, pair) in seqs.windows(2).enumerate() {
        assert_eq!(pair[1], (pair[0] + 1) % 256, "message {k}");
    }
    assert!(seqs.iter().all(|s| *s <= 255));
}

#[test]
fn the_robot_is_a_device_alive_while_the_link_is_up() {
    let mut m = model();
    let mut n = node();
    born(&mut n, t(0), &m);
    m.link.state = LinkState::Down;
    m.link.losses = 1;
    m.robot.invalidate();
    let msgs = drain(&mut n, t(500), &m);
    let tys: Vec<_> = msgs.iter().map(|x| x.ty).collect();
    assert_eq!(tys, [MessageType::DDeath, MessageType::NData]);
    assert_eq!(msgs[0].topic, "spBv1.0/Plant A/DDEATH/cell-7/robot");
    assert!(msgs[0].p.metrics.is_empty());
    assert_eq!(msgs[0].p.timestamp, Some(UTC + 500));
    assert_eq!(names(&msgs[1]), ["Link/State", "Link/Losses"]);
    // While dead, no DDATA.
    m.robot.error_axis = 2;
    assert!(drain(&mut n, t(1000), &m).is_empty());
    // Up again: a DBIRTH with the robot's current values.
    m.link.state = LinkState::Connected;
    m.robot.joints = Some([9.0; 6]);
    let msgs = drain(&mut n, t(2000), &m);
    let tys: Vec<_> = msgs.iter().map(|x| x.ty).collect();
    assert_eq!(tys, [MessageType::DBirth, MessageType::NData]);
    check_birth(&msgs[0], Scope::Device, UTC + 2000);
    assert_eq!(get(&msgs[0], "Joints/J6").value, Some(PValue::Float(9.0)));
    assert_eq!(get(&msgs[0], "Error/Axis").value, Some(PValue::Int(2)));
}

/// The value field each reader takes an integer datatype from, as their
/// code reads (checked 2026-11-29): `(specification, Tahu Java, Tahu
/// JavaScript)`, `true` for `long_value`, `false` for `int_value`, both
/// where a reader takes either. The specification: its datatype table
/// (Sparkplug 3.0, "Datatype Details": Int8-Int32, UInt8-UInt32 in uint32,
/// Int64, UInt64 in uint64, DateTime in uint64). Tahu Java's
/// `SparkplugBPayloadDecoder.getMetricValue`: UInt32 from `int_value` if
/// present, else `long_value`. Tahu JavaScript's `getValue` (npm
/// `sparkplug-payload` 1.0.3, which Node-RED's nodes use): UInt32 from
/// `longValue` only.
fn readers(dt: DataType) -> [&'static [bool]; 3] {
    use DataType as T;
    const INT: &[bool] = &[false];
    const LONG: &[bool] = &[true];
    const EITHER: &[bool] = &[false, true];
    match dt {
        T::Int8 | T::Int16 | T::Int32 | T::UInt8 | T::UInt16 => [INT, INT, INT],
        T::UInt32 => [INT, EITHER, LONG],
        T::Int64 | T::UInt64 | T::DateTime => [LONG, LONG, LONG],
        _ => [&[], &[], &[]],
    }
}

#[test]
fn integers_travel_where_the_specification_and_tahus_decoders_agree() {
    use DataType as T;
    let ints = [
        T::Int8,
        T::Int16,
        T::Int32,
        T::Int64,
        T::UInt8,
        T::UInt16,
        T::UInt32,
        T::UInt64,
        T::DateTime,
    ];
    let agreed = |dt: DataType| {
        let long = dt.field() == ValueField::Long;
        readers(dt).iter().all(|r| r.contains(&long))
    };
    // The one datatype they read from different fields.
    assert_eq!(
        ints.iter().filter(|dt| !agreed(**dt)).collect::<Vec<_>>(),
        [&T::UInt32]
    );
    for def in TABLE {
        if ints.contains(&def.datatype) {
            assert!(
                agreed(def.datatype),
                "{}: {} is read from different fields by the specification and Tahu",
                def.name,
                def.datatype.name()
            );
        }
    }
    // What goes out for each row is the field of its datatype, with the
    // value: read every metric of both births from the wire.
    let mut m = model();
    m.start(Source::Channel(0), 1, 12, t(10));
    m.finish(
        Source::Channel(0),
        Outcome::Error(ErrorSource::RobotMotion, -7),
        t(3000),
    );
    let msgs = born(&mut node(), t(5_000), &m);
    for msg in &msgs[..2] {
        for x in &msg.p.metrics {
            let name = x.name.clone().unwrap();
            if let Some(v) = &x.value {
                let dt = x.datatype.unwrap();
                assert!(fits(dt, v), "{name}: {v:?}");
                assert_ne!(dt, 7, "{name}: UInt32");
            }
        }
    }
    assert_eq!(
        get(&msgs[0], "Last Command/Duration").value,
        Some(PValue::Int(2990))
    );
    assert_eq!(
        get(&msgs[0], "Last Command/Error Id").value,
        Some(PValue::Int(-7i32 as u32))
    );
    assert_eq!(get(&msgs[0], "Gateway/Uptime").value, Some(PValue::Int(5)));
}

#[test]
fn a_value_outside_its_datatype_goes_out_null_never_wrong() {
    use payload::{wire, Wire};
    use DataType as T;
    assert_eq!(wire(T::Int8, &Val::I32(-1)), Wire::Int(u32::MAX));
    assert_eq!(wire(T::Int8, &Val::I32(200)), Wire::Null);
    assert_eq!(wire(T::UInt8, &Val::U32(255)), Wire::Int(255));
    assert_eq!(wire(T::UInt16, &Val::I32(-1)), Wire::Null);
    assert_eq!(wire(T::Int32, &Val::I64(1 << 40)), Wire::Null);
    assert_eq!(wire(T::Int64, &Val::I64(-2)), Wire::Long(-2i64 as u64));
    assert_eq!(wire(T::UInt64, &Val::I64(-2)), Wire::Null);
    assert_eq!(wire(T::UInt64, &Val::U32(7)), Wire::Long(7));
    assert_eq!(wire(T::String, &Val::I32(1)), Wire::Null);
    assert_eq!(wire(T::Boolean, &Val::Str("true")), Wire::Null);
    assert_eq!(wire(T::Float, &Val::F32(0.5)), Wire::Float(0.5));
}

#[test]
fn the_version_is_the_running_images_else_the_platforms() {
    let mut m = model();
    let mut cfg = NodeConfig::new("Plant A", "cell-7").unwrap();
    cfg.version = "2.5.1";
    let mut n = EdgeNode::new(cfg);
    n.set_wall_time(t(0), UTC);
    let msgs = born(&mut n, t(100), &m);
    assert_eq!(
        get(&msgs[0], "Gateway/Version").value,
        Some(PValue::String("2.5.1".into())),
        "no image: the platform's program (Linux: its package's version)"
    );
    // The slots read after the birth: the image's version follows in NDATA.
    m.firmware.running = Some(crate::state::firmware::Version {
        major: 0,
        minor: 2,
        patch: 0,
    });
    let msgs = drain(&mut n, t(200), &m);
    assert_eq!(msgs.len(), 1);
    assert_eq!(msgs[0].ty, MessageType::NData);
    assert_eq!(names(&msgs[0]), ["Gateway/Version"]);
    assert_eq!(
        get(&msgs[0], "Gateway/Version").value,
        Some(PValue::String("0.2.0".into()))
    );
    // And in every later birth.
    n.disconnect();
    let msgs = born(&mut n, t(300), &m);
    assert_eq!(
        get(&msgs[0], "Gateway/Version").value,
        Some(PValue::String("0.2.0".into()))
    );
}

#[test]
fn bd_seq_is_the_same_in_a_sessions_ndeath_and_nbirth_and_counts_sessions() {
    let m = model();
    let mut n = node();
    let mut buf = [0u8; 64];
    for session in 0..260u32 {
        let will = decode(n.connect(t(0), &mut buf).unwrap());
        let msgs = drain(&mut n, t(0), &m);
        let bd = u64::from(session % 256);
        assert_eq!(get(&will, "bdSeq").value, Some(PValue::Long(bd)));
        assert_eq!(get(&msgs[0], "bdSeq").value, Some(PValue::Long(bd)));
        assert_eq!(msgs[0].p.seq, Some(0));
        n.disconnect();
        assert!(drain(&mut n, t(0), &m).is_empty(), "offline: nothing");
    }
    // A buffer too small for the Will: an error, and the session count
    // does not move.
    let bd = n.bd_seq();
    assert!(matches!(
        n.connect(t(0), &mut buf[..10]),
        Err(Error::TooSmall { .. })
    ));
    assert_eq!(n.bd_seq(), bd);
}

/// An NCMD written by the test's own encoder (prost).
fn ncmd(metrics: Vec<PMetric>) -> Vec<u8> {
    PPayload {
        timestamp: Some(UTC),
        metrics,
        ..PPayload::default()
    }
    .encode_to_vec()
}

fn write(name: &str, value: PValue) -> PMetric {
    PMetric {
        name: Some(name.into()),
        value: Some(value),
        ..PMetric::default()
    }
}

#[test]
fn a_rebirth_request_republishes_the_births_in_the_same_session() {
    let mut m = model();
    let mut n = node();
    born(&mut n, t(0), &m);
    m.sessions = 1;
    drain(&mut n, t(100), &m);
    let topic = n.topic(MessageType::NCmd);
    assert_eq!(topic.as_str(), "spBv1.0/Plant A/NCMD/cell-7");
    assert_eq!(n.inbound(&topic), Some(MessageType::NCmd));
    let payload = ncmd(vec![write("Node Control/Rebirth", PValue::Boolean(true))]);
    let s = n.command(MessageType::NCmd, &payload).unwrap();
    assert_eq!(
        s,
        CommandSummary {
            rebirth: true,
            refused: 0
        }
    );
    // Within a second of the session's births: answered once it has
    // passed (the node asks to be polled then).
    assert!(drain(&mut n, t(200), &m).is_empty());
    assert!(n.next_round() <= t(0) + REBIRTH_MIN);
    let msgs = drain(&mut n, t(1000), &m);
    let tys: Vec<_> = msgs.iter().map(|x| (x.ty, x.p.seq)).collect();
    assert_eq!(
        tys,
        [
            (MessageType::NBirth, Some(0)),
            (MessageType::DBirth, Some(1))
        ]
    );
    assert_eq!(
        get(&msgs[0], "bdSeq").value,
        Some(PValue::Long(0)),
        "same session"
    );
    assert_eq!(get(&msgs[0], "Modbus/Sessions").value, Some(PValue::Int(1)));
    assert_eq!(n.stats().rebirths, 1);
    // Offline, a rebirth request changes nothing.
    n.disconnect();
    n.command(MessageType::NCmd, &payload).unwrap();
    assert!(drain(&mut n, t(300), &m).is_empty());
}

/// Issue 25: an NCMD rebirth flood made the gateway publish ~25 birth
/// pairs a second. At most one birth a second, whatever comes; none is
/// lost (the last request of a second is answered).
#[test]
fn rebirth_requests_make_one_birth_a_second_at_most() {
    let mut m = model();
    m.sessions = 1;
    let mut n = node();
    born(&mut n, t(0), &m);
    let payload = ncmd(vec![write("Node Control/Rebirth", PValue::Boolean(true))]);
    let mut births = Vec::new();
    // 25 requests a second for 5 s, the node polled after each.
    for k in 1..=125u64 {
        let now = t(40 * k);
        n.command(MessageType::NCmd, &payload).unwrap();
        for msg in drain(&mut n, now, &m) {
            if msg.ty == MessageType::NBirth {
                births.push(now);
            }
        }
    }
    assert!(
        births.len() <= 5,
        "{} births in 5 s: {births:?}",
        births.len()
    );
    for w in births.windows(2) {
        assert!(w[1] - w[0] >= REBIRTH_MIN, "{births:?}");
    }
    // One more request right after the last birth: answered a second
    // after it, not lost.
    let last = *births.last().unwrap();
    n.command(MessageType::NCmd, &payload).unwrap();
    let due = last + REBIRTH_MIN;
    assert!(n.next_round() <= due, "polled in time");
    assert!(drain(&mut n, due - Duration::from_millis(1), &m).is_empty());
    let msgs = drain(&mut n, due, &m);
    assert_eq!(msgs.first().map(|x| x.ty), Some(MessageType::NBirth));
    assert_eq!(u64::from(n.stats().rebirths), births.len() as u64 + 1);
}

#[test]
fn mqtt_never_moves_the_robot_every_other_write_is_refused_and_counted() {
    let m = model();
    let mut n = node();
    born(&mut n, t(0), &m);
    let payload = ncmd(vec![
        write("Node Control/Rebirth", PValue::Boolean(false)),
        write("Joints/J1", PValue::Float(90.0)),
        write("Channel 0/Phase", PValue::String("running".into())),
        PMetric {
            alias: Some(1),
            value: Some(PValue::Boolean(true)),
            ..PMetric::default()
        },
    ]);
    let s = n.command(MessageType::NCmd, &payload).unwrap();
    assert_eq!(
        s,
        CommandSummary {
            rebirth: false,
            refused: 4
        }
    );
    // A DCMD is refused whole, a rebirth in it too.
    let dcmd_topic = n.topic(MessageType::DCmd);
    assert_eq!(dcmd_topic.as_str(), "spBv1.0/Plant A/DCMD/cell-7/robot");
    assert_eq!(n.inbound(&dcmd_topic), Some(MessageType::DCmd));
    let payload = ncmd(vec![
        write("Node Control/Rebirth", PValue::Boolean(true)),
        write("Flags/Enabled", PValue::Boolean(true)),
    ]);
    let s = n.command(MessageType::DCmd, &payload).unwrap();
    assert_eq!(
        s,
        CommandSummary {
            rebirth: false,
            refused: 2
        }
    );
    // Garbage is counted, not obeyed.
    assert_eq!(n.command(MessageType::NCmd, &[0x12, 0xff]), Err(Malformed));
    assert_eq!((n.stats().refused, n.stats().malformed), (6, 1));
    // No birth came of it; the refusals are a node metric.
    let msgs = drain(&mut n, t(100), &m);
    assert_eq!(msgs.len(), 1);
    assert_eq!(names(&msgs[0]), ["MQTT/Writes Refused"]);
    assert_eq!(
        get(&msgs[0], "MQTT/Writes Refused").value,
        Some(PValue::Int(6))
    );
    // Topics of others are not ours.
    for other in [
        "spBv1.0/Plant A/NCMD/cell-8",
        "spBv1.0/Plant B/NCMD/cell-7",
        "spBv1.0/Plant A/DCMD/cell-7/other",
        "spBv1.0/Plant A/NCMD/cell-7/robot",
        "spBv1.0/Plant A/NDATA/cell-7",
        "spBv1.0/STATE/host",
    ] {
        assert_eq!(n.inbound(other), None, "{other}");
    }
}

/// The command events of `msg`: (source, result, error id, duration, ts).
fn events(msg: &Msg) -> Vec<(String, String, u32, u32, u64)> {
    let of = |name: &'static str| {
        msg.p
            .metrics
            .iter()
            .filter(move |x| x.name.as_deref() == Some(name))
            .cloned()
    };
    let text = |x: PMetric| match x.value {
        Some(PValue::String(s)) => s,
        other => panic!("{other:?}"),
    };
    let int = |x: PMetric| match x.value {
        Some(PValue::Int(v)) => v,
        other => panic!("{other:?}"),
    };
    of("Last Command/Source")
        .zip(of("Last Command/Result"))
        .zip(of("Last Command/Error Id"))
        .zip(of("Last Command/Duration"))
        .map(|(((s, r), e), d)| {
            let ts = s.timestamp.unwrap();
            (text(s), text(r), int(e), int(d), ts)
        })
        .collect()
}

#[test]
fn every_finished_command_is_one_event_none_missed_none_repeated() {
    let mut m = model();
    let mut n = node();
    // Finished before the birth: in the NBIRTH's values, not an event.
    m.start(Source::Raw, 1, 0, t(0));
    m.finish(Source::Raw, Outcome::Done, t(10));
    born(&mut n, t(100), &m);
    // Three finish within one period, one source twice; one still runs.
    m.start(Source::Channel(1), 1, 7, t(110));
    m.finish(Source::Channel(1), Outcome::Done, t(130));
    m.start(Source::Trigger(2), 1, 0, t(115));
    m.start(Source::Channel(0), 2, 12, t(120));
    m.finish(
        Source::Trigger(2),
        Outcome::Error(ErrorSource::RobotFail, 20018),
        t(140),
    );
    m.start(Source::Channel(1), 2, 8, t(150));
    m.finish(Source::Channel(1), Outcome::Aborted, t(190));
    // Released at once: the handshake is idle again, the event stays.
    m.release(Source::Channel(1));
    let msgs = drain(&mut n, t(195), &m);
    assert_eq!(msgs.len(), 1);
    assert_eq!(msgs[0].ty, MessageType::NData);
    assert_eq!(
        events(&msgs[0]),
        [
            ("Channel 1".into(), "done".into(), 0, 20, UTC + 130),
            ("Trigger 2".into(), "error".into(), 20018, 25, UTC + 140),
            ("Channel 1".into(), "aborted".into(), 0, 40, UTC + 190),
        ]
    );
    assert_eq!(
        get(&msgs[0], "Channel 1/Last Outcome").value,
        Some(PValue::String("aborted".into()))
    );
    // Nothing new: no event again. The running one, when it ends.
    assert!(drain(&mut n, t(400), &m).is_empty());
    m.finish(Source::Channel(0), Outcome::Done, t(500));
    let msgs = drain(&mut n, t(500), &m);
    assert_eq!(
        events(&msgs[0]),
        [("Channel 0".into(), "done".into(), 0, 380, UTC + 500)]
    );
    assert_eq!(n.stats().events_lost, 0);
}

#[test]
fn more_events_than_one_payload_holds_go_in_several_messages() {
    let mut m = model();
    let mut n = node();
    born(&mut n, t(0), &m);
    for k in 0..20u64 {
        let s = Source::Trigger((k % 16) as u8);
        m.start(s, 1, 0, t(10 + k));
        m.finish(s, Outcome::Done, t(11 + k));
    }
    m.sessions = 1;
    // Room for about three events per message.
    let msgs = drain_with(&mut n, t(100), &m, 600);
    assert!(msgs.len() >= 6, "{} messages", msgs.len());
    assert!(msgs.iter().all(|x| x.ty == MessageType::NData));
    let all: Vec<_> = msgs.iter().flat_map(events).collect();
    assert_eq!(all.len(), 20, "every event once");
    for (k, e) in all.iter().enumerate() {
        assert_eq!(e.4, UTC + 11 + k as u64, "in order");
    }
    // Each event whole in one message: its fields come in sevens.
    for msg in &msgs {
        let n_cmd = names(msg)
            .iter()
            .filter(|x| x.starts_with("Last Command/"))
            .count();
        assert_eq!(n_cmd % 7, 0);
    }
    // The changed node metrics follow the events.
    let sessions = msgs
        .iter()
        .position(|x| names(x).contains(&"Modbus/Sessions"));
    let last_event = msgs.iter().rposition(|x| !events(x).is_empty());
    assert!(sessions >= last_event && sessions.is_some());
    let seqs: Vec<_> = msgs.iter().map(|x| x.p.seq.unwrap()).collect();
    assert_eq!(seqs, (2..2 + msgs.len() as u64).collect::<Vec<_>>());
    // Data splits; the period then holds for the next round.
    m.sessions = 2;
    assert!(drain_with(&mut n, t(150), &m, 600).is_empty());
}

#[test]
fn events_that_left_the_log_unpublished_are_counted() {
    let mut m = model();
    let mut n = node();
    born(&mut n, t(0), &m);
    let extra = 5;
    for k in 0..(LOG_LEN + extra) as u64 {
        m.start(Source::Raw, 1, 0, t(10 + k));
        m.finish(Source::Raw, Outcome::Done, t(10 + k));
    }
    let msgs = drain(&mut n, t(100), &m);
    let all: Vec<_> = msgs.iter().flat_map(events).collect();
    assert_eq!(all.len(), LOG_LEN);
    assert_eq!(n.stats().events_lost, extra as u32);
}

#[test]
fn a_birth_is_whole_or_not_at_all_and_data_that_cannot_fit_is_dropped_and_counted() {
    let mut m = model();
    let mut n = node();
    let mut buf = vec![0u8; 200];
    n.connect(t(0), &mut buf).unwrap();
    let Err(Error::TooSmall { needed }) = n.poll(t(0), &m, &mut buf) else {
        panic!("a birth in 200 bytes")
    };
    assert!(needed > 200 && needed <= PAYLOAD_BUF, "{needed}");
    // Nothing changed: the same call with room publishes it.
    let mut buf = vec![0u8; needed];
    let p = n.poll(t(0), &m, &mut buf).unwrap().unwrap();
    assert_eq!(
        (p.ty, p.payload.len() <= needed),
        (MessageType::NBirth, true)
    );
    drain(&mut n, t(0), &m);
    // A metric that fits no payload of 40 bytes: dropped, counted, and
    // not tried again.
    m.robot.error_code = 10001;
    m.error_text
        .set(10001, TextSource::Controller, &[b'x'; 100]);
    let msgs = drain_with(&mut n, t(100), &m, 40);
    assert_eq!(names(&msgs[0]), ["Error/Code"]);
    assert_eq!(msgs.len(), 1);
    assert_eq!(n.stats().dropped, 1);
    assert!(drain(&mut n, t(300), &m).is_empty());
}

#[test]
fn the_largest_births_fit_the_payload_buffer() {
    let mut m = model();
    m.link.last_error = Some(GatewayError::NotSupported);
    m.link.level = Some(hans_codec::ProtocolLevel::new(255, 255, 255));
    m.robot.error_code = -1;
    m.error_text.set(
        -1,
        TextSource::Controller,
        &[b'x'; crate::state::ERROR_TEXT],
    );
    m.robot.override_ratio = Some(0.5);
    for g in 0..6 {
        m.robot.io[g] = Some(u16::MAX);
    }
    m.active_motion = Some(Source::Trigger(15));
    for s in Source::all() {
        m.start(s, 1, u16::MAX, t(0));
        m.note_send(s, &[b'y'; 200]);
        m.finish(s, Outcome::Error(ErrorSource::Gateway, -1), t(0));
    }
    let mut n = node();
    n.set_wall_time(t(0), u64::MAX / 2);
    let mut buf = [0u8; 64];
    n.connect(t(u32::MAX.into()), &mut buf).unwrap();
    let mut buf = vec![0u8; PAYLOAD_BUF];
    let now = t(u32::MAX.into());
    let nb = n.poll(now, &m, &mut buf).unwrap().unwrap().payload.len();
    let db = n.poll(now, &m, &mut buf).unwrap().unwrap().payload.len();
    println!("largest NBIRTH {nb} bytes, DBIRTH {db} bytes, PAYLOAD_BUF {PAYLOAD_BUF}");
    assert!(nb <= PAYLOAD_BUF && db <= PAYLOAD_BUF);
    // Not oversized either: a quarter of it is left at most.
    assert!(nb > PAYLOAD_BUF * 3 / 4, "{nb}");
}

#[test]
fn the_table_names_are_unique_bounded_and_node_rows_come_first() {
    let all: Vec<_> = metrics::all().collect();
    assert_eq!(all.len(), metrics::COUNT);
    let names: std::collections::BTreeSet<_> = all.iter().map(|x| x.name()).collect();
    assert_eq!(names.len(), all.len(), "unique names");
    for x in &all {
        let name = x.name();
        assert!(name.len() < metrics::NAME_MAX, "{name}");
        assert!(!x.def.doc.is_empty(), "{name} has no description");
    }
    let first_device = all
        .iter()
        .position(|x| x.def.scope == Scope::Device)
        .unwrap();
    assert!(all[first_device..]
        .iter()
        .all(|x| x.def.scope == Scope::Device));
    assert!(all.iter().any(|x| x.name() == "Trigger 15/Last Error Id"));
    assert!(all.iter().any(|x| x.name() == "RAW/Phase"));
}

#[test]
fn ids_are_checked_once() {
    assert_eq!(Id::new(""), Err(IdError::Empty));
    assert_eq!(Id::new("a/b"), Err(IdError::Forbidden('/')));
    assert_eq!(Id::new("a+"), Err(IdError::Forbidden('+')));
    assert_eq!(Id::new("#"), Err(IdError::Forbidden('#')));
    assert_eq!(Id::new(&"x".repeat(33)), Err(IdError::TooLong));
    let long = "x".repeat(topic::ID_MAX);
    let id = Id::new(&long).unwrap();
    let t = topic::topic(&id, &id, &id, MessageType::DBirth);
    assert_eq!(
        t.len(),
        "spBv1.0".len() + 3 * topic::ID_MAX + "DBIRTH".len() + 4
    );
}

/// The rows of the markdown table after `heading` in SPARKPLUG.md.
fn doc_rows(heading: &str) -> Vec<Vec<String>> {
    let doc = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/SPARKPLUG.md"))
        .expect("SPARKPLUG.md");
    let start = doc.find(heading).unwrap_or_else(|| panic!("no {heading}"));
    doc[start..]
        .lines()
        .skip_while(|l| !l.starts_with('|'))
        .take_while(|l| l.starts_with('|'))
        .skip(2)
        .map(|l| {
            l.trim()
                .trim_matches('|')
                .split('|')
                .map(|c| c.trim().to_string())
                .collect()
        })
        .collect()
}

/// What the document says of a row's publication.
fn when(def: &Def) -> String {
    match def.report {
        Report::Birth => "birth only".into(),
        Report::Change => "on change".into(),
        Report::JointBand => "deadband (joints, default 0.1)".into(),
        Report::PoseBand => "deadband (pose, default 0.1)".into(),
        Report::Band(b) => format!("deadband {b}"),
        Report::Event => "per finished command".into(),
    }
}

#[test]
fn the_documented_metrics_are_the_table() {
    let rows = doc_rows("## Metrics");
    assert_eq!(rows.len(), TABLE.len(), "one row per table row");
    for (row, def) in rows.iter().zip(TABLE) {
        let name = match def.family {
            Family::One => format!("`{}`", def.name),
            Family::PerSource => format!("`SOURCE/{}`", def.name),
        };
        let scope = match def.scope {
            Scope::Node => "NBIRTH/NDATA",
            Scope::Device => "DBIRTH/DDATA",
        };
        assert_eq!(
            (
                row[0].as_str(),
                row[1].as_str(),
                row[2].as_str(),
                row[3].as_str(),
                row[4].as_str()
            ),
            (
                name.as_str(),
                def.datatype.name(),
                def.unit,
                scope,
                when(def).as_str()
            ),
            "row {row:?}"
        );
        assert_eq!(row[5], def.doc, "{}", def.name);
    }
}

/// Prints the document's table from [`TABLE`] (run with `--nocapture`
/// after changing the table, and paste).
#[test]
fn print_the_metric_table() {
    println!("| Metric | Datatype | Unit | Message | Published | Meaning |");
    println!("|---|---|---|---|---|---|");
    for def in TABLE {
        let name = match def.family {
            Family::One => format!("`{}`", def.name),
            Family::PerSource => format!("`SOURCE/{}`", def.name),
        };
        let scope = match def.scope {
            Scope::Node => "NBIRTH/NDATA",
            Scope::Device => "DBIRTH/DDATA",
        };
        println!(
            "| {name} | {} | {} | {scope} | {} | {} |",
            def.datatype.name(),
            def.unit,
            when(def),
            def.doc
        );
    }
}
