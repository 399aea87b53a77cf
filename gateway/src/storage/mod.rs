//! Where the configuration and the trigger table are kept.
//!
//! The stored image ([`image`]) holds the applied configuration, the
//! sixteen trigger entries and the accounts, with a CRC. It is written by the storage task
//! (in `gateway.rs`), one of the gateway's futures, so that a save never stops the
//! robot link, the watchdog or the Modbus sessions: the medium is driven
//! through async calls that yield between flash operations.
//!
//! Two stores, one trait each: a [`ConfigStore`] keeps the image, an
//! [`AuditStore`] the audit log's records (feature `audit`). A platform
//! gives the gateway one value that is both (and, with updates, the
//! firmware slots: `crate::update::SlotStore`); the gateway's `Storage`
//! bound says which a build needs.
//!
//! Implementations:
//! * [`NoStorage`]: no persistence (a board without a medium, Linux without
//!   `--config`); a configuration applied with it is "applied, not saved".
//! * [`flash::FlashStorage`] (feature `flash`): a power-fail-safe map in
//!   NOR flash (sequential-storage over embedded-storage-async's
//!   `NorFlash`), and the audit records in a ring of its own sectors
//!   ([`flash::FlashStorage::with_audit`]). A power cut at any moment of a
//!   save leaves the old or the new image.
//! * On Linux (crate `hans-gateway-linux`): the TOML file, replaced
//!   atomically, and the audit file beside it, joined by [`WithAudit`].

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

/// Where a [`ConfigStore`] keeps the image: what a start's audit record and
/// the views say of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Medium {
    /// Nowhere: a saved configuration is lost at restart ([`NoStorage`]).
    None,
    /// The device's own flash.
    Flash,
    /// A file that people may edit (Linux `--config`).
    File,
}

/// A medium for the stored image. Calls are rare (at start, and on each
/// apply); they must not block the executor for more than a few
/// milliseconds at a time: yield (await) between slow operations.
// The futures are deliberately not `Send` (single-threaded executors).
#[allow(async_fn_in_trait)]
pub trait ConfigStore {
    /// The stored image, empty when nothing is stored (valid until the
    /// next call).
    async fn load(&mut self) -> Result<&[u8], StorageError>;

    /// Replaces the stored image with the one `image` writes.
    async fn save(&mut self, image: &dyn Image) -> Result<(), StorageError>;

    /// Where the image is kept. With [`Medium::None`] a configuration
    /// applied is reported as "applied, not saved" (`CONFIG_RESULT` 3).
    fn medium(&self) -> Medium;
}

impl<S: ConfigStore> ConfigStore for &mut S {
    async fn load(&mut self) -> Result<&[u8], StorageError> {
        (**self).load().await
    }
    async fn save(&mut self, image: &dyn Image) -> Result<(), StorageError> {
        (**self).save(image).await
    }
    fn medium(&self) -> Medium {
        (**self).medium()
    }
}

/// A medium for the audit log's records (feature `audit`, see
/// `crate::audit`): the flash storage's ring, the Linux file, or nothing.
// The futures are deliberately not `Send` (single-threaded executors).
#[allow(async_fn_in_trait)]
pub trait AuditStore {
    /// Calls `each` with every record kept (the bytes [`Self::append`] was
    /// given), oldest first: the gateway reads them at start (the boot
    /// counter, the page's newest records).
    async fn read(&mut self, each: &mut dyn FnMut(&[u8])) -> Result<(), StorageError>;
    /// Keeps one record (at most 128 bytes) so that it survives a restart
    /// and a power cut (a cut loses at most this record); when the medium
    /// is full the oldest records go.
    async fn append(&mut self, record: &[u8]) -> Result<(), StorageError>;
    /// `true` if records survive a restart.
    fn persistent(&self) -> bool;
}

impl<A: AuditStore> AuditStore for &mut A {
    async fn read(&mut self, each: &mut dyn FnMut(&[u8])) -> Result<(), StorageError> {
        (**self).read(each).await
    }
    async fn append(&mut self, record: &[u8]) -> Result<(), StorageError> {
        (**self).append(record).await
    }
    fn persistent(&self) -> bool {
        (**self).persistent()
    }
}

/// The configuration in `config`, the audit records in `audit` (Linux: the
/// TOML file and the audit file beside it).
#[derive(Debug)]
pub struct WithAudit<S, A> {
    /// The configuration's medium.
    pub config: S,
    /// The audit records' medium.
    pub audit: A,
}

impl<S: ConfigStore, A> ConfigStore for WithAudit<S, A> {
    async fn load(&mut self) -> Result<&[u8], StorageError> {
        self.config.load().await
    }
    async fn save(&mut self, image: &dyn Image) -> Result<(), StorageError> {
        self.config.save(image).await
    }
    fn medium(&self) -> Medium {
        self.config.medium()
    }
}

impl<S, A: AuditStore> AuditStore for WithAudit<S, A> {
    async fn read(&mut self, each: &mut dyn FnMut(&[u8])) -> Result<(), StorageError> {
        self.audit.read(each).await
    }
    async fn append(&mut self, record: &[u8]) -> Result<(), StorageError> {
        self.audit.append(record).await
    }
    fn persistent(&self) -> bool {
        self.audit.persistent()
    }
}

/// No persistent storage: boards without it and the Linux gateway without
/// `--config`. A configuration applied with it is reported as "applied,
/// not saved" (`CONFIG_RESULT` 3) and lost at restart; no audit record is
/// kept beyond the log's RAM (nothing would read it back).
#[derive(Clone, Copy, Debug, Default)]
pub struct NoStorage;

impl ConfigStore for NoStorage {
    async fn load(&mut self) -> Result<&[u8], StorageError> {
        Ok(&[])
    }

    async fn save(&mut self, _image: &dyn Image) -> Result<(), StorageError> {
        Ok(())
    }

    fn medium(&self) -> Medium {
        Medium::None
    }
}

impl AuditStore for NoStorage {
    async fn read(&mut self, _each: &mut dyn FnMut(&[u8])) -> Result<(), StorageError> {
        Ok(())
    }

    async fn append(&mut self, _record: &[u8]) -> Result<(), StorageError> {
        Ok(())
    }

    fn persistent(&self) -> bool {
        false
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
