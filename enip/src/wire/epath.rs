//! EPATH, the padded path of CIP: a sequence of segments that name a
//! class, an instance, an attribute, connection points, a route through
//! ports, an electronic key or a block of data.
//!
//! ```text
//! logical:  0b001 TTT FF  value     TTT: 0 class, 1 instance, 2 member,
//!                                        3 connection point, 4 attribute, 5 special
//!                                   FF: 0 8-bit | 1 pad + 16-bit | 2 pad + 32-bit
//! port:     0b000 E PPPP [link size] [port u16 if PPPP = 15] link [pad]
//! key:      0x34 0x04 vendor u16 | device type u16 | product code u16 | major u8 | minor u8
//! data:     0x80 words u8 | words * 2 bytes       (simple data segment)
//! symbol:   0x91 length u8 | bytes [pad]          (ANSI extended symbol)
//! ```
//! Only the padded form exists on EtherNet/IP: every segment has an even
//! length.

use super::{Error, Reader, Writer};

/// The longest path a request may carry here, in bytes (a path size field
/// counts 16-bit words, so 510 is the format's own limit).
pub const MAX_PATH_LEN: usize = 510;

/// A logical segment's kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum LogicalType {
    /// A class id.
    Class,
    /// An instance id.
    Instance,
    /// A member id (of an array attribute).
    Member,
    /// A connection point (of an assembly, in a Forward_Open path).
    ConnectionPoint,
    /// An attribute id.
    Attribute,
    /// A service id.
    ServiceId,
}

impl LogicalType {
    fn bits(self) -> u8 {
        match self {
            LogicalType::Class => 0,
            LogicalType::Instance => 1,
            LogicalType::Member => 2,
            LogicalType::ConnectionPoint => 3,
            LogicalType::Attribute => 4,
            LogicalType::ServiceId => 6,
        }
    }
}

/// An electronic key (key format 4): what the originator expects the device
/// to be. Zero fields match anything.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ElectronicKey {
    /// Vendor id (0: any).
    pub vendor_id: u16,
    /// Device type (0: any).
    pub device_type: u16,
    /// Product code (0: any).
    pub product_code: u16,
    /// Compatibility bit: any revision that can emulate the key's is accepted.
    pub compatibility: bool,
    /// Major revision (0: any).
    pub major: u8,
    /// Minor revision (0: any).
    pub minor: u8,
}

/// How a key failed to match.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum KeyMismatch {
    /// The vendor id or the product code differ.
    VendorOrProduct,
    /// The device type differs.
    DeviceType,
    /// The revision is not one the device is or can emulate.
    Revision,
}

impl ElectronicKey {
    /// Checks the key against a device's identity. With the compatibility
    /// bit the major revision must be equal and the minor at most the
    /// device's; without it both must be equal (zero matches anything).
    pub fn check(&self, id: &crate::device::Identity<'_>) -> Result<(), KeyMismatch> {
        if (self.vendor_id != 0 && self.vendor_id != id.vendor_id)
            || (self.product_code != 0 && self.product_code != id.product_code)
        {
            return Err(KeyMismatch::VendorOrProduct);
        }
        if self.device_type != 0 && self.device_type != id.device_type {
            return Err(KeyMismatch::DeviceType);
        }
        if self.major != 0 {
            if self.major != id.revision.major {
                return Err(KeyMismatch::Revision);
            }
            let minor_ok = if self.compatibility {
                self.minor <= id.revision.minor
            } else {
                self.minor == 0 || self.minor == id.revision.minor
            };
            if !minor_ok {
                return Err(KeyMismatch::Revision);
            }
        }
        Ok(())
    }
}

/// One segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Segment<'a> {
    /// A port and a link address (a route hop).
    Port {
        /// The port number.
        port: u16,
        /// The link address (a slot number is one byte).
        link: &'a [u8],
    },
    /// A logical segment.
    Logical {
        /// The kind.
        kind: LogicalType,
        /// The value.
        value: u32,
    },
    /// An electronic key.
    ElectronicKey(ElectronicKey),
    /// A simple data segment (e.g. configuration data in a Forward_Open).
    Data(&'a [u8]),
    /// An ANSI extended symbol segment (a tag name).
    Symbol(&'a [u8]),
}

/// The segment type byte of an electronic key.
pub const KEY_SEGMENT: u8 = 0x34;
/// The key format this crate reads (4: the normal key).
pub const KEY_FORMAT: u8 = 4;

/// The segments of a path, in order; iteration stops at the first error.
#[derive(Debug, Clone)]
pub struct Segments<'a> {
    r: Reader<'a>,
    failed: bool,
}

