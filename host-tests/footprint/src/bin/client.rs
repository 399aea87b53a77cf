//! A client (the gateway's side): writes a request of ANY command, frames
//! replies from the socket and reads the reply of ANY command against it
//! (see `client_round`).
#![no_std]
#![no_main]

use hans_codec::Framer;
use hans_codec_footprint::{client_round, BUF};

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut rx = [0u8; BUF];
    let mut tx = [0u8; BUF];
    let mut framer = Framer::<BUF>::new();
    loop {
        client_round(&mut framer, &mut rx, &mut tx);
    }
}
