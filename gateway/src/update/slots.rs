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

use crate::storage::{AuditStore, ConfigStore, Image, Medium, StorageError};

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
pub trait SlotStore {
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
    /// A write since the last [`SlotStore::mark_updated`]: a pending update is
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

impl<A: NorFlash, D: NorFlash, S: NorFlash> SlotStore for BootSlots<A, D, S> {
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

/// A medium (`storage`) and the firmware slots of the board (`slots`):
/// the configuration and audit calls go to the first, the slots' to the
/// second.
#[derive(Debug)]
pub struct WithSlots<S, U> {
    /// The configuration's (and audit log's) medium.
    pub storage: S,
    /// The firmware slots.
    pub slots: U,
}

impl<S: ConfigStore, U> ConfigStore for WithSlots<S, U> {
    async fn load(&mut self) -> Result<&[u8], StorageError> {
        self.storage.load().await
    }
    async fn save(&mut self, image: &dyn Image) -> Result<(), StorageError> {
        self.storage.save(image).await
    }
    fn medium(&self) -> Medium {
        self.storage.medium()
    }
}

impl<S: AuditStore, U> AuditStore for WithSlots<S, U> {
    async fn read(&mut self, each: &mut dyn FnMut(&[u8])) -> Result<(), StorageError> {
        self.storage.read(each).await
    }
    async fn append(&mut self, record: &[u8]) -> Result<(), StorageError> {
        self.storage.append(record).await
    }
    fn persistent(&self) -> bool {
        self.storage.persistent()
    }
}

impl<S, U: SlotStore> SlotStore for WithSlots<S, U> {
    async fn state(&mut self) -> Result<BootState, SlotError> {
        self.slots.state().await
    }
    async fn read(&mut self, slot: Slot, offset: u32, buf: &mut [u8]) -> Result<(), SlotError> {
        self.slots.read(slot, offset, buf).await
    }
    async fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), SlotError> {
        self.slots.write(offset, data).await
    }
    async fn mark_updated(&mut self) -> Result<(), SlotError> {
        self.slots.mark_updated().await
    }
    async fn confirm(&mut self) -> Result<(), SlotError> {
        self.slots.confirm().await
    }
}

/// No firmware slots: a platform that installs no image (Linux: its
/// package does; a board without the update layout). Every operation
/// answers [`SlotError::Unsupported`].
#[derive(Clone, Copy, Debug, Default)]
pub struct NoSlots;

impl SlotStore for NoSlots {
    async fn state(&mut self) -> Result<BootState, SlotError> {
        Err(SlotError::Unsupported)
    }
    async fn read(&mut self, _: Slot, _: u32, _: &mut [u8]) -> Result<(), SlotError> {
        Err(SlotError::Unsupported)
    }
    async fn write(&mut self, _: u32, _: &[u8]) -> Result<(), SlotError> {
        Err(SlotError::Unsupported)
    }
    async fn mark_updated(&mut self) -> Result<(), SlotError> {
        Err(SlotError::Unsupported)
    }
    async fn confirm(&mut self) -> Result<(), SlotError> {
        Err(SlotError::Unsupported)
    }
}

/// Nothing kept, no firmware slots either.
impl SlotStore for crate::storage::NoStorage {
    async fn state(&mut self) -> Result<BootState, SlotError> {
        NoSlots.state().await
    }
    async fn read(&mut self, slot: Slot, offset: u32, buf: &mut [u8]) -> Result<(), SlotError> {
        NoSlots.read(slot, offset, buf).await
    }
    async fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), SlotError> {
        NoSlots.write(offset, data).await
    }
    async fn mark_updated(&mut self) -> Result<(), SlotError> {
        NoSlots.mark_updated().await
    }
    async fn confirm(&mut self) -> Result<(), SlotError> {
        NoSlots.confirm().await
    }
}

impl<S: SlotStore> SlotStore for &mut S {
    async fn state(&mut self) -> Result<BootState, SlotError> {
        (**self).state().await
    }
    async fn read(&mut self, slot: Slot, offset: u32, buf: &mut [u8]) -> Result<(), SlotError> {
        (**self).read(slot, offset, buf).await
    }
    async fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), SlotError> {
        (**self).write(offset, data).await
    }
    async fn mark_updated(&mut self) -> Result<(), SlotError> {
        (**self).mark_updated().await
    }
    async fn confirm(&mut self) -> Result<(), SlotError> {
        (**self).confirm().await
    }
}
