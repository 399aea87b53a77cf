//! The A/B swap and rollback of embassy-boot (the bootloader the update
//! issue builds on) on the layout we intend, against a mock NOR flash that
//! cuts the power at one chosen write or erase: for every single write and
//! erase of an update (writing the new image, marking it, the swap, the
//! confirmation, the rollback of an image that never confirms itself), in
//! a loop over all of them. After each cut the power comes back and the
//! bootloader runs again: the device then boots the old image or the new
//! one, whole, never neither, and the configuration's flash is untouched.
//!
//! Pages are 256 bytes here (the F767's sectors are 32-256 KiB): the
//! algorithm works page by page, so small pages give the same sequence of
//! states with more cut points per byte.

use std::cell::RefCell;
use std::rc::Rc;

use embassy_boot::{
    BlockingFirmwareState, BlockingFirmwareUpdater, BootLoader, BootLoaderConfig,
    FirmwareUpdaterConfig, State,
};
use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

const PAGE: usize = 256;
const ACTIVE: usize = 4 * PAGE;
const DFU: usize = 5 * PAGE;
const STATE_LEN: usize = PAGE;
const CONFIG: usize = 2 * PAGE;
/// Offsets of the partitions in the one flash.
const ACTIVE_AT: usize = 0;
const DFU_AT: usize = ACTIVE_AT + ACTIVE;
const STATE_AT: usize = DFU_AT + DFU;
const CONFIG_AT: usize = STATE_AT + STATE_LEN;
const TOTAL: usize = CONFIG_AT + CONFIG;

/// The flash, shared by the partitions' views: counts every write and
/// erase; at the `cut_at`-th it does half of it and the power is gone
/// (every later operation fails) until [`Flash::power_on`].
struct Flash {
    mem: Vec<u8>,
    ops: u32,
    cut_at: Option<u32>,
    dead: bool,
}

#[derive(Debug)]
struct PowerCut;

impl NorFlashError for PowerCut {
    fn kind(&self) -> NorFlashErrorKind {
        NorFlashErrorKind::Other
    }
}

type Shared = Rc<RefCell<Flash>>;

fn power_on(f: &Shared) {
    let mut f = f.borrow_mut();
    f.dead = false;
    f.cut_at = None;
}

/// One partition of the flash.
struct Part {
    flash: Shared,
    at: usize,
    len: usize,
}

impl ErrorType for Part {
    type Error = PowerCut;
}

impl ReadNorFlash for Part {
    const READ_SIZE: usize = 1;
    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), PowerCut> {
        let f = self.flash.borrow();
        if f.dead {
            return Err(PowerCut);
        }
        let o = self.at + offset as usize;
        bytes.copy_from_slice(&f.mem[o..o + bytes.len()]);
        Ok(())
    }
    fn capacity(&self) -> usize {
        self.len
    }
}

impl NorFlash for Part {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = PAGE;
    fn erase(&mut self, from: u32, to: u32) -> Result<(), PowerCut> {
        let mut f = self.flash.borrow_mut();
        if f.dead {
            return Err(PowerCut);
        }
        f.ops += 1;
        let (a, b) = (self.at + from as usize, self.at + to as usize);
        assert!(
            b <= self.at + self.len && (b - a) % PAGE == 0,
            "erase inside the partition, whole pages"
        );
        if f.cut_at == Some(f.ops) {
            // Half erased, then nothing.
            let mid = a + (b - a) / 2;
            f.mem[a..mid].fill(0xFF);
            f.dead = true;
            return Err(PowerCut);
        }
        f.mem[a..b].fill(0xFF);
        Ok(())
    }
    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), PowerCut> {
        let mut f = self.flash.borrow_mut();
        if f.dead {
            return Err(PowerCut);
        }
        f.ops += 1;
        let o = self.at + offset as usize;
        assert!(
            o + bytes.len() <= self.at + self.len,
            "write inside the partition"
        );
        let n = if f.cut_at == Some(f.ops) {
            bytes.len() / 2
        } else {
            bytes.len()
        };
        for (m, b) in f.mem[o..o + n].iter_mut().zip(bytes) {
            // NOR: a write only clears bits.
            *m &= *b;
        }
        if n < bytes.len() {
            f.dead = true;
            return Err(PowerCut);
        }
        Ok(())
    }
}

fn part(f: &Shared, at: usize, len: usize) -> Part {
    Part {
        flash: f.clone(),
        at,
        len,
    }
}

fn image(fill: u8) -> Vec<u8> {
    (0..ACTIVE)
        .map(|i| fill ^ (i as u8).wrapping_mul(7))
        .collect()
}

/// A fresh device: image A active, the rest erased, a configuration.
fn device() -> Shared {
    let mut mem = vec![0xFF; TOTAL];
    mem[ACTIVE_AT..ACTIVE_AT + ACTIVE].copy_from_slice(&image(0xA0));
    for (i, m) in mem[CONFIG_AT..CONFIG_AT + CONFIG].iter_mut().enumerate() {
        *m = (i % 251) as u8;
    }
    Rc::new(RefCell::new(Flash {
        mem,
        ops: 0,
        cut_at: None,
        dead: false,
    }))
}

