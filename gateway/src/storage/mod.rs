//! Where the configuration and the trigger table are kept.
//!
//! The stored image ([`image`]) holds the applied configuration, the
//! sixteen trigger entries and the web password's hash, with a CRC. It is written by the storage task
//! (`task`), one of the gateway's futures, so that a save never stops the
//! robot link, the watchdog or the Modbus sessions: the medium is driven
//! through async calls that yield between flash operations.
//!
//! Implementations:
//! * [`NoStorage`]: no persistence (the QEMU board, the host without
//!   `--config`); a configuration applied with it is "applied, not saved".
//! * [`flash::FlashStorage`] (feature `flash`): a power-fail-safe map in
//!   NOR flash (sequential-storage over embedded-storage-async's
//!   `NorFlash`). A power cut at any moment of a save leaves the old or the
//!   new image.
//! * `FileStorage` in [`crate::host`] (feature `std`): a file, replaced
//!   atomically (write, fsync, rename, fsync the directory).
//!
//! The same medium keeps the audit log's records (feature `audit`, see
//! `crate::audit`): [`Storage::audit_append`] and [`Storage::audit_read`],
//! by default not kept. The flash storage keeps them in a ring of its own
//! sectors ([`flash::FlashStorage::with_audit`]); on Linux [`WithAudit`]
//! joins the configuration file and the audit file
//! (`host::audit_file::AuditFile`).

#[cfg(feature = "flash")]
pub mod flash;
pub mod image;

pub use image::{ImageError, Stored, IMAGE_LEN, IMAGE_MAX};

/// Why storage failed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum StorageError {
    /// The medium reported an error.
    Io,
    /// The image does not fit the medium or the buffer.
    TooLarge,
}

/// Something that writes an image: the storage task's view of the current
/// configuration and trigger table. A medium calls it to fill its own
/// buffer, so the image exists once, where the medium needs it.
pub trait Image {
    /// Writes the image into `out` (at least [`IMAGE_LEN`] bytes) and
    /// returns its length.
    fn write(&self, out: &mut [u8]) -> Result<usize, StorageError>;
}

/// A medium for the stored image. Calls are rare (at start, and on each
/// apply); they must not block the executor for more than a few
/// milliseconds at a time: yield (await) between slow operations.
// The futures are deliberately not `Send` (single-threaded executors).
#[allow(async_fn_in_trait)]
pub trait Storage {
    /// The stored image, empty when nothing is stored (valid until the
    /// next call).
    async fn load(&mut self) -> Result<&[u8], StorageError>;

    /// Replaces the stored image with the one `image` writes.
    async fn save(&mut self, image: &dyn Image) -> Result<(), StorageError>;

    /// `true` if a saved image survives a restart (file, flash). A
    /// configuration applied with a storage that does not is reported as
    /// "applied, not saved" (`CONFIG_RESULT` 3).
    fn is_persistent(&self) -> bool {
        true
    }

    /// Calls `each` with every audit record kept (the bytes
    /// [`Storage::audit_append`] was given), oldest first: the gateway reads
    /// them at start (the boot counter, the page's newest records).
    /// Default: none are kept.
    async fn audit_read(&mut self, each: &mut dyn FnMut(&[u8])) -> Result<(), StorageError> {
        let _ = each;
        Ok(())
    }

    /// Keeps one audit record (at most 128 bytes) so that it survives a
    /// restart and a power cut (a cut loses at most this record); when
    /// the medium is full the oldest records go. Default: not kept.
    async fn audit_append(&mut self, record: &[u8]) -> Result<(), StorageError> {
        let _ = record;
        Ok(())
    }

    /// `true` if audit records are kept ([`Storage::audit_append`]).
    fn audit_persistent(&self) -> bool {
        false
    }

    /// Does `op` on the firmware slots of the medium (feature `update`,
    /// see [`WithSlots`]). Default: there are none
    /// ([`SlotError::Unsupported`](crate::update::SlotError)).
    #[cfg(feature = "update")]
    async fn firmware(
        &mut self,
        op: crate::update::SlotOp<'_>,
    ) -> Result<(), crate::update::SlotError> {
        let _ = op;
        Err(crate::update::SlotError::Unsupported)
    }
}

