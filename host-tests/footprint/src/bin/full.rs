//! Both sides of the command port: everything `client` and `server` do,
//! chosen by an input byte.
#![no_std]
#![no_main]

use hans_codec::Framer;
use hans_codec_footprint::{client_round, selector, server_round, BUF};

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut rx = [0u8; BUF];
    let mut tx = [0u8; BUF];
    let mut framer = Framer::<BUF>::new();
    loop {
        if selector() & 1 == 0 {
            client_round(&mut framer, &mut rx, &mut tx);
        } else {
            server_round(&mut framer, &mut rx, &mut tx);
        }
    }
}
