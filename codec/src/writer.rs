//! Strict writer: always the canonical `Name,p1,...,pn,;`.

use crate::error::EncodeError;
use crate::number::Decimal;

/// Writes one message into a caller's buffer. Every method either writes
/// completely or returns [`EncodeError::BufferTooSmall`]; it never panics.
#[derive(Debug)]
pub struct Writer<'b> {
    buf: &'b mut [u8],
    len: usize,
}

/// `true` for text the grammar can carry unchanged: printable ASCII without
/// `,` and `;`, and without spaces at either end (the reader trims them).
pub(crate) fn is_carriable(s: &str) -> bool {
    s.bytes()
        .all(|b| (0x20..0x7f).contains(&b) && b != b',' && b != b';')
        && !s.starts_with(' ')
        && !s.ends_with(' ')
}

impl<'b> Writer<'b> {
    /// A writer at the start of `buf`.
    pub fn new(buf: &'b mut [u8]) -> Self {
        Writer { buf, len: 0 }
    }

    /// Bytes written so far.
    pub fn len(&self) -> usize {
        self.len
    }

    /// `true` before anything is written.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn bytes(&mut self, b: &[u8]) -> Result<(), EncodeError> {
        let end = self
            .len
            .checked_add(b.len())
            .ok_or(EncodeError::BufferTooSmall)?;
        self.buf
            .get_mut(self.len..end)
            .ok_or(EncodeError::BufferTooSmall)?
            .copy_from_slice(b);
        self.len = end;
        Ok(())
    }

    /// The command name and its separator: `Name,`.
    pub fn name(&mut self, name: &str) -> Result<(), EncodeError> {
        self.bytes(name.as_bytes())?;
        self.bytes(b",")
    }

    /// An integer field: `v,`.
    pub fn int(&mut self, v: i64) -> Result<(), EncodeError> {
        let mut b = itoa::Buffer::new();
        self.bytes(b.format(v).as_bytes())?;
        self.bytes(b",")
    }

    /// A decimal field, with exactly its decimals: `v,`.
    pub fn num(&mut self, v: &Decimal) -> Result<(), EncodeError> {
        let mut b = [0u8; Decimal::MAX_TEXT];
        let n = v.write_to(&mut b).ok_or(EncodeError::BufferTooSmall)?;
        self.bytes(b.get(..n).ok_or(EncodeError::BufferTooSmall)?)?;
        self.bytes(b",")
    }

    /// A text field, checked to be carriable: `s,`.
    pub fn text(&mut self, s: &str, param: &'static str) -> Result<(), EncodeError> {
        if !is_carriable(s) {
            return Err(EncodeError::InvalidText { param });
        }
        self.bytes(s.as_bytes())?;
        self.bytes(b",")
    }

    /// Raw, already-validated field text followed by `,` (used for the
    /// `OK`/`Fail` markers and pass-through fields).
    pub(crate) fn raw_field(&mut self, s: &str) -> Result<(), EncodeError> {
        self.bytes(s.as_bytes())?;
        self.bytes(b",")
    }

    /// Terminates the message with `;` and returns its length.
    pub fn finish(mut self) -> Result<usize, EncodeError> {
        self.bytes(b";")?;
        Ok(self.len)
    }
}
