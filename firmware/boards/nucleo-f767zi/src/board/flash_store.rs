//! The configuration's flash: sectors 12-15 of the STM32F767's second bank,
//! as an async `NorFlash` for the gateway's power-fail-safe storage
//! (`hans_gateway::storage::flash::FlashStorage`, sequential-storage).
//!
//! Why the second bank: erasing a sector takes hundreds of milliseconds
//! (16 KiB: ~250 ms typical), and while the flash erases or programs, a
//! read of the same bank (every instruction fetch) stalls the CPU. With the
//! flash in dual-bank mode (option bit nDBANK = 0) the program runs from
//! bank 1 while bank 2 erases: the CPU goes on, and this driver yields to
//! the executor while the flash is busy. So a save never stops the robot
//! link, the watchdog or the Modbus sessions for more than one program
//! step of [`YIELD_EVERY`] words (~1 ms).
//!
//! Why its own driver: embassy-stm32 0.6 has no async flash for the F7
//! (its blocking driver spins until an erase ends); the register sequence
//! (RM0410, 3.3.x) is short.
//!
//! Layout in dual-bank mode: bank 1 = 0x0800_0000-0x080F_FFFF (the
//! program: `memory.x` gives it 1 MiB), bank 2 = 0x0810_0000-0x081F_FFFF;
//! bank 2 starts with four 16 KiB sectors (12-15, SNB 0x10-0x13), the
//! smallest of the part, which this store uses (64 KiB). In single-bank
//! mode (the factory default) the same addresses belong to 256 KiB sectors
//! shared with nothing else, but erasing them would stall the CPU for 1-2 s:
//! [`is_dual_bank`] tells, and the board then keeps the configuration in RAM
//! and says so (see the README).

use core::ptr;

use embassy_stm32::pac;
use embassy_time::Timer;
use embedded_storage_async::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// Start of the configuration's store: sector 12, the first of bank 2.
pub const BASE: u32 = 0x0810_0000;
/// Sectors 12-15.
pub const SECTORS: u32 = 4;
/// Size of each.
pub const SECTOR_SIZE: u32 = 16 * 1024;
/// Words programmed between two yields to the executor.
pub const YIELD_EVERY: usize = 64;

/// The configuration's store: sectors 12-15 (16 KiB each; SNB 0x10-0x13,
/// bit 4 selects bank 2).
pub type Bank2 = Sectors<BASE, SECTOR_SIZE, SECTORS, 0x10>;
/// The firmware update's boot state: sector 16 (64 KiB, SNB 0x14), at
/// `hans_fw_image::layout::NUCLEO_F767ZI.state`.
pub type BootState = Sectors<0x0811_0000, 0x1_0000, 1, 0x14>;
/// The download slot: sectors 17-23 (128 KiB each, SNB 0x15-0x1B), at
/// `NUCLEO_F767ZI.dfu`.
pub type Download = Sectors<0x0812_0000, 0x2_0000, 7, 0x15>;

/// Takes the flash peripheral: the three stores of bank 2 are its only
/// users (the configuration's, and with updates the boot state and the
/// download slot), driven one operation at a time by the gateway's storage
/// task. Only use them in dual-bank mode.
pub fn split(
    _flash: embassy_stm32::Peri<'static, embassy_stm32::peripherals::FLASH>,
) -> (Bank2, BootState, Download) {
    (Sectors(()), Sectors(()), Sectors(()))
}

/// `true` when the flash is in dual-bank mode (nDBANK = 0).
pub fn is_dual_bank() -> bool {
    !pac::FLASH.optcr().read().n_dbank()
}

/// Why a flash operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum FlashError {
    /// Outside the store, or not word aligned.
    Bounds,
    /// The flash controller reported an error (programming sequence,
    /// alignment, parallelism, write protection).
    Controller,
}

impl NorFlashError for FlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            FlashError::Bounds => NorFlashErrorKind::OutOfBounds,
            FlashError::Controller => NorFlashErrorKind::Other,
        }
    }
}

/// `COUNT` sectors of `SIZE` bytes of bank 2 from address `BASE`, the
/// first with sector number `SNB`; offsets count from `BASE`. Made by
/// [`split`].
pub struct Sectors<const BASE: u32, const SIZE: u32, const COUNT: u32, const SNB: u8>(());

impl<const BASE: u32, const SIZE: u32, const COUNT: u32, const SNB: u8>
    Sectors<BASE, SIZE, COUNT, SNB>
{
    fn check(offset: u32, len: usize, align: u32) -> Result<(), FlashError> {
        let end = offset as usize + len;
        if !offset.is_multiple_of(align) || end > (COUNT * SIZE) as usize {
            return Err(FlashError::Bounds);
        }
        Ok(())
    }

    fn unlock() {
        if pac::FLASH.cr().read().lock() {
            pac::FLASH.keyr().write_value(0x4567_0123);
            pac::FLASH.keyr().write_value(0xCDEF_89AB);
        }
    }

    fn lock() {
        pac::FLASH.cr().modify(|w| w.set_lock(true));
    }

    /// The error bits of the last operation (and clears them).
    fn take_errors() -> Result<(), FlashError> {
        let sr = pac::FLASH.sr().read();
        // Write-1-to-clear: writing back what was read clears them.
        pac::FLASH.sr().write_value(sr);
        if sr.erserr() || sr.pgperr() || sr.pgaerr() || sr.wrperr() || sr.operr() {
            Err(FlashError::Controller)
        } else {
            Ok(())
        }
    }

    fn busy() -> bool {
        pac::FLASH.sr().read().bsy()
    }

    /// Waits while busy, yielding: for erases, which take hundreds of ms.
    async fn idle() {
        while Self::busy() {
            Timer::after_millis(1).await;
        }
    }
}

