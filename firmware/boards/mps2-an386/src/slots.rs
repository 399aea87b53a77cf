//! The field device's flash: the flash file the bootloader started it
//! from (`semihosting-flash`, the word `flash=PATH` of QEMU's command
//! line), cut into the partitions of
//! [`MPS2_AN386`](hans_fw_image::layout::MPS2_AN386):
//!
//! * embassy-boot's boot state, the active slot and the download slot, as
//!   [`BootSlots`]: the gateway writes an upload into the download slot,
//!   marks it, confirms a trial image; the bootloader swaps and reverts at
//!   the next start;
//! * the gateway's store ([`Store`]): the configuration with the accounts,
//!   and the audit log's records, as on the NUCLEO's flash
//!   (`FlashStorage`, sequential-storage). Neither the bootloader nor an
//!   update touches it, so what the page or the PLC saved is kept across
//!   QEMU's restarts (the same flash file: `FLASH_FILE`) and updates.

use core::ops::Range;

use embassy_embedded_hal::flash::partition::{Error as PartError, Partition};
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::mutex::Mutex;
use embedded_storage_async::nor_flash::{ErrorType, NorFlash, ReadNorFlash};
use hans_gateway::storage::flash::FlashStorage;
use hans_gateway::update::layout::MPS2_AN386;
use hans_gateway::update::BootSlots;
use semihosting_flash::{FlashPath, SemihostingFlash};
use static_cell::StaticCell;

use crate::BoardError;

/// One partition of the flash file.
pub type Part = Partition<'static, NoopRawMutex, SemihostingFlash>;
/// The slots the gateway is given.
pub type Slots = BootSlots<Part, Part, Part>;
/// The gateway's configuration and audit records.
pub type Store = FlashStorage<Sectors>;

/// The erase unit of the store: 16 KiB, four of the file's 4 KiB pages, as
/// the NUCLEO's configuration sectors. A stored configuration (up to
/// `hans_gateway::storage::IMAGE_MAX`, ~6 KiB with 8 accounts and 16
/// trigger texts) is one sequential-storage item, and an item never spans
/// two erase units: 4 KiB pages are too small for it.
pub const SECTOR: u32 = 16 * 1024;
/// The configuration's part of the store (two sectors: the map's minimum,
/// an image written beside the old one).
const CONFIG: Range<u32> = 0..2 * SECTOR;
/// The audit records' part (two sectors, ~250 records of at most 128
/// bytes: more than the 64 newest the log keeps in RAM; when full, the
/// oldest sector's are erased).
const AUDIT: Range<u32> = 2 * SECTOR..4 * SECTOR;

/// The store's partition, erased [`SECTOR`] at a time. Why a wrapper of
/// our own: sequential-storage takes the erase unit from the flash type,
/// and nothing else here needs a larger one.
pub struct Sectors(Part);

impl ErrorType for Sectors {
    type Error = PartError<semihosting_flash::Error>;
}

impl ReadNorFlash for Sectors {
    const READ_SIZE: usize = semihosting_flash::READ_SIZE;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Self::Error> {
        self.0.read(offset, bytes).await
    }

    fn capacity(&self) -> usize {
        self.0.capacity()
    }
}

impl NorFlash for Sectors {
    const WRITE_SIZE: usize = semihosting_flash::WRITE_SIZE;
    const ERASE_SIZE: usize = SECTOR as usize;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), Self::Error> {
        if !from.is_multiple_of(SECTOR) || !to.is_multiple_of(SECTOR) {
            return Err(PartError::Flash(semihosting_flash::Error::NotAligned));
        }
        self.0.erase(from, to).await
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Self::Error> {
        self.0.write(offset, bytes).await
    }
}

/// What the field device stores through: its store (configuration,
/// accounts, audit records) beside its firmware slots.
pub type DeviceStorage = hans_gateway::WithSlots<Store, Slots>;

/// Opens the flash file and makes the slots and the store over it, in
/// `slot`; once (a second call is [`BoardError::Flash`]).
///
/// In a slot the caller keeps (the gateway task's, in its static future),
/// and not inlined: the store (its work buffer holds a whole stored image)
/// is built in this function's frame, gone once it returns. Returned by
/// value, it was a temporary in the frame of the gateway task's poll,
/// which the stack carries for as long as the gateway runs, under the web
/// server's deepest path (that frame was 16.3 KiB).
#[inline(never)]
pub fn open_into(slot: &mut Option<DeviceStorage>) -> Result<&mut DeviceStorage, BoardError> {
    static FLASH: StaticCell<Mutex<NoopRawMutex, SemihostingFlash>> = StaticCell::new();
    let path = FlashPath::from_args().map_err(|e| BoardError::Flash(e.as_str()))?;
    let flash = SemihostingFlash::open(&path, MPS2_AN386.size).map_err(|e| {
        defmt::error!("flash file {=str}: {=str}", path.as_str(), e.as_str());
        BoardError::Flash(e.as_str())
    })?;
    let flash: &'static _ = FLASH
        .try_init(Mutex::new(flash))
        .ok_or(BoardError::Flash("the flash file is already open"))?;
    let part = |r: &Range<u32>| Partition::new(flash, r.start, r.end - r.start);
    let slots = BootSlots::new(
        part(&MPS2_AN386.active),
        part(&MPS2_AN386.dfu),
        part(&MPS2_AN386.state),
    );
    let store = FlashStorage::with_audit(Sectors(part(&MPS2_AN386.store)), CONFIG, AUDIT)
        .map_err(|_| BoardError::Flash("the store is not whole sectors"))?;
    Ok(slot.insert(hans_gateway::WithSlots {
        storage: store,
        slots,
    }))
}
