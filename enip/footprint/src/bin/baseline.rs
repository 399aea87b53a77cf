//! The runtime and the harness without hans-enip.
#![no_std]
#![no_main]

use hans_enip_footprint::{receive, send, BUF};

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {}
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let mut rx = [0u8; BUF];
    loop {
        let n = receive(&mut rx);
        send(&rx[..n]);
    }
}
