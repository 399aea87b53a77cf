//! The bootloader of the NUCLEO-F767ZI, what runs at reset (sectors 0-3 of
//! bank 1, flashed once with a probe: firmware/README.md):
//!
//! 1. writes the flash only in dual-bank mode (option bit nDBANK = 0): the
//!    slots' sectors are those of that mode (in single-bank mode it only
//!    checks and starts the active image: no updates);
//! 2. reads the boot state (bank 2, sector 16) and, before a swap that has
//!    not begun, checks the image in the download slot (bank 2, sectors
//!    17-23: signature with the key compiled in, board, hash): one that
//!    fails is never swapped in, the boot state is cleared
//!    ([`fw_boot::refuse_or_swap`], shared with the QEMU board's
//!    bootloader);
//! 3. embassy-boot's power-fail-safe swap (resumed where a power cut left
//!    it) or the revert of a trial image that never confirmed itself;
//! 4. checks the active slot's image (bank 1, sectors 5-10) in place and
//!    starts it only if it passes: VTOR at its vector table
//!    (`layout.entry`, 0x0802_0400), its stack pointer, its reset handler.
//!
//! The log is defmt over RTT (`probe-rs attach --chip STM32F767ZITx
//! target/.../bootloader-nucleo` shows it). An image that cannot be
//! started leaves the board halted in the bootloader with the reason in
//! that log and the user LED (LD3, red) on.
//!
//! The key is `fw_keys::TRUSTED`: the development key unless the build has
//! `HANS_FW_PUBKEY` (firmware/keys/README.md).
#![no_std]
#![no_main]

use core::cell::RefCell;

use defmt_rtt as _;
use embassy_embedded_hal::flash::partition::BlockingPartition;
use embassy_stm32::flash::Flash;
use embassy_stm32::gpio::{Level, Output, Speed};
use embassy_stm32::pac;
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use fw_boot::{check_image, expect, refuse_or_swap, Pending};
use hans_fw_image::layout::{Layout, NUCLEO_F767ZI};

/// This board's layout.
const LAYOUT: Layout = NUCLEO_F767ZI;
/// Bank 2's first byte, as an offset from the flash's start.
const BANK2: u32 = 0x10_0000;
/// Bank 1's region of 128 KiB sectors (5-11) starts here.
const BANK1_BIG: u32 = 0x2_0000;
/// Bank 2's 64 KiB sector (16) and its 128 KiB sectors (17-23).
const BANK2_MID: u32 = BANK2 + 0x1_0000;
const BANK2_BIG: u32 = BANK2 + 0x2_0000;

/// Bytes moved at once in the swap (divides the 128 KiB page).
const BUF: usize = 4096;

/// Halts with the red LED on: nothing can be started.
fn halt(led: &mut Output<'_>) -> ! {
    led.set_high();
    loop {
        cortex_m::asm::wfi();
    }
}

/// Steps 2 and 3 (dual-bank mode): the update refused or swapped in, a
/// swap resumed, a trial image reverted; halts when the flash fails.
fn prepare<A, D, S>(
    active: &Mutex<NoopRawMutex, RefCell<A>>,
    dfu: &Mutex<NoopRawMutex, RefCell<D>>,
    state: &Mutex<NoopRawMutex, RefCell<S>>,
    buf: &mut [u8],
    led: &mut Output<'_>,
) where
    A: embedded_storage::nor_flash::NorFlash,
    D: embedded_storage::nor_flash::NorFlash,
    S: embedded_storage::nor_flash::NorFlash,
{
    let len = |r: &core::ops::Range<u32>| r.end - r.start;
    let prepared = refuse_or_swap(
        BlockingPartition::new(active, 0, len(&LAYOUT.active)),
        BlockingPartition::new(dfu, 0, len(&LAYOUT.dfu)),
        BlockingPartition::new(state, 0, len(&LAYOUT.state)),
        &LAYOUT,
        &fw_keys::TRUSTED,
        buf,
    );
    let prepared = match prepared {
        Ok(p) => p,
        Err(e) => {
            defmt::error!("boot: {=str}", e.as_str());
            halt(led)
        }
    };
    if let Some(e) = prepared.refused {
        defmt::warn!(
            "boot: update refused, not swapped in: {=str}; the running image stays",
            e.as_str()
        );
    }
    if let Some(h) = prepared.swapped_in {
        let v = h.version;
        defmt::info!(
            "boot: swapped in {}.{}.{} from the download slot",
            v.major,
            v.minor,
            v.patch
        );
    }
    match prepared.pending {
        Pending::SwapResumed => defmt::info!("boot: resumed the swap a power cut interrupted"),
        Pending::Revert => {
            defmt::warn!("boot: reverted: the image on trial did not confirm itself")
        }
        Pending::Boot | Pending::Swap => {}
    }
}

