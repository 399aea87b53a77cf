//! The CIP Identity item of a ListIdentity reply, and the communications
//! item of a ListServices reply.
//!
//! ```text
//! CIP Identity (item 0x000C):
//! | version u16 | sockaddr 16 (big-endian) | vendor u16 | device type u16 | product code u16 |
//! | major u8 | minor u8 | status u16 | serial u32 | name length u8 | name | state u8 |
//! ListServices (item 0x0100):
//! | version u16 | capability flags u16 | name, 16 bytes NUL-padded ("Communications") |
//! ```

use core::net::SocketAddrV4;

use super::cpf::Sockaddr;
use super::{Error, Reader, Writer};
use crate::device::{Identity, Revision};

/// The longest product name an identity may carry (a SHORT_STRING holds 255,
/// the Identity object's attribute 7 is specified with 32).
pub const MAX_PRODUCT_NAME: usize = 32;

/// The state byte of a ListIdentity reply: "operational".
pub const STATE_OPERATIONAL: u8 = 0x03;

/// The CIP Identity item's data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct IdentityItem<'a> {
    /// The encapsulation protocol version (1).
    pub version: u16,
    /// The device's address and TCP port for encapsulation.
    pub socket: SocketAddrV4,
    /// The identity.
    pub identity: Identity<'a>,
    /// The device state (0xFF when not implemented).
    pub state: u8,
}

impl<'a> IdentityItem<'a> {
    /// Reads the item's data.
    pub fn parse(data: &'a [u8]) -> Result<IdentityItem<'a>, Error> {
        let mut r = Reader::new(data);
        let version = r.u16("identity version")?;
        let socket = Sockaddr::parse(r.take(16, "identity sockaddr")?)?.addr;
        let vendor_id = r.u16("identity vendor id")?;
        let device_type = r.u16("identity device type")?;
        let product_code = r.u16("identity product code")?;
        let major = r.u8("identity major revision")?;
        let minor = r.u8("identity minor revision")?;
        let status = r.u16("identity status")?;
        let serial = r.u32("identity serial")?;
        let n = r.u8("identity name length")?;
        let name = r.take(usize::from(n), "identity name")?;
        let product_name = core::str::from_utf8(name).map_err(|_| Error::Invalid {
            what: "identity name",
            value: u32::from(n),
        })?;
        let state = r.u8("identity state")?;
        if !r.is_empty() {
            return Err(Error::TrailingBytes {
                what: "identity item",
                extra: r.rest().len(),
            });
        }
        Ok(IdentityItem {
            version,
            socket,
            identity: Identity {
                vendor_id,
                device_type,
                product_code,
                revision: Revision { major, minor },
                status,
                serial,
                product_name,
            },
            state,
        })
    }

    /// Writes the item's data. A product name longer than
    /// [`MAX_PRODUCT_NAME`] is cut there (on a character boundary).
    pub fn emit(&self, w: &mut Writer<'_>) -> Result<(), Error> {
        let id = &self.identity;
        w.u16(self.version, "identity version")?;
        Sockaddr { addr: self.socket }.emit(w)?;
        w.u16(id.vendor_id, "identity vendor id")?;
        w.u16(id.device_type, "identity device type")?;
        w.u16(id.product_code, "identity product code")?;
        w.u8(id.revision.major, "identity major revision")?;
        w.u8(id.revision.minor, "identity minor revision")?;
        w.u16(id.status, "identity status")?;
        w.u32(id.serial, "identity serial")?;
        let name = short_name(id.product_name);
        // Cannot truncate: short_name keeps at most 32 bytes.
        w.u8(
            u8::try_from(name.len()).unwrap_or(0),
            "identity name length",
        )?;
        w.bytes(name.as_bytes(), "identity name")?;
        w.u8(self.state, "identity state")
    }
}

/// The product name as sent: at most [`MAX_PRODUCT_NAME`] bytes, cut on a
/// character boundary.
pub fn short_name(name: &str) -> &str {
    if name.len() <= MAX_PRODUCT_NAME {
        return name;
    }
    let mut end = MAX_PRODUCT_NAME;
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    name.get(..end).unwrap_or("")
}

/// ListServices capability flag: CIP encapsulation over TCP.
pub const CAPABILITY_CIP_TCP: u16 = 0x0020;
/// ListServices capability flag: CIP class 0/1 I/O over UDP.
pub const CAPABILITY_CLASS01_UDP: u16 = 0x0100;

/// The ListServices communications item's data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ServicesItem {
    /// The protocol version (1).
    pub version: u16,
    /// The capability flags.
    pub capabilities: u16,
    /// The service name, NUL-padded.
    pub name: [u8; 16],
}