/// Iterates over the segments of a path.
pub fn segments(path: &[u8]) -> Segments<'_> {
    Segments {
        r: Reader::new(path),
        failed: false,
    }
}

impl<'a> Segments<'a> {
    fn next_segment(&mut self) -> Result<Segment<'a>, Error> {
        let r = &mut self.r;
        let t = r.u8("segment type")?;
        match t >> 5 {
            0b000 => {
                let extended_link = t & 0x10 != 0;
                let link_len = if extended_link {
                    usize::from(r.u8("port segment link size")?)
                } else {
                    1
                };
                let port = if t & 0x0F == 0x0F {
                    r.u16("port segment port")?
                } else {
                    u16::from(t & 0x0F)
                };
                let link = r.take(link_len, "port segment link")?;
                // Total length: 1 + (1 if extended) + (2 if port 15) + link.
                let total = 1
                    + usize::from(extended_link)
                    + if t & 0x0F == 0x0F { 2 } else { 0 }
                    + link_len;
                if total % 2 == 1 {
                    r.take(1, "port segment pad")?;
                }
                Ok(Segment::Port { port, link })
            }
            0b001 => {
                if t == KEY_SEGMENT {
                    let format = r.u8("electronic key format")?;
                    if format != KEY_FORMAT {
                        return Err(Error::Invalid {
                            what: "electronic key format",
                            value: u32::from(format),
                        });
                    }
                    let vendor_id = r.u16("electronic key vendor")?;
                    let device_type = r.u16("electronic key device type")?;
                    let product_code = r.u16("electronic key product code")?;
                    let major = r.u8("electronic key major")?;
                    let minor = r.u8("electronic key minor")?;
                    return Ok(Segment::ElectronicKey(ElectronicKey {
                        vendor_id,
                        device_type,
                        product_code,
                        compatibility: major & 0x80 != 0,
                        major: major & 0x7F,
                        minor,
                    }));
                }
                let kind = match (t >> 2) & 0x07 {
                    0 => LogicalType::Class,
                    1 => LogicalType::Instance,
                    2 => LogicalType::Member,
                    3 => LogicalType::ConnectionPoint,
                    4 => LogicalType::Attribute,
                    6 => LogicalType::ServiceId,
                    _ => {
                        return Err(Error::Invalid {
                            what: "logical segment type",
                            value: u32::from(t),
                        })
                    }
                };
                let value = match t & 0x03 {
                    0 => u32::from(r.u8("logical value")?),
                    1 => {
                        r.take(1, "logical pad")?;
                        u32::from(r.u16("logical value")?)
                    }
                    2 => {
                        r.take(1, "logical pad")?;
                        r.u32("logical value")?
                    }
                    _ => {
                        return Err(Error::Invalid {
                            what: "logical segment format",
                            value: u32::from(t),
                        })
                    }
                };
                Ok(Segment::Logical { kind, value })
            }
            0b100 if t == 0x80 => {
                let words = r.u8("data segment size")?;
                Ok(Segment::Data(
                    r.take(usize::from(words) * 2, "data segment")?,
                ))
            }
            0b100 if t == 0x91 => {
                let n = r.u8("symbol size")?;
                let s = r.take(usize::from(n), "symbol")?;
                if n % 2 == 1 {
                    r.take(1, "symbol pad")?;
                }
                Ok(Segment::Symbol(s))
            }
            _ => Err(Error::Invalid {
                what: "segment type",
                value: u32::from(t),
            }),
        }
    }
}

impl<'a> Iterator for Segments<'a> {
    type Item = Result<Segment<'a>, Error>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed || self.r.is_empty() {
            return None;
        }
        let s = self.next_segment();
        self.failed = s.is_err();
        Some(s)
    }
}

