//! Robot bytes into the engine: every reply of the robot comes from the
//! input (any bytes, any length, cut and joined at random), while the PLC
//! fires motions, outputs, reads and stops from both channels and RAW. The
//! real gateway future runs it in virtual time. Never a panic; the robot
//! sees no protocol violation; every status word stays one of the valid
//! ones; the gateway keeps serving the PLC.
//!
//! One world per process (`common.rs`): each input starts once the link
//! is up (after a previous input broke it, the gateway reconnects and
//! brings it up again), and what an input stored is put back before the
//! next. Commands an input started may end during the next one, as on a
//! gateway that runs.
//!
//! Input: a sequence of replies, each a length byte then that many bytes;
//! the length byte's top bit asks for a PLC command before the reply.
#![no_main]

#[path = "common.rs"]
mod common;

use core::cell::RefCell;

use embassy_time::Duration;
use hans_gateway::config::Config;
use hans_gateway::registers as r;
use hans_gateway::testkit::plc::{pdu, Answer};
use hans_gateway::testkit::robot::Fault;
use hans_gateway::testkit::world::{World, WorldConfig, ANSWER_LIMIT};
use libfuzzer_sys::fuzz_target;

const VALID: [u16; 7] = [0, 0x21, 0x01, 0x11, 0x02, 0x04, 0x08];

const RAW: [&str; 6] = [
    "MoveRelJ,0,1,1,5,;",
    "SetBoxDO,1,1,;",
    "GrpStop,0,;",
    "ReadActPos,0,;",
    "ReadBoxDI,0,1,;",
    "ReadVersion,;",
];

thread_local! {
    static WORLD: RefCell<Option<(World, Config)>> = const { RefCell::new(None) };
}

fn make() -> World {
    let mut w = World::new(WorldConfig::default());
    w.run_for(Duration::from_millis(20));
    w
}

fn text_words(t: &str) -> Vec<u16> {
    let b = t.as_bytes();
    (0..b.len() / 2 + 1)
        .map(|i| {
            let at = |k: usize| u16::from(b.get(k).copied().unwrap_or(0));
            (at(2 * i) << 8) | at(2 * i + 1)
        })
        .collect()
}

/// PLC 0 writes each of `writes` in turn, sent back to back (the session
/// takes them in order); every one must be answered without an exception.
fn set_all(w: &mut World, writes: &[(u16, Vec<u16>)]) {
    w.catch_up();
    let tids: Vec<u16> = writes
        .iter()
        .map(|(a, v)| w.plcs[0].send(&pdu::write(*a, v)))
        .collect();
    let end = w.now() + ANSWER_LIMIT;
    let mut done = 0;
    while done < tids.len() {
        w.catch_up();
        while let Some(&tid) = tids.get(done) {
            match w.plcs[0].answer(tid) {
                Some(Answer::Pdu(_)) => done += 1,
                Some(Answer::Exception(e)) => panic!("writing {}: exception {e}", writes[done].0),
                None => break,
            }
        }
        if done < tids.len() {
            assert!(
                w.turn(end),
                "no answer to the PLC's writes within {ANSWER_LIMIT:?}"
            );
        }
    }
}

fuzz_target!(|data: &[u8]| {
    common::with_world(&WORLD, make, |w| {
        // The engine backs off at most 5 s after a lost link.
        let up = w.run_until_cond(Duration::from_secs(7), |w| w.model(|m| m.link.is_up()));
        assert!(up, "the link does not come back");
        let mut rest = data;
        let mut n = 0u16;
        while let Some((&len, tail)) = rest.split_first() {
            let take = usize::from(len & 0x7F).min(tail.len());
            let (reply, tail) = tail.split_at(take);
            w.robot.script.push_back(Fault::Reply(reply.to_vec()));
            if len & 0x80 != 0 {
                n = n.wrapping_add(1);
                match n % 4 {
                    0 => {
                        let t = RAW[usize::from(n) % RAW.len()];
                        set_all(
                            w,
                            &[
                                (r::RAW_CONTROL, vec![0]),
                                (r::RAW_REQUEST, text_words(t)),
                                (r::RAW_CONTROL, vec![1]),
                            ],
                        );
                    }
                    k => {
                        let ch = r::channel_base(usize::from(k % 2));
                        let code = [13, 21, 40, 6][usize::from(n) % 4];
                        // P0 = 1, P1 = 1 (axis 1 +1°, or DO 1 on).
                        set_all(
                            w,
                            &[
                                (ch, vec![0, code, n, 0, 0x3F80, 0, 0x3F80, 0]),
                                (ch, vec![1]),
                            ],
                        );
                    }
                }
            }
            w.run_for(Duration::from_millis(3));
            rest = tail;
        }
        // What the input did not use is not for the next one.
        w.robot.script.clear();
        w.run_for(Duration::from_millis(5));
        assert!(w.robot.violations.is_empty(), "{:?}", w.robot.violations);
        for base in [r::channel_base(0), r::channel_base(1)] {
            let st = w.reg(base + r::CH_STATUS);
            assert!(VALID.contains(&st), "status {st:#x}");
        }
        let raw = w.reg(r::RAW_STATUS);
        assert!(VALID.contains(&raw), "RAW status {raw:#x}");
        assert_eq!(w.reg(r::STATUS_VERSION), r::MAP_VERSION);
    });
});