#[cortex_m_rt::entry]
fn main() -> ! {
    let p = embassy_stm32::init(Default::default());
    let mut led = Output::new(p.PB14, Level::Low, Speed::Low);
    let dual_bank = !pac::FLASH.optcr().read().n_dbank();
    // The layout's partitions are the regions embassy-stm32 names.
    const {
        assert!(LAYOUT.active.start == BANK1_BIG);
        assert!(LAYOUT.state.start == BANK2_MID && LAYOUT.state.end == BANK2_BIG);
        assert!(LAYOUT.dfu.start == BANK2_BIG);
    }
    let regions = Flash::new_blocking(p.FLASH).into_blocking_regions();
    let active = Mutex::<NoopRawMutex, _>::new(RefCell::new(regions.bank1_region3));
    let state = Mutex::<NoopRawMutex, _>::new(RefCell::new(regions.bank2_region2));
    let dfu = Mutex::<NoopRawMutex, _>::new(RefCell::new(regions.bank2_region3));
    let len = |r: &core::ops::Range<u32>| r.end - r.start;
    let mut buf = [0u8; BUF];
    if dual_bank {
        prepare(&active, &dfu, &state, &mut buf, &mut led);
    } else {
        // The slots' sectors are those of dual-bank mode: nothing is
        // written; the active image is checked and started (the firmware
        // then offers no updates and keeps its configuration in RAM).
        defmt::warn!("boot: the flash is in single-bank mode (nDBANK = 1): no updates; set nDBANK = 0 (firmware/README.md)");
    }

    let mut slot = BlockingPartition::new(&active, 0, len(&LAYOUT.active));
    let header = match check_image(
        &mut slot,
        0,
        &expect(&LAYOUT, &fw_keys::TRUSTED),
        &mut buf,
        None,
    ) {
        Ok(h) => h,
        Err(e) => {
            defmt::error!(
                "boot: the active slot's image is refused: {=str}; not started",
                e.as_str()
            );
            halt(&mut led)
        }
    };
    let entry = LAYOUT.entry;
    // The image must be linked where it runs: its reset handler inside it.
    // SAFETY: the active slot is memory-mapped flash, readable at any time.
    let reset = unsafe { core::ptr::read_volatile((entry + 4) as *const u32) };
    if !(entry..entry + header.body_len).contains(&reset) {
        defmt::error!(
            "boot: the image is not linked at {=u32:#x}: not started",
            entry
        );
        halt(&mut led);
    }
    let v = header.version;
    defmt::info!(
        "boot: starting {}.{}.{} at {=u32:#x}",
        v.major,
        v.minor,
        v.patch,
        entry
    );
    // SAFETY: the vector table at `entry` is the checked image's; the
    // bootloader enabled no interrupt, and nothing of it is needed after
    // the jump.
    unsafe {
        let scb = &*cortex_m::peripheral::SCB::PTR;
        scb.vtor.write(entry);
        cortex_m::asm::dsb();
        cortex_m::asm::isb();
        cortex_m::asm::bootload(entry as *const u32)
    }
}

#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    defmt::error!("boot: panic");
    loop {
        cortex_m::asm::wfi();
    }
}