/// The length of a ListServices item's data.
pub const SERVICES_ITEM_LEN: usize = 20;

impl ServicesItem {
    /// The one service an EtherNet/IP device lists: "Communications", CIP
    /// over TCP and class 0/1 over UDP.
    pub fn communications() -> ServicesItem {
        let mut name = [0u8; 16];
        let s = b"Communications";
        if let Some(n) = name.get_mut(..s.len()) {
            n.copy_from_slice(s);
        }
        ServicesItem {
            version: 1,
            capabilities: CAPABILITY_CIP_TCP | CAPABILITY_CLASS01_UDP,
            name,
        }
    }

    /// Reads the item's data.
    pub fn parse(data: &[u8]) -> Result<ServicesItem, Error> {
        let mut r = Reader::new(data);
        let version = r.u16("services version")?;
        let capabilities = r.u16("services capabilities")?;
        let name = r.array("services name")?;
        if !r.is_empty() {
            return Err(Error::TrailingBytes {
                what: "services item",
                extra: r.rest().len(),
            });
        }
        Ok(ServicesItem {
            version,
            capabilities,
            name,
        })
    }

    /// Writes the item's data.
    pub fn emit(&self, w: &mut Writer<'_>) -> Result<(), Error> {
        w.u16(self.version, "services version")?;
        w.u16(self.capabilities, "services capabilities")?;
        w.bytes(&self.name, "services name")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::net::Ipv4Addr;

    fn item(name: &str) -> IdentityItem<'_> {
        IdentityItem {
            version: 1,
            socket: SocketAddrV4::new(Ipv4Addr::new(192, 168, 1, 10), 44818),
            identity: Identity {
                vendor_id: 0xFFF0,
                device_type: 0x0C,
                product_code: 7,
                revision: Revision { major: 1, minor: 2 },
                status: 0x30,
                serial: 0xDEADBEEF,
                product_name: name,
            },
            state: STATE_OPERATIONAL,
        }
    }

    #[test]
    fn identity_round_trips() {
        let mut buf = [0u8; 128];
        let mut w = Writer::new(&mut buf);
        item("Hans gateway").emit(&mut w).unwrap();
        let n = w.len();
        assert_eq!(n, 2 + 16 + 2 * 3 + 2 + 2 + 4 + 1 + 12 + 1);
        assert_eq!(&buf[2..6], &[0, 2, 0xAF, 0x12], "sockaddr is big-endian");
        assert_eq!(
            IdentityItem::parse(&buf[..n]).unwrap(),
            item("Hans gateway")
        );
    }

    #[test]
    fn long_names_are_cut_on_a_character_boundary() {
        let long = "ééééééééééééééééééééé"; // 21 two-byte characters
        assert_eq!(short_name(long).len(), 32);
        let long = "aéééééééééééééééééééé";
        assert_eq!(short_name(long).len(), 31);
        let mut buf = [0u8; 128];
        let mut w = Writer::new(&mut buf);
        item(long).emit(&mut w).unwrap();
        let n = w.len();
        assert_eq!(
            IdentityItem::parse(&buf[..n])
                .unwrap()
                .identity
                .product_name,
            short_name(long)
        );
    }

    #[test]
    fn identity_errors() {
        let mut buf = [0u8; 128];
        let mut w = Writer::new(&mut buf);
        item("x").emit(&mut w).unwrap();
        let n = w.len();
        for cut in 0..n {
            assert!(IdentityItem::parse(&buf[..cut]).is_err(), "{cut}");
        }
        assert!(matches!(
            IdentityItem::parse(&buf[..n + 1]),
            Err(Error::TrailingBytes { .. })
        ));
        buf[n - 2] = 0xFF; // the name: not UTF-8
        assert!(matches!(
            IdentityItem::parse(&buf[..n]),
            Err(Error::Invalid {
                what: "identity name",
                ..
            })
        ));
        let mut small = [0u8; 20];
        assert!(item("x").emit(&mut Writer::new(&mut small)).is_err());
    }

    #[test]
    fn services_round_trips() {
        let s = ServicesItem::communications();
        let mut buf = [0u8; 20];
        s.emit(&mut Writer::new(&mut buf)).unwrap();
        assert_eq!(&buf[..4], &[1, 0, 0x20, 0x01]);
        assert_eq!(&buf[4..18], b"Communications");
        assert_eq!(ServicesItem::parse(&buf).unwrap(), s);
        assert!(ServicesItem::parse(&buf[..19]).is_err());
        assert!(ServicesItem::parse(&[0u8; 21]).is_err());
    }
}
