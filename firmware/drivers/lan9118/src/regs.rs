//! Register map of the SMSC LAN9118 (datasheet rev. 1.5, section 5), as far as
//! this driver uses it.
//!
//! The controller is reached through 32-bit memory-mapped registers: the data
//! FIFOs at the bottom of the window, then the system control and status
//! registers (CSRs). The MAC's own registers are indirect: a command written to
//! `MAC_CSR_CMD` moves a value between `MAC_CSR_DATA` and one MAC register. The
//! PHY is reached through two of those MAC registers (MII management).

/// Byte offsets of the directly addressed registers.
pub mod csr {
    /// RX data FIFO port (any address in 0x00..0x20 pops one word).
    pub const RX_DATA_FIFO: usize = 0x00;
    /// TX data FIFO port (any address in 0x20..0x40 pushes one word).
    pub const TX_DATA_FIFO: usize = 0x20;
    /// RX status FIFO port: one status word per received frame.
    pub const RX_STATUS_FIFO: usize = 0x40;
    /// Chip ID (upper 16 bits, 0x0118 for the LAN9118) and revision.
    pub const ID_REV: usize = 0x50;
    /// Interrupt pin configuration.
    pub const IRQ_CFG: usize = 0x54;
    /// Interrupt status; write 1 to clear a bit.
    pub const INT_STS: usize = 0x58;
    /// Interrupt enable mask.
    pub const INT_EN: usize = 0x5c;
    /// Reads 0x8765_4321 once the bus interface is up, whatever the byte order.
    pub const BYTE_TEST: usize = 0x64;
    /// FIFO level interrupt thresholds.
    pub const FIFO_INT: usize = 0x68;
    /// Receive configuration (alignment, RX dump).
    pub const RX_CFG: usize = 0x6c;
    /// Transmit configuration (TX on, status overrun allowed).
    pub const TX_CFG: usize = 0x70;
    /// Hardware configuration (soft reset, FIFO sizes).
    pub const HW_CFG: usize = 0x74;
    /// RX FIFO information: status entries used (23:16), data bytes used (15:0).
    pub const RX_FIFO_INF: usize = 0x7c;
    /// TX FIFO information: free data space in bytes (15:0).
    pub const TX_FIFO_INF: usize = 0x80;
    /// Power management; bit 0 is READY.
    pub const PMT_CTRL: usize = 0x84;
    /// MAC CSR indirect access command.
    pub const MAC_CSR_CMD: usize = 0xa4;
    /// MAC CSR indirect access data.
    pub const MAC_CSR_DATA: usize = 0xa8;
}

/// `BYTE_TEST` value of a correctly attached controller.
pub const BYTE_TEST_PATTERN: u32 = 0x8765_4321;

/// `IRQ_CFG` bits.
pub mod irq_cfg {
    /// Master interrupt enable of the IRQ pin.
    pub const IRQ_EN: u32 = 1 << 8;
    /// Active-high polarity.
    pub const IRQ_POL: u32 = 1 << 4;
    /// Push-pull output (otherwise open drain, active low).
    pub const IRQ_TYPE: u32 = 1 << 0;
}

/// `INT_STS` / `INT_EN` bits.
pub mod int {
    /// PHY interrupt (link change); cleared by reading the PHY's source register.
    pub const PHY: u32 = 1 << 18;
    /// TX data FIFO has at least the `FIFO_INT` TX-available level free.
    pub const TDFA: u32 = 1 << 9;
    /// RX status FIFO holds more entries than the `FIFO_INT` RX-status level.
    pub const RSFL: u32 = 1 << 3;
    /// Every bit, to acknowledge all at once.
    pub const ALL: u32 = 0xffff_ffff;
}

/// `FIFO_INT` fields.
pub mod fifo_int {
    /// TX data available level, in units of 64 bytes (bits 31:24).
    pub const TX_DATA_AVAIL_SHIFT: u32 = 24;
    /// RX status level (bits 7:0): interrupt when more entries than this.
    pub const RX_STS_LEVEL_MASK: u32 = 0xff;
}

