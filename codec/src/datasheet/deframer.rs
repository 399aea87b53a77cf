//! Streaming deframer for the DataSheet ports: bytes in, payloads out.
//!
//! Feed it whatever a TCP read returned; it yields one item per packet
//! header, whether packets arrive split across reads or several in one:
//! * `Ok(payload)`: a complete payload with its NUL, `\n` and `\t` bytes
//!   removed (as the official readers do before parsing the JSON), ready for
//!   [`DataSheet::parse`](super::DataSheet::parse).
//! * `Err(HeaderError)`: a header was rejected: total length not
//!   `12 + payload`, payload length zero (or only stripped bytes), or payload
//!   longer than `N` or than [`MAX_PAYLOAD`].
//!
//! # Resynchronisation
//! Between packets the deframer scans for the magic `LTBR`; bytes that
//! cannot start a packet are dropped and counted ([`Deframer::discarded`]),
//! not reported one by one.
//!
//! After a rejected header, whatever the reason (including a consistent
//! header whose payload is only too large), the deframer does **not** skip
//! the declared payload: it drops the first byte of the rejected magic and
//! scans again from the byte after it, through the rest of the header and
//! whatever follows. Why scan rather than skip:
//! * a header found in garbage may be bogus; skipping its declared length
//!   (up to 1 MiB) would lose every valid packet inside that span;
//! * a genuine over-size packet's payload is JSON text, and text cannot
//!   form a header we accept: any length field made of printable bytes is
//!   at least `0x2020_2020`, far over the 1 MiB cap. Scanning it costs CPU,
//!   not packets, and the next real packet is found right after it;
//! * a bogus header that overlaps a real one is always rejected: the magic
//!   does not overlap itself, so the real magic lands inside a length field
//!   of the bogus header and puts a byte of at least `0x42` into its most
//!   significant byte (over the cap) or makes the lengths disagree.
//!
//! So the only way to lose a valid packet is a complete, self-consistent,
//! small-enough 12-byte header made up entirely by the garbage before it.
//!
//! # Memory
//! `N` bytes for the payload (a payload is accepted only if its declared
//! length, before stripping, fits), 12 for the header, a few words of state.
//! No allocation; no input makes it panic.

use super::header::{check_fields, HeaderError, HEADER_LEN, MAGIC, MAX_PAYLOAD};
use super::scan;

/// `true` for the bytes official readers remove from a payload.
pub(crate) const fn is_stripped(b: u8) -> bool {
    matches!(b, 0 | b'\n' | b'\t')
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    /// Collecting the 12 header bytes (`hdr[..hdr_len]`, always starting
    /// with a prefix of the magic).
    Header,
    /// Copying `remaining` more payload bytes into `buf`.
    Payload,
}

/// The deframer, holding payloads of up to `N` bytes.
///
/// ```
/// use hans_codec::datasheet::{Deframer, HEADER_LEN};
///
/// let mut wire = [0u8; HEADER_LEN + 9];
/// hans_codec::datasheet::emit_header(9, &mut wire).unwrap();
/// wire[HEADER_LEN..].copy_from_slice(b"{\n\t\"a\":1}");
///
/// let mut deframer = Deframer::<64>::new();
/// let mut got = 0;
/// // Garbage, then the packet split in two reads.
/// for read in [&b"junk"[..], &wire[..7], &wire[7..]] {
///     deframer.feed(read, |item| {
///         assert_eq!(item, Ok(&b"{\"a\":1}"[..]));
///         got += 1;
///     });
/// }
/// assert_eq!((got, deframer.discarded()), (1, 4));
/// ```
#[derive(Clone, Debug)]
pub struct Deframer<const N: usize> {
    buf: [u8; N],
    /// Payload bytes kept in `buf` (stripped bytes are not kept).
    len: usize,
    hdr: [u8; HEADER_LEN],
    hdr_len: usize,
    /// Declared payload length of the packet being read.
    payload_len: usize,
    /// Payload bytes still to come.
    remaining: usize,
    state: State,
    discarded: u64,
}

/// Shows the state, not the buffer.
#[cfg(feature = "defmt")]
impl<const N: usize> defmt::Format for Deframer<N> {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(
            f,
            "Deframer {{ capacity: {=usize}, pending: {=usize}, discarded: {=u64} }}",
            Self::CAPACITY,
            self.pending(),
            self.discarded
        )
    }
}

