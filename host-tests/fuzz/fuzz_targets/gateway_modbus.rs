//! Modbus TCP bytes from a PLC, in reads of any size, through a whole
//! gateway session (the real gateway future, in virtual time) into its
//! state: register writes, text areas, configuration commands, trigger bits,
//! frames too long, frames that are not Modbus. Never a panic; the state
//! stays consistent (every status word one of the valid ones) and the
//! gateway keeps answering a second PLC.
//!
//! Input: the first byte picks the chunk sizes (1-64 bytes); the rest is the
//! stream, sent chunk by chunk with 1 ms of virtual time between chunks.
#![no_main]

use embassy_time::Duration;
use hans_gateway::registers as r;
use hans_gateway::testkit::plc::{pdu, Answer};
use hans_gateway::testkit::world::{World, WorldConfig};
use libfuzzer_sys::fuzz_target;

const VALID: [u16; 7] = [0, 0x21, 0x01, 0x11, 0x02, 0x04, 0x08];

fuzz_target!(|data: &[u8]| {
    let Some((&seed, stream)) = data.split_first() else {
        return;
    };
    let mut w = World::new(WorldConfig {
        plcs: 2,
        ..WorldConfig::default()
    });
    w.run_for(Duration::from_millis(20));
    let mut rest = stream;
    let mut k = usize::from(seed);
    while !rest.is_empty() {
        let n = (k % 64 + 1).min(rest.len());
        k = k.wrapping_mul(31).wrapping_add(7);
        let (chunk, tail) = rest.split_at(n);
        w.plcs[0].send_raw(chunk);
        w.run_for(Duration::from_millis(1));
        rest = tail;
    }
    w.run_for(Duration::from_millis(200));
    // Read through the other PLC (the first one's stream is the input's).
    let mut read1 = |addr: u16| match w.request(1, &pdu::read(addr, 1)) {
        Answer::Pdu(p) => pdu::registers(&p)[0],
        Answer::Exception(e) => panic!("exception {e} reading {addr}"),
    };
    for base in [r::channel_base(0), r::channel_base(1)] {
        let st = read1(base + r::CH_STATUS);
        assert!(VALID.contains(&st), "status {st:#x}");
    }
    assert!(VALID.contains(&read1(r::RAW_STATUS)));
    // The other PLC is still served, the map intact.
    assert_eq!(read1(r::STATUS_VERSION), r::MAP_VERSION);
});
