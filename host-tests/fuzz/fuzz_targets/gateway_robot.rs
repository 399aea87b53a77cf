//! Robot bytes into the engine: every reply of the robot comes from the
//! input (any bytes, any length, cut and joined at random), while the PLC
//! fires motions, outputs, reads and stops from both channels and RAW. The
//! real gateway future runs it in virtual time. Never a panic; every command
//! ends (or is Busy while the gateway has it) and the gateway keeps serving
//! the PLC.
//!
//! Input: a sequence of replies, each a length byte then that many bytes;
//! the length byte's top bit asks for a PLC command before the reply.
#![no_main]

use embassy_time::Duration;
use hans_gateway::registers as r;
use hans_gateway::testkit::robot::Fault;
use hans_gateway::testkit::world::{World, WorldConfig};
use libfuzzer_sys::fuzz_target;

const RAW: [&str; 6] = [
    "MoveRelJ,0,1,1,5,;",
    "SetBoxDO,1,1,;",
    "GrpStop,0,;",
    "ReadActPos,0,;",
    "ReadBoxDI,0,1,;",
    "ReadVersion,;",
];

fn text_words(t: &str) -> Vec<u16> {
    let b = t.as_bytes();
    (0..b.len() / 2 + 1)
        .map(|i| {
            let at = |k: usize| u16::from(b.get(k).copied().unwrap_or(0));
            (at(2 * i) << 8) | at(2 * i + 1)
        })
        .collect()
}

fuzz_target!(|data: &[u8]| {
    let mut w = World::new(WorldConfig::default());
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
                    w.set(r::RAW_CONTROL, &[0]);
                    w.set(r::RAW_REQUEST, &text_words(t));
                    w.set(r::RAW_CONTROL, &[1]);
                }
                k => {
                    let ch = r::channel_base(usize::from(k % 2));
                    let code = [13, 21, 40, 6][usize::from(n) % 4];
                    // P0 = 1, P1 = 1 (axis 1 +1°, or DO 1 on).
                    w.set(ch, &[0, code, n, 0, 0x3F80, 0, 0x3F80, 0]);
                    w.set(ch, &[1]);
                }
            }
        }
        w.run_for(Duration::from_millis(3));
        rest = tail;
    }
    w.robot.script.clear();
    w.run_for(Duration::from_secs(1));
    assert!(w.robot.violations.is_empty(), "{:?}", w.robot.violations);
    assert_eq!(w.reg(r::STATUS_VERSION), r::MAP_VERSION);
});
