//! Not measured for flash: its symbols' sizes are the RAM the adapter's
//! state takes on this target (`llvm-nm -S`), for the sizes a board uses.
#![no_std]
#![no_main]

use core::mem::size_of;

use hans_enip::{Adapter, Framer};

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {}
}

/// An adapter with 4 sessions and 4 connections.
#[used]
#[no_mangle]
static ENIP_ADAPTER_4_4: [u8; size_of::<Adapter<'static, 4, 4>>()] =
    [0; size_of::<Adapter<'static, 4, 4>>()];
/// An adapter with 8 sessions and 8 connections.
#[used]
#[no_mangle]
static ENIP_ADAPTER_8_8: [u8; size_of::<Adapter<'static, 8, 8>>()] =
    [0; size_of::<Adapter<'static, 8, 8>>()];
/// One TCP connection's framer holding 600 data bytes.
#[used]
#[no_mangle]
static ENIP_FRAMER_600: [u8; size_of::<Framer<600>>()] = [0; size_of::<Framer<600>>()];

#[cortex_m_rt::entry]
fn main() -> ! {
    loop {}
}
