//! Sparkplug B telemetry in virtual time: the whole gateway, the simulated
//! robot and the simulated broker (`testkit`), so that when a change is
//! published is asserted exactly (the end-to-end test with Mosquitto,
//! `host-tests/e2e/tests/mqtt.rs`, checks what is published; the fleet
//! benchmark measures how fast on a real machine).

use embassy_time::{Duration, Instant};
use hans_gateway::testkit::broker::BrokerMode;
use hans_gateway::testkit::world::{World, WorldConfig};
use prost::Message as _;

/// A Sparkplug B payload: the fields read here, by the specification's
/// field numbers (not the gateway's encoder).
#[derive(Clone, PartialEq, prost::Message)]
struct Payload {
    #[prost(message, repeated, tag = "2")]
    metrics: Vec<Metric>,
}

#[derive(Clone, PartialEq, prost::Message)]
struct Metric {
    #[prost(string, optional, tag = "1")]
    name: Option<String>,
    #[prost(uint32, optional, tag = "10")]
    int: Option<u32>,
}

fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}

/// When the first DDATA published at or after `since` with `IO/Box DI`
/// = `want` was published.
fn box_di_published(w: &World, since: Instant, want: u32) -> Option<Instant> {
    let broker = w.broker.as_ref()?;
    broker
        .published
        .iter()
        .filter(|p| p.at >= since && p.topic.contains("/DDATA/"))
        .filter_map(|p| {
            let payload = Payload::decode(&p.payload[..]).ok()?;
            let di = payload
                .metrics
                .iter()
                .find(|m| m.name.as_deref() == Some("IO/Box DI"))?;
            (di.int? == want).then_some(p.at)
        })
        .next()
}

/// When the robot was asked for its box inputs at or after `since` (the
/// first time).
fn box_di_read(w: &World, since: Instant) -> Option<Instant> {
    w.robot
        .log
        .iter()
        .find(|m| m.at >= since && m.text.starts_with("ReadBoxDI,"))
        .map(|m| m.at)
}

/// What one change of a box input took.
struct Change {
    /// From the change to the first read of the inputs after it.
    read: Duration,
    /// From that read's answer to the DDATA.
    held: Duration,
    /// From the change to the DDATA.
    total: Duration,
}

/// While `moving`, J1 turns 1° every 10 ms (a change the next status read
/// sees, published with its round).
fn step_joints(w: &mut World, moving: bool) {
    if moving {
        w.robot.model.joints[0] = (w.now().as_millis() / 10 % 360) as i32;
    }
}

/// Flips a box input 25 times, 237 ms apart (each falls 37 ms later in the
/// 100 ms poll period than the one before: together at every phase of
/// it), and times each until its DDATA.
fn box_input_changes(moving: bool) -> Vec<Change> {
    let mut w = World::new(WorldConfig {
        broker: Some(BrokerMode::Up),
        ..WorldConfig::default()
    });
    let latency = w.robot.latency;
    let born = w.run_until_cond(ms(5000), |w| {
        w.broker
            .as_ref()
            .is_some_and(|b| b.published.iter().any(|p| p.topic.contains("/DBIRTH/")))
    });
    assert!(born, "births within 5 s");
    let start = w.now();
    let mut changes = Vec::new();
    for k in 0..25u64 {
        let changed = start + ms(237 * (k + 1));
        assert!(w.now() <= changed, "change {k}: the last one still pending");
        w.run_until_cond(changed - w.now(), |w| {
            step_joints(w, moving);
            false
        });
        w.robot.model.io[0] ^= 2;
        let want = u32::from(w.robot.model.io[0]);
        let out = w.run_until_cond(ms(1000), |w| {
            step_joints(w, moving);
            box_di_published(w, changed, want).is_some()
        });
        assert!(out, "change {k}: no DDATA with the box inputs {want:#x}");
        let published = box_di_published(&w, changed, want).unwrap();
        let read = box_di_read(&w, changed).expect("the inputs read after the change");
        changes.push(Change {
            read: read - changed,
            held: published - (read + latency),
            total: published - changed,
        });
    }
    changes
}

/// A robot input that changes is read by the next status round (one per
/// `CFG_POLL_MS`), and its DDATA goes out at most one publish period
/// (`mqtt.period_ms`) after that read's answer: at once when nothing was
/// published within the period, else when the period is over. At most
/// 200 ms (and the robot's answer) after the change with the defaults,
/// wherever the change falls.
#[test]
fn a_robot_change_is_published_within_the_publish_period_after_the_poll_that_sees_it() {
    let config = hans_gateway::config::Config::default();
    let poll = ms(config.poll_ms.into());
    let period = ms(config.mqtt.period_ms.into());
    let latency = World::new(WorldConfig::default()).robot.latency;
    for moving in [false, true] {
        let changes = box_input_changes(moving);
        for (k, c) in changes.iter().enumerate() {
            let what = format!("moving {moving}, change {k}");
            // The first read after the change sees it (its answer is made
            // when the request arrives), within one poll period.
            assert!(c.read <= poll, "{what}: read {:?} after it", c.read);
            assert!(
                c.held <= period,
                "{what}: published {:?} after the read's answer",
                c.held
            );
            assert!(c.total <= poll + latency + period, "{what}: {:?}", c.total);
            if !moving {
                // Nothing else published: at once.
                assert_eq!(c.held, Duration::from_ticks(0), "{what}");
            }
        }
        let worst = changes.iter().map(|c| c.total).max().unwrap();
        let reads = changes.iter().map(|c| c.read).max().unwrap();
        // The changes fell at every phase of the poll period: one just
        // after a read of the inputs.
        assert!(reads > poll * 9 / 10, "moving {moving}: {reads:?}");
        if moving {
            // J1's data, published with each round just before the inputs
            // were read, held them for most of a period.
            assert!(worst > poll + period / 2, "{worst:?}");
        }
    }
}
