//! Connection Manager (class 0x06) services: Forward_Open (0x54),
//! Large_Forward_Open (0x5B) and Forward_Close (0x4E), the data after the
//! Message Router header.
//!
//! ```text
//! Forward_Open request:
//!  0 priority/tick u8 | 1 timeout ticks u8 | 2 O->T id u32 | 6 T->O id u32 | 10 serial u16 |
//! 12 originator vendor u16 | 14 originator serial u32 | 18 timeout multiplier u8 | 19 reserved 3 |
//! 22 O->T RPI u32 | 26 O->T parameters u16 (u32 in Large) | T->O RPI u32 | T->O parameters u16 (u32) |
//!    transport type/trigger u8 | path size u8 (words) | path
//! Forward_Open reply (success):
//!    O->T id u32 | T->O id u32 | serial u16 | vendor u16 | originator serial u32 |
//!    O->T API u32 | T->O API u32 | application reply size u8 (words) | reserved u8 | reply
//! Forward_Close request:
//!    priority/tick u8 | timeout ticks u8 | serial u16 | vendor u16 | originator serial u32 |
//!    path size u8 (words) | reserved u8 | path
//! Forward_Close reply (success):
//!    serial u16 | vendor u16 | originator serial u32 | application reply size u8 | reserved u8
//! Failure reply of either (general status 0x01, extended status in the additional status):
//!    serial u16 | vendor u16 | originator serial u32 | remaining path size u8 | reserved u8
//! ```
//! The serial, the originator's vendor id and the originator's serial
//! number together (the connection triad) name a connection.

use super::{get_u16, get_u32, Error, Field, Reader, Writer};

/// The named byte ranges of the fixed start of a Forward_Open request
/// (the same in Large_Forward_Open).
pub mod field {
    use super::Field;
    /// Priority and time tick.
    pub const PRIORITY_TICK: Field = 0..1;
    /// Timeout in ticks (for the unconnected request itself).
    pub const TIMEOUT_TICKS: Field = 1..2;
    /// The O->T network connection id the originator proposes.
    pub const O_T_ID: Field = 2..6;
    /// The T->O network connection id the originator proposes.
    pub const T_O_ID: Field = 6..10;
    /// The connection serial number.
    pub const SERIAL: Field = 10..12;
    /// The originator's vendor id.
    pub const VENDOR: Field = 12..14;
    /// The originator's serial number.
    pub const ORIGINATOR_SERIAL: Field = 14..18;
    /// The connection timeout multiplier (0-7: x4, x8, ... x512).
    pub const MULTIPLIER: Field = 18..19;
    /// Reserved.
    pub const RESERVED: Field = 19..22;
    /// The O->T requested packet interval in microseconds.
    pub const O_T_RPI: Field = 22..26;
    /// Where the variable-width part starts.
    pub const REST: usize = 26;
}

/// The length of a Forward_Open request without its path.
pub const FORWARD_OPEN_FIXED_LEN: usize = 36;
/// The length of a Large_Forward_Open request without its path.
pub const LARGE_FORWARD_OPEN_FIXED_LEN: usize = 40;

enum_with_unknown! {
    /// The extended status of a failed connection service.
    pub enum ExtendedStatus(u16) {
        /// The connection (triad) is already open: a duplicate Forward_Open.
        ConnectionInUse = 0x0100,
        /// The transport class and trigger are not supported.
        TransportNotSupported = 0x0103,
        /// Another originator owns the output (exclusive owner).
        OwnershipConflict = 0x0106,
        /// Forward_Close: no connection with this triad.
        ConnectionNotFound = 0x0107,
        /// The network connection parameters (type, priority) are not supported.
        InvalidConnectionType = 0x0108,
        /// The connection size is not supported (either direction).
        InvalidConnectionSize = 0x0109,
        /// The RPI is out of the supported range.
        RpiNotSupported = 0x0111,
        /// No free connection.
        OutOfConnections = 0x0113,
        /// The electronic key's vendor id or product code differ.
        VendorOrProductMismatch = 0x0114,
        /// The electronic key's device type differs.
        DeviceTypeMismatch = 0x0115,
        /// The electronic key's revision does not match.
        RevisionMismatch = 0x0116,
        /// The connection points do not name an input or output assembly.
        InvalidApplicationPath = 0x0117,
        /// The configuration path or data is not valid.
        InvalidConfigurationPath = 0x0118,
        /// A listen-only connection without an owning connection to listen to.
        NonListenOnlyNotOpen = 0x0119,
        /// The O->T size does not match the output (or heartbeat) point.
        InvalidOToTSize = 0x0127,
        /// The T->O size does not match the input assembly.
        InvalidTToOSize = 0x0128,
        /// The connection timed out.
        ConnectionTimedOut = 0x0203,
        /// A parameter of the request is in error.
        ParameterError = 0x0205,
        /// The connection path has a segment that cannot be used.
        InvalidSegment = 0x0315,
    }
}

