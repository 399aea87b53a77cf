//! A board's flash for the update tests (features `testkit` and
//! `update`): the QEMU board's layout ([`MPS2_AN386`]) in RAM, the
//! application's slots over it ([`BootSlots`], what the board gives the
//! gateway), and the bootloader's step at power-up ([`SimFlash::try_boot`]:
//! embassy-boot's `prepare_boot`, as the boards' bootloaders run it). A
//! [`World`](super::world::World) whose storage has one updates as a board
//! does: upload, restart, trial, confirmation or rollback.

use core::ops::Range;
use std::cell::RefCell;
use std::rc::Rc;
use std::vec;
use std::vec::Vec;

use embassy_boot::{BootLoader, BootLoaderConfig, State};
use embedded_storage_async::nor_flash as a;

use crate::update::BootSlots;
use hans_fw_image::layout::{Layout, HEADER_PAGE, MPS2_AN386};
use hans_fw_image::{Header, Version, HEADER_LEN};

/// The signing key of the test images (its seed).
pub const TEST_KEY_SEED: [u8; 32] = [7; 32];

/// The public key of [`TEST_KEY_SEED`] (what the world's gateway trusts).
pub fn test_key() -> [u8; 32] {
    hans_fw_image::public_key(&TEST_KEY_SEED)
}

/// An image of `body` for `board` at `version`, signed with the seed
/// `key` (as `hans-fw sign` makes it).
pub fn sign(key: &[u8; 32], board: &str, version: Version, body: &[u8]) -> Vec<u8> {
    let mut out = hans_fw_image::sign(key, board, version, body)
        .expect("a body that fits a header")
        .to_vec();
    out.extend_from_slice(body);
    out
}

/// `major.minor.patch`.
pub const fn version(major: u16, minor: u16, patch: u16) -> Version {
    Version {
        major,
        minor,
        patch,
    }
}

/// The flash: shared by every view of it (it survives a restart). The
/// power can be cut at a chosen write or erase ([`SimFlash::cut_after`]):
/// that operation is done half, and every later one fails until
/// [`SimFlash::power_on`].
#[derive(Clone, Debug)]
pub struct SimFlash {
    mem: Rc<RefCell<Vec<u8>>>,
    layout: &'static Layout,
    power: Rc<Power>,
}

/// The power went during the bootloader's step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PowerCut;

/// The power of a [`SimFlash`].
#[derive(Debug, Default)]
struct Power {
    /// Writes and erases left before the cut.
    left: core::cell::Cell<Option<u32>>,
    /// The power is off: every operation fails.
    off: core::cell::Cell<bool>,
    /// Writes and erases done since the start.
    ops: core::cell::Cell<u64>,
}

impl Default for SimFlash {
    fn default() -> Self {
        Self::new()
    }
}

impl SimFlash {
    /// An erased flash of the QEMU board's layout.
    pub fn new() -> Self {
        SimFlash {
            mem: Rc::new(RefCell::new(vec![0xFF; MPS2_AN386.size as usize])),
            layout: &MPS2_AN386,
            power: Rc::new(Power::default()),
        }
    }

    /// The first flashing (a probe's, or `hans-fw install`'s): `image` in
    /// the active slot, the boot state erased.
    pub fn install(&self, image: &[u8]) {
        let mut m = self.mem.borrow_mut();
        let at = self.layout.active.start as usize;
        m[at..at + HEADER_LEN].copy_from_slice(&image[..HEADER_LEN]);
        let body = &image[HEADER_LEN..];
        let b = at + HEADER_PAGE as usize;
        m[b..b + body.len()].copy_from_slice(body);
    }

    fn part(&self, r: &Range<u32>) -> Part {
        Part {
            mem: self.mem.clone(),
            power: self.power.clone(),
            at: r.start as usize,
            len: (r.end - r.start) as usize,
        }
    }

    /// Cuts the power at the `n`-th write or erase from now (0: the next):
    /// it is done half, and everything after fails until [`Self::power_on`].
    pub fn cut_after(&self, n: u32) {
        self.power.left.set(Some(n));
    }

    /// The power is back (no cut scheduled).
    pub fn power_on(&self) {
        self.power.off.set(false);
        self.power.left.set(None);
    }

    /// The power is off (a cut happened).
    pub fn is_off(&self) -> bool {
        self.power.off.get()
    }

    /// Writes and erases done since the start (to pick cut points).
    pub fn ops(&self) -> u64 {
        self.power.ops.get()
    }

    /// The bootloader at power-up, where the power may be cut: its state,
    /// or [`PowerCut`] when the power went (run it again after
    /// [`Self::power_on`], as the next power-up does).
    pub fn try_boot(&self) -> Result<State, PowerCut> {
        let l = self.layout;
        let mut boot = BootLoader::new(BootLoaderConfig {
            active: self.part(&l.active),
            dfu: self.part(&l.dfu),
            state: self.part(&l.state),
        });
        let mut buf = [0u8; 4096];
        boot.prepare_boot(&mut buf).map_err(|_| PowerCut)
    }

    /// The application's view: its slots.
    pub fn slots(&self) -> BootSlots<Part, Part, Part> {
        let l = self.layout;
        BootSlots::new(self.part(&l.active), self.part(&l.dfu), self.part(&l.state))
    }

    /// The header in a slot (`dfu`: the download slot).
    pub fn header(&self, dfu: bool) -> Option<Header> {
        let r = if dfu {
            &self.layout.dfu
        } else {
            &self.layout.active
        };
        let m = self.mem.borrow();
        Header::parse(&m[r.start as usize..r.start as usize + HEADER_LEN]).ok()
    }

