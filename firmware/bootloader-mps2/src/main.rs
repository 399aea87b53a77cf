//! The bootloader of the QEMU board (mps2-an386), what runs at reset when a
//! field device starts under QEMU (`scripts/qemu-run.sh` loads it with
//! `-kernel`; the application is in the flash file):
//!
//! 1. opens the flash file (the word `flash=PATH` of QEMU's command line,
//!    `flash.bin` without it; `semihosting-flash`) with the layout
//!    [`MPS2_AN386`]: boot state, active slot, download slot;
//! 2. before a swap that has not begun, checks the image in the download
//!    slot (signature, board, hash) and refuses to swap in one that fails:
//!    the boot state is cleared and the running image stays;
//! 3. runs embassy-boot's `prepare_boot`: the power-fail-safe swap of an
//!    update marked by the application (resumed where a power cut left
//!    it), or the revert of a trial image that never confirmed itself;
//! 4. checks the active slot's image the same way, copying it into RAM at
//!    `entry - HEADER_PAGE` (0x0001_0000) as it reads, and hashing the
//!    copy: an image that fails is never started (the reason is logged,
//!    with whether the download slot holds a valid image, and QEMU exits
//!    with status 1);
//! 5. points VTOR at the copy's vector table (`entry`, 0x0001_0400), loads
//!    its stack pointer and jumps to its reset handler.
//!
//! The public key compiled in is `fw_keys::TRUSTED`: by default the
//! **development key** (`firmware/keys/dev.pub`), with which anyone can
//! sign. A plant builds the bootloader and the firmware with its own:
//! `HANS_FW_PUBKEY=$(cat plant.pub) cargo build --release -p
//! bootloader-mps2` (see firmware/keys/README.md).
//!
//! The log is text on semihosting's stderr (QEMU's stderr), one line per
//! step, `hans-boot: ...`: QEMU's stdout carries the application's defmt
//! frames, which are decoded with the application's ELF.
#![no_std]
#![no_main]

use core::cell::RefCell;

use cortex_m_rt::entry;
use embassy_boot::State;
use embassy_embedded_hal::flash::partition::BlockingPartition;
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embedded_storage::nor_flash::ReadNorFlash;
use fw_boot::{check_image, expect, refuse_or_swap, Pending, Refusal};
use hans_fw_image::layout::{Layout, HEADER_PAGE, MPS2_AN386};
use hans_fw_image::{Header, Version, HEADER_LEN};
use semihosting::io::Write as _;
use semihosting_flash::{FlashPath, SemihostingFlash};

/// This board's layout.
const LAYOUT: Layout = MPS2_AN386;

/// The flash file's bytes moved at once (one page: one read and one write
/// per page of the swap).
const BUF: usize = 4096;

/// A line of the log on semihosting's stderr.
struct Line {
    buf: [u8; 200],
    len: usize,
}

impl Line {
    fn new() -> Line {
        let mut line = Line {
            buf: [0; 200],
            len: 0,
        };
        line.s("hans-boot: ");
        line
    }

    fn s(&mut self, text: &str) -> &mut Line {
        for b in text.bytes() {
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = b;
                self.len += 1;
            }
        }
        self
    }

    fn n(&mut self, mut v: u32) -> &mut Line {
        let mut digits = [0u8; 10];
        let mut i = digits.len();
        loop {
            i -= 1;
            if let Some(d) = digits.get_mut(i) {
                *d = b'0' + (v % 10) as u8;
            }
            v /= 10;
            if v == 0 || i == 0 {
                break;
            }
        }
        for &d in digits.get(i..).unwrap_or(&[]) {
            if let Some(slot) = self.buf.get_mut(self.len) {
                *slot = d;
                self.len += 1;
            }
        }
        self
    }

    fn version(&mut self, v: Version) -> &mut Line {
        self.n(v.major.into())
            .s(".")
            .n(v.minor.into())
            .s(".")
            .n(v.patch.into())
    }

    fn emit(&mut self) {
        self.s("\n");
        if let Ok(mut err) = semihosting::io::stderr() {
            let _ = err.write_all(self.buf.get(..self.len).unwrap_or(&[]));
        }
    }
}

/// Logs `line` and ends QEMU with status 1.
fn fail(line: &mut Line) -> ! {
    line.emit();
    semihosting::process::exit(1)
}

/// Checks the image whose header is at `at` in the flash file, through
/// a partition-less view (the whole file).
fn check_slot(
    flash: &mut SemihostingFlash,
    at: u32,
    buf: &mut [u8; BUF],
    copy: Option<&mut [u8]>,
) -> Result<Header, Refusal> {
    check_image(flash, at, &expect(&LAYOUT, &fw_keys::TRUSTED), buf, copy)
}

