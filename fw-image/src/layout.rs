//! Where the bootloader, the boot state and the two firmware slots sit on
//! each board: one definition read by the bootloader, the application
//! (which writes the download slot) and the host tool that makes a first
//! flash image (`hans-fw install`).
//!
//! A slot holds a signed image as it was uploaded, in two parts: the
//! image's header ([`crate::HEADER_LEN`] bytes) at the slot's
//! start, padded to [`HEADER_PAGE`], then the body (the firmware, whose
//! vector table therefore sits at `slot + HEADER_PAGE`, aligned as the
//! Cortex-M's VTOR needs). The swap moves whole slots, headers with them:
//! the active slot's header names the running version, the download
//! slot's after an update the previous one.

use core::ops::Range;

/// Bytes from a slot's start to its body: the header and its padding.
/// 1 KiB keeps the vector table aligned for up to 256 vectors.
pub const HEADER_PAGE: u32 = 1024;

/// One board's layout, as offsets into the medium the bootloader and the
/// application share (the NUCLEO's flash from 0x0800_0000; the QEMU
/// board's flash file from its first byte).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Layout {
    /// The board id in the image headers.
    pub board: &'static str,
    /// The boot state (embassy-boot's magic and swap progress).
    pub state: Range<u32>,
    /// The running image's slot.
    pub active: Range<u32>,
    /// The download slot: one page larger than the active slot (the swap
    /// needs it).
    pub dfu: Range<u32>,
    /// The gateway's own store (its configuration, accounts and audit
    /// records: `hans_gateway::storage::flash::FlashStorage`), apart from
    /// the slots: neither the bootloader nor an update touches it, so what
    /// it holds survives restarts and updates.
    pub store: Range<u32>,
    /// The swap's page: the erase size of the slots' medium.
    pub page: u32,
    /// Where the application's body runs: the address its vector table is
    /// linked at (a slot's body, in flash on the NUCLEO; on the QEMU board
    /// the bootloader copies the active slot into RAM at
    /// `entry - HEADER_PAGE`).
    pub entry: u32,
    /// Bytes of the medium (the QEMU board's flash file).
    pub size: u32,
}

impl Layout {
    /// The largest body a slot holds.
    pub const fn max_body(&self) -> u32 {
        (self.active.end - self.active.start) - HEADER_PAGE
    }
}

/// The QEMU board (mps2-an386): its "flash" is a file on the host, read
/// and written through semihosting, with 4 KiB pages. The bootloader sits
/// at 0x0 (64 KiB of the code memory); it copies the active slot to
/// 0x0001_0000, so the application is linked at 0x0001_0400. The gateway's
/// store (64 KiB: the configuration, then the audit records) follows the
/// download slot, at the end of the file.
pub const MPS2_AN386: Layout = Layout {
    board: "mps2-an386",
    state: 0..0x1000,
    active: 0x1000..0x8_1000,
    dfu: 0x8_1000..0x10_2000,
    store: 0x10_2000..0x11_2000,
    page: 0x1000,
    entry: 0x0001_0400,
    size: 0x11_2000,
};

/// The NUCLEO-F767ZI in dual-bank mode (firmware/README.md draws it):
/// offsets from 0x0800_0000; bank 1 holds the bootloader (sectors 0-3)
/// and the active slot (sectors 5-10), bank 2 the configuration (12-15,
/// as before updates), the boot state (16) and the download slot (17-23).
/// Everything the running firmware writes is in bank 2: the program runs
/// from bank 1 and is never stalled by an erase.
pub const NUCLEO_F767ZI: Layout = Layout {
    board: "nucleo-f767zi",
    state: 0x11_0000..0x12_0000,
    active: 0x2_0000..0x0E_0000,
    dfu: 0x12_0000..0x20_0000,
    store: 0x10_0000..0x11_0000,
    page: 0x2_0000,
    entry: 0x0802_0400,
    size: 0x20_0000,
};

/// The layout of the board named `board` (an image header's board id).
pub fn of(board: &str) -> Option<&'static Layout> {
    [&MPS2_AN386, &NUCLEO_F767ZI]
        .into_iter()
        .find(|l| l.board == board)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(l: &Layout) {
        let (a, d) = (l.active.end - l.active.start, l.dfu.end - l.dfu.start);
        assert_eq!(
            d,
            a + l.page,
            "{}: the download slot is one page larger",
            l.board
        );
        for r in [&l.state, &l.active, &l.dfu, &l.store] {
            assert_eq!(
                r.start % l.page.min(0x4000),
                0,
                "{}: {r:?} page-aligned",
                l.board
            );
            assert!(r.end <= l.size);
        }
        let apart = |a: &Range<u32>, b: &Range<u32>| a.end <= b.start || b.end <= a.start;
        assert!(apart(&l.state, &l.active) && apart(&l.state, &l.dfu) && apart(&l.active, &l.dfu));
        for r in [&l.state, &l.active, &l.dfu] {
            assert!(
                apart(r, &l.store),
                "{}: the store is apart from {r:?}",
                l.board
            );
        }
        assert_eq!(l.entry % HEADER_PAGE, 0);
        assert!(
            l.max_body() >= 384 * 1024,
            "{}: a slot holds the field-device budget",
            l.board
        );
    }

    #[test]
    fn layouts_are_consistent() {
        check(&MPS2_AN386);
        check(&NUCLEO_F767ZI);
        // The NUCLEO's configuration (bank 2, sectors 12-15) stays outside
        // every slot: a board updated from the layout before keeps it.
        let config = NUCLEO_F767ZI.store.clone();
        assert_eq!(config, 0x10_0000..0x11_0000);
        // What the running firmware writes (the boot state, the download
        // slot) is in bank 2, away from the program in bank 1.
        let n = &NUCLEO_F767ZI;
        assert!(n.state.start >= 0x10_0000 && n.dfu.start >= 0x10_0000);
        assert!(n.active.end <= 0x10_0000);
        for r in [
            &NUCLEO_F767ZI.state,
            &NUCLEO_F767ZI.active,
            &NUCLEO_F767ZI.dfu,
        ] {
            assert!(r.end <= config.start || r.start >= config.end);
        }
    }
}
