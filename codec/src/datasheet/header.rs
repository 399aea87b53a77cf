//! The 12-byte header in front of every DataSheet packet (chapter 5.2).
//!
//! ```text
//!  offset  size  field          encoding
//!  0       4     magic          the bytes 4C 54 42 52 ("LTBR")
//!  4       4     total length   u32, little-endian: header + payload = 12 + payload length
//!  8       4     payload length u32, little-endian, not zero
//!  12      n     payload        JSON text (may contain NUL, '\n', '\t' to be ignored)
//! ```
//!
//! The document writes the magic as "RBTL": that is the constant
//! `0x5242544C` read most significant byte first. A controller stores it as a
//! little-endian `u32` like the two lengths, so the wire carries `L T B R`.
//!
//! Official readers reject a header whose total is not `12 + payload`, whose
//! payload length is zero, or whose size is over 1 MiB ([`MAX_PAYLOAD`];
//! this crate applies that cap to the payload length).
//!
//! [`Packet`] wraps a buffer in the manner of smoltcp's `wire` module:
//! [`Packet::new_checked`] validates once, after which every getter returns
//! exactly what the header says. On a packet built with
//! [`Packet::new_unchecked`] the getters still never panic: a field the
//! buffer is too short for reads as zero and the payload as the bytes that
//! are there.

use core::fmt;

/// Byte ranges of the header fields.
pub mod field {
    /// A byte range inside the packet.
    pub type Field = core::ops::Range<usize>;
    /// The magic bytes, `LTBR`.
    pub const MAGIC: Field = 0..4;
    /// Total length (header + payload), u32 little-endian.
    pub const TOTAL_LEN: Field = 4..8;
    /// Payload length, u32 little-endian.
    pub const PAYLOAD_LEN: Field = 8..12;
    /// Where the payload starts.
    pub const PAYLOAD: usize = 12;
}

/// The magic bytes as they appear on the wire.
pub const MAGIC: [u8; 4] = *b"LTBR";

/// The magic as the document names it: the `u32` `0x5242544C` ("RBTL" when
/// written most significant byte first), stored little-endian.
pub const MAGIC_U32: u32 = 0x5242_544C;

/// Length of the header in bytes.
pub const HEADER_LEN: usize = field::PAYLOAD;

/// The largest payload accepted or written: 1 MiB, the cap of the official
/// readers.
pub const MAX_PAYLOAD: usize = 1 << 20;

/// Why a header (or a buffer meant to hold a packet) is not acceptable.
///
/// ```
/// use hans_codec::datasheet::{HeaderError, Packet};
///
/// // Total length 20 with a payload of 2: not 12 + 2.
/// let bytes = [b'L', b'T', b'B', b'R', 20, 0, 0, 0, 2, 0, 0, 0, b'{', b'}'];
/// assert_eq!(
///     Packet::new_checked(&bytes[..]).unwrap_err(),
///     HeaderError::LengthMismatch { total: 20, payload: 2 }
/// );
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum HeaderError {
    /// The buffer is shorter than the header, or than the packet the header
    /// declares (reading), or than the header (writing).
    Truncated {
        /// Bytes needed.
        needed: usize,
        /// Bytes available.
        got: usize,
    },
    /// The first four bytes are not `LTBR`.
    BadMagic([u8; 4]),
    /// The total length is not 12 + the payload length.
    LengthMismatch {
        /// Total length field.
        total: u32,
        /// Payload length field.
        payload: u32,
    },
    /// The payload length is zero (or, from the [`Deframer`], the payload
    /// held only NUL, `\n` and `\t` bytes).
    ///
    /// [`Deframer`]: super::Deframer
    EmptyPayload,
    /// The payload is longer than the limit: [`MAX_PAYLOAD`], or the buffer
    /// of a [`Deframer`](super::Deframer).
    TooLarge {
        /// Payload length field.
        payload: u32,
        /// The limit that applied.
        max: usize,
    },
}

