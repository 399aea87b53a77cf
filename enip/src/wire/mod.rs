//! The byte formats of EtherNet/IP and CIP, one file each, in the manner of
//! smoltcp's `wire`: a `Packet<T: AsRef<[u8]>>` view over a buffer with a
//! `mod field` of named byte ranges where the format has a fixed layout, and
//! a plain `Repr` that parses from and emits into bytes. All multi-byte
//! numbers are little-endian (CIP's byte order).
//!
//! | module | what |
//! |---|---|
//! | [`encap`] | the 24-byte encapsulation header, its commands and status codes |
//! | [`session`] | RegisterSession's data and the SendRRData / SendUnitData prefix |
//! | [`cpf`] | Common Packet Format items |
//! | [`identity_item`] | the CIP Identity item of ListIdentity, ListServices' item |
//! | [`epath`] | EPATH segments: logical, port, electronic key, data |
//! | [`cip`] | Message Router request and response, general status |
//! | [`conn_mgr`] | Forward_Open, Large_Forward_Open, Forward_Close, extended status |
//! | [`io`] | class 1 implicit I/O packets |

pub mod cip;
pub mod conn_mgr;
pub mod cpf;
pub mod encap;
pub mod epath;
pub mod identity_item;
pub mod io;
pub mod session;

/// A byte range in a fixed layout.
pub type Field = core::ops::Range<usize>;
/// The bytes from an offset to the end.
pub type Rest = core::ops::RangeFrom<usize>;

/// Why bytes could not be read or written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// Fewer bytes than the format needs.
    Truncated {
        /// What was being read.
        what: &'static str,
        /// Bytes needed.
        expected: usize,
        /// Bytes there.
        got: usize,
    },
    /// A field holds a value the format does not allow.
    Invalid {
        /// Which field.
        what: &'static str,
        /// The value found.
        value: u32,
    },
    /// Bytes left over after a structure that must fill its container.
    TrailingBytes {
        /// What was being read.
        what: &'static str,
        /// How many bytes are left.
        extra: usize,
    },
    /// The output buffer is too small.
    Exhausted {
        /// What was being written.
        what: &'static str,
    },
}

impl core::fmt::Display for Error {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Error::Truncated {
                what,
                expected,
                got,
            } => {
                write!(f, "{what}: {expected} bytes needed, {got} there")
            }
            Error::Invalid { what, value } => write!(f, "{what}: invalid value {value:#x}"),
            Error::TrailingBytes { what, extra } => write!(f, "{what}: {extra} bytes left over"),
            Error::Exhausted { what } => write!(f, "{what}: output buffer too small"),
        }
    }
}

/// A cursor over input bytes that never reads past the end: every read
/// checks the length and names what it was reading when it fails.
#[derive(Clone, Debug)]
pub(crate) struct Reader<'a> {
    buf: &'a [u8],
}

impl<'a> Reader<'a> {
    pub(crate) fn new(buf: &'a [u8]) -> Self {
        Reader { buf }
    }

    pub(crate) fn rest(&self) -> &'a [u8] {
        self.buf
    }

    pub(crate) fn is_empty(&self) -> bool {
        self.buf.is_empty()
    }

    pub(crate) fn take(&mut self, n: usize, what: &'static str) -> Result<&'a [u8], Error> {
        if self.buf.len() < n {
            return Err(Error::Truncated {
                what,
                expected: n,
                got: self.buf.len(),
            });
        }
        let (head, tail) = self.buf.split_at(n);
        self.buf = tail;
        Ok(head)
    }

    pub(crate) fn array<const N: usize>(&mut self, what: &'static str) -> Result<[u8; N], Error> {
        let mut out = [0u8; N];
        out.copy_from_slice(self.take(N, what)?);
        Ok(out)
    }

    pub(crate) fn u8(&mut self, what: &'static str) -> Result<u8, Error> {
        Ok(u8::from_le_bytes(self.array(what)?))
    }

    pub(crate) fn u16(&mut self, what: &'static str) -> Result<u16, Error> {
        Ok(u16::from_le_bytes(self.array(what)?))
    }

    pub(crate) fn u32(&mut self, what: &'static str) -> Result<u32, Error> {
        Ok(u32::from_le_bytes(self.array(what)?))
    }
}

