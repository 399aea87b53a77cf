//! The encapsulation header: 24 bytes in front of every EtherNet/IP message
//! on TCP and UDP port 44818.
//!
//! ```text
//!  0      2      4              8              12                     20             24
//! +------+------+--------------+--------------+----------------------+--------------+----
//! | cmd  | len  | session      | status       | sender context       | options      | data (len bytes)
//! +------+------+--------------+--------------+----------------------+--------------+----
//! ```
//! `len` counts the data after the header. A reply echoes the command, the
//! session handle and the sender context of its request.

use super::{get_u16, get_u32, set_bytes, Error, Field, Rest};

/// The named byte ranges of the header.
pub mod field {
    use super::{Field, Rest};
    /// The command code.
    pub const COMMAND: Field = 0..2;
    /// The length of the data after the header.
    pub const LENGTH: Field = 2..4;
    /// The session handle (0 before RegisterSession).
    pub const SESSION: Field = 4..8;
    /// The status (0 in requests).
    pub const STATUS: Field = 8..12;
    /// Eight bytes of the sender's own, echoed in the reply.
    pub const CONTEXT: Field = 12..20;
    /// Options (0; a packet with other options is discarded).
    pub const OPTIONS: Field = 20..24;
    /// The command's data.
    pub const PAYLOAD: Rest = 24..;
}

/// The header's size.
pub const HEADER_LEN: usize = field::PAYLOAD.start;

enum_with_unknown! {
    /// An encapsulation command.
    pub enum Command(u16) {
        /// No operation, no reply (a keep-alive).
        Nop = 0x0000,
        /// Which encapsulation services the target has.
        ListServices = 0x0004,
        /// The target's identity (also over UDP, for discovery).
        ListIdentity = 0x0063,
        /// Non-CIP interfaces of the target.
        ListInterfaces = 0x0064,
        /// Opens a session on this TCP connection.
        RegisterSession = 0x0065,
        /// Closes the session (and the TCP connection).
        UnRegisterSession = 0x0066,
        /// An unconnected (request/response) CIP message.
        SendRrData = 0x006F,
        /// A connected (class 3) CIP message.
        SendUnitData = 0x0070,
    }
}

enum_with_unknown! {
    /// The status field of an encapsulation reply.
    pub enum Status(u32) {
        /// Success.
        Success = 0x0000,
        /// The command is not a valid or supported one.
        InvalidCommand = 0x0001,
        /// The target has no room to handle the command (e.g. no free session).
        InsufficientMemory = 0x0002,
        /// The data of the command is malformed.
        IncorrectData = 0x0003,
        /// The session handle is not a registered one.
        InvalidSessionHandle = 0x0064,
        /// The length is not valid for the command, or too large for the target.
        InvalidLength = 0x0065,
        /// The requested protocol version is not supported.
        UnsupportedProtocolRevision = 0x0069,
    }
}

/// A view of an encapsulation packet in a buffer.
#[derive(Debug, Clone, Copy)]
pub struct Packet<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Packet<T> {
    /// Wraps a buffer without checking it: getters of fields past its end
    /// return zero.
    pub const fn new_unchecked(buffer: T) -> Self {
        Packet { buffer }
    }

    /// Wraps a buffer that holds at least the header and the data its
    /// length field announces.
    pub fn new_checked(buffer: T) -> Result<Self, Error> {
        let p = Packet { buffer };
        p.check_len()?;
        Ok(p)
    }

    /// Checks that the header is there and the data its length announces.
    pub fn check_len(&self) -> Result<(), Error> {
        let len = self.buffer.as_ref().len();
        if len < HEADER_LEN {
            return Err(Error::Truncated {
                what: "encapsulation header",
                expected: HEADER_LEN,
                got: len,
            });
        }
        let total = HEADER_LEN + usize::from(self.length());
        if len < total {
            return Err(Error::Truncated {
                what: "encapsulation data",
                expected: total,
                got: len,
            });
        }
        Ok(())
    }

    /// The buffer back.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// The command.
    pub fn command(&self) -> Command {
        Command::from(get_u16(self.buffer.as_ref(), field::COMMAND))
    }

    /// The length of the data.
    pub fn length(&self) -> u16 {
        get_u16(self.buffer.as_ref(), field::LENGTH)
    }

    /// The session handle.
    pub fn session(&self) -> u32 {
        get_u32(self.buffer.as_ref(), field::SESSION)
    }

    /// The status.
    pub fn status(&self) -> Status {
        Status::from(get_u32(self.buffer.as_ref(), field::STATUS))
    }

    /// The sender context.
    pub fn context(&self) -> [u8; 8] {
        let mut out = [0u8; 8];
        if let Some(b) = self.buffer.as_ref().get(field::CONTEXT) {
            out.copy_from_slice(b);
        }
        out
    }

    /// The options.
    pub fn options(&self) -> u32 {
        get_u32(self.buffer.as_ref(), field::OPTIONS)
    }