impl<const N: usize> Default for Deframer<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Deframer<N> {
    /// An empty deframer, waiting for a header.
    pub const fn new() -> Self {
        Deframer {
            buf: [0; N],
            len: 0,
            hdr: [0; HEADER_LEN],
            hdr_len: 0,
            payload_len: 0,
            remaining: 0,
            state: State::Header,
            discarded: 0,
        }
    }

    /// Drops any partial packet (for example after reconnecting). The
    /// [`Deframer::discarded`] count is kept.
    pub fn reset(&mut self) {
        self.len = 0;
        self.hdr_len = 0;
        self.payload_len = 0;
        self.remaining = 0;
        self.state = State::Header;
    }

    /// The largest payload this deframer accepts: `N`, or [`MAX_PAYLOAD`] if
    /// that is smaller.
    pub const CAPACITY: usize = if N < MAX_PAYLOAD { N } else { MAX_PAYLOAD };

    /// Bytes of an unfinished packet seen so far (header bytes plus payload
    /// bytes, stripped ones included); 0 between packets.
    pub fn pending(&self) -> usize {
        match self.state {
            State::Header => self.hdr_len,
            State::Payload => HEADER_LEN + (self.payload_len - self.remaining),
        }
    }

    /// Bytes dropped so far while looking for a header (garbage, and the
    /// bytes of rejected headers that could not start a packet). Saturates.
    pub fn discarded(&self) -> u64 {
        self.discarded
    }

    /// Consumes bytes from `input` up to the end of the next item: returns
    /// how many bytes were used and, if a packet ended or a header was
    /// rejected, that item. Call again with the rest of `input` until it is
    /// empty (or use [`Deframer::feed`]); the same calling convention as
    /// [`Framer::push`](crate::Framer::push).
    pub fn push(&mut self, input: &[u8]) -> (usize, Option<Result<&[u8], HeaderError>>) {
        let mut used = 0;
        while let Some(rest) = input.get(used..).filter(|r| !r.is_empty()) {
            match self.state {
                State::Header => {
                    let Some(&b) = rest.first() else { break };
                    used += 1;
                    if let Some(e) = self.header_byte(b) {
                        return (used, Some(Err(e)));
                    }
                }
                State::Payload => {
                    let take = rest.len().min(self.remaining);
                    self.keep(rest.get(..take).unwrap_or(&[]));
                    used += take;
                    self.remaining -= take;
                    if self.remaining == 0 {
                        self.state = State::Header;
                        self.hdr_len = 0;
                        let item = if self.len == 0 {
                            Err(HeaderError::EmptyPayload)
                        } else {
                            Ok(self.buf.get(..self.len).unwrap_or(&[]))
                        };
                        return (used, Some(item));
                    }
                }
            }
        }
        (used, None)
    }

    /// Feeds all of `input`, calling `on_item` for every payload completed
    /// and every header rejected in it.
    pub fn feed(&mut self, mut input: &[u8], mut on_item: impl FnMut(Result<&[u8], HeaderError>)) {
        while !input.is_empty() {
            let (used, item) = self.push(input);
            if let Some(item) = item {
                on_item(item);
            }
            input = input.get(used..).unwrap_or(&[]);
        }
    }

    /// Appends the bytes of `payload` that are not stripped to `buf`.
    fn keep(&mut self, payload: &[u8]) {
        // `len` + what is left of the payload <= `payload_len` <= `N`: the
        // room is always there.
        let room = self.buf.get_mut(self.len..).unwrap_or(&mut []);
        self.len += scan::copy_kept(room, payload);
    }

    /// One header byte; `Some(error)` when it completed a header that was
    /// rejected.
    fn header_byte(&mut self, b: u8) -> Option<HeaderError> {
        let at = self.hdr_len;
        let Some(slot) = self.hdr.get_mut(at) else {
            // Unreachable: a full header is handled below as it completes.
            self.realign(1);
            return None;
        };
        *slot = b;
        self.hdr_len += 1;
        if let Some(&m) = MAGIC.get(at) {
            if b != m {
                self.realign(1);
            }
            return None;
        }
        if self.hdr_len < HEADER_LEN {
            return None;
        }
        let word = |i: usize| {
            let mut w = [0u8; 4];
            if let Some(src) = self.hdr.get(i..i + 4) {
                w.copy_from_slice(src);
            }
            w
        };
        let total = u32::from_le_bytes(word(4));
        let payload = u32::from_le_bytes(word(8));
        match check_fields(word(0), total, payload, N) {
            Ok(len) => {
                self.state = State::Payload;
                self.payload_len = len;
                self.remaining = len;
                self.len = 0;
                None
            }
            Err(e) => {
                self.realign(1);
                Some(e)
            }
        }
    }