/// The kind of a network connection (bits 13-14 of the 16-bit parameters).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConnectionType {
    /// No connection (a null Forward_Open).
    Null,
    /// Multicast.
    Multicast,
    /// Point to point (unicast).
    PointToPoint,
    /// The reserved value 3.
    Reserved,
}

/// Network connection parameters of one direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct NetParams {
    /// Redundant owner.
    pub redundant_owner: bool,
    /// Connection type.
    pub kind: ConnectionType,
    /// Priority (0 low, 1 high, 2 scheduled, 3 urgent).
    pub priority: u8,
    /// Variable (true) or fixed size.
    pub variable: bool,
    /// Size in bytes (for class 1: with the sequence count and any run/idle header).
    pub size: u16,
}

impl NetParams {
    fn kind_from(bits: u32) -> ConnectionType {
        match bits & 3 {
            0 => ConnectionType::Null,
            1 => ConnectionType::Multicast,
            2 => ConnectionType::PointToPoint,
            _ => ConnectionType::Reserved,
        }
    }

    fn kind_bits(self) -> u32 {
        match self.kind {
            ConnectionType::Null => 0,
            ConnectionType::Multicast => 1,
            ConnectionType::PointToPoint => 2,
            ConnectionType::Reserved => 3,
        }
    }

    /// Reads the 16-bit form (size in bits 0-8).
    pub fn from_u16(v: u16) -> NetParams {
        let v = u32::from(v);
        NetParams {
            redundant_owner: v & 0x8000 != 0,
            kind: Self::kind_from(v >> 13),
            priority: ((v >> 10) & 3) as u8,
            variable: v & 0x0200 != 0,
            size: (v & 0x01FF) as u16,
        }
    }

    /// Reads the 32-bit form of Large_Forward_Open (size in bits 0-15).
    pub fn from_u32(v: u32) -> NetParams {
        NetParams {
            redundant_owner: v & 0x8000_0000 != 0,
            kind: Self::kind_from(v >> 29),
            priority: ((v >> 26) & 3) as u8,
            variable: v & 0x0200_0000 != 0,
            size: (v & 0xFFFF) as u16,
        }
    }

    /// The 16-bit form (a size over 511 does not fit it and is cut).
    pub fn to_u16(self) -> u16 {
        let v = (u32::from(self.redundant_owner) << 15)
            | (self.kind_bits() << 13)
            | (u32::from(self.priority & 3) << 10)
            | (u32::from(self.variable) << 9)
            | u32::from(self.size & 0x01FF);
        v as u16
    }

    /// The 32-bit form.
    pub fn to_u32(self) -> u32 {
        (u32::from(self.redundant_owner) << 31)
            | (self.kind_bits() << 29)
            | (u32::from(self.priority & 3) << 26)
            | (u32::from(self.variable) << 25)
            | u32::from(self.size)
    }
}

/// The transport class and trigger byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Transport {
    /// Direction bit: set for a server (class 2/3 target side).
    pub server: bool,
    /// Production trigger: 0 cyclic, 1 change of state, 2 application.
    pub trigger: u8,
    /// Transport class (0-3).
    pub class: u8,
}

