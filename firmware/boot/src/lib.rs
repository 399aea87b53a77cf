//! What every board's bootloader decides, over the board's three flash
//! partitions (boot state, active slot, download slot; see
//! `hans_fw_image::layout`), written once for the QEMU board's
//! bootloader (`bootloader-mps2`) and the NUCLEO's (`bootloader-nucleo`):
//!
//! 1. [`read_pending`]: what the boot state asks for, read as embassy-boot
//!    0.7 will read it (a swap not begun, one a power cut interrupted, the
//!    revert of a trial image that never confirmed itself);
//! 2. [`refuse_or_swap`]: before a swap that has not begun, the image in
//!    the download slot is checked ([`check_image`]: signature with the
//!    key compiled in, board, size, hash) and one that fails is never
//!    swapped in (the boot state is cleared: the running image stays);
//!    then embassy-boot's power-fail-safe `prepare_boot` swaps, resumes or
//!    reverts;
//! 3. the board checks the active slot's image ([`check_image`]) and
//!    starts it only if it passes (the QEMU board copies it to RAM as it
//!    reads; the NUCLEO runs it in place).
//!
//! The boards keep what differs: the flash drivers, where the log goes,
//! the jump.
#![no_std]

use embassy_boot::{BootLoader, BootLoaderConfig, State};
use embedded_storage::nor_flash::{NorFlash, ReadNorFlash};
use hans_fw_image::layout::{Layout, HEADER_PAGE};
use hans_fw_image::{Expect, Header, ImageError, Verifier, Version, HEADER_LEN};

/// The boot state's words (embassy-boot 0.7: the magic, the progress's
/// validity, then one word per step of the swap), `WORD` bytes each (the
/// flash's write size).
const SWAP_MAGIC: u8 = 0xF0;
const ERASED: u8 = 0xFF;

/// What the boot state asks for, read before embassy-boot acts on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pending {
    /// Nothing: boot the active slot.
    Boot,
    /// A swap marked by the application, not begun.
    Swap,
    /// A swap a power cut interrupted: embassy-boot resumes it.
    SwapResumed,
    /// The swapped-in image ran but never confirmed itself: revert.
    Revert,
}

/// Why an image is refused: its own checks, or the flash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Refusal {
    /// The image's checks.
    Image(ImageError),
    /// The flash failed to read.
    Flash,
}

impl Refusal {
    /// A short text for the log.
    pub fn as_str(self) -> &'static str {
        match self {
            Refusal::Image(e) => e.as_str(),
            Refusal::Flash => "flash read error",
        }
    }
}

