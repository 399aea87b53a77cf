//! [`embassy-net-driver`] for the SMSC LAN9118 Ethernet controller.
//!
//! The LAN9118 is a MAC + PHY with on-chip FIFOs reached by programmed I/O: no
//! DMA descriptors, one 32-bit port to push a frame into and one to pop a
//! received frame from. It sits on the Arm MPS2 boards (and QEMU's `mps2-*`
//! machines) at `0x4020_0000`. No published Rust driver for it existed, hence
//! this one.
//!
//! # Design
//! * Receive is interrupt driven: the RX status FIFO level interrupt (`RSFL`)
//!   wakes the network stack. The interrupt handler masks `RSFL` and wakes the
//!   task; [`Driver::receive`] re-enables it only once the FIFO is empty, so a
//!   level-triggered source cannot storm.
//! * Transmit pushes a whole frame into the TX data FIFO in one go. When the
//!   FIFO lacks room for a full frame, the TX-data-available interrupt wakes
//!   the stack when it has.
//! * Link state comes from the internal PHY. PHY interrupts (link up/down)
//!   tell [`Driver::link_state`] to re-read the status over MII; otherwise the
//!   cached value is returned, so polling it costs no MII access.
//! * One receive buffer and one transmit buffer of [`MTU`] bytes live inside
//!   the driver. A received frame longer than that, or one flagged with an
//!   error, is dropped and counted (see [`Stats`]).
//!
//! The board calls [`on_interrupt`] from the controller's interrupt vector.
//!
//! ```ignore
//! // Board code (interrupt 13 on the MPS2 AN385/AN386):
//! static BUFFERS: StaticCell<lan9118::Buffers> = StaticCell::new();
//! let eth = unsafe { lan9118::Lan9118::new(0x4020_0000, BUFFERS.init(lan9118::Buffers::new())) }?;
//! #[interrupt] fn ETHERNET() { unsafe { lan9118::on_interrupt(0x4020_0000) } }
//! ```
//!
//! [`embassy-net-driver`]: embassy_net_driver
#![no_std]
#![deny(missing_docs)]

pub mod regs;

use core::ptr;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use core::task::Context;

use embassy_net_driver::{Capabilities, HardwareAddress, LinkState};
use embassy_sync::waitqueue::AtomicWaker;

use regs::*;

/// Largest Ethernet frame handled (header + payload, without FCS).
pub const MTU: usize = 1514;

/// Size of the frame buffers: MTU rounded up to whole FIFO words.
const BUF_LEN: usize = (MTU + 3) & !3;

/// Upper bound on polls of a busy bit before a register access is declared
/// failed. Real silicon finishes a MAC CSR access in well under a microsecond
/// and an MII access in about 50 us; QEMU finishes both at once.
const BUSY_POLLS: u32 = 100_000;

/// Most RX status entries examined in one `receive` call before yielding, so
/// a stream of bad frames cannot hog the executor.
const RX_DROPS_PER_CALL: u32 = 8;

static RX_WAKER: AtomicWaker = AtomicWaker::new();
static TX_WAKER: AtomicWaker = AtomicWaker::new();
static LINK_WAKER: AtomicWaker = AtomicWaker::new();
static LINK_EVENT: AtomicBool = AtomicBool::new(false);

static RX_FRAMES: AtomicU32 = AtomicU32::new(0);
static TX_FRAMES: AtomicU32 = AtomicU32::new(0);
static RX_DROPPED: AtomicU32 = AtomicU32::new(0);
static INTERRUPTS: AtomicU32 = AtomicU32::new(0);

/// Why the controller could not be brought up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum InitError {
    /// `BYTE_TEST` did not read the fixed pattern: nothing (or something else)
    /// answers at the base address, or the bus is misconfigured.
    ByteTest(u32),
    /// `ID_REV` names a chip outside the LAN9118 family.
    ChipId(u32),
    /// The device never reported ready (`PMT_CTRL.READY`) or never finished
    /// the soft reset.
    NotReady,
    /// A MAC CSR or MII access stayed busy past the poll limit.
    Busy,
}

/// Counters kept since power-on, for diagnostics.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Stats {
    /// Frames handed to the network stack.
    pub rx_frames: u32,
    /// Frames pushed into the TX FIFO.
    pub tx_frames: u32,
    /// Received frames dropped: error flagged, filtered, or longer than [`MTU`].
    pub rx_dropped: u32,
    /// Interrupts handled.
    pub interrupts: u32,
}

