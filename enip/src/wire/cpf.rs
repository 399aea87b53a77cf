//! Common Packet Format: the item list inside SendRRData, SendUnitData,
//! ListIdentity, ListServices and class 1 I/O datagrams.
//!
//! ```text
//! | item count u16 | type u16 | length u16 | data (length bytes) | type u16 | ...
//! ```
//! A Sockaddr Info item's data is the only big-endian structure of
//! EtherNet/IP (it copies BSD's `sockaddr_in`).

use core::net::{Ipv4Addr, SocketAddrV4};

use super::{Error, Reader, Writer};

enum_with_unknown! {
    /// The type of a CPF item.
    pub enum ItemType(u16) {
        /// Null address (unconnected messages).
        NullAddress = 0x0000,
        /// CIP Identity (ListIdentity reply).
        CipIdentity = 0x000C,
        /// Connected address: a connection id.
        ConnectedAddress = 0x00A1,
        /// Connected data: a connected (class 1 or 3) message.
        ConnectedData = 0x00B1,
        /// Unconnected data: a Message Router request or response.
        UnconnectedData = 0x00B2,
        /// ListServices communications item.
        ListServices = 0x0100,
        /// Sockaddr Info, originator to target.
        SockaddrOT = 0x8000,
        /// Sockaddr Info, target to originator.
        SockaddrTO = 0x8001,
        /// Sequenced address: a connection id and a 32-bit sequence number.
        SequencedAddress = 0x8002,
    }
}

/// The most items a list may hold here; SendRRData's Forward_Open carries
/// four at most (address, data, two Sockaddr Info items). A list with more
/// is refused as malformed.
pub const MAX_ITEMS: usize = 4;

/// The length of an item's type and length fields.
pub const ITEM_HEADER_LEN: usize = 4;

/// One item: its type and its data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Item<'a> {
    /// The type.
    pub kind: ItemType,
    /// The data.
    pub data: &'a [u8],
}

/// A parsed item list.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Cpf<'a> {
    items: heapless::Vec<Item<'a>, MAX_ITEMS>,
}

impl<'a> Cpf<'a> {
    /// Reads an item list that fills `bytes` exactly.
    pub fn parse(bytes: &'a [u8]) -> Result<Cpf<'a>, Error> {
        let mut r = Reader::new(bytes);
        let count = r.u16("CPF item count")?;
        if usize::from(count) > MAX_ITEMS {
            return Err(Error::Invalid {
                what: "CPF item count",
                value: u32::from(count),
            });
        }
        let mut items = heapless::Vec::new();
        for _ in 0..count {
            let kind = ItemType::from(r.u16("CPF item type")?);
            let len = r.u16("CPF item length")?;
            let data = r.take(usize::from(len), "CPF item data")?;
            // Cannot fail: count <= MAX_ITEMS was checked above.
            items
                .push(Item { kind, data })
                .map_err(|_| Error::Invalid {
                    what: "CPF item count",
                    value: u32::from(count),
                })?;
        }
        if !r.is_empty() {
            return Err(Error::TrailingBytes {
                what: "CPF",
                extra: r.rest().len(),
            });
        }
        Ok(Cpf { items })
    }

    /// The items in order.
    pub fn items(&self) -> &[Item<'a>] {
        &self.items
    }

    /// The item at `index`.
    pub fn get(&self, index: usize) -> Option<&Item<'a>> {
        self.items.get(index)
    }

    /// The first item of a type.
    pub fn find(&self, kind: ItemType) -> Option<&Item<'a>> {
        self.items.iter().find(|i| i.kind == kind)
    }
}

/// Writes an item list: the count first, then items one by one.
#[derive(Debug)]
pub struct CpfWriter {
    count_at: usize,
    count: u16,
}

impl CpfWriter {
    /// Writes a zero count to be updated as items are added.
    pub fn begin(w: &mut Writer<'_>) -> Result<CpfWriter, Error> {
        let count_at = w.len();
        w.u16(0, "CPF item count")?;
        Ok(CpfWriter { count_at, count: 0 })
    }

