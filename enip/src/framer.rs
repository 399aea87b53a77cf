//! Encapsulation packets out of a TCP byte stream, which arrives in pieces
//! of any size.
//!
//! One [`Framer`] per TCP connection: it keeps the 24-byte header and up to
//! `N` bytes of data. A packet whose length field announces more than `N`
//! bytes is not stored: its data is skipped as it arrives (the framer holds
//! a counter, not the bytes) and it comes out as [`Frame::TooLong`], which
//! the adapter answers with status 0x0065 (invalid length). The stream stays
//! in step either way, since the header says where the next packet starts.

use crate::wire::encap::{Header, HEADER_LEN};

/// A packet taken from the stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Frame<'a> {
    /// A whole packet.
    Complete {
        /// Its header.
        header: Header,
        /// Its data (`header.length` bytes).
        data: &'a [u8],
    },
    /// A packet with more data than the framer holds; the data was skipped.
    TooLong {
        /// Its header.
        header: Header,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    Header,
    Data { header: Header },
    Skip { header: Header, remaining: usize },
    Ready { header: Header },
    ReadyTooLong { header: Header },
}

/// Reassembles encapsulation packets of at most `N` data bytes.
#[derive(Debug, Clone)]
pub struct Framer<const N: usize> {
    head: [u8; HEADER_LEN],
    data: [u8; N],
    len: usize,
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
            head: [0; HEADER_LEN],
            data: [0; N],
            len: 0,
            state: State::Header,
        }
    }

    /// Takes bytes until a packet is complete; returns how many it took.
    /// While a packet is ready and not yet taken with [`Framer::frame`], it
    /// takes nothing. Call it again with the rest.
    pub fn push(&mut self, bytes: &[u8]) -> usize {
        let mut used = 0;
        loop {
            let rest = bytes.get(used..).unwrap_or(&[]);
            match self.state {
                State::Ready { .. } | State::ReadyTooLong { .. } => return used,
                _ if rest.is_empty() => return used,
                State::Header => {
                    let n = rest.len().min(HEADER_LEN - self.len);
                    if let (Some(dst), Some(src)) =
                        (self.head.get_mut(self.len..self.len + n), rest.get(..n))
                    {
                        dst.copy_from_slice(src);
                    }
                    self.len += n;
                    used += n;
                    if self.len == HEADER_LEN {
                        self.len = 0;
                        // Cannot fail: the header is complete.
                        let Ok(header) = Header::parse(&self.head) else {
                            return used;
                        };
                        let want = usize::from(header.length);
                        self.state = if want > N {
                            State::Skip {
                                header,
                                remaining: want,
                            }
                        } else if want == 0 {
                            State::Ready { header }
                        } else {
                            State::Data { header }
                        };
                    }
                }
                State::Data { header } => {
                    let want = usize::from(header.length);
                    let n = rest.len().min(want - self.len);
                    if let (Some(dst), Some(src)) =
                        (self.data.get_mut(self.len..self.len + n), rest.get(..n))
                    {
                        dst.copy_from_slice(src);
                    }
                    self.len += n;
                    used += n;
                    if self.len == want {
                        self.state = State::Ready { header };
                    }
                }
                State::Skip { header, remaining } => {
                    let n = rest.len().min(remaining);
                    used += n;
                    self.state = if n == remaining {
                        State::ReadyTooLong { header }
                    } else {
                        State::Skip {
                            header,
                            remaining: remaining - n,
                        }
                    };
                }
            }
        }
    }

    /// The packet completed by [`Framer::push`], once; the next push starts
    /// the next packet.
    pub fn frame(&mut self) -> Option<Frame<'_>> {
        match self.state {
            State::Ready { header } => {
                let n = self.len;
                self.len = 0;
                self.state = State::Header;
                Some(Frame::Complete {
                    header,
                    data: self.data.get(..n).unwrap_or(&[]),
                })
            }
            State::ReadyTooLong { header } => {
                self.state = State::Header;
                Some(Frame::TooLong { header })
            }
            _ => None,
        }
    }

    /// Whether the framer is between packets (no partial packet held): a
    /// TCP connection that closes now closed cleanly.
    pub fn is_idle(&self) -> bool {
        self.state == State::Header && self.len == 0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::encap::{Command, Status};

    fn packet(len: u16, fill: u8) -> ([u8; 24], heapless::Vec<u8, 64>) {
        let h = Header {
            command: Command::SendRrData,
            length: len,
            session: 9,
            status: Status::Success,
            context: [1; 8],
            options: 0,
        };
        let mut head = [0u8; 24];
        h.emit(&mut head).unwrap();
        let mut data = heapless::Vec::new();
        for _ in 0..len.min(64) {
            data.push(fill).unwrap();
        }
        (head, data)
    }

    #[test]
    fn reassembles_byte_by_byte_and_back_to_back() {
        let (h1, d1) = packet(5, 0xAA);
        let (h2, d2) = packet(0, 0);
        let mut stream: heapless::Vec<u8, 128> = heapless::Vec::new();
        stream.extend_from_slice(&h1).unwrap();
        stream.extend_from_slice(&d1).unwrap();
        stream.extend_from_slice(&h2).unwrap();
        let mut f = Framer::<16>::new();
        let mut got = 0;
        for b in stream.iter() {
            assert_eq!(f.push(core::slice::from_ref(b)), 1);
            if let Some(fr) = f.frame() {
                match (got, fr) {
                    (0, Frame::Complete { header, data }) => {
                        assert_eq!(header.length, 5);
                        assert_eq!(data, &d1[..]);
                    }
                    (1, Frame::Complete { header, data }) => {
                        assert_eq!(header.length, 0);
                        assert_eq!(data, &d2[..]);
                    }
                    other => panic!("{other:?}"),
                }
                got += 1;
            }
        }
        assert_eq!(got, 2);
        assert!(f.is_idle());
        // All at once: push stops at the end of each packet.
        let mut f = Framer::<16>::new();
        let n = f.push(&stream);
        assert_eq!(n, 29);
        assert_eq!(
            f.push(&stream[n..]),
            0,
            "nothing taken while a packet waits"
        );
        assert!(matches!(f.frame(), Some(Frame::Complete { .. })));
        assert!(f.frame().is_none());
        assert_eq!(f.push(&stream[n..]), 24);
        assert!(matches!(f.frame(), Some(Frame::Complete { .. })));
    }

    #[test]
    fn too_long_packets_are_skipped_and_reported() {
        let (h, _) = packet(1000, 0);
        let mut f = Framer::<16>::new();
        assert_eq!(f.push(&h), 24);
        assert!(f.frame().is_none());
        assert!(!f.is_idle());
        let zeros = [0u8; 300];
        for _ in 0..3 {
            assert_eq!(f.push(&zeros), 300);
            assert!(f.frame().is_none());
        }
        assert_eq!(f.push(&zeros), 100);
        match f.frame() {
            Some(Frame::TooLong { header }) => assert_eq!(header.length, 1000),
            other => panic!("{other:?}"),
        }
        // In step again.
        let (h2, d2) = packet(3, 7);
        f.push(&h2);
        f.push(&d2);
        assert!(matches!(
            f.frame(),
            Some(Frame::Complete {
                data: &[7, 7, 7],
                ..
            })
        ));
    }
}
