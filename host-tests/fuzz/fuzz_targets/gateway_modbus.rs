//! Modbus TCP bytes from a PLC, in reads of any size, through a gateway
//! session (the real gateway future, in virtual time) into its state:
//! register writes, text areas, configuration commands, trigger bits,
//! frames too long, frames that are not Modbus. Never a panic; the state
//! stays consistent (every status word one of the valid ones, the
//! configuration in range) and the gateway keeps answering a second PLC.
//!
//! One world per process (`common.rs`): each input is a new PLC connection
//! to it; what the input stored is put back before the next. The robot is
//! not reachable (connects are refused): commands the PLC starts end on
//! the link being down, which keeps virtual time cheap; the robot's side
//! is `gateway_robot`'s.
//!
//! Input: the first byte picks the chunk sizes (1-64 bytes); the rest is the
//! stream, sent chunk by chunk with 1 ms of virtual time between chunks.
#![no_main]

#[path = "common.rs"]
mod common;

use core::cell::RefCell;
use core::net::{Ipv4Addr, SocketAddrV4};

use embassy_time::Duration;
use hans_gateway::config::Config;
use hans_gateway::registers as r;
use hans_gateway::testkit::plc::{pdu, Answer, Plc};
use hans_gateway::testkit::world::{World, WorldConfig, MODBUS_PORT};
use libfuzzer_sys::fuzz_target;

const VALID: [u16; 7] = [0, 0x21, 0x01, 0x11, 0x02, 0x04, 0x08];

thread_local! {
    static WORLD: RefCell<Option<(World, Config)>> = const { RefCell::new(None) };
}

fn make() -> World {
    let mut w = World::new(WorldConfig {
        plcs: 1,
        config: Config {
            // Nobody listens there: the link stays down.
            robot_ip: Ipv4Addr::new(10, 0, 0, 99),
            ..Config::default()
        },
        ..WorldConfig::default()
    });
    w.run_for(Duration::from_millis(20));
    w
}

fn read(w: &mut World, addr: u16, n: u16) -> Vec<u16> {
    match w.request(0, &pdu::read(addr, n)) {
        Answer::Pdu(p) => pdu::registers(&p),
        Answer::Exception(e) => panic!("exception {e} reading {addr}"),
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&seed, stream)) = data.split_first() else {
        return;
    };
    common::with_world(&WORLD, make, |w| {
        let from = SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, 11), 50001);
        let mut plc = Plc::new(
            w.net
                .connect(from, MODBUS_PORT)
                .expect("the Modbus port is served"),
        );
        w.settle();
        let mut rest = stream;
        let mut k = usize::from(seed);
        while !rest.is_empty() {
            let n = (k % 64 + 1).min(rest.len());
            k = k.wrapping_mul(31).wrapping_add(7);
            let (chunk, tail) = rest.split_at(n);
            plc.send_raw(chunk);
            w.run_for(Duration::from_millis(1));
            rest = tail;
        }
        w.run_for(Duration::from_millis(200));
        // The input's PLC leaves; the other one reads the state.
        plc.close();
        drop(plc);
        w.run_for(Duration::from_millis(1));
        for base in [r::channel_base(0), r::channel_base(1)] {
            let st = read(w, base + r::CH_STATUS, 1)[0];
            assert!(VALID.contains(&st), "status {st:#x}");
        }
        let raw = read(w, r::RAW_STATUS, 1)[0];
        assert!(VALID.contains(&raw), "RAW status {raw:#x}");
        // Whatever the PLC applied is in range (what is in use reads back
        // from its registers' words as itself).
        let active = w.model(|m| m.config.active);
        assert_eq!(active.check(), Ok(()), "configuration in use out of range");
        // The other PLC is still served, the map intact.
        assert_eq!(read(w, r::STATUS_VERSION, 1)[0], r::MAP_VERSION);
    });
});
