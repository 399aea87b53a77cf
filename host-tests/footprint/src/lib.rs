//! The harness every footprint binary shares, the baseline included, so that
//! "binary minus baseline" is the codec alone.
//!
//! * Input comes from volatile reads of RAM, one byte at a time, as from a
//!   UART or a DMA buffer: the compiler cannot know a single byte. (A
//!   volatile read of a whole array would compile into a byte-by-byte copy
//!   unrolled in flash and distort the numbers.)
//! * Results are consumed by volatile writes and `black_box`, so nothing is
//!   optimised away.
//! * A panic halts (`panic = "abort"`); nothing on input panics in the codec.
#![no_std]

use core::hint::black_box;
use core::ptr::{read_volatile, write_volatile};

/// Where the bytes come from (RAM the program never writes).
const RX: usize = 0x2010_0000;
/// Where results go.
const TX: usize = 0x2018_0000;

/// Fills `buf` from the receive area, one volatile read per byte, and
/// returns the bytes as text (empty if they are not UTF-8).
pub fn input(buf: &mut [u8]) -> &str {
    for (i, b) in buf.iter_mut().enumerate() {
        // SAFETY: a readable RAM address of the target (memory.x); the
        // binary is built to be measured, not run on other memory maps.
        *b = unsafe { read_volatile((RX + i) as *const u8) };
    }
    core::str::from_utf8(buf).unwrap_or("")
}

/// One byte of input, for choices (which request, which expectation).
pub fn selector() -> u8 {
    // SAFETY: as in `input`.
    unsafe { read_volatile((RX + 0xFFFF) as *const u8) }
}

/// Consumes a value: its address escapes and a word derived from it is
/// written out.
pub fn output<T>(value: &T, word: u32) {
    black_box(value);
    // SAFETY: a writable RAM address of the target (memory.x).
    unsafe { write_volatile(TX as *mut u32, word) };
}

/// Consumes written bytes.
pub fn output_bytes(bytes: &[u8]) {
    black_box(bytes);
    // SAFETY: as in `output`.
    unsafe { write_volatile(TX as *mut u32, bytes.len() as u32) };
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    loop {
        core::hint::spin_loop();
    }
}