/// Reads the driver's counters.
pub fn stats() -> Stats {
    Stats {
        rx_frames: RX_FRAMES.load(Ordering::Relaxed),
        tx_frames: TX_FRAMES.load(Ordering::Relaxed),
        rx_dropped: RX_DROPPED.load(Ordering::Relaxed),
        interrupts: INTERRUPTS.load(Ordering::Relaxed),
    }
}

/// The controller's register window.
#[derive(Clone, Copy)]
struct Regs {
    base: usize,
}

impl Regs {
    fn read(self, offset: usize) -> u32 {
        // SAFETY: `base` was given to `Lan9118::new`, whose caller promised it is
        // the LAN9118's register window; every offset used is a register in it.
        unsafe { ptr::read_volatile((self.base + offset) as *const u32) }
    }

    fn write(self, offset: usize, value: u32) {
        // SAFETY: as in `read`.
        unsafe { ptr::write_volatile((self.base + offset) as *mut u32, value) }
    }

    /// Sets or clears bits of `INT_EN`, which the interrupt handler also
    /// modifies: read-modify-write inside a critical section.
    fn int_enable(self, bits: u32, on: bool) {
        critical_section::with(|_| {
            let en = self.read(csr::INT_EN);
            self.write(csr::INT_EN, if on { en | bits } else { en & !bits });
        });
    }

    fn wait_clear(self, offset: usize, bit: u32) -> Result<(), InitError> {
        for _ in 0..BUSY_POLLS {
            if self.read(offset) & bit == 0 {
                return Ok(());
            }
        }
        Err(InitError::Busy)
    }

    fn mac_read(self, index: u8) -> Result<u32, InitError> {
        self.wait_clear(csr::MAC_CSR_CMD, mac_csr_cmd::BUSY)?;
        self.write(
            csr::MAC_CSR_CMD,
            mac_csr_cmd::BUSY | mac_csr_cmd::READ | u32::from(index),
        );
        self.wait_clear(csr::MAC_CSR_CMD, mac_csr_cmd::BUSY)?;
        Ok(self.read(csr::MAC_CSR_DATA))
    }

    fn mac_write(self, index: u8, value: u32) -> Result<(), InitError> {
        self.wait_clear(csr::MAC_CSR_CMD, mac_csr_cmd::BUSY)?;
        self.write(csr::MAC_CSR_DATA, value);
        self.write(csr::MAC_CSR_CMD, mac_csr_cmd::BUSY | u32::from(index));
        self.wait_clear(csr::MAC_CSR_CMD, mac_csr_cmd::BUSY)
    }

    fn mii_command(reg: u8, write: bool) -> u32 {
        (mii_acc::INTERNAL_PHY << mii_acc::PHY_ADDR_SHIFT)
            | (u32::from(reg) << mii_acc::REG_SHIFT)
            | if write { mii_acc::WRITE } else { 0 }
            | mii_acc::BUSY
    }

    fn wait_mii(self) -> Result<(), InitError> {
        for _ in 0..BUSY_POLLS {
            if self.mac_read(mac::MII_ACC)? & mii_acc::BUSY == 0 {
                return Ok(());
            }
        }
        Err(InitError::Busy)
    }

    fn phy_read(self, reg: u8) -> Result<u32, InitError> {
        self.wait_mii()?;
        self.mac_write(mac::MII_ACC, Self::mii_command(reg, false))?;
        self.wait_mii()?;
        Ok(self.mac_read(mac::MII_DATA)? & 0xffff)
    }

    fn phy_write(self, reg: u8, value: u32) -> Result<(), InitError> {
        self.wait_mii()?;
        self.mac_write(mac::MII_DATA, value & 0xffff)?;
        self.mac_write(mac::MII_ACC, Self::mii_command(reg, true))?;
        self.wait_mii()
    }

    /// Reads the link bit. BMSR's link bit latches low: the first read reports
    /// a drop since the last read, the second the current state.
    fn phy_link_up(self) -> Result<bool, InitError> {
        let _latched = self.phy_read(phy::BMSR)?;
        Ok(self.phy_read(phy::BMSR)? & phy::BMSR_LINK_UP != 0)
    }
}