impl<const BASE: u32, const SIZE: u32, const COUNT: u32, const SNB: u8> ErrorType
    for Sectors<BASE, SIZE, COUNT, SNB>
{
    type Error = FlashError;
}

impl<const BASE: u32, const SIZE: u32, const COUNT: u32, const SNB: u8> ReadNorFlash
    for Sectors<BASE, SIZE, COUNT, SNB>
{
    const READ_SIZE: usize = 1;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        Self::check(offset, bytes.len(), 1)?;
        // Bank 2 is idle whenever this runs (every write and erase of this
        // driver waits for the end of its operation): a plain read.
        let src = (BASE + offset) as *const u8;
        for (i, b) in bytes.iter_mut().enumerate() {
            // SAFETY: `offset + i` is inside the store (checked above), which
            // is memory-mapped flash, readable at any time.
            *b = unsafe { ptr::read_volatile(src.add(i)) };
        }
        Ok(())
    }

    fn capacity(&self) -> usize {
        (COUNT * SIZE) as usize
    }
}

impl<const BASE: u32, const SIZE: u32, const COUNT: u32, const SNB: u8> NorFlash
    for Sectors<BASE, SIZE, COUNT, SNB>
{
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = SIZE as usize;

    async fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        Self::check(from, to.saturating_sub(from) as usize, SIZE)?;
        if !to.is_multiple_of(SIZE) || to < from {
            return Err(FlashError::Bounds);
        }
        for sector in from / SIZE..to / SIZE {
            Self::idle().await;
            Self::unlock();
            let _ = Self::take_errors();
            pac::FLASH.cr().modify(|w| {
                w.set_ser(true);
                w.set_snb(SNB + sector as u8);
                w.set_psize(pac::flash::vals::Psize::PSIZE32);
            });
            pac::FLASH.cr().modify(|w| w.set_strt(true));
            // Bank 2 erases; bank 1 (this program) runs on.
            Self::idle().await;
            pac::FLASH.cr().modify(|w| w.set_ser(false));
            let result = Self::take_errors();
            Self::lock();
            result?;
        }
        Ok(())
    }

    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        Self::check(offset, bytes.len(), 4)?;
        if !bytes.len().is_multiple_of(4) {
            return Err(FlashError::Bounds);
        }
        Self::idle().await;
        Self::unlock();
        let _ = Self::take_errors();
        pac::FLASH.cr().modify(|w| {
            w.set_pg(true);
            w.set_psize(pac::flash::vals::Psize::PSIZE32);
        });
        let mut result = Ok(());
        for (i, word) in bytes.chunks_exact(4).enumerate() {
            let v = u32::from_le_bytes([word[0], word[1], word[2], word[3]]);
            let dst = (BASE + offset + 4 * i as u32) as *mut u32;
            // SAFETY: a word-aligned address inside the store (checked
            // above), with PG set: the flash controller programs it.
            unsafe { ptr::write_volatile(dst, v) };
            core::sync::atomic::fence(core::sync::atomic::Ordering::SeqCst);
            // One word programs in ~16-100 µs: spin, then yield now and then.
            while Self::busy() {}
            result = Self::take_errors();
            if result.is_err() {
                break;
            }
            if i % YIELD_EVERY == YIELD_EVERY - 1 {
                embassy_futures::yield_now().await;
            }
        }
        pac::FLASH.cr().modify(|w| w.set_pg(false));
        Self::lock();
        result
    }
}

/// The active slot (bank 1, sectors 5-10, `NUCLEO_F767ZI.active`), read
/// only: the running firmware reads its own header from it; only the
/// bootloader writes it (a write or erase here is refused).
#[cfg(feature = "field-device")]
pub struct ActiveSlot;

/// The active slot's address.
#[cfg(feature = "field-device")]
const ACTIVE_BASE: u32 = 0x0802_0000;
/// Its bytes.
#[cfg(feature = "field-device")]
const ACTIVE_LEN: u32 = 6 * 0x2_0000;

#[cfg(feature = "field-device")]
impl ErrorType for ActiveSlot {
    type Error = FlashError;
}

#[cfg(feature = "field-device")]
impl ReadNorFlash for ActiveSlot {
    const READ_SIZE: usize = 1;

    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        if offset as usize + bytes.len() > ACTIVE_LEN as usize {
            return Err(FlashError::Bounds);
        }
        let src = (ACTIVE_BASE + offset) as *const u8;
        for (i, b) in bytes.iter_mut().enumerate() {
            // SAFETY: inside the active slot (checked above), memory-mapped
            // flash that nothing writes while the program runs.
            *b = unsafe { ptr::read_volatile(src.add(i)) };
        }
        Ok(())
    }

    fn capacity(&self) -> usize {
        ACTIVE_LEN as usize
    }
}

#[cfg(feature = "field-device")]
impl NorFlash for ActiveSlot {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = 0x2_0000;

    async fn erase(&mut self, _from: u32, _to: u32) -> Result<(), FlashError> {
        Err(FlashError::Bounds)
    }

    async fn write(&mut self, _offset: u32, _bytes: &[u8]) -> Result<(), FlashError> {
        Err(FlashError::Bounds)
    }
}