impl From<u8> for Transport {
    fn from(v: u8) -> Transport {
        Transport {
            server: v & 0x80 != 0,
            trigger: (v >> 4) & 0x07,
            class: v & 0x0F,
        }
    }
}

impl From<Transport> for u8 {
    fn from(t: Transport) -> u8 {
        (u8::from(t.server) << 7) | ((t.trigger & 7) << 4) | (t.class & 0x0F)
    }
}

/// The connection triad: what names a connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Triad {
    /// The connection serial number.
    pub serial: u16,
    /// The originator's vendor id.
    pub vendor: u16,
    /// The originator's serial number.
    pub originator_serial: u32,
}

impl Triad {
    fn emit(&self, w: &mut Writer<'_>) -> Result<(), Error> {
        w.u16(self.serial, "connection serial")?;
        w.u16(self.vendor, "originator vendor")?;
        w.u32(self.originator_serial, "originator serial")
    }
}

/// A Forward_Open or Large_Forward_Open request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ForwardOpen<'a> {
    /// Large_Forward_Open (32-bit network parameters).
    pub large: bool,
    /// Priority and time tick.
    pub priority_tick: u8,
    /// Timeout ticks.
    pub timeout_ticks: u8,
    /// The O->T connection id the originator proposes.
    pub o_t_id: u32,
    /// The T->O connection id the originator proposes.
    pub t_o_id: u32,
    /// The triad.
    pub triad: Triad,
    /// The timeout multiplier (0-7).
    pub multiplier: u8,
    /// O->T RPI in microseconds.
    pub o_t_rpi: u32,
    /// O->T parameters.
    pub o_t_params: NetParams,
    /// T->O RPI in microseconds.
    pub t_o_rpi: u32,
    /// T->O parameters.
    pub t_o_params: NetParams,
    /// Transport class and trigger.
    pub transport: Transport,
    /// The connection path.
    pub path: &'a [u8],
}