impl fmt::Display for HeaderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            HeaderError::Truncated { needed, got } => {
                write!(f, "buffer of {got} bytes, {needed} needed")
            }
            HeaderError::BadMagic(m) => write!(f, "bad magic {m:02x?}, expected \"LTBR\""),
            HeaderError::LengthMismatch { total, payload } => {
                write!(
                    f,
                    "total length {total} is not 12 + payload length {payload}"
                )
            }
            HeaderError::EmptyPayload => f.write_str("empty payload"),
            HeaderError::TooLarge { payload, max } => {
                write!(f, "payload of {payload} bytes exceeds the limit of {max}")
            }
        }
    }
}

impl core::error::Error for HeaderError {}

/// Checks the three header fields: magic, `total == 12 + payload`,
/// `payload != 0`, `payload <= max`. Returns the payload length.
pub(crate) fn check_fields(
    magic: [u8; 4],
    total: u32,
    payload: u32,
    max: usize,
) -> Result<usize, HeaderError> {
    if magic != MAGIC {
        return Err(HeaderError::BadMagic(magic));
    }
    if u64::from(total) != u64::from(payload) + HEADER_LEN as u64 {
        return Err(HeaderError::LengthMismatch { total, payload });
    }
    if payload == 0 {
        return Err(HeaderError::EmptyPayload);
    }
    let len = usize::try_from(payload).unwrap_or(usize::MAX);
    let max = max.min(MAX_PAYLOAD);
    if len > max {
        return Err(HeaderError::TooLarge { payload, max });
    }
    Ok(len)
}

fn read_u32(bytes: &[u8], range: field::Field) -> u32 {
    match bytes.get(range).and_then(|b| <[u8; 4]>::try_from(b).ok()) {
        Some(b) => u32::from_le_bytes(b),
        None => 0,
    }
}

/// A DataSheet packet (header and payload) in a buffer.
///
/// ```
/// use hans_codec::datasheet::{emit_header, Packet, HEADER_LEN};
///
/// let mut buf = [0u8; HEADER_LEN + 2];
/// emit_header(2, &mut buf).unwrap();
/// buf[HEADER_LEN..].copy_from_slice(b"{}");
/// assert_eq!(&buf[..4], b"LTBR");
///
/// let packet = Packet::new_checked(&buf[..]).unwrap();
/// assert_eq!(packet.total_len(), 14);
/// assert_eq!(packet.payload(), b"{}");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Packet<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> Packet<T> {
    /// Wraps a buffer without checking it.
    pub const fn new_unchecked(buffer: T) -> Self {
        Packet { buffer }
    }

    /// Wraps a buffer after [`Packet::check`]: a valid header and the whole
    /// payload it declares. Bytes after the packet are allowed (see
    /// [`Packet::packet_len`]).
    pub fn new_checked(buffer: T) -> Result<Self, HeaderError> {
        let packet = Packet::new_unchecked(buffer);
        packet.check()?;
        Ok(packet)
    }

    /// Checks the header (magic, lengths, the [`MAX_PAYLOAD`] cap) and that
    /// the buffer holds the whole packet.
    pub fn check(&self) -> Result<(), HeaderError> {
        let got = self.buffer.as_ref().len();
        if got < HEADER_LEN {
            return Err(HeaderError::Truncated {
                needed: HEADER_LEN,
                got,
            });
        }
        let len = check_fields(
            self.magic(),
            self.total_len(),
            self.payload_len(),
            MAX_PAYLOAD,
        )?;
        let needed = HEADER_LEN + len;
        if got < needed {
            return Err(HeaderError::Truncated { needed, got });
        }
        Ok(())
    }

    /// The buffer.
    pub fn into_inner(self) -> T {
        self.buffer
    }

    /// The magic bytes (zeros where the buffer is too short).
    pub fn magic(&self) -> [u8; 4] {
        self.buffer
            .as_ref()
            .get(field::MAGIC)
            .and_then(|b| <[u8; 4]>::try_from(b).ok())
            .unwrap_or([0; 4])
    }

    /// The total length field (header + payload).
    pub fn total_len(&self) -> u32 {
        read_u32(self.buffer.as_ref(), field::TOTAL_LEN)
    }

    /// The payload length field.
    pub fn payload_len(&self) -> u32 {
        read_u32(self.buffer.as_ref(), field::PAYLOAD_LEN)
    }

    /// Bytes the packet occupies: header plus payload length (saturating).
    pub fn packet_len(&self) -> usize {
        let payload = usize::try_from(self.payload_len()).unwrap_or(usize::MAX);
        HEADER_LEN.saturating_add(payload)
    }

    /// The payload as declared by the payload length (cut short where the
    /// buffer ends), with NUL, `\n` and `\t` bytes still in it.
    pub fn payload(&self) -> &[u8] {
        let b = self.buffer.as_ref();
        let end = self.packet_len().min(b.len());
        b.get(field::PAYLOAD..end).unwrap_or(&[])
    }
}

