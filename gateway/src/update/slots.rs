//! The firmware slots as the application sees them: the running image's
//! header, the download slot it writes an update into, and the boot state
//! it marks (an update to swap in, a trial image confirmed).
//!
//! [`BootSlots`] is the implementation over embassy-boot's state partition
//! (the bootloader of the boards is embassy-boot: its power-fail-safe swap
//! and rollback are tested under a power cut at every write and erase in
//! `gateway/tests/update_swap.rs`). The download slot is written here
//! rather than through embassy-boot's `FirmwareUpdater`, whose writer keeps
//! a borrowed buffer (a self-referential struct for a long-lived owner);
//! its rule is the same: a page is erased when the first byte is written
//! into it.

use embedded_storage_async::nor_flash::{NorFlash, NorFlashError, NorFlashErrorKind};

use embassy_boot::{AlignedBuffer, FirmwareState, FirmwareUpdaterError, State};

/// Which slot to read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Slot {
    /// The running image.
    Active,
    /// The download slot: an update being written.
    Dfu,
    /// The previous image, after a swap: in the download slot one page
    /// in (where embassy-boot's swap leaves the old image's pages).
    Previous,
}

pub use crate::state::firmware::BootState;

/// Why a slot operation failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SlotError {
    /// This platform installs no firmware (Linux: the package does).
    Unsupported,
    /// The flash reported an error.
    Flash,
    /// Out of the slot, or not aligned to the flash's write size.
    OutOfRange,
    /// The running image is on trial: it must be confirmed (or rolled
    /// back) before another update is written.
    OnTrial,
}

impl SlotError {
    /// A short text for the page and the log.
    pub fn as_str(self) -> &'static str {
        match self {
            SlotError::Unsupported => {
                "this gateway installs no firmware (updates come with its package)"
            }
            SlotError::Flash => "flash error while writing the update",
            SlotError::OutOfRange => "write outside the update slot",
            SlotError::OnTrial => "the running firmware is on trial: it must confirm itself first",
        }
    }
}

impl From<FirmwareUpdaterError> for SlotError {
    fn from(e: FirmwareUpdaterError) -> Self {
        match e {
            FirmwareUpdaterError::BadState => SlotError::OnTrial,
            _ => SlotError::Flash,
        }
    }
}

fn flash<E: NorFlashError>(e: E) -> SlotError {
    match e.kind() {
        NorFlashErrorKind::NotAligned | NorFlashErrorKind::OutOfBounds => SlotError::OutOfRange,
        _ => SlotError::Flash,
    }
}

/// What the gateway needs of the firmware slots. Writes go to the
/// download slot only; the active slot is read (its header).
// The futures are deliberately not `Send` (single-threaded executors).
#[allow(async_fn_in_trait)]
pub trait Slots {
    /// The boot state.
    async fn state(&mut self) -> Result<BootState, SlotError>;
    /// Reads `buf.len()` bytes of `slot` from `offset`.
    async fn read(&mut self, slot: Slot, offset: u32, buf: &mut [u8]) -> Result<(), SlotError>;
    /// Writes `data` into the download slot at `offset` (a multiple of the
    /// flash's write size; `data` too, but for the last piece, which is
    /// padded with the erased value), erasing each page when the first
    /// byte is written into it. Refused while the running image is on
    /// trial or an update is pending (the swap would take a half-written
    /// slot).
    async fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), SlotError>;
    /// Marks the download slot for the swap at the next restart.
    async fn mark_updated(&mut self) -> Result<(), SlotError>;
    /// Confirms the running image (ends its trial).
    async fn confirm(&mut self) -> Result<(), SlotError>;
}

/// The largest write size of a flash [`BootSlots`] takes (the F7's is 32
/// bytes in its widest mode).
const WORD_MAX: usize = 32;

/// The slots of a board with embassy-boot's bootloader: the active slot,
/// the download slot and the boot state, each a partition of its own.
pub struct BootSlots<A, D, S> {
    active: A,
    dfu: D,
    state: S,
    aligned: AlignedBuffer<WORD_MAX>,
    /// The page erased last (written since): writes go forward.
    erased: Option<u32>,
    /// A write since the last [`Slots::mark_updated`]: a pending update is
    /// overwritten, so its mark must go.
    pending: bool,
}

impl<A: NorFlash, D: NorFlash, S: NorFlash> BootSlots<A, D, S> {
    /// The slots over their partitions.
    pub fn new(active: A, dfu: D, state: S) -> Self {
        const {
            assert!(S::WRITE_SIZE <= WORD_MAX && S::READ_SIZE <= WORD_MAX);
            assert!(D::WRITE_SIZE <= WORD_MAX);
        }
        BootSlots {
            active,
            dfu,
            state,
            aligned: AlignedBuffer([0; WORD_MAX]),
            erased: None,
            pending: false,
        }
    }

    fn firmware_state(&mut self) -> FirmwareState<'_, &mut S> {
        let n = S::WRITE_SIZE.max(S::READ_SIZE);
        // `new` checks n <= WORD_MAX at compile time.
        let aligned = self.aligned.0.get_mut(..n).unwrap_or(&mut []);
        FirmwareState::new(&mut self.state, aligned)
    }
}