impl<'a> ForwardOpen<'a> {
    /// Reads a request's data; `large` for Large_Forward_Open. Bytes after
    /// the path are an error.
    pub fn parse(data: &'a [u8], large: bool) -> Result<ForwardOpen<'a>, Error> {
        let fixed = if large {
            LARGE_FORWARD_OPEN_FIXED_LEN
        } else {
            FORWARD_OPEN_FIXED_LEN
        };
        if data.len() < fixed {
            return Err(Error::Truncated {
                what: "Forward_Open",
                expected: fixed,
                got: data.len(),
            });
        }
        let mut r = Reader::new(data.get(field::REST..).unwrap_or(&[]));
        let (o_t_params, t_o_rpi, t_o_params) = if large {
            let o = NetParams::from_u32(r.u32("O->T parameters")?);
            let rpi = r.u32("T->O RPI")?;
            (o, rpi, NetParams::from_u32(r.u32("T->O parameters")?))
        } else {
            let o = NetParams::from_u16(r.u16("O->T parameters")?);
            let rpi = r.u32("T->O RPI")?;
            (o, rpi, NetParams::from_u16(r.u16("T->O parameters")?))
        };
        let transport = Transport::from(r.u8("transport")?);
        let words = r.u8("connection path size")?;
        let path = r.take(usize::from(words) * 2, "connection path")?;
        if !r.is_empty() {
            return Err(Error::TrailingBytes {
                what: "Forward_Open",
                extra: r.rest().len(),
            });
        }
        let byte = |f: Field| data.get(f.start).copied().unwrap_or(0);
        Ok(ForwardOpen {
            large,
            priority_tick: byte(field::PRIORITY_TICK),
            timeout_ticks: byte(field::TIMEOUT_TICKS),
            o_t_id: get_u32(data, field::O_T_ID),
            t_o_id: get_u32(data, field::T_O_ID),
            triad: Triad {
                serial: get_u16(data, field::SERIAL),
                vendor: get_u16(data, field::VENDOR),
                originator_serial: get_u32(data, field::ORIGINATOR_SERIAL),
            },
            multiplier: byte(field::MULTIPLIER),
            o_t_rpi: get_u32(data, field::O_T_RPI),
            o_t_params,
            t_o_rpi,
            t_o_params,
            transport,
            path,
        })
    }

    /// Writes the request's data (what a scanner sends; used by tests and
    /// the fuzz seeds).
    pub fn emit(&self, w: &mut Writer<'_>) -> Result<(), Error> {
        if self.path.len() % 2 == 1 {
            return Err(Error::Invalid {
                what: "connection path length",
                value: self.path.len() as u32,
            });
        }
        let words = u8::try_from(self.path.len() / 2).map_err(|_| Error::Exhausted {
            what: "connection path",
        })?;
        w.u8(self.priority_tick, "priority/tick")?;
        w.u8(self.timeout_ticks, "timeout ticks")?;
        w.u32(self.o_t_id, "O->T id")?;
        w.u32(self.t_o_id, "T->O id")?;
        self.triad.emit(w)?;
        w.u8(self.multiplier, "timeout multiplier")?;
        w.bytes(&[0; 3], "reserved")?;
        w.u32(self.o_t_rpi, "O->T RPI")?;
        if self.large {
            w.u32(self.o_t_params.to_u32(), "O->T parameters")?;
        } else {
            w.u16(self.o_t_params.to_u16(), "O->T parameters")?;
        }
        w.u32(self.t_o_rpi, "T->O RPI")?;
        if self.large {
            w.u32(self.t_o_params.to_u32(), "T->O parameters")?;
        } else {
            w.u16(self.t_o_params.to_u16(), "T->O parameters")?;
        }
        w.u8(self.transport.into(), "transport")?;
        w.u8(words, "connection path size")?;
        w.bytes(self.path, "connection path")
    }
}

/// A Forward_Open reply's data on success.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ForwardOpenReply {
    /// The O->T connection id (the target's choice for point-to-point).
    pub o_t_id: u32,
    /// The T->O connection id.
    pub t_o_id: u32,
    /// The triad of the request.
    pub triad: Triad,
    /// The actual O->T packet interval in microseconds.
    pub o_t_api: u32,
    /// The actual T->O packet interval in microseconds.
    pub t_o_api: u32,
}

impl ForwardOpenReply {
    /// The length of the reply data (no application reply).
    pub const LEN: usize = 26;

    /// Writes the reply data (no application reply).
    pub fn emit(&self, w: &mut Writer<'_>) -> Result<(), Error> {
        w.u32(self.o_t_id, "O->T id")?;
        w.u32(self.t_o_id, "T->O id")?;
        self.triad.emit(w)?;
        w.u32(self.o_t_api, "O->T API")?;
        w.u32(self.t_o_api, "T->O API")?;
        w.u8(0, "application reply size")?;
        w.u8(0, "reserved")
    }

    /// Reads the reply data (ignoring any application reply).
    pub fn parse(data: &[u8]) -> Result<ForwardOpenReply, Error> {
        let mut r = Reader::new(data);
        let o_t_id = r.u32("O->T id")?;
        let t_o_id = r.u32("T->O id")?;
        let triad = Triad {
            serial: r.u16("connection serial")?,
            vendor: r.u16("originator vendor")?,
            originator_serial: r.u32("originator serial")?,
        };
        let o_t_api = r.u32("O->T API")?;
        let t_o_api = r.u32("T->O API")?;
        let words = r.u8("application reply size")?;
        r.u8("reserved")?;
        r.take(usize::from(words) * 2, "application reply")?;
        Ok(ForwardOpenReply {
            o_t_id,
            t_o_id,
            triad,
            o_t_api,
            t_o_api,
        })
    }
}

/// Writes the data of a failure reply (Forward_Open or Forward_Close): the
/// triad and the remaining path size (0: the target is the end of the path).
pub fn emit_failure(triad: &Triad, w: &mut Writer<'_>) -> Result<(), Error> {
    triad.emit(w)?;
    w.u8(0, "remaining path size")?;
    w.u8(0, "reserved")
}

