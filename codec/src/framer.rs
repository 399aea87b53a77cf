//! Streaming framer for the command port: bytes in, messages out.
//!
//! Feed it whatever a TCP read returned. It yields each complete message
//! (ending at `;`), whether it arrived split across many reads or packed with
//! others into one. It is a byte-at-a-time state machine over a fixed buffer
//! of `N` bytes chosen by the caller; there is no allocation and no input on
//! which it panics.
//!
//! Each message yields exactly one item, when its `;` arrives:
//! * `Ok(text)`: the message including its `;`, as a `&str` (every byte was
//!   checked to be printable ASCII).
//! * `Err(FrameError::TooLong)`: the message did not fit in `N` bytes. Its
//!   bytes were dropped; the framer resynchronised at its `;` and the
//!   messages after it are unaffected.
//! * `Err(FrameError::InvalidByte)`: the message held a control character or
//!   a non-ASCII byte. Only that message is lost.
//!
//! Whitespace (space, tab, CR, LF) between messages is skipped, and so are
//! empty messages (a doubled `;`). A message still open when the stream ends
//! stays in the buffer ([`Framer::pending`]); [`Framer::reset`] drops it.

use core::fmt;

use crate::grammar::is_space;

/// Why one message was dropped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// The message was longer than the buffer; `len` bytes were seen
    /// (saturating) before its `;`.
    TooLong {
        /// Bytes of the message seen, including the ones dropped.
        len: usize,
    },
    /// A byte that is not printable ASCII (0x20-0x7E) inside a message.
    InvalidByte {
        /// The first offending byte.
        byte: u8,
        /// Its offset in the message.
        offset: usize,
    },
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameError::TooLong { len } => write!(f, "message of {len} bytes exceeds the buffer"),
            FrameError::InvalidByte { byte, offset } => {
                write!(f, "invalid byte 0x{byte:02x} at offset {offset}")
            }
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    /// Between messages.
    Idle,
    /// Inside a message that is still good.
    Collecting,
    /// Inside a message already known bad; skipping to its `;`.
    Skipping(FrameError),
}

/// The framer, with an `N`-byte message buffer (the longest message it can
/// deliver, `;` included).
#[derive(Clone, Debug)]
pub struct Framer<const N: usize> {
    buf: [u8; N],
    len: usize,
    /// Length of the message so far, counting dropped bytes.
    seen: usize,
    state: State,
}

impl<const N: usize> Default for Framer<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Framer<N> {
    /// An empty framer.
    pub const fn new() -> Self {
        Framer {
            buf: [0; N],
            len: 0,
            seen: 0,
            state: State::Idle,
        }
    }

    /// Drops any partial message.
    pub fn reset(&mut self) {
        self.len = 0;
        self.seen = 0;
        self.state = State::Idle;
    }

    /// Bytes of an unfinished message held (0 between messages).
    pub fn pending(&self) -> usize {
        match self.state {
            State::Idle => 0,
            _ => self.seen,
        }
    }

    /// Consumes bytes from `input` up to the end of the next message.
    ///
    /// Returns how many bytes were consumed and, if a message ended, the
    /// message or why it was dropped. Call again with the rest of `input`
    /// until it is empty:
    ///
    /// ```
    /// use hans_codec::Framer;
    /// let mut framer = Framer::<64>::new();
    /// let mut input: &[u8] = b"GrpEnable,OK,;GrpReset,";
    /// let mut got = 0;
    /// while !input.is_empty() {
    ///     let (used, item) = framer.push(input);
    ///     input = &input[used..];
    ///     if let Some(Ok(msg)) = item {
    ///         assert_eq!(msg, "GrpEnable,OK,;");
    ///         got += 1;
    ///     }
    /// }
    /// assert_eq!((got, framer.pending()), (1, 9));
    /// ```
    pub fn push(&mut self, input: &[u8]) -> (usize, Option<Result<&str, FrameError>>) {
        let mut used = 0;
        for &b in input {
            used += 1;
            if self.step(b) {
                return (used, Some(self.take()));
            }
        }
        (used, None)
    }

