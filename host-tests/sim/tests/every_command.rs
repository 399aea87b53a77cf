//! Every request line of the chapter-4 corpus (`host-tests/vectors/
//! chapter4.txt`: the document's examples, repaired and reconstructed
//! lines) sent to a fresh simulator in StandBy, one command block at a
//! time: every request the codec reads gets a reply of the right shape
//! for its command, and each command either succeeds or is refused with
//! the code the current state explains.

mod support;

use std::collections::BTreeMap;
use std::time::Duration;

use hans_codec::{CommandId, Reply, Request};
use hans_sim::{ClockMode, Config, Sim};
use support::Client;

/// Commands whose document example cannot succeed on a robot that has just
/// been brought up, with the code the simulator answers and why.
const REFUSED: &[(&str, i32)] = &[
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

fn corpus() -> Vec<(String, Vec<String>)> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../vectors/chapter4.txt");
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

#[tokio::test]
async fn every_command_of_the_corpus_gets_a_reply_of_its_shape() {
    let blocks = corpus();
    assert!(blocks.len() >= 139, "corpus has {} blocks", blocks.len());
    let mut outcome: BTreeMap<&'static str, Vec<String>> = BTreeMap::new();
    let mut sent = 0;
    for (_, lines) in &blocks {
        let sim = Sim::start(Config {
            clock: ClockMode::Manual,
            datasheet_ports: vec![],
            ..Config::ready()
        })
        .await
        .unwrap();
        let mut c = Client::connect(sim.command_addr()).await;
        for msg in lines {
            let Ok(req) = Request::parse(msg) else {
                // Garbled beyond reading: the simulator must still answer.
                let r = c.call(msg).await;
                assert!(
                    r.contains("Fail,20007") || r.starts_with("errorcmd"),
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
            assert_ne!(code, 20005, "{msg} is a known command");
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
    for id in CommandId::ALL {
        let Some(results) = outcome.get(id.name()) else {
            problems.push(format!("{}: no request in the corpus", id.name()));
            continue;
        };
        let any_ok = results.iter().any(|r| r.starts_with("0 "));
        let refused = REFUSED.iter().find(|(n, _)| *n == id.name());
        match (any_ok, refused) {
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