#[entry]
fn main() -> ! {
    let path = match FlashPath::from_args() {
        Ok(p) => p,
        Err(e) => fail(Line::new().s("the flash file's name: ").s(e.as_str())),
    };
    let flash = match SemihostingFlash::open(&path, LAYOUT.size) {
        Ok(f) => f,
        Err(e) => fail(
            Line::new()
                .s("flash file ")
                .s(path.as_str())
                .s(": ")
                .s(e.as_str())
                .s(" (expected ")
                .n(LAYOUT.size)
                .s(" bytes; make one with hans-fw install)"),
        ),
    };
    let mut buf = [0u8; BUF];

    let shared = Mutex::<NoopRawMutex, _>::new(RefCell::new(flash));
    let prepared = {
        let part =
            |r: &core::ops::Range<u32>| BlockingPartition::new(&shared, r.start, r.end - r.start);
        refuse_or_swap(
            part(&LAYOUT.active),
            part(&LAYOUT.dfu),
            part(&LAYOUT.state),
            &LAYOUT,
            &fw_keys::TRUSTED,
            &mut buf,
        )
    };
    let mut flash = shared.into_inner().into_inner();
    let prepared = match prepared {
        Ok(p) => p,
        Err(e) => fail(Line::new().s(e.as_str())),
    };
    if let Some(e) = prepared.refused {
        Line::new()
            .s("update refused, not swapped in: ")
            .s(e.as_str())
            .s("; the running image stays")
            .emit();
    }
    if let Some(h) = prepared.swapped_in {
        Line::new()
            .s("swapped in ")
            .version(h.version)
            .s(" from the download slot")
            .emit();
    }
    match prepared.pending {
        Pending::SwapResumed => Line::new()
            .s("resumed the swap a power cut interrupted")
            .emit(),
        Pending::Revert => Line::new()
            .s("reverted: the image on trial did not confirm itself")
            .emit(),
        Pending::Boot | Pending::Swap => {}
    }
    let (pending, state) = (prepared.pending, prepared.state);

    // The active slot, checked as it is copied to where it runs.
    let run_at = LAYOUT.entry - HEADER_PAGE;
    let max = (LAYOUT.active.end - LAYOUT.active.start) as usize;
    // SAFETY: the code memory from 0x0001_0000 is RAM of QEMU's machine
    // (4 MiB at 0x0) that this bootloader (below 64 KiB, its data and
    // stack at 0x2000_0000) does not use; nothing else refers to it.
    let ram = unsafe { core::slice::from_raw_parts_mut(run_at as *mut u8, max) };
    let (head_ram, body_ram) = ram.split_at_mut(HEADER_PAGE as usize);
    let header = match check_slot(&mut flash, LAYOUT.active.start, &mut buf, Some(body_ram)) {
        Ok(h) => h,
        Err(e) => {
            let mut line = Line::new();
            line.s("the active slot's image is refused: ")
                .s(e.as_str())
                .s("; not started");
            // Say what could be started instead: an update not swapped
            // (at the slot's start) or the previous image after a swap
            // (one page further).
            for (at, what) in [
                (LAYOUT.dfu.start, "; the download slot holds a valid image "),
                (
                    LAYOUT.dfu.start + LAYOUT.page,
                    "; the download slot holds a valid previous image ",
                ),
            ] {
                if let Ok(h) = check_slot(&mut flash, at, &mut buf, None) {
                    line.s(what).version(h.version);
                    break;
                }
            }
            fail(&mut line)
        }
    };
    if let Some(first) = head_ram.get_mut(..HEADER_LEN) {
        if flash.read(LAYOUT.active.start, first).is_err() {
            fail(Line::new().s("reading the active slot's header"));
        }
    }
    drop(flash); // closes the file: the application opens it again

    // The body must be linked where it runs: its reset handler inside it.
    let vectors = body_ram.get(..8).unwrap_or(&[]);
    let reset = vectors
        .get(4..8)
        .and_then(|w| <[u8; 4]>::try_from(w).ok())
        .map(u32::from_le_bytes)
        .unwrap_or(0);
    if !(LAYOUT.entry..LAYOUT.entry + header.body_len).contains(&reset) {
        fail(
            Line::new()
                .s("the image ")
                .version(header.version)
                .s(" is not linked at ")
                .n(LAYOUT.entry)
                .s(": not started"),
        );
    }

    let mut line = Line::new();
    line.s("booting ").version(header.version);
    if pending == Pending::Revert {
        line.s(" (reverted)");
    } else if pending != Pending::Boot && state == State::Swap {
        line.s(" (swapped in: on trial until it confirms itself)");
    }
    line.emit();

    // SAFETY: the vector table at `entry` is the checked image's, copied
    // above; nothing of the bootloader is needed after the jump (no
    // interrupt enabled, the file closed).
    unsafe {
        let scb = &*cortex_m::peripheral::SCB::PTR;
        scb.vtor.write(LAYOUT.entry);
        cortex_m::asm::dsb();
        cortex_m::asm::isb();
        cortex_m::asm::bootload(LAYOUT.entry as *const u32)
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    Line::new().s("panic").emit();
    semihosting::process::exit(1)
}