    /// Drops header bytes from the front, at least `from`, until what is
    /// left starts with a prefix of the magic (possibly nothing).
    fn realign(&mut self, from: usize) {
        let held = self.hdr.get(..self.hdr_len).unwrap_or(&[]);
        let shift = (from..self.hdr_len)
            .find(|&i| {
                let rest = held.get(i..).unwrap_or(&[]);
                rest.iter().zip(MAGIC.iter()).all(|(a, m)| a == m)
            })
            .unwrap_or(self.hdr_len);
        self.hdr.copy_within(shift.., 0);
        self.hdr_len -= shift;
        self.discarded = self.discarded.saturating_add(shift as u64);
    }
}

#[cfg(test)]
mod tests {
    use super::super::header::emit_header;
    use super::*;

    type Items = heapless::Vec<Result<heapless::Vec<u8, 64>, HeaderError>, 16>;

    fn wire(payload: &[u8]) -> heapless::Vec<u8, 128> {
        let mut v = heapless::Vec::new();
        v.resize(HEADER_LEN + payload.len(), 0).unwrap();
        emit_header(payload.len(), &mut v).unwrap();
        v[HEADER_LEN..].copy_from_slice(payload);
        v
    }

    fn all<const N: usize>(d: &mut Deframer<N>, input: &[u8]) -> Items {
        let mut out = Items::new();
        d.feed(input, |item| {
            out.push(item.map(|p| heapless::Vec::from_slice(p).unwrap()))
                .unwrap();
        });
        out
    }

    fn ok(items: &Items, i: usize) -> &[u8] {
        items[i].as_ref().unwrap()
    }

    #[test]
    fn one_byte_at_a_time() {
        let mut d = Deframer::<32>::new();
        let w = wire(b"{\"a\":\n1}");
        let mut got = Items::new();
        for b in w.chunks(1) {
            got.extend(all(&mut d, b));
            if got.is_empty() {
                assert!(d.pending() > 0);
            }
        }
        assert_eq!(got.len(), 1);
        assert_eq!(ok(&got, 0), b"{\"a\":1}");
        assert_eq!((d.pending(), d.discarded()), (0, 0));
    }

    #[test]
    fn several_packets_in_one_read() {
        let mut d = Deframer::<32>::new();
        let mut input = heapless::Vec::<u8, 256>::new();
        input.extend_from_slice(&wire(b"{}")).unwrap();
        input.extend_from_slice(&wire(b"[1]")).unwrap();
        input.extend_from_slice(&wire(b"\0{\t}\0")).unwrap();
        let got = all(&mut d, &input);
        assert_eq!(got.len(), 3);
        assert_eq!(ok(&got, 0), b"{}");
        assert_eq!(ok(&got, 1), b"[1]");
        assert_eq!(ok(&got, 2), b"{}");
    }

    #[test]
    fn garbage_and_partial_magics_before_a_packet() {
        let mut d = Deframer::<32>::new();
        // "LTB" then the real magic: the 'L' restarts the match.
        let mut input = heapless::Vec::<u8, 256>::new();
        input.extend_from_slice(b"xxLTLTBLTB").unwrap();
        input.extend_from_slice(&wire(b"{}")).unwrap();
        let got = all(&mut d, &input);
        assert_eq!(got.len(), 1);
        assert_eq!(ok(&got, 0), b"{}");
        assert_eq!(d.discarded(), 10);
    }