/// Chip IDs sharing the LAN9118 register map: LAN9115..LAN9118 (QEMU's
/// model reports 0x0118), LAN9215..LAN9218 and LAN9220/9221 (the real MPS2+
/// board carries a LAN9220).
fn is_lan911x_family(chip: u32) -> bool {
    matches!(chip, 0x0115..=0x0118 | 0x9115..=0x9118 | 0x9215..=0x9218 | 0x9220 | 0x9221)
}

/// The driver's frame buffers (3 KiB). Kept outside [`Lan9118`] so the board
/// can place them in a `static` and the driver stays small enough to move
/// around by value without costing stack.
pub struct Buffers {
    rx: [u8; BUF_LEN],
    tx: [u8; BUF_LEN],
}

impl Buffers {
    /// Zeroed buffers (fit for a `static`).
    pub const fn new() -> Self {
        Buffers {
            rx: [0; BUF_LEN],
            tx: [0; BUF_LEN],
        }
    }
}

impl Default for Buffers {
    fn default() -> Self {
        Self::new()
    }
}

/// A LAN9118 driving one Ethernet port, to hand to `embassy_net::new`.
pub struct Lan9118<'d> {
    regs: Regs,
    mac: [u8; 6],
    link_up: bool,
    rx_buf: &'d mut [u8; BUF_LEN],
    tx_buf: &'d mut [u8; BUF_LEN],
}

impl<'d> Lan9118<'d> {
    /// Resets and configures the controller at `base`, keeping the MAC address
    /// it loaded (from its EEPROM, or QEMU's `-nic` option).
    ///
    /// Interrupts are configured active-high push-pull and enabled at the
    /// controller; the board still has to unmask the line in the NVIC and call
    /// [`on_interrupt`] from its vector.
    ///
    /// # Safety
    /// `base` must be the address of a LAN9118 register window, and nothing
    /// else may access it while the returned driver exists (besides
    /// [`on_interrupt`]).
    pub unsafe fn new(base: usize, buffers: &'d mut Buffers) -> Result<Self, InitError> {
        let regs = Regs { base };
        let byte_test = regs.read(csr::BYTE_TEST);
        if byte_test != BYTE_TEST_PATTERN {
            return Err(InitError::ByteTest(byte_test));
        }
        let id = regs.read(csr::ID_REV);
        if !is_lan911x_family(id >> 16) {
            return Err(InitError::ChipId(id));
        }
        Self::wait_set(regs, csr::PMT_CTRL, pmt_ctrl::READY)?;

        regs.write(csr::HW_CFG, hw_cfg::SRST);
        regs.wait_clear(csr::HW_CFG, hw_cfg::SRST)
            .map_err(|_| InitError::NotReady)?;
        Self::wait_set(regs, csr::PMT_CTRL, pmt_ctrl::READY)?;

        // Interrupts off and acknowledged while configuring.
        regs.write(csr::INT_EN, 0);
        regs.write(csr::INT_STS, int::ALL);

        let addrl = regs.mac_read(mac::ADDRL)?.to_le_bytes();
        let addrh = regs.mac_read(mac::ADDRH)?.to_le_bytes();
        let mac = [addrl[0], addrl[1], addrl[2], addrl[3], addrh[0], addrh[1]];

        // Receive: interrupt as soon as one status entry is queued (level 0),
        // start with empty FIFOs. Transmit on, status FIFO allowed to overrun.
        let fifo_int = regs.read(csr::FIFO_INT) & !fifo_int::RX_STS_LEVEL_MASK;
        regs.write(csr::FIFO_INT, fifo_int);
        regs.write(csr::RX_CFG, rx_cfg::RX_DUMP);
        regs.write(csr::TX_CFG, tx_cfg::TX_ON | tx_cfg::TXSAO);
        // Unicast to our address and broadcast; promiscuous mode (the reset
        // default) off. Full duplex: QEMU's and the boards' PHYs negotiate it.
        regs.mac_write(mac::MAC_CR, mac_cr::TXEN | mac_cr::RXEN | mac_cr::FDPX)?;

        // Link events from the PHY raise PHY_INT.
        regs.phy_write(phy::INT_MASK, phy::INT_LINK_EVENTS)?;
        let _ = regs.phy_read(phy::INT_SOURCE)?;
        let link_up = regs.phy_link_up()?;

        regs.write(
            csr::IRQ_CFG,
            irq_cfg::IRQ_EN | irq_cfg::IRQ_POL | irq_cfg::IRQ_TYPE,
        );
        regs.write(csr::INT_EN, int::RSFL | int::PHY);

        Ok(Self {
            regs,
            mac,
            link_up,
            rx_buf: &mut buffers.rx,
            tx_buf: &mut buffers.tx,
        })
    }

