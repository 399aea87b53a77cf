//! Stack high-water mark from a painted stack.
//!
//! `cortex-m-rt`'s `paint-stack` feature fills the whole stack region, from
//! `_stack_end` (just above `.bss` and `.uninit`) up to `_stack_start` (top of
//! RAM), with [`PAINT`] before `main` runs. The stack grows down from
//! `_stack_start`; the lowest word no longer holding the pattern marks the
//! deepest the stack has ever reached. Interrupt handlers run on the same
//! (main) stack, so their use is included.
//!
//! A word that happens to be written with the pattern itself would be missed,
//! which can only make the mark read low by the words below it that still
//! hold the pattern; the scan goes up from the bottom, so that only happens
//! when a live frame stores `0xCCCC_CCCC` at its very deepest word.

use core::ptr::{addr_of, read_volatile};

/// The value `cortex-m-rt` paints the stack with.
pub const PAINT: u32 = cortex_m_rt::STACK_PAINT_VALUE;

extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

/// Stack use measured from the paint.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Usage {
    /// Size of the stack region in bytes.
    pub size: usize,
    /// Most bytes ever used (high-water mark).
    pub used: usize,
}

/// Scans the painted stack and reports its high-water mark.
///
/// The scan reads the untouched part of the region once, so it costs time in
/// proportion to the free stack (4 MiB on the QEMU board: a few ms). Call it
/// from a task when a figure is wanted, not in a hot loop.
pub fn usage() -> Usage {
    // Linker symbols from cortex-m-rt's link.x: only their addresses are used.
    let (bottom, top) = (
        addr_of!(_stack_end) as usize,
        addr_of!(_stack_start) as usize,
    );
    let size = top.saturating_sub(bottom);
    let mut addr = bottom;
    while addr < top {
        // SAFETY: `addr` is word-aligned (the linker script asserts both ends
        // are) and inside the stack region, which is RAM owned by this
        // program; reading it races with nothing that matters (a word changing
        // under us only moves the mark by that word).
        let word = unsafe { read_volatile(addr as *const u32) };
        if word != PAINT {
            break;
        }
        addr += 4;
    }
    Usage {
        size,
        used: top - addr,
    }
}
