//! What every footprint binary shares, the baseline too, so that "binary
//! minus baseline" is hans-enip alone. Input bytes come from volatile
//! reads of RAM one at a time (the compiler cannot know them), results go
//! out through volatile writes and `black_box`, so nothing is folded away.
#![no_std]

use core::hint::black_box;
use core::ptr::{read_volatile, write_volatile};

/// RAM the program never writes: the "received" bytes.
const RX: usize = 0x2010_0000;
/// Where results go.
const TX: usize = 0x2018_0000;

/// The receive buffer's size.
pub const BUF: usize = 600;

/// Fills `buf` with received bytes; returns how many (also received).
pub fn receive(buf: &mut [u8]) -> usize {
    for (i, b) in buf.iter_mut().enumerate() {
        // SAFETY: an address inside the RAM of memory.x; the binary is built
        // to be measured, not run.
        *b = unsafe { read_volatile((RX + i) as *const u8) };
    }
    usize::from(word() as u16) % (buf.len() + 1)
}

/// A received word (a time, a choice).
pub fn word() -> u32 {
    // SAFETY: as in `receive`.
    unsafe { read_volatile((RX + 0xFFF0) as *const u32) }
}

/// Consumes bytes as if sent.
pub fn send(bytes: &[u8]) {
    black_box(bytes);
    // SAFETY: an address inside the RAM of memory.x.
    unsafe { write_volatile(TX as *mut u32, bytes.len() as u32) };
}