    fn wait_set(regs: Regs, offset: usize, bit: u32) -> Result<(), InitError> {
        for _ in 0..BUSY_POLLS {
            if regs.read(offset) & bit != 0 {
                return Ok(());
            }
        }
        Err(InitError::NotReady)
    }

    /// The MAC address the controller filters on.
    pub fn mac_address(&self) -> [u8; 6] {
        self.mac
    }

    /// Pops the next good frame from the RX FIFO into `rx_buf`, dropping bad
    /// ones. Returns its length, or `None` when the FIFO is empty (or after
    /// [`RX_DROPS_PER_CALL`] dropped frames).
    fn pop_frame(&mut self) -> Option<usize> {
        let regs = self.regs;
        for _ in 0..RX_DROPS_PER_CALL {
            let used = (regs.read(csr::RX_FIFO_INF) >> 16) & 0xff;
            if used == 0 {
                return None;
            }
            let status = regs.read(csr::RX_STATUS_FIFO);
            let len = ((status >> rx_status::LEN_SHIFT) & rx_status::LEN_MASK) as usize;
            let words = len.div_ceil(4);
            let bad = status & (rx_status::ERROR | rx_status::FILTER_FAIL) != 0;
            if bad || len <= FCS_LEN || len - FCS_LEN > MTU {
                self.discard(words);
                RX_DROPPED.fetch_add(1, Ordering::Relaxed);
                continue;
            }
            let frame_len = len - FCS_LEN;
            // The FCS words land past `frame_len`; BUF_LEN leaves room for the
            // word that mixes the last frame bytes with the FCS, not for the
            // whole FCS, so copy what fits and pop the rest.
            for i in 0..words {
                let word = regs.read(csr::RX_DATA_FIFO).to_le_bytes();
                if let Some(dst) = self.rx_buf.get_mut(i * 4..i * 4 + 4) {
                    dst.copy_from_slice(&word);
                }
            }
            RX_FRAMES.fetch_add(1, Ordering::Relaxed);
            return Some(frame_len);
        }
        // Dropped a burst of bad frames: let the stack poll us again soon.
        RX_WAKER.wake();
        None
    }

    /// Drops the `words` data words of the current frame by reading them out.
    /// (The chip also has a fast-forward command, `RX_DP_CTRL.RX_FFWD`, but
    /// some QEMU versions' model of it loses track of the FIFO level; reading
    /// at most 380 words for a rare bad frame costs little.)
    fn discard(&self, words: usize) {
        for _ in 0..words {
            let _ = self.regs.read(csr::RX_DATA_FIFO);
        }
    }

    fn tx_space(&self) -> bool {
        // Room for a full frame plus the two command words.
        (self.regs.read(csr::TX_FIFO_INF) & 0xffff) as usize >= BUF_LEN + 8
    }
}

/// Handles the controller's interrupt: masks the sources that fired and wakes
/// the tasks waiting on them. Call it from the board's interrupt vector.
///
/// # Safety
/// `base` must be the register window given to [`Lan9118::new`].
pub unsafe fn on_interrupt(base: usize) {
    let regs = Regs { base };
    INTERRUPTS.fetch_add(1, Ordering::Relaxed);
    let pending = regs.read(csr::INT_STS) & regs.read(csr::INT_EN);
    // Mask what fired; the driver re-enables each source when it has drained
    // the condition. Status bits are acknowledged where they are consumed.
    regs.int_enable(pending, false);
    if pending & int::RSFL != 0 {
        RX_WAKER.wake();
    }
    if pending & int::TDFA != 0 {
        regs.write(csr::INT_STS, int::TDFA);
        TX_WAKER.wake();
    }
    if pending & int::PHY != 0 {
        LINK_EVENT.store(true, Ordering::Release);
        LINK_WAKER.wake();
    }
}

/// A received frame, borrowed from the driver's receive buffer.
pub struct RxToken<'a> {
    buf: &'a mut [u8],
}

