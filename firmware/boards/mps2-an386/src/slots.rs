//! The field device's firmware slots: the flash file the bootloader
//! started it from (`semihosting-flash`, the word `flash=PATH` of QEMU's
//! command line), cut into the three partitions of
//! [`MPS2_AN386`](hans_fw_image::layout::MPS2_AN386): embassy-boot's
//! boot state, the active slot and the download slot, as
//! [`BootSlots`]. The gateway writes an upload into the download slot,
//! marks it, confirms a trial image; the bootloader swaps and reverts at
//! the next start. (The configuration stays in RAM on this board.)

use core::ops::Range;

use embassy_embedded_hal::flash::partition::Partition;
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::mutex::Mutex;
use hans_gateway::update::layout::MPS2_AN386;
use hans_gateway::update::BootSlots;
use semihosting_flash::{FlashPath, SemihostingFlash};
use static_cell::StaticCell;

use crate::BoardError;

/// One partition of the flash file.
pub type Part = Partition<'static, NoopRawMutex, SemihostingFlash>;
/// The slots the gateway is given.
pub type Slots = BootSlots<Part, Part, Part>;

/// Opens the flash file and makes the slots over it; once (a second call
/// is [`BoardError::Flash`]).
pub fn open() -> Result<Slots, BoardError> {
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
    Ok(BootSlots::new(
        part(&MPS2_AN386.active),
        part(&MPS2_AN386.dfu),
        part(&MPS2_AN386.state),
    ))
}
