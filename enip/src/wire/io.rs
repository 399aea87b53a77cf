//! Class 1 implicit I/O datagrams (UDP port 2222): a CPF of two items.
//!
//! ```text
//! | count u16 = 2 |
//! | 0x8002 | 8 | connection id u32 | encapsulation sequence number u32 |   sequenced address
//! | 0x00B1 | n | CIP sequence count u16 | [run/idle header u32] | data |  connected data
//! ```
//! The 32-bit sequence number counts every datagram of a connection; the
//! 16-bit sequence count in the data counts new data. O->T data of an
//! exclusive-owner connection starts with the 32-bit run/idle header (bit 0
//! set: run); T->O data has none ("modeless").

use super::cpf::{parse_sequenced_address, Cpf, CpfWriter, ItemType};
use super::{Error, Reader, Writer};

/// The run bit of the run/idle header.
pub const RUN: u32 = 0x0000_0001;

/// The length of a class 1 datagram without its data: the CPF count, two
/// item headers, the sequenced address and the sequence count.
pub const OVERHEAD: usize = 2 + 4 + 8 + 4 + 2;

/// A class 1 datagram.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct IoPacket<'a> {
    /// The connection id.
    pub connection_id: u32,
    /// The encapsulation sequence number.
    pub sequence: u32,
    /// The CIP sequence count.
    pub sequence_count: u16,
    /// The data after the sequence count (with the run/idle header if the
    /// connection has one).
    pub data: &'a [u8],
}

impl<'a> IoPacket<'a> {
    /// Reads a datagram: exactly a sequenced address item then a connected
    /// data item.
    pub fn parse(bytes: &'a [u8]) -> Result<IoPacket<'a>, Error> {
        let cpf = Cpf::parse(bytes)?;
        let [addr, data] = cpf.items() else {
            return Err(Error::Invalid {
                what: "I/O item count",
                value: cpf.items().len() as u32,
            });
        };
        if addr.kind != ItemType::SequencedAddress {
            return Err(Error::Invalid {
                what: "I/O address item",
                value: u32::from(u16::from(addr.kind)),
            });
        }
        if data.kind != ItemType::ConnectedData {
            return Err(Error::Invalid {
                what: "I/O data item",
                value: u32::from(u16::from(data.kind)),
            });
        }
        let (connection_id, sequence) = parse_sequenced_address(addr.data)?;
        let mut r = Reader::new(data.data);
        let sequence_count = r.u16("I/O sequence count")?;
        Ok(IoPacket {
            connection_id,
            sequence,
            sequence_count,
            data: r.rest(),
        })
    }

    /// Writes a datagram.
    pub fn emit(&self, w: &mut Writer<'_>) -> Result<(), Error> {
        let mut c = CpfWriter::begin(w)?;
        let mut addr = [0u8; 8];
        addr[..4].copy_from_slice(&self.connection_id.to_le_bytes());
        addr[4..].copy_from_slice(&self.sequence.to_le_bytes());
        c.item(w, ItemType::SequencedAddress, &addr)?;
        c.item_with::<Error>(w, ItemType::ConnectedData, |w| {
            w.u16(self.sequence_count, "I/O sequence count")?;
            w.bytes(self.data, "I/O data")
        })
    }
}

/// Splits O->T data into its run/idle header and the application data.
pub fn split_run_idle(data: &[u8]) -> Result<(u32, &[u8]), Error> {
    let mut r = Reader::new(data);
    let header = r.u32("run/idle header")?;
    Ok((header, r.rest()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trips() {
        let p = IoPacket {
            connection_id: 0x1122_3344,
            sequence: 9,
            sequence_count: 3,
            data: &[1, 0, 0, 0, 0xAB],
        };
        let mut buf = [0u8; 64];
        let mut w = Writer::new(&mut buf);
        p.emit(&mut w).unwrap();
        let n = w.len();
        assert_eq!(n, OVERHEAD + 5);
        assert_eq!(&buf[..6], &[2, 0, 0x02, 0x80, 8, 0]);
        let back = IoPacket::parse(&buf[..n]).unwrap();
        assert_eq!(back, p);
        assert_eq!(split_run_idle(back.data).unwrap(), (RUN, &[0xAB][..]));
    }

    #[test]
    fn every_error_path() {
        let p = IoPacket {
            connection_id: 1,
            sequence: 2,
            sequence_count: 3,
            data: &[],
        };
        let mut buf = [0u8; 64];
        let mut w = Writer::new(&mut buf);
        p.emit(&mut w).unwrap();
        let n = w.len();
        for cut in 0..n {
            assert!(IoPacket::parse(&buf[..cut]).is_err(), "{cut}");
        }
        // One item only.
        assert!(matches!(
            IoPacket::parse(&[1, 0, 0, 0, 0, 0]),
            Err(Error::Invalid {
                what: "I/O item count",
                ..
            })
        ));
        // Wrong item types.
        let mut bad = buf;
        bad[2] = 0xA1;
        bad[3] = 0x00;
        assert!(matches!(
            IoPacket::parse(&bad[..n]),
            Err(Error::Invalid {
                what: "I/O address item",
                ..
            })
        ));
        let mut bad = buf;
        bad[14] = 0xB2;
        assert!(matches!(
            IoPacket::parse(&bad[..n]),
            Err(Error::Invalid {
                what: "I/O data item",
                ..
            })
        ));
        // A connected data item shorter than the sequence count.
        let short = [
            2, 0, 0x02, 0x80, 8, 0, 1, 0, 0, 0, 2, 0, 0, 0, 0xB1, 0, 1, 0, 7,
        ];
        assert!(matches!(
            IoPacket::parse(&short),
            Err(Error::Truncated {
                what: "I/O sequence count",
                ..
            })
        ));
        assert!(split_run_idle(&[1, 0, 0]).is_err());
        assert!(p.emit(&mut Writer::new(&mut [0u8; OVERHEAD - 1])).is_err());
    }
}