/// Reads the boot state (`state`, the whole partition, through `buf`) as
/// embassy-boot 0.7 will in `prepare_boot`: the swap magic in the first
/// word; the swap's progress from the third word on, a word with an erased
/// byte being a step not done; invalid progress (the second word written)
/// counts as swapped. `word` is the state flash's write size; `pages` the
/// active slot's pages.
pub fn read_pending<S: ReadNorFlash>(
    state: &mut S,
    word: usize,
    pages: u32,
    buf: &mut [u8],
) -> Result<Pending, Refusal> {
    // The magic and the progress's words fit the buffer (a bootloader's
    // buffer is a page); the rest of the partition is never progress.
    let len = state.capacity().min(buf.len());
    let state_bytes = buf.get_mut(..len).ok_or(Refusal::Flash)?;
    state.read(0, state_bytes).map_err(|_| Refusal::Flash)?;
    let at = |i: usize| state_bytes.get(i * word..(i + 1) * word).unwrap_or(&[]);
    if at(0).is_empty() || at(0).iter().any(|b| *b != SWAP_MAGIC) {
        return Ok(Pending::Boot);
    }
    let max_index = (len / word).saturating_sub(2) as u32;
    let progress = if at(1).iter().any(|b| *b != ERASED) {
        max_index
    } else {
        (0..max_index)
            .find(|i| at(2 + *i as usize).contains(&ERASED))
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

/// What an image must match to be started or swapped in: signed by `key`,
/// for `layout`'s board, no larger than a slot. Any version: the
/// application refused a downgrade the administrator did not allow before
/// it marked the update.
pub fn expect<'k>(layout: &Layout, key: &'k [u8; 32]) -> Expect<'k>
where
    'static: 'k,
{
    Expect {
        key,
        board: layout.board,
        running: Version {
            major: 0,
            minor: 0,
            patch: 0,
        },
        allow_downgrade: true,
        max_body: layout.max_body(),
    }
}

/// Checks the image whose header is at `at` of `flash` (its body at
/// `at + HEADER_PAGE`), reading through `buf`; with `copy`, each piece of
/// the body goes to `copy` first and is hashed from there (the RAM the
/// image will run in).
pub fn check_image<F: ReadNorFlash>(
    flash: &mut F,
    at: u32,
    expect: &Expect<'_>,
    buf: &mut [u8],
    mut copy: Option<&mut [u8]>,
) -> Result<Header, Refusal> {
    let head = buf.get_mut(..HEADER_LEN).ok_or(Refusal::Flash)?;
    flash.read(at, head).map_err(|_| Refusal::Flash)?;
    let mut v = Verifier::new(head, expect).map_err(Refusal::Image)?;
    let len = v.header().body_len;
    let body = at + HEADER_PAGE;
    let step = buf.len() as u32;
    let mut done = 0u32;
    while done < len {
        let n = (len - done).min(step);
        let piece = match copy.as_deref_mut() {
            Some(ram) => ram
                .get_mut(done as usize..(done + n) as usize)
                .ok_or(Refusal::Image(ImageError::TooLarge))?,
            None => buf.get_mut(..n as usize).ok_or(Refusal::Flash)?,
        };
        flash.read(body + done, piece).map_err(|_| Refusal::Flash)?;
        v.update(piece).map_err(Refusal::Image)?;
        done += n;
    }
    v.finish().map_err(Refusal::Image)
}

/// What [`refuse_or_swap`] did.
#[derive(Debug)]
pub struct Prepared {
    /// What the boot state asked for (after a refusal: [`Pending::Boot`]).
    pub pending: Pending,
    /// The update swapped in (its header), if one was.
    pub swapped_in: Option<Header>,
    /// The update refused, and why (the boot state was cleared).
    pub refused: Option<Refusal>,
    /// embassy-boot's state after `prepare_boot`.
    pub state: State,
}

/// Why the bootloader cannot go on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BootFail {
    /// The boot state could not be read.
    State,
    /// The boot state could not be cleared after a refused update.
    Clear,
    /// The swap failed (a flash error).
    Swap,
}

impl BootFail {
    /// A short text for the log.
    pub fn as_str(self) -> &'static str {
        match self {
            BootFail::State => "the boot state cannot be read",
            BootFail::Clear => "the boot state cannot be cleared",
            BootFail::Swap => "the swap failed (flash error)",
        }
    }
}

/// Steps 1 and 2: reads the boot state, refuses an update that fails its
/// checks (clearing the boot state) or lets embassy-boot swap it in (or
/// resume a swap, or revert a trial image). `buf` is a page of the slots
/// (embassy-boot's progress unit), aligned for the flashes.
pub fn refuse_or_swap<A: NorFlash, D: NorFlash, S: NorFlash>(
    active: A,
    mut dfu: D,
    mut state: S,
    layout: &Layout,
    key: &[u8; 32],
    buf: &mut [u8],
) -> Result<Prepared, BootFail> {
    let pages = (layout.active.end - layout.active.start) / layout.page;
    let mut pending =
        read_pending(&mut state, S::WRITE_SIZE, pages, buf).map_err(|_| BootFail::State)?;
    let mut swapped_in = None;
    let mut refused = None;
    if pending == Pending::Swap {
        match check_image(&mut dfu, 0, &expect(layout, key), buf, None) {
            Ok(h) => swapped_in = Some(h),
            Err(e) => {
                refused = Some(e);
                let end = state.capacity() as u32;
                state.erase(0, end).map_err(|_| BootFail::Clear)?;
                pending = Pending::Boot;
            }
        }
    }
    let mut bl = BootLoader::new(BootLoaderConfig { active, dfu, state });
    let state = bl.prepare_boot(buf).map_err(|_| BootFail::Swap)?;
    Ok(Prepared {
        pending,
        swapped_in,
        refused,
        state,
    })
}