impl<T: AsRef<[u8]> + AsMut<[u8]>> Packet<T> {
    fn write_u32(&mut self, range: field::Field, v: u32) {
        if let Some(dst) = self.buffer.as_mut().get_mut(range) {
            dst.copy_from_slice(&v.to_le_bytes());
        }
    }

    /// Writes the magic bytes (nothing if the buffer is too short).
    pub fn set_magic(&mut self) {
        if let Some(dst) = self.buffer.as_mut().get_mut(field::MAGIC) {
            dst.copy_from_slice(&MAGIC);
        }
    }

    /// Writes the total length field (nothing if the buffer is too short).
    pub fn set_total_len(&mut self, v: u32) {
        self.write_u32(field::TOTAL_LEN, v)
    }

    /// Writes the payload length field (nothing if the buffer is too short).
    pub fn set_payload_len(&mut self, v: u32) {
        self.write_u32(field::PAYLOAD_LEN, v)
    }

    /// The payload, writable: from byte 12 up to the declared payload length
    /// or the end of the buffer, whichever comes first.
    pub fn payload_mut(&mut self) -> &mut [u8] {
        let end = self.packet_len();
        let b = self.buffer.as_mut();
        let end = end.min(b.len());
        b.get_mut(field::PAYLOAD..end).unwrap_or(&mut [])
    }
}

