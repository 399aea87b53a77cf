//! Firmware updates (feature `update`): signed images (the crate
//! `hans-fw-image`) written into the download slot of an A/B layout
//! ([`layout`], [`slots`]) while
//! the gateway keeps serving, swapped in by the bootloader (embassy-boot)
//! at the restart an administrator asks for, run on trial, and confirmed
//! by the new image's own check or rolled back.
//!
//! The flash belongs to the storage task (it also saves the configuration
//! and keeps the audit log: one owner for one flash controller). The web
//! server's upload hands it the image piece by piece through the hub's
//! [`Updates`] mailbox: one piece of [`PIECE`] bytes in flight, so an
//! upload holds one buffer and never more than one flash operation waits.
//! A slow flash slows the upload (TCP's window closes), never the engine
//! or the Modbus sessions.

pub mod slots;

use core::cell::{Cell, RefCell};

use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::mutex::{Mutex, MutexGuard};
use embassy_sync::signal::Signal;

pub use hans_fw_image::{layout, Header, ImageError, Version};
pub use slots::{BootSlots, BootState, NoSlots, Slot, SlotError, SlotStore, WithSlots};

/// Bytes handed to the storage task at once (a multiple of every flash
/// write size the boards have, and at least an image header). Small: the
/// buffer is static RAM of every field device, and a piece costs a signal
/// there and back, nothing that a larger one would save.
pub const PIECE: usize = 512;

const _: () = assert!(PIECE >= hans_fw_image::HEADER_LEN);

/// What the storage task is asked to do with the slots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Op {
    /// Read the boot state into the state again (an upload's writes may
    /// have unmarked an update that waited for the restart). The versions
    /// stay those read at start: the running one does not change until a
    /// restart, and the previous one is the version the running firmware
    /// replaced, which no upload (refused or not) changes.
    BootState,
    /// Write `len` bytes of the piece buffer into the download slot at
    /// `offset`.
    Write { offset: u32, len: usize },
    /// Mark the download slot for the swap at the next restart.
    MarkUpdated,
    /// Confirm the running image (end its trial).
    Confirm,
}

pub use crate::state::firmware::{Firmware as Status, Upload};

/// The mailbox between the web server's upload and the storage task (in
/// the hub); the firmware's status is in the state (`Model::firmware`).
pub struct Updates {
    request: Signal<NoopRawMutex, Op>,
    done: Signal<NoopRawMutex, Result<(), SlotError>>,
    /// One operation (one upload) at a time.
    lock: Mutex<NoopRawMutex, ()>,
    /// The piece being handed over.
    pub(crate) piece: RefCell<[u8; PIECE]>,
    /// The key, board id and largest body an upload must match
    /// ([`Updates::trust_images`]); `None`: nothing is installed.
    trust: Cell<Option<([u8; 32], &'static str, u32)>>,
}

impl Default for Updates {
    fn default() -> Self {
        Self::new()
    }
}

impl Updates {
    /// An idle mailbox, trusting no image.
    pub const fn new() -> Self {
        Updates {
            request: Signal::new(),
            done: Signal::new(),
            lock: Mutex::new(()),
            piece: RefCell::new([0; PIECE]),
            trust: Cell::new(None),
        }
    }

    /// Uploads are checked against `key` and `board` (whose layout gives
    /// the largest body, see [`layout::of`]); a board without a layout
    /// installs nothing.
    pub fn trust_images(&self, key: [u8; 32], board: &'static str) {
        self.trust
            .set(layout::of(board).map(|l| (key, board, l.max_body())));
    }

    /// What an upload must match: the key, the board id, the largest body.
    pub(crate) fn trust(&self) -> Option<([u8; 32], &'static str, u32)> {
        self.trust.get()
    }

    /// Takes the mailbox for one operation or a whole upload; `None` if
    /// it is taken (another upload runs).
    pub(crate) fn try_take(&self) -> Option<MutexGuard<'_, NoopRawMutex, ()>> {
        self.lock.try_lock().ok()
    }

    /// Waits for the mailbox (the trial check's confirmation).
    pub(crate) async fn take(&self) -> MutexGuard<'_, NoopRawMutex, ()> {
        self.lock.lock().await
    }

    /// Has the storage task do `op` and returns its result. The caller
    /// holds the mailbox ([`Self::try_take`]).
    pub(crate) async fn ask(&self, op: Op) -> Result<(), SlotError> {
        self.done.reset();
        self.request.signal(op);
        self.done.wait().await
    }

    /// The storage task's side: the next operation asked.
    pub(crate) async fn next(&self) -> Op {
        self.request.wait().await
    }

    /// The storage task's side: the result of the operation.
    pub(crate) fn answer(&self, result: Result<(), SlotError>) {
        self.done.signal(result);
    }
}
