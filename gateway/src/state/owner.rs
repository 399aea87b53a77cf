//! Who owns the command inputs (the channels' and RAW's inputs, the
//! trigger bits, `PLC_HEARTBEAT`) when two PLCs are connected, one over
//! Modbus and one over EtherNet/IP, and what the EtherNet/IP adapter
//! reports of itself (registers `COMMAND_OWNER`, `ENIP_CONNECTIONS`,
//! `ENIP_REFUSED`, `ENIP_MISSED`, `ENIP_IO_DROPPED`).
//!
//! The rule (ENIP.md, "Who owns the command channels"):
//! an EtherNet/IP exclusive-owner connection owns the command inputs for as
//! long as it is open; otherwise Modbus does. While EtherNet/IP owns them,
//! a Modbus write that touches them is refused whole (exception 01,
//! `WRITES_REFUSED`); an exclusive-owner Forward_Open is refused
//! (extended status 0x0106, ownership conflict) while a command fired by
//! another master (Modbus, or an EtherNet/IP owner at another address) is
//! Busy. The rules are `crate::plc`'s; this is the state they read.

use core::net::Ipv4Addr;

/// The EtherNet/IP exclusive owner, while its connection is open.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EnipOwner {
    /// Its connection (the O->T connection id).
    pub connection: u32,
    /// The PLC's address.
    pub ip: Ipv4Addr,
    /// Its data says Run (the PLC runs its program); `false` while Idle
    /// (program mode), whose data is not applied.
    pub run: bool,
    /// No data applied yet: its first Run data is taken as the inputs'
    /// levels, without edges (an Execute already high fires nothing).
    pub fresh: bool,
    /// O->T datagrams its connection took.
    pub received: u32,
    /// O->T datagrams its connection missed: produced by the PLC at its
    /// RPI (its sequence numbers count them) and never received.
    pub missed: u32,
}

/// Who fired the commands that may still be Busy.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Commander {
    /// Nobody yet, or a Modbus client (or an explicit EtherNet/IP write,
    /// which has no connection to own anything with).
    #[default]
    Modbus,
    /// The EtherNet/IP exclusive owner at this address.
    Enip(Ipv4Addr),
}

/// Ownership of the command inputs, and the EtherNet/IP adapter's counters.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Ownership {
    /// The EtherNet/IP exclusive owner, while one is connected.
    pub enip_owner: Option<EnipOwner>,
    /// Who last fired a command.
    pub commander: Commander,
    /// EtherNet/IP connections (class 1 and class 3) open now.
    pub enip_connections: u16,
    /// EtherNet/IP sessions and datagrams refused by `enip.allow`,
    /// and Forward_Opens refused by the ownership rule (wraps).
    pub enip_refused: u16,
    /// O->T datagrams missed by every class 1 connection since start
    /// (gaps in their sequence numbers: expected at the RPI, never
    /// received; wraps).
    pub enip_missed: u16,
    /// Datagrams on the I/O port (UDP 2222) from allowed addresses that no
    /// connection took: an unknown connection id, not from the
    /// connection's originator, malformed, stale or of the wrong size
    /// (dropped; wraps).
    pub enip_io_dropped: u16,
}

impl Ownership {
    /// `COMMAND_OWNER`: 0 Modbus, 1 EtherNet/IP (Run), 2 EtherNet/IP (Idle:
    /// the PLC is in program mode, its outputs are not applied).
    pub fn code(&self) -> u16 {
        match self.enip_owner {
            None => 0,
            Some(o) if o.run => 1,
            Some(_) => 2,
        }
    }

    /// EtherNet/IP owns the command inputs.
    pub fn enip_owns(&self) -> bool {
        self.enip_owner.is_some()
    }
}
