//! Strict writer: always the canonical `Name,p1,...,pn,;`.

use crate::catalogue::CommandId;
use crate::error::EncodeError;
use crate::number::Decimal;
use crate::types::Param;

/// Receives the numbers a checking [`Writer`] walks past instead of
/// writing them (crate-internal: range checks, see `catalogue`). Called
/// through a reference, so that a program that never checks links none of
/// the checking code.
pub(crate) trait Check {
    /// A value of parameter `param` of `command`.
    fn value(&mut self, v: Decimal, param: Param, command: Option<CommandId>);
}

/// Writes one message into a caller's buffer. It never panics: the first
/// error (buffer too small, text the grammar cannot carry) is kept, later
/// writes do nothing, and [`Writer::finish`] returns it. Keeping the error
/// instead of returning it from every call keeps the code generated per
/// parameter to a single call.
pub struct Writer<'b> {
    buf: &'b mut [u8],
    len: usize,
    err: Option<EncodeError>,
    /// The command written, to name a parameter in an error.
    command: Option<CommandId>,
    /// Set in checking mode: nothing is written, numbers go here instead.
    check: Option<&'b mut dyn Check>,
}

impl core::fmt::Debug for Writer<'_> {
    // By hand: the check is a trait object without `Debug` (a `Debug`
    // bound would put formatting code into every check's vtable).
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("Writer")
            .field("len", &self.len)
            .field("err", &self.err)
            .field("command", &self.command)
            .field("checking", &self.check.is_some())
            .finish()
    }
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
        Writer {
            buf,
            len: 0,
            err: None,
            command: None,
            check: None,
        }
    }

    /// A writer of command `command` (or of an unknown one).
    pub(crate) fn of(buf: &'b mut [u8], command: Option<CommandId>) -> Self {
        Writer {
            command,
            ..Writer::new(buf)
        }
    }

    /// A writer of command `command` that writes nothing and hands every
    /// number to `check` instead.
    pub(crate) fn checking(command: CommandId, check: &'b mut dyn Check) -> Self {
        Writer {
            check: Some(check),
            ..Writer::of(&mut [], Some(command))
        }
    }

    /// Bytes written so far.
    pub fn len(&self) -> usize {
        self.len
    }

    /// `true` before anything is written.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Records an error (the first one is kept).
    pub fn fail(&mut self, e: EncodeError) {
        if self.err.is_none() {
            self.err = Some(e);
        }
    }

    fn bytes(&mut self, b: &[u8]) {
        if self.err.is_some() || self.check.is_some() {
            return;
        }
        let end = self.len.saturating_add(b.len());
        match self.buf.get_mut(self.len..end) {
            Some(dst) => {
                dst.copy_from_slice(b);
                self.len = end;
            }
            None => self.fail(EncodeError::BufferTooSmall),
        }
    }

    /// Raw field text followed by `,`; the caller has validated it.
    pub(crate) fn raw_field(&mut self, s: &str) {
        self.bytes(s.as_bytes());
        self.bytes(b",");
    }

    /// The command name and its separator: `Name,`.
    pub fn name(&mut self, name: &str) {
        self.raw_field(name)
    }

    /// An integer field: `v,`.
    #[inline(never)]
    pub fn int(&mut self, v: i32) {
        // 32-bit formatting: the protocol's integers are C `int`s.
        let mut b = itoa::Buffer::new();
        self.raw_field(b.format(v))
    }

    /// A decimal field, with exactly its decimals: `v,`.
    #[inline(never)]
    pub fn num(&mut self, v: &Decimal) {
        let mut b = [0u8; Decimal::MAX_TEXT];
        let n = v.write_to(&mut b).unwrap_or(0);
        self.bytes(b.get(..n).unwrap_or(b""));
        self.bytes(b",");
    }

    /// An integer of parameter `param`: written, or handed to the check.
    #[inline(never)]
    pub(crate) fn int_at(&mut self, v: i32, param: Param) {
        match &mut self.check {
            Some(c) => c.value(Decimal::from(v), param, self.command),
            None => self.int(v),
        }
    }

    /// A decimal of parameter `param`: written, or handed to the check.
    #[inline(never)]
    pub(crate) fn num_at(&mut self, v: &Decimal, param: Param) {
        match &mut self.check {
            Some(c) => c.value(*v, param, self.command),
            None => self.num(v),
        }
    }

    /// A text field, checked to be carriable: `s,`.
    #[inline(never)]
    pub fn text(&mut self, s: &str, param: &'static str) {
        if is_carriable(s) {
            self.raw_field(s)
        } else {
            self.fail(EncodeError::InvalidText { param })
        }
    }

    /// A text parameter of the command table, checked to be carriable.
    #[inline(never)]
    pub(crate) fn text_at(&mut self, s: &str, param: Param) {
        if is_carriable(s) {
            self.raw_field(s)
        } else {
            self.fail_at(param, |param| EncodeError::InvalidText { param })
        }
    }

    /// A text parameter the grammar cannot carry.
    pub(crate) fn fail_invalid_text(&mut self, param: Param) {
        self.fail_at(param, |param| EncodeError::InvalidText { param })
    }

    /// A list parameter with more elements than its count field can say.
    pub(crate) fn fail_list_too_long(&mut self, param: Param) {
        self.fail_at(param, |param| EncodeError::ListTooLong { param })
    }

    /// Records an error about `param`, named now (errors are rare).
    #[cold]
    #[inline(never)]
    fn fail_at(&mut self, param: Param, e: fn(&'static str) -> EncodeError) {
        self.fail(e(param.name(self.command)))
    }

    /// Terminates the message with `;` and returns its length, or the
    /// first error met.
    pub fn finish(mut self) -> Result<usize, EncodeError> {
        self.bytes(b";");
        match self.err {
            Some(e) => Err(e),
            None => Ok(self.len),
        }
    }
}
