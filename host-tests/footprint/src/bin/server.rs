//! A server (the simulator's side, or a controller): frames requests, reads
//! and validates a request of ANY command, writes the reply of ANY command
//! (see `server_round`).
#![no_std]
#![no_main]

use hans_codec::Framer;
use hans_codec_footprint::{server_round, BUF};

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut rx = [0u8; BUF];
    let mut tx = [0u8; BUF];
    let mut framer = Framer::<BUF>::new();
    loop {
        server_round(&mut framer, &mut rx, &mut tx);
    }
}
