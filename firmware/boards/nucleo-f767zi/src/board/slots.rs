//! The firmware slots of the field device (signed A/B updates): the
//! active slot (bank 1, read only), the download slot and the boot state
//! (bank 2, written while the program runs from bank 1), or none when the
//! flash is in single-bank mode (then the gateway says updates are not
//! supported here).

use hans_gateway::update::{BootSlots, BootState, Slot, SlotError, SlotStore};

use super::flash_store::{ActiveSlot, BootState as StateSectors, Download};

/// The slots, if the flash is in dual-bank mode.
pub struct BoardSlots(pub Option<BootSlots<ActiveSlot, Download, StateSectors>>);

impl BoardSlots {
    fn get(&mut self) -> Result<&mut BootSlots<ActiveSlot, Download, StateSectors>, SlotError> {
        self.0.as_mut().ok_or(SlotError::Unsupported)
    }
}

impl SlotStore for BoardSlots {
    async fn state(&mut self) -> Result<BootState, SlotError> {
        self.get()?.state().await
    }

    async fn read(&mut self, slot: Slot, offset: u32, buf: &mut [u8]) -> Result<(), SlotError> {
        self.get()?.read(slot, offset, buf).await
    }

    async fn write(&mut self, offset: u32, data: &[u8]) -> Result<(), SlotError> {
        self.get()?.write(offset, data).await
    }

    async fn mark_updated(&mut self) -> Result<(), SlotError> {
        self.get()?.mark_updated().await
    }

    async fn confirm(&mut self) -> Result<(), SlotError> {
        self.get()?.confirm().await
    }
}