    /// Adds an item with the given data.
    pub fn item(&mut self, w: &mut Writer<'_>, kind: ItemType, data: &[u8]) -> Result<(), Error> {
        let len = u16::try_from(data.len()).map_err(|_| Error::Exhausted {
            what: "CPF item length",
        })?;
        w.u16(kind.into(), "CPF item type")?;
        w.u16(len, "CPF item length")?;
        w.bytes(data, "CPF item data")?;
        self.bump(w)
    }

    /// Adds an item whose data `fill` writes; its length is set from what
    /// `fill` wrote.
    pub fn item_with<E: From<Error>>(
        &mut self,
        w: &mut Writer<'_>,
        kind: ItemType,
        fill: impl FnOnce(&mut Writer<'_>) -> Result<(), E>,
    ) -> Result<(), E> {
        w.u16(kind.into(), "CPF item type")?;
        let len_at = w.len();
        w.u16(0, "CPF item length")?;
        let start = w.len();
        fill(w)?;
        let len = u16::try_from(w.len() - start).map_err(|_| Error::Exhausted {
            what: "CPF item length",
        })?;
        w.patch_u16(len_at, len, "CPF item length")?;
        self.bump(w)?;
        Ok(())
    }

    fn bump(&mut self, w: &mut Writer<'_>) -> Result<(), Error> {
        self.count = self.count.saturating_add(1);
        w.patch_u16(self.count_at, self.count, "CPF item count")
    }
}

/// A Sockaddr Info item's data (16 bytes, big-endian).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sockaddr {
    /// The address and port (an address of 0.0.0.0 means "the sender's").
    pub addr: SocketAddrV4,
}

/// The length of a Sockaddr Info item's data.
pub const SOCKADDR_LEN: usize = 16;
/// `sin_family` for IPv4.
pub const AF_INET: u16 = 2;

impl Sockaddr {
    /// Reads a Sockaddr Info item's data.
    pub fn parse(data: &[u8]) -> Result<Sockaddr, Error> {
        if data.len() != SOCKADDR_LEN {
            return Err(Error::Truncated {
                what: "Sockaddr Info",
                expected: SOCKADDR_LEN,
                got: data.len(),
            });
        }
        let mut r = Reader::new(data);
        let family = u16::from_be_bytes(r.array("sin_family")?);
        if family != AF_INET {
            return Err(Error::Invalid {
                what: "sin_family",
                value: u32::from(family),
            });
        }
        let port = u16::from_be_bytes(r.array("sin_port")?);
        let ip = Ipv4Addr::from(r.array::<4>("sin_addr")?);
        Ok(Sockaddr {
            addr: SocketAddrV4::new(ip, port),
        })
    }

    /// Writes a Sockaddr Info item's data.
    pub fn emit(&self, w: &mut Writer<'_>) -> Result<(), Error> {
        w.bytes(&AF_INET.to_be_bytes(), "sin_family")?;
        w.bytes(&self.addr.port().to_be_bytes(), "sin_port")?;
        w.bytes(&self.addr.ip().octets(), "sin_addr")?;
        w.bytes(&[0u8; 8], "sin_zero")
    }
}

/// Reads a Connected Address item's data: the connection id.
pub fn parse_connected_address(data: &[u8]) -> Result<u32, Error> {
    let mut r = Reader::new(data);
    let id = r.u32("connected address")?;
    if !r.is_empty() {
        return Err(Error::TrailingBytes {
            what: "connected address",
            extra: r.rest().len(),
        });
    }
    Ok(id)
}