/// A Forward_Close request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ForwardClose<'a> {
    /// Priority and time tick.
    pub priority_tick: u8,
    /// Timeout ticks.
    pub timeout_ticks: u8,
    /// The triad of the connection to close.
    pub triad: Triad,
    /// The connection path (not used to find the connection).
    pub path: &'a [u8],
}

/// The length of a Forward_Close request without its path.
pub const FORWARD_CLOSE_FIXED_LEN: usize = 12;

impl<'a> ForwardClose<'a> {
    /// Reads a request's data.
    pub fn parse(data: &'a [u8]) -> Result<ForwardClose<'a>, Error> {
        let mut r = Reader::new(data);
        let priority_tick = r.u8("priority/tick")?;
        let timeout_ticks = r.u8("timeout ticks")?;
        let triad = Triad {
            serial: r.u16("connection serial")?,
            vendor: r.u16("originator vendor")?,
            originator_serial: r.u32("originator serial")?,
        };
        let words = r.u8("connection path size")?;
        r.u8("reserved")?;
        let path = r.take(usize::from(words) * 2, "connection path")?;
        if !r.is_empty() {
            return Err(Error::TrailingBytes {
                what: "Forward_Close",
                extra: r.rest().len(),
            });
        }
        Ok(ForwardClose {
            priority_tick,
            timeout_ticks,
            triad,
            path,
        })
    }

    /// Writes a request's data.
    pub fn emit(&self, w: &mut Writer<'_>) -> Result<(), Error> {
        if self.path.len() % 2 == 1 {
            return Err(Error::Invalid {
                what: "connection path length",
                value: self.path.len() as u32,
            });
        }
        let words = u8::try_from(self.path.len() / 2).map_err(|_| Error::Exhausted {
            what: "connection path",
        })?;
        w.u8(self.priority_tick, "priority/tick")?;
        w.u8(self.timeout_ticks, "timeout ticks")?;
        self.triad.emit(w)?;
        w.u8(words, "connection path size")?;
        w.u8(0, "reserved")?;
        w.bytes(self.path, "connection path")
    }
}

/// Writes a Forward_Close success reply's data.
pub fn emit_close_reply(triad: &Triad, w: &mut Writer<'_>) -> Result<(), Error> {
    triad.emit(w)?;
    w.u8(0, "application reply size")?;
    w.u8(0, "reserved")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request(large: bool) -> ForwardOpen<'static> {
        ForwardOpen {
            large,
            priority_tick: 0x0A,
            timeout_ticks: 0x0E,
            o_t_id: 0,
            t_o_id: 0x1234_5678,
            triad: Triad {
                serial: 7,
                vendor: 1,
                originator_serial: 0xCAFE,
            },
            multiplier: 2,
            o_t_rpi: 10_000,
            o_t_params: NetParams {
                redundant_owner: false,
                kind: ConnectionType::PointToPoint,
                priority: 0,
                variable: false,
                size: 38,
            },
            t_o_rpi: 10_000,
            t_o_params: NetParams {
                redundant_owner: false,
                kind: ConnectionType::PointToPoint,
                priority: 0,
                variable: false,
                size: if large { 1000 } else { 66 },
            },
            transport: Transport {
                server: false,
                trigger: 0,
                class: 1,
            },
            path: &[0x20, 0x04, 0x24, 0x01, 0x2C, 0x96, 0x2C, 0x64],
        }
    }

    #[test]
    fn forward_open_round_trips_in_both_forms() {
        for large in [false, true] {
            let fo = request(large);
            let mut buf = [0u8; 64];
            let mut w = Writer::new(&mut buf);
            fo.emit(&mut w).unwrap();
            let n = w.len();
            let fixed = if large {
                LARGE_FORWARD_OPEN_FIXED_LEN
            } else {
                FORWARD_OPEN_FIXED_LEN
            };
            assert_eq!(n, fixed + 8);
            assert_eq!(ForwardOpen::parse(&buf[..n], large).unwrap(), fo);
            for cut in 0..n {
                assert!(ForwardOpen::parse(&buf[..cut], large).is_err(), "{cut}");
            }
            let mut long = [0u8; 65];
            long[..n].copy_from_slice(&buf[..n]);
            assert!(matches!(
                ForwardOpen::parse(&long[..n + 1], large),
                Err(Error::TrailingBytes { extra: 1, .. })
            ));
        }
    }