impl<A: NorFlash, D: NorFlash, S: NorFlash> Slots for BootSlots<A, D, S> {
    async fn state(&mut self) -> Result<BootState, SlotError> {
        let state = self.firmware_state().get_state().await?;
        Ok(match state {
            // The magic says "swap" both before the swap (an update
            // marked) and after it (the new image on trial): the running
            // application knows which from whether it marked one itself.
            State::Swap if self.pending => BootState::Pending,
            State::Swap => BootState::Trial,
            State::Revert => BootState::RolledBack,
            State::Boot | State::DfuDetach => BootState::Confirmed,
        })
    }

    async fn read(&mut self, slot: Slot, offset: u32, buf: &mut [u8]) -> Result<(), SlotError> {
        match slot {
            Slot::Active => self.active.read(offset, buf).await.map_err(flash),
            Slot::Dfu => self.dfu.read(offset, buf).await.map_err(flash),
            Slot::Previous => {
                let page = A::ERASE_SIZE.max(D::ERASE_SIZE) as u32;
                let at = offset.checked_add(page).ok_or(SlotError::OutOfRange)?;
                self.dfu.read(at, buf).await.map_err(flash)
            }
        }
    }

    async fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), SlotError> {
        match self.state().await? {
            BootState::Trial => return Err(SlotError::OnTrial),
            BootState::Pending => {
                // A new upload replaces the marked one: unmark it first,
                // so that a restart in the middle swaps nothing.
                self.firmware_state().mark_booted().await?;
                self.pending = false;
            }
            BootState::Confirmed | BootState::RolledBack => {}
        }
        let page = D::ERASE_SIZE as u32;
        let end = offset
            .checked_add(data.len() as u32)
            .filter(|e| *e as usize <= self.dfu.capacity())
            .ok_or(SlotError::OutOfRange)?;
        if offset == 0 {
            self.erased = None;
        }
        let mut at = offset;
        let mut rest = data;
        while at < end {
            let this_page = at / page;
            if self.erased.is_none_or(|p| p < this_page) {
                let start = this_page * page;
                self.dfu.erase(start, start + page).await.map_err(flash)?;
                self.erased = Some(this_page);
            }
            let upto = ((this_page + 1) * page).min(end);
            let (now, later) = rest.split_at((upto - at) as usize);
            self.write_padded(at, now).await?;
            at = upto;
            rest = later;
        }
        Ok(())
    }

    async fn mark_updated(&mut self) -> Result<(), SlotError> {
        self.firmware_state().mark_updated().await?;
        self.pending = true;
        Ok(())
    }

    async fn confirm(&mut self) -> Result<(), SlotError> {
        Ok(self.firmware_state().mark_booted().await?)
    }
}

impl<A: NorFlash, D: NorFlash, S: NorFlash> BootSlots<A, D, S> {
    /// Writes `data` at `at`; a tail shorter than the write size is padded
    /// with the erased value (0xFF).
    async fn write_padded(&mut self, at: u32, data: &[u8]) -> Result<(), SlotError> {
        let w = D::WRITE_SIZE.max(1);
        if !(at as usize).is_multiple_of(w) {
            return Err(SlotError::OutOfRange);
        }
        let whole = data.len() - data.len() % w;
        let (head, tail) = data.split_at(whole);
        if !head.is_empty() {
            self.dfu.write(at, head).await.map_err(flash)?;
        }
        if !tail.is_empty() {
            let mut word = [0xFFu8; WORD_MAX];
            let word = word.get_mut(..w).ok_or(SlotError::OutOfRange)?;
            word.get_mut(..tail.len())
                .ok_or(SlotError::OutOfRange)?
                .copy_from_slice(tail);
            self.dfu
                .write(at + whole as u32, word)
                .await
                .map_err(flash)?;
        }
        Ok(())
    }
}

/// One operation on the slots, as a medium's
/// [`Storage::firmware`](crate::storage::Storage::firmware) takes it (one
/// method, so that a medium without slots needs no code for them).
#[derive(Debug)]
pub enum SlotOp<'a> {
    /// [`Slots::state`], into the place given.
    State(&'a mut BootState),
    /// [`Slots::read`].
    Read {
        /// Which slot.
        slot: Slot,
        /// From where.
        offset: u32,
        /// Into what.
        buf: &'a mut [u8],
    },
    /// [`Slots::write`].
    Write {
        /// Where in the download slot.
        offset: u32,
        /// What.
        data: &'a [u8],
    },
    /// [`Slots::mark_updated`].
    MarkUpdated,
    /// [`Slots::confirm`].
    Confirm,
}

impl SlotOp<'_> {
    /// Does the operation on `slots`.
    pub async fn apply<U: Slots>(self, slots: &mut U) -> Result<(), SlotError> {
        match self {
            SlotOp::State(out) => {
                *out = slots.state().await?;
                Ok(())
            }
            SlotOp::Read { slot, offset, buf } => slots.read(slot, offset, buf).await,
            SlotOp::Write { offset, data } => slots.write(offset, data).await,
            SlotOp::MarkUpdated => slots.mark_updated().await,
            SlotOp::Confirm => slots.confirm().await,
        }
    }
}