impl embassy_net_driver::RxToken for RxToken<'_> {
    fn consume<R, F>(self, f: F) -> R
    where
        F: FnOnce(&mut [u8]) -> R,
    {
        f(self.buf)
    }
}

/// Room for one frame to transmit.
pub struct TxToken<'a> {
    regs: Regs,
    buf: &'a mut [u8; BUF_LEN],
}

impl embassy_net_driver::TxToken for TxToken<'_> {
    fn consume<R, F>(self, len: usize, f: F) -> R
    where
        F: FnOnce(&mut [u8]) -> R,
    {
        // The stack never asks for more than the MTU it was given; clamp
        // instead of panicking if it ever did.
        let len = len.min(MTU);
        let (frame, _) = self.buf.split_at_mut(len);
        let result = f(frame);
        let regs = self.regs;
        let size = len as u32 & tx_cmd_a::BUF_SIZE_MASK;
        regs.write(
            csr::TX_DATA_FIFO,
            tx_cmd_a::FIRST_SEG | tx_cmd_a::LAST_SEG | size,
        );
        // Command B: packet tag (the length, for debugging) and frame length.
        regs.write(csr::TX_DATA_FIFO, (size << 16) | size);
        for chunk in self.buf[..len].chunks(4) {
            let mut word = [0u8; 4];
            word[..chunk.len()].copy_from_slice(chunk);
            regs.write(csr::TX_DATA_FIFO, u32::from_le_bytes(word));
        }
        TX_FRAMES.fetch_add(1, Ordering::Relaxed);
        result
    }
}

impl embassy_net_driver::Driver for Lan9118<'_> {
    type RxToken<'a>
        = RxToken<'a>
    where
        Self: 'a;
    type TxToken<'a>
        = TxToken<'a>
    where
        Self: 'a;

    fn receive(&mut self, cx: &mut Context) -> Option<(Self::RxToken<'_>, Self::TxToken<'_>)> {
        if !self.tx_space() {
            // Without room to answer, leave the frame queued; the TX wake-up
            // brings the stack back.
            TX_WAKER.register(cx.waker());
            self.regs.int_enable(int::TDFA, true);
            return None;
        }
        RX_WAKER.register(cx.waker());
        // Acknowledge the level flag before looking, so a frame arriving after
        // the look raises it again.
        self.regs.write(csr::INT_STS, int::RSFL);
        match self.pop_frame() {
            Some(len) => {
                let regs = self.regs;
                Some((
                    RxToken {
                        buf: &mut self.rx_buf[..len],
                    },
                    TxToken {
                        regs,
                        buf: self.tx_buf,
                    },
                ))
            }
            None => {
                self.regs.int_enable(int::RSFL, true);
                None
            }
        }
    }

    fn transmit(&mut self, cx: &mut Context) -> Option<Self::TxToken<'_>> {
        if self.tx_space() {
            Some(TxToken {
                regs: self.regs,
                buf: self.tx_buf,
            })
        } else {
            TX_WAKER.register(cx.waker());
            let level = ((BUF_LEN + 8).div_ceil(64) as u32) << fifo_int::TX_DATA_AVAIL_SHIFT;
            let fifo_int = self.regs.read(csr::FIFO_INT) & 0x00ff_ffff;
            self.regs.write(csr::FIFO_INT, fifo_int | level);
            self.regs.int_enable(int::TDFA, true);
            // Re-check: the FIFO may have drained before TDFA was armed.
            if self.tx_space() {
                TX_WAKER.wake();
            }
            None
        }
    }

    fn link_state(&mut self, cx: &mut Context) -> LinkState {
        LINK_WAKER.register(cx.waker());
        if LINK_EVENT.swap(false, Ordering::Acquire) {
            // Reading the source register clears PHY_INT; then re-arm it.
            let _ = self.regs.phy_read(phy::INT_SOURCE);
            if let Ok(up) = self.regs.phy_link_up() {
                self.link_up = up;
            }
            self.regs.write(csr::INT_STS, int::PHY);
            self.regs.int_enable(int::PHY, true);
        }
        if self.link_up {
            LinkState::Up
        } else {
            LinkState::Down
        }
    }

    fn capabilities(&self) -> Capabilities {
        let mut caps = Capabilities::default();
        caps.max_transmission_unit = MTU;
        caps
    }

    fn hardware_address(&self) -> HardwareAddress {
        HardwareAddress::Ethernet(self.mac)
    }
}
