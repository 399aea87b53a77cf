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
use embassy_boot::{BootLoader, BootLoaderConfig, State};
use embassy_embedded_hal::flash::partition::BlockingPartition;
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embedded_storage::nor_flash::{NorFlash, ReadNorFlash};
use hans_gateway::update::image::{Expect, Header, ImageError, Verifier, Version, HEADER_LEN};
use hans_gateway::update::layout::{Layout, HEADER_PAGE, MPS2_AN386};
use semihosting::io::Write as _;
use semihosting_flash::{FlashPath, SemihostingFlash};

/// This board's layout.
const LAYOUT: Layout = MPS2_AN386;

/// The flash file's bytes moved at once (one page: one read and one write
/// per page of the swap).
const BUF: usize = 4096;

/// The embassy-boot state partition's words (4 bytes, the flash's write
/// size): the magic, the progress's validity, then the progress indices
/// (embassy-boot 0.7, `BootLoader`'s documentation of the format).
const WORD: u32 = 4;
const SWAP_MAGIC: u8 = 0xF0;
const ERASED: u8 = 0xFF;

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

/// What the boot state asks for, read before embassy-boot acts on it.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Pending {
    /// Nothing: boot the active slot.
    Boot,
    /// A swap marked by the application, not begun.
    Swap,
    /// A swap a power cut interrupted: embassy-boot resumes it.
    SwapResumed,
    /// The swapped-in image ran but never confirmed itself: revert.
    Revert,
}

/// Reads the boot state as embassy-boot 0.7 will (`prepare_boot`): swap
/// magic in the first word; the swap's progress from the third word on, a
/// word with an erased byte being a step not done; invalid progress (the
/// second word written) counts as swapped.
fn read_pending(
    flash: &mut SemihostingFlash,
    buf: &mut [u8; BUF],
) -> Result<Pending, &'static str> {
    let state = buf
        .get_mut(..(LAYOUT.state.end - LAYOUT.state.start) as usize)
        .ok_or("the boot state is larger than the buffer")?;
    flash
        .read(LAYOUT.state.start, state)
        .map_err(|e| e.as_str())?;
    let word = |i: u32| {
        let at = (i * WORD) as usize;
        state.get(at..at + WORD as usize).unwrap_or(&[])
    };
    if word(0).iter().any(|b| *b != SWAP_MAGIC) {
        return Ok(Pending::Boot);
    }
    let pages = (LAYOUT.active.end - LAYOUT.active.start) / LAYOUT.page;
    let max_index = (state.len() as u32 - WORD) / WORD - 2;
    let progress = if word(1).iter().any(|b| *b != ERASED) {
        max_index
    } else {
        (0..max_index)
            .find(|i| word(2 + i).contains(&ERASED))
            .unwrap_or(max_index)
    };
    Ok(if progress >= 2 * pages {
        Pending::Revert
    } else if progress == 0 {
        Pending::Swap
    } else {
        Pending::SwapResumed
    })
}

/// What an image must match here: signed by the trusted key, for this board, no
/// larger than a slot. Any version: the application refused a downgrade
/// the administrator did not allow before it marked the update.
fn expect() -> Expect<'static> {
    Expect {
        key: &fw_keys::TRUSTED,
        board: LAYOUT.board,
        running: Version {
            major: 0,
            minor: 0,
            patch: 0,
        },
        allow_downgrade: true,
        max_body: LAYOUT.max_body(),
    }
}

/// Why an image is refused: its own checks, or the flash.
#[derive(Clone, Copy)]
enum Refusal {
    Image(ImageError),
    Flash(&'static str),
}

impl Refusal {
    fn as_str(self) -> &'static str {
        match self {
            Refusal::Image(e) => e.as_str(),
            Refusal::Flash(e) => e,
        }
    }
}

/// Checks the image whose header is at `at` in the flash file (its body
/// at `at + HEADER_PAGE`); with `copy`, each piece of the body read goes
/// to `copy` first and is hashed from there (the RAM the image runs in).
fn check_slot(
    flash: &mut SemihostingFlash,
    at: u32,
    buf: &mut [u8; BUF],
    mut copy: Option<&mut [u8]>,
) -> Result<Header, Refusal> {
    let head = buf.get_mut(..HEADER_LEN).ok_or(Refusal::Flash("buffer"))?;
    flash
        .read(at, head)
        .map_err(|e| Refusal::Flash(e.as_str()))?;
    let mut v = Verifier::new(head, &expect()).map_err(Refusal::Image)?;
    let len = v.header().body_len;
    let body = at + HEADER_PAGE;
    let mut done = 0u32;
    while done < len {
        let n = (len - done).min(BUF as u32);
        let piece = match copy.as_deref_mut() {
            Some(ram) => ram
                .get_mut(done as usize..(done + n) as usize)
                .ok_or(Refusal::Image(ImageError::TooLarge))?,
            None => buf.get_mut(..n as usize).ok_or(Refusal::Flash("buffer"))?,
        };
        flash
            .read(body + done, piece)
            .map_err(|e| Refusal::Flash(e.as_str()))?;
        v.update(piece).map_err(Refusal::Image)?;
        done += n;
    }
    v.finish().map_err(Refusal::Image)
}

#[entry]
fn main() -> ! {
    let path = match FlashPath::from_args() {
        Ok(p) => p,
        Err(e) => fail(Line::new().s("the flash file's name: ").s(e.as_str())),
    };
    let mut flash = match SemihostingFlash::open(&path, LAYOUT.size) {
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

    let mut pending = match read_pending(&mut flash, &mut buf) {
        Ok(p) => p,
        Err(e) => fail(Line::new().s("boot state: ").s(e)),
    };
    if pending == Pending::Swap {
        // Never swap in an image that would not be started: the running
        // one stays, and the boot state is cleared (the application then
        // sees no update pending).
        match check_slot(&mut flash, LAYOUT.dfu.start, &mut buf, None) {
            Ok(h) => Line::new()
                .s("swapping in ")
                .version(h.version)
                .s(" from the download slot")
                .emit(),
            Err(e) => {
                Line::new()
                    .s("update refused, not swapped in: ")
                    .s(e.as_str())
                    .s("; the running image stays")
                    .emit();
                if let Err(e) = flash.erase(LAYOUT.state.start, LAYOUT.state.end) {
                    fail(Line::new().s("clearing the boot state: ").s(e.as_str()));
                }
                pending = Pending::Boot;
            }
        }
    }
    match pending {
        Pending::SwapResumed => Line::new()
            .s("resuming the swap a power cut interrupted")
            .emit(),
        Pending::Revert => Line::new()
            .s("reverting: the image on trial did not confirm itself")
            .emit(),
        Pending::Boot | Pending::Swap => {}
    }

    let shared = Mutex::<NoopRawMutex, _>::new(RefCell::new(flash));
    let state = {
        let part =
            |r: &core::ops::Range<u32>| BlockingPartition::new(&shared, r.start, r.end - r.start);
        let mut bl = BootLoader::new(BootLoaderConfig {
            active: part(&LAYOUT.active),
            dfu: part(&LAYOUT.dfu),
            state: part(&LAYOUT.state),
        });
        bl.prepare_boot(&mut buf)
    };
    let mut flash = shared.into_inner().into_inner();
    let state = match state {
        Ok(s) => s,
        Err(_) => fail(Line::new().s("the swap failed (flash error)")),
    };

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