    #[test]
    fn bogus_header_overlapping_a_real_one_is_rejected_then_recovered() {
        // A magic in garbage, then `gap` zero bytes, then the real packet
        // (`LTBR 13000000 07000000 {"k":2}`): the bogus header's length
        // fields are the zeros and the start of the real header. Each bogus
        // header is rejected (the lengths, worked out by hand from those
        // bytes, never agree), its 4 + `gap` bytes up to the real magic are
        // dropped, and the real packet comes out whole.
        const L: u32 = u32::from_le_bytes(*b"LTBR");
        // (total, payload) of the bogus header, by gap.
        let bogus = [
            // 0: the real magic is the total length.
            (L, 0x13),
            // 1-3: the real magic straddles the two length fields.
            (0x4254_4C00, 0x1352),
            (0x544C_0000, 0x13_5242),
            (0x4C00_0000, 0x1352_4254),
            // 4-7: the payload length is the real magic, or its start.
            (0, L),
            (0, 0x4254_4C00),
            (0, 0x544C_0000),
            (0, 0x4C00_0000),
            // 8-11: zeros only.
            (0, 0),
            (0, 0),
            (0, 0),
            (0, 0),
        ];
        for (gap, &(total, payload)) in bogus.iter().enumerate() {
            let mut d = Deframer::<32>::new();
            let mut input = heapless::Vec::<u8, 256>::new();
            input.extend_from_slice(b"LTBR").unwrap();
            for _ in 0..gap {
                input.push(0).unwrap();
            }
            input.extend_from_slice(&wire(b"{\"k\":2}")).unwrap();
            let got = all(&mut d, &input);
            assert_eq!(got.len(), 2, "gap {gap}: {got:?}");
            assert_eq!(
                got[0],
                Err(HeaderError::LengthMismatch { total, payload }),
                "gap {gap}"
            );
            assert_eq!(ok(&got, 1), b"{\"k\":2}", "gap {gap}");
            assert_eq!(d.discarded(), 4 + gap as u64, "gap {gap}");
            assert_eq!(d.pending(), 0, "gap {gap}");
        }
    }

    #[test]
    fn inconsistent_headers_are_typed_errors() {
        let mut d = Deframer::<32>::new();
        let mut bad = wire(b"{}");
        bad[4] = 99;
        let got = all(&mut d, &bad);
        assert_eq!(
            got[0],
            Err(HeaderError::LengthMismatch {
                total: 99,
                payload: 2
            })
        );
        let mut empty = [0u8; 12];
        empty[..4].copy_from_slice(b"LTBR");
        empty[4] = 12;
        let got = all(&mut d, &empty);
        assert_eq!(got[0], Err(HeaderError::EmptyPayload));
        // A payload of only stripped bytes is empty too.
        let got = all(&mut d, &wire(b"\n\0\t"));
        assert_eq!(got[0], Err(HeaderError::EmptyPayload));
        assert_eq!(d.pending(), 0);
    }

    #[test]
    fn oversize_packet_is_reported_and_the_next_one_kept() {
        let mut d = Deframer::<8>::new();
        let mut input = heapless::Vec::<u8, 256>::new();
        input
            .extend_from_slice(&wire(b"{\"long\":\"0123456789\"}"))
            .unwrap();
        input.extend_from_slice(&wire(b"{}")).unwrap();
        let got = all(&mut d, &input);
        assert_eq!(got.len(), 2);
        assert_eq!(
            got[0],
            Err(HeaderError::TooLarge {
                payload: 21,
                max: 8
            })
        );
        assert_eq!(ok(&got, 1), b"{}");
        // Exactly N fits.
        let got = all(&mut d, &wire(b"12345678"));
        assert_eq!(ok(&got, 0), b"12345678");
    }

    #[test]
    fn over_the_protocol_cap_even_with_a_big_buffer() {
        let mut d = Deframer::<16>::new();
        let mut h = [0u8; 12];
        h[..4].copy_from_slice(b"LTBR");
        let p: u32 = (1 << 20) + 1;
        h[4..8].copy_from_slice(&(p + 12).to_le_bytes());
        h[8..].copy_from_slice(&p.to_le_bytes());
        let got = all(&mut d, &h);
        assert_eq!(
            got[0],
            Err(HeaderError::TooLarge {
                payload: p,
                max: 16
            })
        );
        assert_eq!(Deframer::<{ 2 << 20 }>::CAPACITY, MAX_PAYLOAD);
        assert_eq!(Deframer::<16>::CAPACITY, 16);
    }

    #[test]
    fn reset_drops_a_partial_packet() {
        let mut d = Deframer::<32>::new();
        let w = wire(b"{\"a\":1}");
        assert!(all(&mut d, &w[..15]).is_empty());
        assert_eq!(d.pending(), 15);
        d.reset();
        assert_eq!(d.pending(), 0);
        let got = all(&mut d, &w);
        assert_eq!(ok(&got, 0), b"{\"a\":1}");
    }
}
