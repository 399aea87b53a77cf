//! The command-specific data of RegisterSession, and the prefix of
//! SendRRData and SendUnitData.
//!
//! ```text
//! RegisterSession:          | protocol version u16 (1) | options u16 (0) |
//! SendRRData/SendUnitData:  | interface handle u32 (0) | timeout u16 | CPF ... |
//! ```

use super::{get_u16, get_u32, Error, Field, Rest, Writer};

/// The named byte ranges of RegisterSession's data.
pub mod field {
    use super::{Field, Rest};
    /// The protocol version the originator speaks (1).
    pub const VERSION: Field = 0..2;
    /// Option flags (0).
    pub const OPTIONS: Field = 2..4;
    /// SendRRData / SendUnitData: the interface handle (0 for CIP).
    pub const INTERFACE: Field = 0..4;
    /// SendRRData / SendUnitData: the timeout in seconds (0 in SendUnitData).
    pub const TIMEOUT: Field = 4..6;
    /// SendRRData / SendUnitData: the Common Packet Format items.
    pub const CPF: Rest = 6..;
}

/// The length of RegisterSession's data.
pub const REGISTER_LEN: usize = 4;
/// The only encapsulation protocol version there is.
pub const PROTOCOL_VERSION: u16 = 1;

/// RegisterSession's data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RegisterRepr {
    /// The protocol version.
    pub version: u16,
    /// The option flags.
    pub options: u16,
}

impl RegisterRepr {
    /// Reads RegisterSession's data, which must be exactly 4 bytes.
    pub fn parse(data: &[u8]) -> Result<RegisterRepr, Error> {
        if data.len() < REGISTER_LEN {
            return Err(Error::Truncated {
                what: "RegisterSession data",
                expected: REGISTER_LEN,
                got: data.len(),
            });
        }
        if data.len() > REGISTER_LEN {
            return Err(Error::TrailingBytes {
                what: "RegisterSession data",
                extra: data.len() - REGISTER_LEN,
            });
        }
        Ok(RegisterRepr {
            version: get_u16(data, field::VERSION),
            options: get_u16(data, field::OPTIONS),
        })
    }

    /// Writes RegisterSession's data.
    pub fn emit(&self, w: &mut Writer<'_>) -> Result<(), Error> {
        w.u16(self.version, "RegisterSession version")?;
        w.u16(self.options, "RegisterSession options")
    }
}

/// The prefix of SendRRData and SendUnitData, and the CPF bytes after it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SendDataRepr<'a> {
    /// The interface handle (0 for CIP).
    pub interface: u32,
    /// The timeout in seconds.
    pub timeout: u16,
    /// The Common Packet Format items.
    pub cpf: &'a [u8],
}

/// The length of the SendRRData / SendUnitData prefix.
pub const SEND_DATA_PREFIX_LEN: usize = field::CPF.start;

impl<'a> SendDataRepr<'a> {
    /// Reads the prefix; the CPF is everything after it.
    pub fn parse(data: &'a [u8]) -> Result<SendDataRepr<'a>, Error> {
        if data.len() < SEND_DATA_PREFIX_LEN {
            return Err(Error::Truncated {
                what: "SendRRData prefix",
                expected: SEND_DATA_PREFIX_LEN,
                got: data.len(),
            });
        }
        Ok(SendDataRepr {
            interface: get_u32(data, field::INTERFACE),
            timeout: get_u16(data, field::TIMEOUT),
            cpf: data.get(field::CPF).unwrap_or(&[]),
        })
    }

    /// Writes the prefix (not the CPF: the caller writes the items after it).
    pub fn emit_prefix(interface: u32, timeout: u16, w: &mut Writer<'_>) -> Result<(), Error> {
        w.u32(interface, "SendRRData interface handle")?;
        w.u16(timeout, "SendRRData timeout")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn register_round_trips() {
        let r = RegisterRepr::parse(&[1, 0, 0, 0]).unwrap();
        assert_eq!(
            r,
            RegisterRepr {
                version: 1,
                options: 0
            }
        );
        let mut buf = [0u8; 4];
        let mut w = Writer::new(&mut buf);
        r.emit(&mut w).unwrap();
        assert_eq!(buf, [1, 0, 0, 0]);
    }

    #[test]
    fn register_length_errors() {
        assert!(matches!(
            RegisterRepr::parse(&[1, 0, 0]),
            Err(Error::Truncated {
                expected: 4,
                got: 3,
                ..
            })
        ));
        assert!(matches!(
            RegisterRepr::parse(&[1, 0, 0, 0, 0]),
            Err(Error::TrailingBytes { extra: 1, .. })
        ));
        let mut buf = [0u8; 3];
        assert!(RegisterRepr {
            version: 1,
            options: 0
        }
        .emit(&mut Writer::new(&mut buf))
        .is_err());
    }

    #[test]
    fn send_data_prefix() {
        let d = [0, 0, 0, 0, 5, 0, 0xAA];
        let s = SendDataRepr::parse(&d).unwrap();
        assert_eq!(
            s,
            SendDataRepr {
                interface: 0,
                timeout: 5,
                cpf: &[0xAA]
            }
        );
        assert!(SendDataRepr::parse(&d[..5]).is_err());
        let mut buf = [0u8; 6];
        SendDataRepr::emit_prefix(0, 5, &mut Writer::new(&mut buf)).unwrap();
        assert_eq!(&buf, &d[..6]);
    }
}