    /// The data: as many bytes as the length says (fewer if the buffer is
    /// shorter, which `new_checked` rules out).
    pub fn payload(&self) -> &[u8] {
        let b = self.buffer.as_ref();
        let end = HEADER_LEN
            .saturating_add(usize::from(self.length()))
            .min(b.len());
        b.get(HEADER_LEN..end).unwrap_or(&[])
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> Packet<T> {
    /// Sets the command.
    pub fn set_command(&mut self, c: Command) {
        set_bytes(
            self.buffer.as_mut(),
            field::COMMAND,
            &u16::from(c).to_le_bytes(),
        );
    }

    /// Sets the length of the data.
    pub fn set_length(&mut self, v: u16) {
        set_bytes(self.buffer.as_mut(), field::LENGTH, &v.to_le_bytes());
    }

    /// Sets the session handle.
    pub fn set_session(&mut self, v: u32) {
        set_bytes(self.buffer.as_mut(), field::SESSION, &v.to_le_bytes());
    }

    /// Sets the status.
    pub fn set_status(&mut self, s: Status) {
        set_bytes(
            self.buffer.as_mut(),
            field::STATUS,
            &u32::from(s).to_le_bytes(),
        );
    }

    /// Sets the sender context.
    pub fn set_context(&mut self, c: [u8; 8]) {
        set_bytes(self.buffer.as_mut(), field::CONTEXT, &c);
    }

    /// Sets the options.
    pub fn set_options(&mut self, v: u32) {
        set_bytes(self.buffer.as_mut(), field::OPTIONS, &v.to_le_bytes());
    }

    /// The data, writable (from the header's end to the buffer's end).
    pub fn payload_mut(&mut self) -> &mut [u8] {
        self.buffer
            .as_mut()
            .get_mut(field::PAYLOAD)
            .unwrap_or(&mut [])
    }
}

/// The header as plain values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Header {
    /// The command.
    pub command: Command,
    /// The length of the data.
    pub length: u16,
    /// The session handle.
    pub session: u32,
    /// The status.
    pub status: Status,
    /// The sender context.
    pub context: [u8; 8],
    /// The options.
    pub options: u32,
}

impl Header {
    /// Reads the header of a packet (the data need not be there).
    pub fn parse(bytes: &[u8]) -> Result<Header, Error> {
        if bytes.len() < HEADER_LEN {
            return Err(Error::Truncated {
                what: "encapsulation header",
                expected: HEADER_LEN,
                got: bytes.len(),
            });
        }
        let p = Packet::new_unchecked(bytes);
        Ok(Header {
            command: p.command(),
            length: p.length(),
            session: p.session(),
            status: p.status(),
            context: p.context(),
            options: p.options(),
        })
    }

    /// The header of a reply to this request: same command, session and
    /// context, the given status and length.
    pub fn reply(&self, status: Status, length: u16) -> Header {
        Header {
            status,
            length,
            options: 0,
            ..*self
        }
    }

    /// Writes the header into the first 24 bytes of `buf`.
    pub fn emit(&self, buf: &mut [u8]) -> Result<(), Error> {
        if buf.len() < HEADER_LEN {
            return Err(Error::Exhausted {
                what: "encapsulation header",
            });
        }
        let mut p = Packet::new_unchecked(buf);
        p.set_command(self.command);
        p.set_length(self.length);
        p.set_session(self.session);
        p.set_status(self.status);
        p.set_context(self.context);
        p.set_options(self.options);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const REGISTER: [u8; 28] = [
        0x65, 0x00, 0x04, 0x00, 0, 0, 0, 0, 0, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 0, 0, 0, 0, 0x01,
        0x00, 0x00, 0x00,
    ];

    #[test]
    fn reads_a_register_session_request() {
        let p = Packet::new_checked(&REGISTER[..]).unwrap();
        assert_eq!(p.command(), Command::RegisterSession);
        assert_eq!(p.length(), 4);
        assert_eq!(p.session(), 0);
        assert_eq!(p.status(), Status::Success);
        assert_eq!(p.context(), [1, 2, 3, 4, 5, 6, 7, 8]);
        assert_eq!(p.payload(), &[1, 0, 0, 0]);
    }

    #[test]
    fn header_round_trips() {
        let h = Header::parse(&REGISTER).unwrap();
        let mut out = [0u8; 24];
        h.emit(&mut out).unwrap();
        assert_eq!(&out[..], &REGISTER[..24]);
        let r = h.reply(Status::UnsupportedProtocolRevision, 4);
        r.emit(&mut out).unwrap();
        assert_eq!(Header::parse(&out).unwrap(), r);
        assert_eq!(&out[8..12], &[0x69, 0, 0, 0]);
    }

    #[test]
    fn short_header_and_short_data_are_errors() {
        assert_eq!(
            Packet::new_checked(&REGISTER[..23]).unwrap_err(),
            Error::Truncated {
                what: "encapsulation header",
                expected: 24,
                got: 23
            }
        );
        assert_eq!(
            Packet::new_checked(&REGISTER[..26]).unwrap_err(),
            Error::Truncated {
                what: "encapsulation data",
                expected: 28,
                got: 26
            }
        );
        assert!(Header::parse(&REGISTER[..10]).is_err());
        assert_eq!(
            Header::parse(&REGISTER).unwrap().emit(&mut [0u8; 23]),
            Err(Error::Exhausted {
                what: "encapsulation header"
            })
        );
    }

    #[test]
    fn unknown_commands_and_statuses_survive() {
        assert_eq!(Command::from(0x1234), Command::Unknown(0x1234));
        assert_eq!(u16::from(Command::Unknown(0x1234)), 0x1234);
        assert_eq!(u16::from(Command::SendUnitData), 0x70);
        assert_eq!(Status::from(0x65), Status::InvalidLength);
        assert_eq!(u32::from(Status::Unknown(7)), 7);
    }

    #[test]
    fn unchecked_getters_do_not_panic_on_short_buffers() {
        let p = Packet::new_unchecked(&REGISTER[..3]);
        assert_eq!(p.session(), 0);
        assert_eq!(p.context(), [0; 8]);
        assert_eq!(p.payload(), &[] as &[u8]);
    }
}
