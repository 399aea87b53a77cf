//! What the device is: its identity, its network interface, and its
//! assemblies and connection points. The adapter answers from these values,
//! and the EDS writer describes the same ones, so that the two cannot drift.

use core::net::Ipv4Addr;

/// A major and minor revision.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Revision {
    /// Major revision (1-127).
    pub major: u8,
    /// Minor revision (1-255).
    pub minor: u8,
}

/// The values of the Identity object (class 0x01, instance 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Identity<'a> {
    /// The vendor id ODVA assigned to the maker (attribute 1).
    pub vendor_id: u16,
    /// The CIP device type (attribute 2; 0x0C is "communications adapter",
    /// 0x2B "generic device, keyable").
    pub device_type: u16,
    /// The maker's product code (attribute 3).
    pub product_code: u16,
    /// The revision (attribute 4).
    pub revision: Revision,
    /// The status word (attribute 5): bit 0 owned, bit 2 configured, bits
    /// 4-7 extended status, bits 8-11 faults.
    pub status: u16,
    /// The serial number (attribute 6), unique per vendor.
    pub serial: u32,
    /// The product name (attribute 7), at most 32 characters.
    pub product_name: &'a str,
}

/// Identity status bits (attribute 5) the adapter keeps itself.
pub mod status {
    /// Bit 0: an I/O connection with an exclusive owner is open.
    pub const OWNED: u16 = 0x0001;
    /// Bit 2: the device has a configuration other than the factory one.
    pub const CONFIGURED: u16 = 0x0004;
    /// Bits 4-7 = 6: at least one I/O connection is in the run mode.
    pub const EXT_IO_RUN: u16 = 0x0060;
    /// Bits 4-7 = 7: I/O connections are open, none in the run mode.
    pub const EXT_IO_IDLE: u16 = 0x0070;
    /// Bits 4-7 = 3: no I/O connection is open.
    pub const EXT_NO_IO: u16 = 0x0030;
    /// Bits 4-7: the extended device status field.
    pub const EXT_MASK: u16 = 0x00F0;
}

/// The values of the TCP/IP Interface object (class 0xF5, instance 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct TcpIpInfo<'a> {
    /// Attribute 1, interface status (1: a valid configuration).
    pub status: u32,
    /// Attribute 2, configuration capability (bit 2: DHCP client).
    pub config_capability: u32,
    /// Attribute 3, configuration control (0: static, 2: DHCP).
    pub config_control: u32,
    /// Attribute 5: the IP address.
    pub ip: Ipv4Addr,
    /// Attribute 5: the network mask.
    pub netmask: Ipv4Addr,
    /// Attribute 5: the gateway.
    pub gateway: Ipv4Addr,
    /// Attribute 5: the first name server.
    pub dns1: Ipv4Addr,
    /// Attribute 5: the second name server.
    pub dns2: Ipv4Addr,
    /// Attribute 5: the domain name (at most 48 characters).
    pub domain: &'a str,
    /// Attribute 6: the host name (at most 64 characters).
    pub host_name: &'a str,
}

/// The values of the Ethernet Link object (class 0xF6, instance 1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct EthernetLinkInfo {
    /// Attribute 1: the interface speed in Mbit/s.
    pub speed_mbps: u32,
    /// Attribute 2: interface flags (bit 0 link up, bit 1 full duplex,
    /// bits 2-4 negotiation status).
    pub flags: u32,
    /// Attribute 3: the MAC address.
    pub mac: [u8; 6],
}

/// What an assembly instance is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum AssemblyKind {
    /// Data the device produces (T->O), the PLC's inputs.
    Input,
    /// Data the device consumes (O->T), the PLC's outputs.
    Output,
    /// Configuration data sent with a Forward_Open.
    Config,
}

/// An assembly instance (class 0x04).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Assembly<'a> {
    /// The instance number (1-0xFFFF; vendor-specific range 100-199 is usual).
    pub instance: u16,
    /// What it is for.
    pub kind: AssemblyKind,
    /// Its size in bytes (fixed).
    pub size: u16,
    /// Its name in the EDS.
    pub name: &'a str,
}

/// The kind of a class 1 connection, by what the PLC may do with it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConnectionKind {
    /// Writes the output assembly and reads the input one; one owner at a time.
    ExclusiveOwner,
    /// Reads the input assembly; O->T carries only a heartbeat. Several may be open.
    InputOnly,
    /// Reads the input assembly; needs an exclusive-owner or input-only
    /// connection open on the same input assembly.
    ListenOnly,
    /// A class 3 (connected explicit messaging) connection to the Message Router.
    Explicit,
}

/// A class 1 connection the device accepts: the connection points of its
/// Forward_Open path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IoConnection<'a> {
    /// What it is.
    pub kind: ConnectionKind,
    /// The O->T connection point: the output assembly, or for input-only and
    /// listen-only the heartbeat connection point (an instance that is not an
    /// assembly, with no data).
    pub o_to_t: u16,
    /// The T->O connection point: an input assembly.
    pub t_to_o: u16,
    /// The configuration instance in the path (any value is accepted there
    /// if no config assembly of that instance exists and no data is sent).
    pub config: u16,
    /// Its name in the EDS.
    pub name: &'a str,
}

/// The device's assemblies and the connections it accepts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Device<'a> {
    /// The assembly instances.
    pub assemblies: &'a [Assembly<'a>],
    /// The class 1 connections.
    pub connections: &'a [IoConnection<'a>],
}

impl<'a> Device<'a> {
    /// The assembly with this instance number.
    pub fn assembly(&self, instance: u16) -> Option<&Assembly<'a>> {
        self.assemblies.iter().find(|a| a.instance == instance)
    }

    /// The connection whose path names these connection points.
    pub fn connection(&self, o_to_t: u16, t_to_o: u16) -> Option<&IoConnection<'a>> {
        self.connections
            .iter()
            .find(|c| c.o_to_t == o_to_t && c.t_to_o == t_to_o)
    }
}