    /// Feeds all of `input`, calling `on_message` for every message that ends
    /// in it.
    pub fn feed(&mut self, mut input: &[u8], mut on_message: impl FnMut(Result<&str, FrameError>)) {
        while !input.is_empty() {
            let (used, item) = self.push(input);
            if let Some(item) = item {
                on_message(item);
            }
            input = input.get(used..).unwrap_or(&[]);
        }
    }

    /// Advances the state machine by one byte; `true` when a message ended.
    fn step(&mut self, b: u8) -> bool {
        match self.state {
            State::Idle => {
                if b == b';' || is_space(b) {
                    return false;
                }
                self.len = 0;
                self.seen = 0;
                self.state = State::Collecting;
                self.collect(b)
            }
            State::Collecting => self.collect(b),
            State::Skipping(_) => {
                self.seen = self.seen.saturating_add(1);
                b == b';'
            }
        }
    }

    fn collect(&mut self, b: u8) -> bool {
        let offset = self.seen;
        self.seen = self.seen.saturating_add(1);
        if !(0x20..0x7f).contains(&b) {
            self.state = State::Skipping(FrameError::InvalidByte { byte: b, offset });
            return false;
        }
        match self.buf.get_mut(self.len) {
            Some(slot) => {
                *slot = b;
                self.len += 1;
            }
            None => {
                self.state = State::Skipping(FrameError::TooLong { len: 0 });
                return b == b';';
            }
        }
        b == b';'
    }

    /// Hands out the message that just ended and returns to idle.
    fn take(&mut self) -> Result<&str, FrameError> {
        let state = core::mem::replace(&mut self.state, State::Idle);
        match state {
            State::Skipping(FrameError::TooLong { .. }) => {
                Err(FrameError::TooLong { len: self.seen })
            }
            State::Skipping(e) => Err(e),
            _ => {
                let bytes = self.buf.get(..self.len).unwrap_or(&[]);
                // Every byte was checked to be printable ASCII.
                core::str::from_utf8(bytes)
                    .map_err(|_| FrameError::InvalidByte { byte: 0, offset: 0 })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn all<const N: usize>(
        f: &mut Framer<N>,
        input: &[u8],
    ) -> heapless::Vec<Result<heapless::String<64>, FrameError>, 16> {
        let mut out = heapless::Vec::new();
        f.feed(input, |m| {
            let _ = out.push(m.map(|s| heapless::String::try_from(s).unwrap()));
        });
        out
    }

    #[test]
    fn split_and_packed() {
        let mut f = Framer::<64>::new();
        assert!(all(&mut f, b"ReadActPos,").is_empty());
        assert!(all(&mut f, b"0").is_empty());
        let r = all(&mut f, b",;GrpStop,0,;\r\nGrpReset,0,;;");
        assert_eq!(r.len(), 3);
        assert_eq!(r[0].as_ref().unwrap(), "ReadActPos,0,;");
        assert_eq!(r[1].as_ref().unwrap(), "GrpStop,0,;");
        assert_eq!(r[2].as_ref().unwrap(), "GrpReset,0,;");
        assert_eq!(f.pending(), 0);
    }

    #[test]
    fn too_long_resynchronises() {
        let mut f = Framer::<8>::new();
        let r = all(&mut f, b"ReadActPos,0,;A,;");
        assert_eq!(r[0], Err(FrameError::TooLong { len: 14 }));
        assert_eq!(r[1].as_ref().unwrap(), "A,;");
        // Exactly N bytes fits.
        let r = all(&mut f, b"ABCDEFG;");
        assert_eq!(r[0].as_ref().unwrap(), "ABCDEFG;");
    }

    #[test]
    fn invalid_bytes_cost_one_message() {
        let mut f = Framer::<32>::new();
        let r = all(&mut f, b"Gr\x00p,;A,\xff;B,;");
        assert_eq!(r[0], Err(FrameError::InvalidByte { byte: 0, offset: 2 }));
        assert_eq!(
            r[1],
            Err(FrameError::InvalidByte {
                byte: 0xff,
                offset: 2
            })
        );
        assert_eq!(r[2].as_ref().unwrap(), "B,;");
    }
}