impl Segment<'_> {
    /// Writes the segment in the padded form (a logical value in the
    /// smallest format that holds it).
    pub fn emit(&self, w: &mut Writer<'_>) -> Result<(), Error> {
        match *self {
            Segment::Logical { kind, value } => {
                let t = 0x20 | (kind.bits() << 2);
                if let Ok(v) = u8::try_from(value) {
                    w.u8(t, "logical segment")?;
                    w.u8(v, "logical value")
                } else if let Ok(v) = u16::try_from(value) {
                    w.bytes(&[t | 1, 0], "logical segment")?;
                    w.u16(v, "logical value")
                } else {
                    w.bytes(&[t | 2, 0], "logical segment")?;
                    w.u32(value, "logical value")
                }
            }
            Segment::Port { port, link } => {
                let extended = link.len() != 1;
                let wide_port = port >= 15;
                let mut t = if wide_port { 0x0F } else { port as u8 & 0x0F };
                if extended {
                    t |= 0x10;
                }
                w.u8(t, "port segment")?;
                if extended {
                    let n = u8::try_from(link.len()).map_err(|_| Error::Exhausted {
                        what: "port segment link",
                    })?;
                    w.u8(n, "port segment link size")?;
                }
                if wide_port {
                    w.u16(port, "port segment port")?;
                }
                w.bytes(link, "port segment link")?;
                let total = 1 + usize::from(extended) + if wide_port { 2 } else { 0 } + link.len();
                if total % 2 == 1 {
                    w.u8(0, "port segment pad")?;
                }
                Ok(())
            }
            Segment::ElectronicKey(k) => {
                w.bytes(&[KEY_SEGMENT, KEY_FORMAT], "electronic key")?;
                w.u16(k.vendor_id, "electronic key vendor")?;
                w.u16(k.device_type, "electronic key device type")?;
                w.u16(k.product_code, "electronic key product code")?;
                w.u8(
                    k.major | if k.compatibility { 0x80 } else { 0 },
                    "electronic key major",
                )?;
                w.u8(k.minor, "electronic key minor")
            }
            Segment::Data(d) => {
                if d.len() % 2 == 1 {
                    return Err(Error::Invalid {
                        what: "data segment length",
                        value: d.len() as u32,
                    });
                }
                let words = u8::try_from(d.len() / 2).map_err(|_| Error::Exhausted {
                    what: "data segment",
                })?;
                w.bytes(&[0x80, words], "data segment")?;
                w.bytes(d, "data segment")
            }
            Segment::Symbol(s) => {
                let n = u8::try_from(s.len()).map_err(|_| Error::Exhausted { what: "symbol" })?;
                w.bytes(&[0x91, n], "symbol")?;
                w.bytes(s, "symbol")?;
                if n % 2 == 1 {
                    w.u8(0, "symbol pad")?;
                }
                Ok(())
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::{Identity, Revision};

    fn all(path: &[u8]) -> Result<heapless::Vec<Segment<'_>, 8>, Error> {
        let mut v = heapless::Vec::new();
        for s in segments(path) {
            v.push(s?).unwrap();
        }
        Ok(v)
    }

    #[test]
    fn reads_logical_segments_of_each_size() {
        let p = [
            0x20, 0x04, 0x25, 0x00, 0x34, 0x12, 0x2C, 0x96, 0x31, 0x00, 0x03, 0x00, 0x26, 0x00, 1,
            2, 3, 4,
        ];
        let s = all(&p).unwrap();
        assert_eq!(
            s[0],
            Segment::Logical {
                kind: LogicalType::Class,
                value: 4
            }
        );
        assert_eq!(
            s[1],
            Segment::Logical {
                kind: LogicalType::Instance,
                value: 0x1234
            }
        );
        assert_eq!(
            s[2],
            Segment::Logical {
                kind: LogicalType::ConnectionPoint,
                value: 0x96
            }
        );
        assert_eq!(
            s[3],
            Segment::Logical {
                kind: LogicalType::Attribute,
                value: 3
            }
        );
        assert_eq!(
            s[4],
            Segment::Logical {
                kind: LogicalType::Instance,
                value: 0x04030201
            }
        );
    }

    #[test]
    fn emits_what_it_reads() {
        let key = ElectronicKey {
            vendor_id: 1,
            device_type: 0x0C,
            product_code: 2,
            compatibility: true,
            major: 3,
            minor: 4,
        };
        let segs = [
            Segment::Port {
                port: 1,
                link: &[0],
            },
            Segment::Port {
                port: 18,
                link: &[1, 2, 3],
            },
            Segment::ElectronicKey(key),
            Segment::Logical {
                kind: LogicalType::Class,
                value: 6,
            },
            Segment::Logical {
                kind: LogicalType::Instance,
                value: 0x1_0000,
            },
            Segment::Logical {
                kind: LogicalType::Member,
                value: 300,
            },
            Segment::Data(&[1, 2, 3, 4]),
            Segment::Symbol(b"abc"),
        ];
        let mut buf = [0u8; 128];
        let mut w = Writer::new(&mut buf);
        for s in &segs {
            s.emit(&mut w).unwrap();
        }
        let n = w.len();
        assert_eq!(n % 2, 0);
        assert_eq!(&buf[..2], &[0x01, 0x00]);
        assert_eq!(all(&buf[..n]).unwrap().as_slice(), &segs);
    }

    #[test]
    fn every_error_path() {
        for bad in [
            &[0x20][..],                     // no value
            &[0x21, 0x00, 0x01],             // 16-bit value cut
            &[0x23, 0x00],                   // reserved format
            &[0x3C, 0x00],                   // reserved logical type (7)
            &[0x34, 0x05, 0, 0],             // key format 5
            &[0x34, 0x04, 1, 0],             // key cut
            &[0x80, 0x02, 1, 2, 3],          // data cut
            &[0x91, 0x03, b'a', b'b', b'c'], // no pad
            &[0x12, 0x05, 1, 2],             // port link cut
            &[0x40, 0x00],                   // network segment: not read here
            &[0x0F, 0x01],                   // port 15: wide port cut
        ] {
            assert!(all(bad).is_err(), "{bad:02x?}");
        }
        // Iteration stops after the first error.
        let mut it = segments(&[0x23, 0x00, 0x20, 0x01]);
        assert!(it.next().unwrap().is_err());
        assert!(it.next().is_none());
        let mut small = [0u8; 3];
        assert!(Segment::Logical {
            kind: LogicalType::Class,
            value: 300
        }
        .emit(&mut Writer::new(&mut small))
        .is_err());
        assert!(Segment::Data(&[1])
            .emit(&mut Writer::new(&mut [0u8; 8]))
            .is_err());
    }

    #[test]
    fn key_checks() {
        let id = Identity {
            vendor_id: 10,
            device_type: 0x0C,
            product_code: 20,
            revision: Revision { major: 2, minor: 5 },
            status: 0,
            serial: 1,
            product_name: "x",
        };
        let any = ElectronicKey {
            vendor_id: 0,
            device_type: 0,
            product_code: 0,
            compatibility: false,
            major: 0,
            minor: 0,
        };
        assert_eq!(any.check(&id), Ok(()));
        let exact = ElectronicKey {
            vendor_id: 10,
            device_type: 0x0C,
            product_code: 20,
            major: 2,
            minor: 5,
            ..any
        };
        assert_eq!(exact.check(&id), Ok(()));
        assert_eq!(
            ElectronicKey {
                vendor_id: 11,
                ..exact
            }
            .check(&id),
            Err(KeyMismatch::VendorOrProduct)
        );
        assert_eq!(
            ElectronicKey {
                product_code: 21,
                ..exact
            }
            .check(&id),
            Err(KeyMismatch::VendorOrProduct)
        );
        assert_eq!(
            ElectronicKey {
                device_type: 0x2B,
                ..exact
            }
            .check(&id),
            Err(KeyMismatch::DeviceType)
        );
        assert_eq!(
            ElectronicKey { major: 3, ..exact }.check(&id),
            Err(KeyMismatch::Revision)
        );
        assert_eq!(
            ElectronicKey { minor: 4, ..exact }.check(&id),
            Err(KeyMismatch::Revision)
        );
        assert_eq!(
            ElectronicKey {
                minor: 4,
                compatibility: true,
                ..exact
            }
            .check(&id),
            Ok(())
        );
        assert_eq!(
            ElectronicKey {
                minor: 6,
                compatibility: true,
                ..exact
            }
            .check(&id),
            Err(KeyMismatch::Revision)
        );
        assert_eq!(ElectronicKey { minor: 0, ..exact }.check(&id), Ok(()));
    }
}
