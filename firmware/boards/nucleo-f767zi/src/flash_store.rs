//! Persistent storage of the gateway configuration in the last flash sector.
//!
//! Layout of sector 11 (0x081C_0000, 256 KiB, excluded from the program by
//! `memory.x`):
//!
//! | offset | size | content                                           |
//! |--------|------|---------------------------------------------------|
//! | 0      | 4    | magic `HGWF`                                      |
//! | 4      | 4    | image length `n`, little-endian                   |
//! | 8      | n    | the image (the gateway checks its own CRC)        |
//! | 8 + n  | pad  | `0xFF` up to the flash write granularity          |
//!
//! An erased sector (all `0xFF`) or a wrong magic reads as "nothing stored".
//! Saving erases the sector and writes the record: erasing 256 KiB takes
//! about 1-2 s on this part, during which the CPU stalls on instruction
//! fetches (single-bank flash). Saves happen only on an explicit PLC command,
//! so that pause is accepted; a power loss in it leaves an erased or partial
//! record, which reads back as "nothing stored" or fails the gateway's CRC,
//! and the defaults apply.

use embassy_stm32::flash::{Blocking, Flash, WRITE_SIZE};
use hans_gateway::{Storage, StorageError};

/// Offset of the configuration sector from the start of flash.
pub const SECTOR_OFFSET: u32 = 0x001C_0000;
/// Size of the configuration sector.
pub const SECTOR_SIZE: u32 = 256 * 1024;

const MAGIC: [u8; 4] = *b"HGWF";
const HEADER: usize = 8;
/// Largest image accepted; the gateway's image is far smaller.
pub const MAX_IMAGE: usize = 2048;

/// Why a flash operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum StoreError {
    /// The flash controller reported an error.
    Flash,
    /// The image is larger than [`MAX_IMAGE`] or the caller's buffer.
    TooLarge,
}

/// The configuration record in flash.
pub struct FlashStore {
    flash: Flash<'static, Blocking>,
}

impl FlashStore {
    /// Wraps the flash driver.
    pub fn new(flash: Flash<'static, Blocking>) -> Self {
        FlashStore { flash }
    }

    /// Copies the stored image into `buf`; 0 when nothing is stored.
    pub fn load(&mut self, buf: &mut [u8]) -> Result<usize, StoreError> {
        let mut header = [0u8; HEADER];
        self.flash
            .blocking_read(SECTOR_OFFSET, &mut header)
            .map_err(|_| StoreError::Flash)?;
        if header[..4] != MAGIC {
            return Ok(0);
        }
        let len = u32::from_le_bytes([header[4], header[5], header[6], header[7]]) as usize;
        if len > MAX_IMAGE {
            return Ok(0);
        }
        let dst = buf.get_mut(..len).ok_or(StoreError::TooLarge)?;
        self.flash
            .blocking_read(SECTOR_OFFSET + HEADER as u32, dst)
            .map_err(|_| StoreError::Flash)?;
        Ok(len)
    }

    /// Replaces the stored image (erase, then write).
    pub fn save(&mut self, image: &[u8]) -> Result<(), StoreError> {
        if image.len() > MAX_IMAGE {
            return Err(StoreError::TooLarge);
        }
        // One buffer for header + image + padding, written in one call
        // (flash is programmed in WRITE_SIZE units).
        const CAP: usize = (HEADER + MAX_IMAGE).next_multiple_of(WRITE_SIZE);
        let mut record = [0xffu8; CAP];
        record[..4].copy_from_slice(&MAGIC);
        record[4..HEADER].copy_from_slice(&(image.len() as u32).to_le_bytes());
        record[HEADER..HEADER + image.len()].copy_from_slice(image);
        let len = (HEADER + image.len()).next_multiple_of(WRITE_SIZE);

        self.flash
            .blocking_erase(SECTOR_OFFSET, SECTOR_OFFSET + SECTOR_SIZE)
            .map_err(|_| StoreError::Flash)?;
        self.flash
            .blocking_write(SECTOR_OFFSET, &record[..len])
            .map_err(|_| StoreError::Flash)
    }
}

impl Storage for FlashStore {
    fn load(&mut self, buf: &mut [u8]) -> Result<usize, StorageError> {
        FlashStore::load(self, buf).map_err(|e| match e {
            StoreError::Flash => StorageError::Io,
            StoreError::TooLarge => StorageError::TooLarge,
        })
    }

    fn save(&mut self, image: &[u8]) -> Result<(), StorageError> {
        defmt::info!(
            "config: saving {=usize} bytes to flash (erases sector 11)",
            image.len()
        );
        FlashStore::save(self, image).map_err(|e| match e {
            StoreError::Flash => StorageError::Io,
            StoreError::TooLarge => StorageError::TooLarge,
        })
    }
}