    #[test]
    fn net_params_bits() {
        // Logix's usual exclusive-owner O->T: point to point, scheduled, fixed, 38 bytes.
        let p = NetParams::from_u16(0x4826);
        assert_eq!(p.kind, ConnectionType::PointToPoint);
        assert_eq!(p.priority, 2);
        assert!(!p.variable);
        assert_eq!(p.size, 38);
        assert_eq!(p.to_u16(), 0x4826);
        let l = NetParams::from_u32(0x4800_0400);
        assert_eq!(
            (l.kind, l.priority, l.size),
            (ConnectionType::PointToPoint, 2, 0x400)
        );
        assert_eq!(l.to_u32(), 0x4800_0400);
        assert_eq!(NetParams::from_u16(0x2000).kind, ConnectionType::Multicast);
        assert_eq!(NetParams::from_u16(0x6000).kind, ConnectionType::Reserved);
        assert_eq!(NetParams::from_u16(0x0000).kind, ConnectionType::Null);
        assert!(NetParams::from_u16(0x8200).redundant_owner);
    }

    #[test]
    fn transport_byte() {
        assert_eq!(
            Transport::from(0x01),
            Transport {
                server: false,
                trigger: 0,
                class: 1
            }
        );
        assert_eq!(
            Transport::from(0xA3),
            Transport {
                server: true,
                trigger: 2,
                class: 3
            }
        );
        assert_eq!(u8::from(Transport::from(0xA3)), 0xA3);
    }

    #[test]
    fn replies() {
        let r = ForwardOpenReply {
            o_t_id: 1,
            t_o_id: 2,
            triad: Triad {
                serial: 3,
                vendor: 4,
                originator_serial: 5,
            },
            o_t_api: 10_000,
            t_o_api: 20_000,
        };
        let mut buf = [0u8; 32];
        let mut w = Writer::new(&mut buf);
        r.emit(&mut w).unwrap();
        assert_eq!(w.len(), ForwardOpenReply::LEN);
        assert_eq!(ForwardOpenReply::parse(&buf[..26]).unwrap(), r);
        assert!(ForwardOpenReply::parse(&buf[..25]).is_err());
        let mut w = Writer::new(&mut buf);
        emit_failure(&r.triad, &mut w).unwrap();
        assert_eq!(&buf[..10], &[3, 0, 4, 0, 5, 0, 0, 0, 0, 0]);
        assert!(emit_failure(&r.triad, &mut Writer::new(&mut [0u8; 9])).is_err());
        assert!(r.emit(&mut Writer::new(&mut [0u8; 25])).is_err());
    }

    #[test]
    fn forward_close_round_trips() {
        let fc = ForwardClose {
            priority_tick: 0x0A,
            timeout_ticks: 0x0E,
            triad: Triad {
                serial: 7,
                vendor: 1,
                originator_serial: 0xCAFE,
            },
            path: &[0x20, 0x04, 0x24, 0x01],
        };
        let mut buf = [0u8; 32];
        let mut w = Writer::new(&mut buf);
        fc.emit(&mut w).unwrap();
        let n = w.len();
        assert_eq!(n, 16);
        assert_eq!(ForwardClose::parse(&buf[..n]).unwrap(), fc);
        for cut in 0..n {
            assert!(ForwardClose::parse(&buf[..cut]).is_err());
        }
        assert!(ForwardClose::parse(&buf[..n + 1]).is_err());
        let mut w = Writer::new(&mut buf);
        emit_close_reply(&fc.triad, &mut w).unwrap();
        assert_eq!(w.len(), 10);
        let odd = ForwardClose { path: &[1], ..fc };
        assert!(odd.emit(&mut Writer::new(&mut [0u8; 32])).is_err());
    }
}
