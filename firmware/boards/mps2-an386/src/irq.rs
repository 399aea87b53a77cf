//! The device interrupts of the MPS2+ AN386 and its vector table.
//!
//! Chips normally get these from a PAC crate; the AN386 FPGA image has none,
//! so the board declares the one line it uses. QEMU's model has 32 external
//! lines; the LAN9118 is wired to line 13 (AN386 application note, table
//! "Interrupt map").

use cortex_m::interrupt::InterruptNumber;

/// Device interrupt lines used by this board.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u16)]
pub enum Interrupt {
    /// SMSC LAN9118 Ethernet controller.
    Ethernet = 13,
}

// SAFETY: the numbers are the AN386's external interrupt lines, all < 32.
unsafe impl InterruptNumber for Interrupt {
    fn number(self) -> u16 {
        self as u16
    }
}

/// Number of external interrupt lines in the vector table.
const LINES: usize = 32;

/// One vector table entry: a handler, or a reserved word.
#[derive(Clone, Copy)]
#[repr(C)]
pub union Vector {
    handler: unsafe extern "C" fn(),
    reserved: usize,
}

extern "C" {
    fn DefaultHandler();
}

/// The external part of the vector table, placed after the core exceptions by
/// cortex-m-rt's linker script (its `device` feature expects this symbol).
#[link_section = ".vector_table.interrupts"]
#[no_mangle]
pub static __INTERRUPTS: [Vector; LINES] = {
    let mut table = [Vector {
        handler: DefaultHandler,
    }; LINES];
    table[Interrupt::Ethernet as usize] = Vector { handler: ETHERNET };
    table
};

/// LAN9118 interrupt: wakes the network stack.
#[no_mangle]
unsafe extern "C" fn ETHERNET() {
    // SAFETY: the window `init` gave the driver.
    unsafe { lan9118::on_interrupt(crate::ETH_BASE) }
}