/// The bootloader at power-up; `Err` if the power went during it.
fn boot(f: &Shared) -> Result<State, ()> {
    let mut bl = BootLoader::new(BootLoaderConfig {
        active: part(f, ACTIVE_AT, ACTIVE),
        dfu: part(f, DFU_AT, DFU),
        state: part(f, STATE_AT, STATE_LEN),
    });
    let mut buf = [0u8; PAGE];
    bl.prepare_boot(&mut buf).map_err(|_| ())
}

/// The running image writes B into the download slot and marks it.
fn download(f: &Shared) -> Result<(), ()> {
    let mut aligned = [0u8; 4];
    let mut up = BlockingFirmwareUpdater::new(
        FirmwareUpdaterConfig {
            dfu: part(f, DFU_AT, DFU),
            state: part(f, STATE_AT, STATE_LEN),
        },
        &mut aligned,
    );
    let b = image(0xB0);
    for (k, chunk) in b.chunks(100).enumerate() {
        up.write_firmware(k * 100, chunk).map_err(|_| ())?;
    }
    up.mark_updated().map_err(|_| ())
}

/// The new image confirms itself.
fn confirm(f: &Shared) -> Result<(), ()> {
    let mut aligned = [0u8; 4];
    let mut st = BlockingFirmwareState::new(part(f, STATE_AT, STATE_LEN), &mut aligned);
    st.mark_booted().map_err(|_| ())
}

fn active(f: &Shared) -> Vec<u8> {
    f.borrow().mem[ACTIVE_AT..ACTIVE_AT + ACTIVE].to_vec()
}

/// Which whole image is active, if one is.
fn which(f: &Shared) -> Option<char> {
    let a = active(f);
    if a == image(0xA0) {
        Some('A')
    } else if a == image(0xB0) {
        Some('B')
    } else {
        None
    }
}

fn config_intact(f: &Shared) -> bool {
    f.borrow().mem[CONFIG_AT..CONFIG_AT + CONFIG]
        .iter()
        .enumerate()
        .all(|(i, m)| *m == (i % 251) as u8)
}

/// An update as the device lives it: download and mark, restart (swap),
/// then `confirm` or not, restart. `Err` at the power cut.
fn update(f: &Shared, confirms: bool) -> Result<(), ()> {
    download(f)?;
    boot(f)?;
    if confirms {
        confirm(f)?;
    }
    boot(f)?;
    Ok(())
}

/// After a cut: the power comes back, the device restarts (more than once
/// if the new image does not confirm itself) until it settles. The image
/// it then runs must be A or B whole.
fn recover(f: &Shared, confirms: bool) -> char {
    power_on(f);
    for _ in 0..3 {
        boot(f).expect("the bootloader runs with the power on");
        let now = which(f).unwrap_or_else(|| panic!("neither image is active after a restart"));
        // B on trial confirms itself (if it would), else the next restart
        // brings A back.
        if now == 'B' && confirms {
            let _ = confirm(f);
        }
    }
    which(f).expect("a whole image")
}

fn ops_of(confirms: bool) -> u32 {
    let f = device();
    update(&f, confirms).expect("no cut");
    assert_eq!(
        which(&f),
        Some(if confirms { 'B' } else { 'A' }),
        "the update without cuts"
    );
    let n = f.borrow().ops;
    n
}

#[test]
fn a_power_cut_at_any_write_or_erase_of_a_confirmed_update_leaves_a_or_b() {
    let total = ops_of(true);
    assert!(total > 20, "writes and erases of an update: {total}");
    let mut ended = [0u32; 2];
    let mut torn = 0;
    for cut in 1..=total {
        let f = device();
        f.borrow_mut().cut_at = Some(cut);
        assert!(
            update(&f, true).is_err(),
            "the cut at {cut} of {total} happened"
        );
        // Cut in the middle of the swap, the active slot holds pages of
        // both: only the bootloader's resumption makes it whole.
        torn += u32::from(which(&f).is_none());
        let got = recover(&f, true);
        assert!(config_intact(&f), "cut {cut}: the configuration");
        ended[usize::from(got == 'B')] += 1;
    }
    // Early cuts keep A (the download was not complete), late ones have B.
    assert!(
        ended[0] > 0 && ended[1] > 0,
        "A {} times, B {} times",
        ended[0],
        ended[1]
    );
    assert!(
        torn > 0,
        "no cut tore the active slot: the test would not see a broken swap"
    );
    println!(
        "{total} writes and erases; after the cuts: A {} times, B {} times, {torn} torn slots made whole",
        ended[0], ended[1]
    );
}

#[test]
fn an_image_that_never_confirms_itself_is_rolled_back_whatever_the_cuts() {
    let total = ops_of(false);
    for cut in 1..=total {
        let f = device();
        f.borrow_mut().cut_at = Some(cut);
        assert!(
            update(&f, false).is_err(),
            "the cut at {cut} of {total} happened"
        );
        let got = recover(&f, false);
        assert_eq!(got, 'A', "cut {cut} of {total}: the old image is back");
        assert!(config_intact(&f), "cut {cut}: the configuration");
    }
}
