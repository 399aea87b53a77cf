//! What the adapter asks of the application that uses it: the values of
//! the identity and the network interface, the assemblies' data, and what
//! it is told when connections open, close and change between run and idle.

use core::net::Ipv4Addr;

use crate::device::{ConnectionKind, EthernetLinkInfo, Identity, TcpIpInfo};
use crate::wire::cip::GeneralStatus;
use crate::wire::conn_mgr::ExtendedStatus;

/// A class 1 or class 3 connection, named by its O->T connection id (unique
/// among open connections).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ConnectionId(pub u32);

/// Why a connection closed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum CloseReason {
    /// The originator sent Forward_Close.
    ForwardClose,
    /// Nothing arrived within the timeout (RPI x the timeout multiplier, or
    /// the first-packet timeout for a connection that never sent).
    TimedOut,
    /// The TCP connection of its session closed (class 3 only).
    LinkClosed,
}

/// What the adapter tells the application.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Event {
    /// A Forward_Open was accepted.
    Opened {
        /// The connection.
        connection: ConnectionId,
        /// Its kind.
        kind: ConnectionKind,
        /// The output assembly it writes (exclusive owner only).
        output: Option<u16>,
        /// The input assembly it reads (class 1 only).
        input: Option<u16>,
        /// The originator's address.
        originator: Ipv4Addr,
    },
    /// A connection closed. For an exclusive owner that timed out, this is
    /// the lost heartbeat the application's watchdog acts on.
    Closed {
        /// The connection.
        connection: ConnectionId,
        /// Its kind.
        kind: ConnectionKind,
        /// Why.
        reason: CloseReason,
    },
    /// The run/idle bit of an exclusive owner's O->T data changed (the first
    /// datagram of a connection reports its state too).
    RunIdle {
        /// The connection.
        connection: ConnectionId,
        /// `true`: run; `false`: idle (the PLC is in program mode).
        run: bool,
    },
}

/// Where an assembly write comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum WriteOrigin {
    /// Class 1 O->T data of an exclusive-owner connection.
    Io {
        /// The connection.
        connection: ConnectionId,
        /// The run/idle bit that came with the data.
        run: bool,
    },
    /// An explicit Set_Attribute_Single on attribute 3.
    Explicit,
}

/// The application behind the adapter: the gateway implements it over its
/// typed state; tests implement it over plain buffers.
pub trait Application {
    /// The Identity object's values. The adapter sets the "owned" bit and
    /// the extended status field (bits 4-7) of `status` from its connections;
    /// the other bits are the application's.
    fn identity(&self) -> Identity<'_>;

    /// The TCP/IP Interface object's values.
    fn tcp_ip(&self) -> TcpIpInfo<'_>;

    /// The Ethernet Link object's values.
    fn ethernet_link(&self) -> EthernetLinkInfo;

    /// Fills `buf` (exactly the assembly's size) with an assembly's data:
    /// an input assembly for T->O production and explicit reads, an output
    /// assembly for explicit reads of what was last written.
    fn read_assembly(&mut self, instance: u16, buf: &mut [u8]);

    /// Takes an output assembly's new data (exactly its size). Refusing an
    /// explicit write answers the request with the status returned; refusing
    /// an I/O write drops the data (the connection stays open).
    fn write_assembly(
        &mut self,
        instance: u16,
        data: &[u8],
        origin: WriteOrigin,
    ) -> Result<(), GeneralStatus>;

    /// Told what happened.
    fn event(&mut self, event: Event);

    /// Asked before a Forward_Open that passed every check of the adapter
    /// is accepted (its configuration data, if any, is written by then):
    /// the application's own rules, such as who may own the
    /// outputs now or how many connections one originator may hold.
    /// `held` is how many connections `originator` has open already.
    /// `Err(status)` refuses the Forward_Open with that extended status.
    /// The default accepts.
    fn admit_open(
        &mut self,
        kind: ConnectionKind,
        originator: Ipv4Addr,
        held: usize,
    ) -> Result<(), ExtendedStatus> {
        let _ = (kind, originator, held);
        Ok(())
    }

    /// The Identity object's Reset service (0: like a power cycle, 1: back
    /// to the factory defaults, then like a power cycle). Return `true` to
    /// accept: the reply goes out first and the application resets after
    /// it. The default refuses (the reply is "object state conflict").
    fn reset(&mut self, kind: u8) -> bool {
        let _ = kind;
        false
    }
}