/// `RX_CFG` bits.
pub mod rx_cfg {
    /// Discard everything in the RX data and status FIFOs.
    pub const RX_DUMP: u32 = 1 << 15;
}

/// `TX_CFG` bits.
pub mod tx_cfg {
    /// Enable the transmitter.
    pub const TX_ON: u32 = 1 << 1;
    /// Let the TX status FIFO overrun: this driver never reads TX status.
    pub const TXSAO: u32 = 1 << 2;
}

/// `HW_CFG` bits.
pub mod hw_cfg {
    /// Soft reset; self-clearing.
    pub const SRST: u32 = 1 << 0;
}

/// `PMT_CTRL` bits.
pub mod pmt_ctrl {
    /// The device is ready to be accessed.
    pub const READY: u32 = 1 << 0;
}

/// `MAC_CSR_CMD` bits.
pub mod mac_csr_cmd {
    /// Set to start an access; reads as 1 until it is done.
    pub const BUSY: u32 = 1 << 31;
    /// Read (1) or write (0).
    pub const READ: u32 = 1 << 30;
}

/// Indices of the MAC registers behind `MAC_CSR_CMD`.
pub mod mac {
    /// MAC control.
    pub const MAC_CR: u8 = 1;
    /// MAC address, bytes 4 and 5.
    pub const ADDRH: u8 = 2;
    /// MAC address, bytes 0 to 3.
    pub const ADDRL: u8 = 3;
    /// MII management access (PHY register address and command).
    pub const MII_ACC: u8 = 6;
    /// MII management data.
    pub const MII_DATA: u8 = 7;
}

/// `MAC_CR` bits.
pub mod mac_cr {
    /// Full duplex.
    pub const FDPX: u32 = 1 << 20;
    /// Transmitter enable.
    pub const TXEN: u32 = 1 << 3;
    /// Receiver enable.
    pub const RXEN: u32 = 1 << 2;
}

/// `MII_ACC` fields.
pub mod mii_acc {
    /// PHY address field (bits 15:11).
    pub const PHY_ADDR_SHIFT: u32 = 11;
    /// PHY register index field (bits 10:6).
    pub const REG_SHIFT: u32 = 6;
    /// Write (1) or read (0).
    pub const WRITE: u32 = 1 << 1;
    /// Set to start; reads as 1 until done.
    pub const BUSY: u32 = 1 << 0;
    /// The internal PHY's address.
    pub const INTERNAL_PHY: u32 = 1;
}

/// Internal PHY registers used.
pub mod phy {
    /// Basic status register.
    pub const BMSR: u8 = 1;
    /// BMSR: link is up.
    pub const BMSR_LINK_UP: u32 = 1 << 2;
    /// Interrupt source register; reading clears it.
    pub const INT_SOURCE: u8 = 29;
    /// Interrupt mask register.
    pub const INT_MASK: u8 = 30;
    /// Interrupt sources: energy on, auto-negotiation complete, link down.
    pub const INT_LINK_EVENTS: u32 = (1 << 7) | (1 << 6) | (1 << 4);
}

/// RX status word fields.
pub mod rx_status {
    /// Frame length including the 4-byte FCS (bits 29:16).
    pub const LEN_SHIFT: u32 = 16;
    /// Width mask of the length field after shifting.
    pub const LEN_MASK: u32 = 0x3fff;
    /// Error summary.
    pub const ERROR: u32 = 1 << 15;
    /// The frame failed the address filter (only seen in receive-all mode).
    pub const FILTER_FAIL: u32 = 1 << 30;
}

/// TX command A fields.
pub mod tx_cmd_a {
    /// First segment of a frame.
    pub const FIRST_SEG: u32 = 1 << 13;
    /// Last segment of a frame.
    pub const LAST_SEG: u32 = 1 << 12;
    /// Buffer size mask (bits 10:0).
    pub const BUF_SIZE_MASK: u32 = 0x7ff;
}

/// Length of the frame check sequence the controller appends in the RX FIFO.
pub const FCS_LEN: usize = 4;
