//! Every request line of the chapter-4 corpora (`host-tests/vectors/
//! chapter4.txt`, HR-TCP V1.0.0.3's examples, and `vectors/v6/chapter4.txt`,
//! the V6 document's: the documents' examples, repaired and reconstructed
//! lines) sent to a fresh simulator in StandBy at the level of its
//! document, one command block at a time: every request the codec reads
//! gets a reply of the right shape for its command, and each command either
//! succeeds or is refused with the code the current state explains. A
//! command the level does not have (the V6 document still prints the ones
//! it removed) gets `Fail,20005`, and nothing else does.

mod support;

use std::collections::BTreeMap;
use std::time::Duration;

use hans_codec::{CommandId, ProtocolLevel, Reply, Request};
use hans_sim::{ClockMode, Config, Sim};
use support::Client;

/// Commands whose HR-TCP example cannot succeed on a robot that has just
/// been brought up, with the code the simulator answers and why.
const REFUSED_V5: &[(&str, i32)] = &[
    ("GrpContinue", 20018),        // nothing paused
    ("GrpInterrupt", 20018),       // nothing moving
    ("GrpCloseFreeDriver", 20018), // free drive not open
    ("ContinueScript", 20018),     // no script paused
    ("PauseScript", 20018),        // no script running
    ("GrpFCInterrupt", 40020),     // force control off
    ("GrpFCContinue", 40020),      // force control off
    ("PushMovePathJ", 20006),      // no such path
    ("PushMovePathL", 20006),      // no such path
    ("EndPushMovePath", 20006),    // no such path
    ("MovePath", 20042),           // path not ready
    ("MovePathL", 20042),          // path not ready
    ("UpdateMovePathName", 20006), // no such path
    ("DelMovePath", 20006),        // no such path
    ("PushServoJ", 20018),         // StartServo first
    ("PushServoP", 20018),         // StartServo first
    ("MoveC", 20006),              // the corpus' points are collinear: no circle
];

/// The same for the V6 document's examples.
const REFUSED_V6: &[(&str, i32)] = &[
    ("GrpContinue", 20018),
    ("GrpInterrupt", 20018),
    ("GrpCloseFreeDriver", 20018),
    ("ContinueScript", 20018),
    ("PauseScript", 20018),
    ("GrpFCInterrupt", 40020),
    ("GrpFCContinue", 40020),
    ("MovePath", 20042),
    ("MovePathL", 20042),
    ("PushServoJ", 20018),
    ("PushServoP", 20018),
    ("MoveC", 20006),
    ("LongMoveEvent", 20018),     // no long jog running
    ("PushPathPoints", 20006),    // no such path (InitPath is another block)
    ("EndPushPathPoints", 20006), // no such path
    ("DelPath", 20006),           // no such path
    ("UpdatePathName", 20006),    // no such path
    ("SetPathRefJoints", 20006),  // no such path
    ("MovePathJ", 20042),         // path not ready
    ("Quaternion2RPY", 20006),    // the example's quaternion is 0: no rotation
    ("ReadActCoord", 20030),      // the example's UCS_1 is not a frame of the simulator
];

fn corpus(path: &str) -> Vec<(String, Vec<String>)> {
    let text = std::fs::read_to_string(path).expect("read the chapter-4 corpus");
    let mut blocks: Vec<(String, Vec<String>)> = Vec::new();
    for line in text.lines() {
        if let Some(h) = line.strip_prefix("@ ") {
            let name = h.split_whitespace().nth(1).unwrap_or("-").to_string();
            blocks.push((name, Vec::new()));
        } else if let Some(rest) = line.strip_prefix("req ") {
            if let Some((_, msg)) = rest.split_once('|') {
                if let Some(b) = blocks.last_mut() {
                    b.1.push(msg.to_string());
                }
            }
        }
    }
    blocks
}