    /// An update is marked for the swap (the boot state's magic).
    pub fn marked(&self) -> bool {
        let at = self.layout.state.start as usize;
        self.mem.borrow()[at..at + 4] == [0xF0; 4]
    }

    /// The image in the active slot as a file holds it: its header, then
    /// `len` bytes of its body.
    pub fn active_image(&self, len: usize) -> Vec<u8> {
        let at = self.layout.active.start as usize;
        let mut image = self.mem.borrow()[at..at + HEADER_LEN].to_vec();
        image.extend(self.active_body(len));
        image
    }

    /// The body of the image in the active slot, `len` bytes.
    pub fn active_body(&self, len: usize) -> Vec<u8> {
        let at = (self.layout.active.start + HEADER_PAGE) as usize;
        self.mem.borrow()[at..at + len].to_vec()
    }
}

/// One partition of the flash (NOR: a write only clears bits).
#[derive(Debug)]
pub struct Part {
    mem: Rc<RefCell<Vec<u8>>>,
    power: Rc<Power>,
    at: usize,
    len: usize,
}

/// A flash error: out of the partition or misaligned.
#[derive(Debug)]
pub struct Bad(a::NorFlashErrorKind);

impl a::NorFlashError for Bad {
    fn kind(&self) -> a::NorFlashErrorKind {
        self.0
    }
}

impl Part {
    fn check(&self, offset: u32, len: usize, align: usize) -> Result<usize, Bad> {
        let o = offset as usize;
        if o + len > self.len {
            return Err(Bad(a::NorFlashErrorKind::OutOfBounds));
        }
        if !o.is_multiple_of(align) || !len.is_multiple_of(align) {
            return Err(Bad(a::NorFlashErrorKind::NotAligned));
        }
        Ok(self.at + o)
    }
    /// Counts a write or erase; `Ok(true)`: do it whole, `Ok(false)`: do
    /// half of it (the power goes), `Err`: the power is off.
    fn spend(&self) -> Result<bool, Bad> {
        let p = &self.power;
        if p.off.get() {
            return Err(Bad(a::NorFlashErrorKind::Other));
        }
        p.ops.set(p.ops.get() + 1);
        match p.left.get() {
            Some(0) => {
                p.off.set(true);
                p.left.set(None);
                Ok(false)
            }
            Some(n) => {
                p.left.set(Some(n - 1));
                Ok(true)
            }
            None => Ok(true),
        }
    }

    fn do_read(&self, offset: u32, bytes: &mut [u8]) -> Result<(), Bad> {
        if self.power.off.get() {
            return Err(Bad(a::NorFlashErrorKind::Other));
        }
        let at = self.check(offset, bytes.len(), 1)?;
        bytes.copy_from_slice(&self.mem.borrow()[at..at + bytes.len()]);
        Ok(())
    }
    fn do_write(&self, offset: u32, bytes: &[u8]) -> Result<(), Bad> {
        let at = self.check(offset, bytes.len(), 4)?;
        let whole = self.spend()?;
        let n = if whole { bytes.len() } else { bytes.len() / 2 };
        let mut m = self.mem.borrow_mut();
        for (d, s) in m[at..at + n].iter_mut().zip(bytes) {
            *d &= *s;
        }
        if whole {
            Ok(())
        } else {
            Err(Bad(a::NorFlashErrorKind::Other))
        }
    }
    fn do_erase(&self, from: u32, to: u32) -> Result<(), Bad> {
        let len = to
            .checked_sub(from)
            .ok_or(Bad(a::NorFlashErrorKind::OutOfBounds))?;
        let at = self.check(from, len as usize, 4096)?;
        let whole = self.spend()?;
        let n = if whole {
            len as usize
        } else {
            len as usize / 2
        };
        self.mem.borrow_mut()[at..at + n].fill(0xFF);
        if whole {
            Ok(())
        } else {
            Err(Bad(a::NorFlashErrorKind::Other))
        }
    }
}

impl a::ErrorType for Part {
    type Error = Bad;
}

impl a::ReadNorFlash for Part {
    const READ_SIZE: usize = 1;
    async fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Bad> {
        self.do_read(offset, bytes)
    }
    fn capacity(&self) -> usize {
        self.len
    }
}

impl a::NorFlash for Part {
    const WRITE_SIZE: usize = 4;
    const ERASE_SIZE: usize = 4096;
    async fn erase(&mut self, from: u32, to: u32) -> Result<(), Bad> {
        self.do_erase(from, to)
    }
    async fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Bad> {
        self.do_write(offset, bytes)
    }
}

mod blocking {
    use super::{Bad, Part};
    use embedded_storage::nor_flash as b;

    // The error traits are embedded-storage's in both (the async crate
    // re-exports them): implemented once, above.

    impl b::ReadNorFlash for Part {
        const READ_SIZE: usize = 1;
        fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), Bad> {
            self.do_read(offset, bytes)
        }
        fn capacity(&self) -> usize {
            self.len
        }
    }

    impl b::NorFlash for Part {
        const WRITE_SIZE: usize = 4;
        const ERASE_SIZE: usize = 4096;
        fn erase(&mut self, from: u32, to: u32) -> Result<(), Bad> {
            self.do_erase(from, to)
        }
        fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), Bad> {
            self.do_write(offset, bytes)
        }
    }
}