/// Reads a Sequenced Address item's data: the connection id and the
/// 32-bit encapsulation sequence number.
pub fn parse_sequenced_address(data: &[u8]) -> Result<(u32, u32), Error> {
    let mut r = Reader::new(data);
    let id = r.u32("sequenced address id")?;
    let seq = r.u32("sequenced address sequence")?;
    if !r.is_empty() {
        return Err(Error::TrailingBytes {
            what: "sequenced address",
            extra: r.rest().len(),
        });
    }
    Ok((id, seq))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_null_and_unconnected_items() {
        let b = [2, 0, 0, 0, 0, 0, 0xB2, 0, 2, 0, 0x0E, 0x03];
        let cpf = Cpf::parse(&b).unwrap();
        assert_eq!(cpf.items().len(), 2);
        assert_eq!(cpf.get(0).unwrap().kind, ItemType::NullAddress);
        assert_eq!(
            cpf.find(ItemType::UnconnectedData).unwrap().data,
            &[0x0E, 0x03]
        );
        assert!(cpf.find(ItemType::ConnectedData).is_none());
    }

    #[test]
    fn round_trips_through_the_writer() {
        let mut buf = [0u8; 64];
        let mut w = Writer::new(&mut buf);
        let mut c = CpfWriter::begin(&mut w).unwrap();
        c.item(&mut w, ItemType::NullAddress, &[]).unwrap();
        c.item_with::<Error>(&mut w, ItemType::SockaddrTO, |w| {
            Sockaddr {
                addr: SocketAddrV4::new(Ipv4Addr::new(127, 0, 0, 1), 2222),
            }
            .emit(w)
        })
        .unwrap();
        c.item(
            &mut w,
            ItemType::SequencedAddress,
            &[1, 0, 0, 0, 2, 0, 0, 0],
        )
        .unwrap();
        let n = w.len();
        let cpf = Cpf::parse(&buf[..n]).unwrap();
        assert_eq!(cpf.items().len(), 3);
        let sa = Sockaddr::parse(cpf.get(1).unwrap().data).unwrap();
        assert_eq!(
            sa.addr,
            SocketAddrV4::new(Ipv4Addr::new(127, 0, 0, 1), 2222)
        );
        assert_eq!(&cpf.get(1).unwrap().data[..4], &[0, 2, 0x08, 0xAE]);
        assert_eq!(
            parse_sequenced_address(cpf.get(2).unwrap().data).unwrap(),
            (1, 2)
        );
    }

    #[test]
    fn every_error_path() {
        assert!(matches!(
            Cpf::parse(&[1]),
            Err(Error::Truncated {
                what: "CPF item count",
                ..
            })
        ));
        assert!(matches!(
            Cpf::parse(&[5, 0]),
            Err(Error::Invalid {
                what: "CPF item count",
                value: 5
            })
        ));
        assert!(matches!(
            Cpf::parse(&[1, 0, 0]),
            Err(Error::Truncated {
                what: "CPF item type",
                ..
            })
        ));
        assert!(matches!(
            Cpf::parse(&[1, 0, 0, 0, 9]),
            Err(Error::Truncated {
                what: "CPF item length",
                ..
            })
        ));
        assert!(matches!(
            Cpf::parse(&[1, 0, 0, 0, 2, 0, 1]),
            Err(Error::Truncated {
                what: "CPF item data",
                ..
            })
        ));
        assert!(matches!(
            Cpf::parse(&[0, 0, 7]),
            Err(Error::TrailingBytes { extra: 1, .. })
        ));
        assert!(Sockaddr::parse(&[0; 15]).is_err());
        assert!(matches!(
            Sockaddr::parse(&[0; 16]),
            Err(Error::Invalid {
                what: "sin_family",
                ..
            })
        ));
        assert!(parse_connected_address(&[1, 2, 3]).is_err());
        assert!(parse_connected_address(&[1, 2, 3, 4, 5]).is_err());
        assert!(parse_sequenced_address(&[0; 7]).is_err());
        assert!(parse_sequenced_address(&[0; 9]).is_err());
        let mut small = [0u8; 5];
        let mut w = Writer::new(&mut small);
        let mut c = CpfWriter::begin(&mut w).unwrap();
        assert!(c.item(&mut w, ItemType::NullAddress, &[]).is_err());
    }

    #[test]
    fn empty_list_is_valid() {
        assert_eq!(Cpf::parse(&[0, 0]).unwrap().items().len(), 0);
    }
}