/// Sends every block of `path` at `level`; checks each command of the
/// codec's table that the level has against `refused`, and that the ones
/// it has not are refused with 20005.
async fn every_command_at(path: &str, level: ProtocolLevel, refused: &[(&str, i32)]) {
    let blocks = corpus(path);
    let mut outcome: BTreeMap<&'static str, Vec<String>> = BTreeMap::new();
    let mut sent = 0;
    for (_, lines) in &blocks {
        let sim = Sim::start(Config {
            clock: ClockMode::Manual,
            datasheet_ports: vec![],
            protocol: level,
            ..Config::ready()
        })
        .await
        .unwrap();
        let mut c = Client::connect(sim.command_addr()).await;
        for msg in lines {
            if !msg.trim_end().ends_with(';') {
                // A line the document broke in two: on the wire, an
                // incomplete message.
                let r = c.call(msg).await;
                assert!(r.starts_with("errorcmd"), "{msg:?} -> {r}");
                continue;
            }
            let Ok(req) = Request::parse(msg) else {
                // Garbled beyond reading: the simulator must still answer.
                let r = c.call(msg).await;
                assert!(
                    r.contains("Fail,20007")
                        || r.contains("Fail,20005")
                        || r.starts_with("errorcmd"),
                    "{msg:?} -> {r}"
                );
                continue;
            };
            let Some(id) = req.command() else { continue };
            sent += 1;
            let r = c.call(msg).await;
            let reply = Reply::parse(&r, req.expect())
                .unwrap_or_else(|e| panic!("{msg:?} -> {r:?}: not a valid reply: {e}"));
            let code = match reply {
                Reply::Ok(resp) => {
                    assert_eq!(resp.command(), Some(id), "{msg} -> {r}");
                    0
                }
                Reply::Fail(f) => f.code.code(),
                Reply::ErrorCmd(_) => panic!("{msg:?} -> {r}"),
            };
            if id.available_at(level) {
                assert_ne!(code, 20005, "{msg} is a command of {level}");
            } else {
                assert_eq!(code, 20005, "{msg}: not a command of {level}");
            }
            outcome
                .entry(id.name())
                .or_default()
                .push(format!("{code} <- {msg}"));
            // Let any motion finish before the next line.
            sim.advance(Duration::from_secs(60));
        }
        sim.shutdown().await;
    }
    assert!(sent >= 150, "only {sent} requests sent");
    let mut problems = Vec::new();
    let of_the_document = |id: &&CommandId| {
        id.available_at(level)
            && if level == ProtocolLevel::V5 {
                id.section_v5().is_some()
            } else {
                id.section_v6().is_some()
            }
    };
    for id in CommandId::ALL.iter().filter(of_the_document) {
        let Some(results) = outcome.get(id.name()) else {
            problems.push(format!("{}: no request in the corpus", id.name()));
            continue;
        };
        let any_ok = results.iter().any(|r| r.starts_with("0 "));
        let refusal = refused.iter().find(|(n, _)| *n == id.name());
        match (any_ok, refusal) {
            (true, _) => {}
            (false, Some((_, code))) => {
                if !results.iter().all(|r| r.starts_with(&format!("{code} "))) {
                    problems.push(format!("{}: {results:?}", id.name()));
                }
            }
            (false, None) => problems.push(format!("{}: {results:?}", id.name())),
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[tokio::test]
async fn every_command_of_hr_tcp_at_the_v5_level() {
    every_command_at(
        concat!(env!("CARGO_MANIFEST_DIR"), "/../vectors/chapter4.txt"),
        ProtocolLevel::V5,
        REFUSED_V5,
    )
    .await;
}

#[tokio::test]
async fn every_command_of_the_v6_document_at_the_v6_level() {
    every_command_at(
        concat!(env!("CARGO_MANIFEST_DIR"), "/../vectors/v6/chapter4.txt"),
        ProtocolLevel::V6,
        REFUSED_V6,
    )
    .await;
}