impl<S: Storage> Storage for &mut S {
    async fn load(&mut self) -> Result<&[u8], StorageError> {
        (**self).load().await
    }
    async fn save(&mut self, image: &dyn Image) -> Result<(), StorageError> {
        (**self).save(image).await
    }
    fn is_persistent(&self) -> bool {
        (**self).is_persistent()
    }
    async fn audit_read(&mut self, each: &mut dyn FnMut(&[u8])) -> Result<(), StorageError> {
        (**self).audit_read(each).await
    }
    async fn audit_append(&mut self, record: &[u8]) -> Result<(), StorageError> {
        (**self).audit_append(record).await
    }
    fn audit_persistent(&self) -> bool {
        (**self).audit_persistent()
    }
    #[cfg(feature = "update")]
    async fn firmware(
        &mut self,
        op: crate::update::SlotOp<'_>,
    ) -> Result<(), crate::update::SlotError> {
        (**self).firmware(op).await
    }
}

/// A medium for audit records alone (the Linux file), joined to the
/// configuration's medium by [`WithAudit`]. The methods are those of
/// [`Storage`] of the same names.
// The futures are deliberately not `Send` (single-threaded executors).
#[allow(async_fn_in_trait)]
pub trait AuditStore {
    /// Calls `each` with every record kept, oldest first.
    async fn read(&mut self, each: &mut dyn FnMut(&[u8])) -> Result<(), StorageError>;
    /// Keeps one record, durably; when full, the oldest go.
    async fn append(&mut self, record: &[u8]) -> Result<(), StorageError>;
}

/// The configuration in `config`, the audit records in `audit`.
#[derive(Debug)]
pub struct WithAudit<S, A> {
    /// The configuration's medium.
    pub config: S,
    /// The audit records' medium.
    pub audit: A,
}

impl<S: Storage, A: AuditStore> Storage for WithAudit<S, A> {
    async fn load(&mut self) -> Result<&[u8], StorageError> {
        self.config.load().await
    }
    async fn save(&mut self, image: &dyn Image) -> Result<(), StorageError> {
        self.config.save(image).await
    }
    fn is_persistent(&self) -> bool {
        self.config.is_persistent()
    }
    async fn audit_read(&mut self, each: &mut dyn FnMut(&[u8])) -> Result<(), StorageError> {
        self.audit.read(each).await
    }
    async fn audit_append(&mut self, record: &[u8]) -> Result<(), StorageError> {
        self.audit.append(record).await
    }
    fn audit_persistent(&self) -> bool {
        true
    }
}

/// A medium (`storage`) and the firmware slots of the board
/// (`slots`, feature `update`): the configuration and audit calls go to
/// the first, [`Storage::firmware`] to the second.
#[cfg(feature = "update")]
#[derive(Debug)]
pub struct WithSlots<S, U> {
    /// The configuration's (and audit log's) medium.
    pub storage: S,
    /// The firmware slots.
    pub slots: U,
}

#[cfg(feature = "update")]
impl<S: Storage, U: crate::update::Slots> Storage for WithSlots<S, U> {
    async fn load(&mut self) -> Result<&[u8], StorageError> {
        self.storage.load().await
    }
    async fn save(&mut self, image: &dyn Image) -> Result<(), StorageError> {
        self.storage.save(image).await
    }
    fn is_persistent(&self) -> bool {
        self.storage.is_persistent()
    }
    async fn audit_read(&mut self, each: &mut dyn FnMut(&[u8])) -> Result<(), StorageError> {
        self.storage.audit_read(each).await
    }
    async fn audit_append(&mut self, record: &[u8]) -> Result<(), StorageError> {
        self.storage.audit_append(record).await
    }
    fn audit_persistent(&self) -> bool {
        self.storage.audit_persistent()
    }
    async fn firmware(
        &mut self,
        op: crate::update::SlotOp<'_>,
    ) -> Result<(), crate::update::SlotError> {
        op.apply(&mut self.slots).await
    }
}

/// No persistent storage: boards without it (the QEMU board) and the host
/// binary without `--config`. A configuration applied with it is reported
/// as "applied, not saved" (`CONFIG_RESULT` 3) and lost at restart;
/// nothing is kept, not even in RAM (nothing would read it back).
#[derive(Clone, Copy, Debug, Default)]
pub struct NoStorage;

impl Storage for NoStorage {
    fn is_persistent(&self) -> bool {
        false
    }

    async fn load(&mut self) -> Result<&[u8], StorageError> {
        Ok(&[])
    }

    async fn save(&mut self, _image: &dyn Image) -> Result<(), StorageError> {
        Ok(())
    }
}

/// How a save went.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SaveOutcome {
    /// Saved to persistent storage.
    Saved,
    /// Kept in RAM only: lost at restart.
    NotPersistent,
    /// The medium failed.
    Failed(StorageError),
}