/// A cursor over an output buffer: every write checks the room left and
/// fails with [`Error::Exhausted`] instead of panicking.
#[derive(Debug)]
pub struct Writer<'a> {
    buf: &'a mut [u8],
    pos: usize,
}

impl<'a> Writer<'a> {
    /// A writer at the start of `buf`.
    pub fn new(buf: &'a mut [u8]) -> Self {
        Writer { buf, pos: 0 }
    }

    /// Bytes written so far.
    pub fn len(&self) -> usize {
        self.pos
    }

    /// Whether nothing was written yet.
    pub fn is_empty(&self) -> bool {
        self.pos == 0
    }

    /// The room left.
    pub fn remaining(&self) -> usize {
        self.buf.len().saturating_sub(self.pos)
    }

    /// Reserves `n` bytes and returns them to be filled in place.
    pub fn reserve(&mut self, n: usize, what: &'static str) -> Result<&mut [u8], Error> {
        let end = self.pos.checked_add(n).ok_or(Error::Exhausted { what })?;
        let out = self
            .buf
            .get_mut(self.pos..end)
            .ok_or(Error::Exhausted { what })?;
        self.pos = end;
        Ok(out)
    }

    /// Appends bytes.
    pub fn bytes(&mut self, b: &[u8], what: &'static str) -> Result<(), Error> {
        self.reserve(b.len(), what)?.copy_from_slice(b);
        Ok(())
    }

    /// Appends one byte.
    pub fn u8(&mut self, v: u8, what: &'static str) -> Result<(), Error> {
        self.bytes(&[v], what)
    }

    /// Appends a little-endian u16.
    pub fn u16(&mut self, v: u16, what: &'static str) -> Result<(), Error> {
        self.bytes(&v.to_le_bytes(), what)
    }

    /// Appends a little-endian u32.
    pub fn u32(&mut self, v: u32, what: &'static str) -> Result<(), Error> {
        self.bytes(&v.to_le_bytes(), what)
    }

    /// Forgets what was written from `len` on (to replace a reply begun
    /// with an error reply).
    pub(crate) fn truncate(&mut self, len: usize) {
        self.pos = self.pos.min(len);
    }

    /// The bytes written in `range`, to patch a length in place.
    pub(crate) fn written_mut(&mut self, range: Field) -> Option<&mut [u8]> {
        if range.end > self.pos {
            return None;
        }
        self.buf.get_mut(range)
    }

    /// Puts a little-endian u16 at an offset already written.
    pub(crate) fn patch_u16(&mut self, at: usize, v: u16, what: &'static str) -> Result<(), Error> {
        let end = at.checked_add(2).ok_or(Error::Exhausted { what })?;
        self.written_mut(at..end)
            .ok_or(Error::Exhausted { what })?
            .copy_from_slice(&v.to_le_bytes());
        Ok(())
    }
}

/// Reads a little-endian u16 at a field known to be in bounds; zero when it
/// is not (the caller's `new_checked` made sure it is).
pub(crate) fn get_u16(buf: &[u8], f: Field) -> u16 {
    buf.get(f)
        .and_then(|b| <[u8; 2]>::try_from(b).ok())
        .map_or(0, u16::from_le_bytes)
}

/// Reads a little-endian u32 at a field known to be in bounds; zero when it
/// is not.
pub(crate) fn get_u32(buf: &[u8], f: Field) -> u32 {
    buf.get(f)
        .and_then(|b| <[u8; 4]>::try_from(b).ok())
        .map_or(0, u32::from_le_bytes)
}

/// Writes a little-endian number at a field known to be in bounds; does
/// nothing when it is not.
pub(crate) fn set_bytes(buf: &mut [u8], f: Field, v: &[u8]) {
    if let Some(b) = buf.get_mut(f) {
        if b.len() == v.len() {
            b.copy_from_slice(v);
        }
    }
}