/// Writes a header for a payload of `payload_len` bytes into `out[..12]`.
///
/// Fails when `payload_len` is zero or over [`MAX_PAYLOAD`], or `out` is
/// shorter than the header; nothing is written then.
///
/// ```
/// use hans_codec::datasheet::emit_header;
///
/// let mut h = [0u8; 12];
/// emit_header(0x1234, &mut h).unwrap();
/// assert_eq!(h, [b'L', b'T', b'B', b'R', 0x40, 0x12, 0, 0, 0x34, 0x12, 0, 0]);
/// ```
pub fn emit_header(payload_len: usize, out: &mut [u8]) -> Result<(), HeaderError> {
    if out.len() < HEADER_LEN {
        return Err(HeaderError::Truncated {
            needed: HEADER_LEN,
            got: out.len(),
        });
    }
    if payload_len == 0 {
        return Err(HeaderError::EmptyPayload);
    }
    // `payload_len <= MAX_PAYLOAD` makes both conversions exact.
    let payload = u32::try_from(payload_len).unwrap_or(u32::MAX);
    if payload_len > MAX_PAYLOAD {
        return Err(HeaderError::TooLarge {
            payload,
            max: MAX_PAYLOAD,
        });
    }
    let mut packet = Packet::new_unchecked(out);
    packet.set_magic();
    packet.set_total_len(payload + HEADER_LEN as u32);
    packet.set_payload_len(payload);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn packet(payload: &[u8]) -> heapless::Vec<u8, 64> {
        let mut v = heapless::Vec::new();
        v.resize(HEADER_LEN + payload.len(), 0).unwrap();
        emit_header(payload.len(), &mut v).unwrap();
        v[HEADER_LEN..].copy_from_slice(payload);
        v
    }

    #[test]
    fn magic_is_the_documents_constant_little_endian() {
        assert_eq!(MAGIC, MAGIC_U32.to_le_bytes());
        assert_eq!(MAGIC_U32.to_be_bytes(), *b"RBTL");
    }

    #[test]
    fn round_trip_and_getters() {
        let bytes = packet(b"{\"a\":1}");
        let p = Packet::new_checked(&bytes[..]).unwrap();
        assert_eq!(p.magic(), *b"LTBR");
        assert_eq!(p.total_len(), 19);
        assert_eq!(p.payload_len(), 7);
        assert_eq!(p.packet_len(), 19);
        assert_eq!(p.payload(), b"{\"a\":1}");
        // Trailing bytes belong to the next packet, not to this payload.
        let mut longer = bytes.clone();
        longer.extend_from_slice(b"LTBR").unwrap();
        let p = Packet::new_checked(&longer[..]).unwrap();
        assert_eq!(p.payload(), b"{\"a\":1}");
    }

    #[test]
    fn checks() {
        let good = packet(b"{}");
        assert_eq!(
            Packet::new_checked(&good[..5]).unwrap_err(),
            HeaderError::Truncated { needed: 12, got: 5 }
        );
        assert_eq!(
            Packet::new_checked(&good[..13]).unwrap_err(),
            HeaderError::Truncated {
                needed: 14,
                got: 13
            }
        );
        let mut bad = good.clone();
        bad[0] = b'R';
        assert_eq!(
            Packet::new_checked(&bad[..]).unwrap_err(),
            HeaderError::BadMagic(*b"RTBR")
        );
        let mut bad = good.clone();
        bad[4] = 15;
        assert_eq!(
            Packet::new_checked(&bad[..]).unwrap_err(),
            HeaderError::LengthMismatch {
                total: 15,
                payload: 2
            }
        );
        let mut bad = good.clone();
        Packet::new_unchecked(&mut bad[..]).set_total_len(12);
        Packet::new_unchecked(&mut bad[..]).set_payload_len(0);
        assert_eq!(
            Packet::new_checked(&bad[..]).unwrap_err(),
            HeaderError::EmptyPayload
        );
        let mut bad = good.clone();
        Packet::new_unchecked(&mut bad[..]).set_total_len(12 + (1 << 20) + 1);
        Packet::new_unchecked(&mut bad[..]).set_payload_len((1 << 20) + 1);
        assert_eq!(
            Packet::new_checked(&bad[..]).unwrap_err(),
            HeaderError::TooLarge {
                payload: (1 << 20) + 1,
                max: MAX_PAYLOAD
            }
        );
        // The total overflowing u32 is a mismatch, not an overflow.
        let mut bad = good.clone();
        Packet::new_unchecked(&mut bad[..]).set_total_len(10);
        Packet::new_unchecked(&mut bad[..]).set_payload_len(u32::MAX - 1);
        assert!(matches!(
            Packet::new_checked(&bad[..]),
            Err(HeaderError::LengthMismatch { .. })
        ));
    }

    #[test]
    fn unchecked_getters_do_not_panic_on_short_buffers() {
        let p = Packet::new_unchecked(&b"LTB"[..]);
        assert_eq!(p.magic(), [0; 4]);
        assert_eq!(p.total_len(), 0);
        assert_eq!(p.payload(), b"");
        let mut short = [0u8; 6];
        let mut p = Packet::new_unchecked(&mut short[..]);
        p.set_magic();
        p.set_total_len(7);
        p.set_payload_len(7);
        assert!(p.payload_mut().is_empty());
        assert_eq!(short, [b'L', b'T', b'B', b'R', 0, 0]);
        // A declared payload longer than the buffer is cut at the buffer.
        let bytes = packet(b"{}");
        let p = Packet::new_unchecked(&bytes[..13]);
        assert_eq!(p.payload(), b"{");
    }

    #[test]
    fn emit_header_refuses_what_readers_reject() {
        let mut h = [0u8; 12];
        assert_eq!(emit_header(0, &mut h), Err(HeaderError::EmptyPayload));
        assert_eq!(
            emit_header(MAX_PAYLOAD + 1, &mut h),
            Err(HeaderError::TooLarge {
                payload: MAX_PAYLOAD as u32 + 1,
                max: MAX_PAYLOAD
            })
        );
        assert_eq!(
            emit_header(1, &mut h[..11]),
            Err(HeaderError::Truncated {
                needed: 12,
                got: 11
            })
        );
        assert_eq!(h, [0; 12]);
        emit_header(MAX_PAYLOAD, &mut h).unwrap();
        assert_eq!(Packet::new_unchecked(&h[..]).payload_len(), 1 << 20);
    }
}
