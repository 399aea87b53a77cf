//! A minimal zero-allocation JSON pull tokenizer, and the writer the
//! DataSheet encoder uses.
//!
//! # Why our own
//! serde-json-core 0.7, the well-kept `no_std` JSON crate, cannot read the
//! DataSheet: its `deserialize_any` returns `AnyIsUnsupported`, so it cannot
//! read a value that is a string on one controller and a number on another
//! (`"0.000"` vs `48.00`), and it parses floats with core's parser (~20 KiB of
//! flash on Cortex-M, and not exact). We need every number as an exact
//! [`Decimal`] from either form, unknown members skipped
//! whatever their shape, and the vendor's stray NUL/`\n`/`\t` bytes ignored.
//! That takes a tokenizer of a few hundred lines, which is this module.
//!
//! # What it accepts
//! RFC 8259 JSON, with these tolerances for what controllers send:
//! * NUL, `\n` and `\t` bytes are ignored **everywhere**, also inside
//!   strings, numbers and literals: official readers delete them from the
//!   payload before parsing, and skipping them while scanning gives the same
//!   result without a copy or a `&mut` buffer. Token slices still contain
//!   them; [`significant`] filters them out.
//! * `\r` and space are whitespace between tokens, as in JSON.
//! * A trailing comma before `}` or `]` (the document's example has one).
//! * Numbers may have leading zeros (`007`).
//! * Bytes inside strings are not checked (no UTF-8 or control-character
//!   check); escapes must be well-formed but are not decoded.
//!
//! Nesting is limited to [`MAX_DEPTH`] containers; deeper input is an error,
//! so skipping unknown members needs no recursion and bounded state.
//!
//! ```
//! use hans_codec::datasheet::json::{Token, Tokenizer};
//!
//! let mut t = Tokenizer::new(b"{\"robotState\":\n33,\"v\":[\"0.5\"]}");
//! assert_eq!(t.next_token(), Ok(Some(Token::BeginObject)));
//! assert_eq!(t.next_token(), Ok(Some(Token::Key(b"robotState"))));
//! assert_eq!(t.next_token(), Ok(Some(Token::Number(b"33"))));
//! assert_eq!(t.next_token(), Ok(Some(Token::Key(b"v"))));
//! assert_eq!(t.next_token(), Ok(Some(Token::BeginArray)));
//! t.skip_container().unwrap();
//! assert_eq!(t.next_token(), Ok(Some(Token::EndObject)));
//! assert_eq!(t.next_token(), Ok(None));
//! ```

use core::fmt;

use super::deframer::is_stripped;
use super::scan;
use crate::error::EncodeError;
use crate::number::Decimal;

/// The bytes taken as whitespace between tokens, as a pattern: JSON's four,
/// and NUL, which controllers pad payloads with. A pattern, so that the
/// tokenizer's byte dispatch keeps it in its one `match`.
macro_rules! space {
    () => {
        b' ' | b'\r' | b'\n' | b'\t' | 0
    };
}

/// `true` for the bytes [`space!`] names; the DataSheet reader (`read.rs`)
/// skips exactly these too.
#[inline]
pub(super) fn is_space(b: u8) -> bool {
    matches!(b, space!())
}
/// The deepest nesting of objects and arrays accepted.
pub const MAX_DEPTH: usize = 16;

/// One token. Slices borrow the input and are raw: string contents without
/// the quotes and with escapes undecoded; both may contain ignored bytes
/// (see [`significant`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Token<'a> {
    /// `{`
    BeginObject,
    /// `}`
    EndObject,
    /// `[`
    BeginArray,
    /// `]`
    EndArray,
    /// A member name (the string before `:`).
    Key(&'a [u8]),
    /// A string value.
    Str(&'a [u8]),
    /// A number, as written.
    Number(&'a [u8]),
    /// `true` or `false`.
    Bool(bool),
    /// `null`.
    Null,
}

/// What is wrong at [`JsonError::offset`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum JsonErrorKind {
    /// The input ended inside a value.
    UnexpectedEnd,
    /// A byte that cannot come here.
    UnexpectedByte(u8),
    /// More than [`MAX_DEPTH`] nested containers.
    TooDeep,
    /// A `\` escape that is not one of JSON's.
    BadEscape,
    /// A malformed number.
    BadNumber,
    /// Not `true`, `false` or `null`.
    BadLiteral,
}

/// A syntax error and where it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct JsonError {
    /// Byte offset in the input.
    pub offset: usize,
    /// What is wrong.
    pub kind: JsonErrorKind,
}

impl fmt::Display for JsonError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.kind {
            JsonErrorKind::UnexpectedEnd => f.write_str("JSON ends unexpectedly")?,
            JsonErrorKind::UnexpectedByte(b) => write!(f, "unexpected byte 0x{b:02x} in JSON")?,
            JsonErrorKind::TooDeep => write!(f, "JSON nested deeper than {MAX_DEPTH}")?,
            JsonErrorKind::BadEscape => f.write_str("bad escape in JSON string")?,
            JsonErrorKind::BadNumber => f.write_str("malformed JSON number")?,
            JsonErrorKind::BadLiteral => f.write_str("malformed JSON literal")?,
        }
        write!(f, " at offset {}", self.offset)
    }
}

impl core::error::Error for JsonError {}

/// The bytes of a raw token slice that count: all but NUL, `\n` and `\t`.
///
/// ```
/// use hans_codec::datasheet::json::significant;
/// assert!(significant(b"1\n2.\t5\0").eq(b"12.5".iter().copied()));
/// ```
pub fn significant(raw: &[u8]) -> impl Iterator<Item = u8> + '_ {
    raw.iter().copied().filter(|&b| !is_stripped(b))
}

/// What the grammar allows next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Expect {
    /// A value (start of input, after `:`).
    Value,
    /// A value or `]` (after `[` or `,` in an array).
    ValueOrEnd,
    /// A key or `}` (after `{` or `,` in an object).
    KeyOrEnd,
    /// `:` after a key.
    Colon,
    /// `,` or the end of the container, after a value.
    CommaOrEnd,
    /// The top-level value is complete; only whitespace may follow.
    Done,
}

/// The pull tokenizer over one complete JSON text.
///
/// It checks the structure as it goes (keys only in objects, `:` and `,`
/// where they belong, balanced brackets), so a token sequence it yields
/// without error is well-formed. After an error every call returns that
/// error again.
///
/// ```
/// use hans_codec::datasheet::json::{JsonErrorKind, Token, Tokenizer};
///
/// let mut t = Tokenizer::new(b"[\"0.000\", 48.00,]");
/// assert_eq!(t.next_token(), Ok(Some(Token::BeginArray)));
/// assert_eq!(t.next_token(), Ok(Some(Token::Str(b"0.000"))));
/// assert_eq!(t.next_token(), Ok(Some(Token::Number(b"48.00"))));
/// assert_eq!(t.next_token(), Ok(Some(Token::EndArray))); // trailing comma tolerated
/// assert_eq!(t.next_token(), Ok(None));
///
/// let mut bad = Tokenizer::new(b"{\"a\" 1}");
/// bad.next_token().unwrap();
/// bad.next_token().unwrap();
/// let e = bad.next_token().unwrap_err();
/// assert_eq!((e.offset, e.kind), (5, JsonErrorKind::UnexpectedByte(b'1')));
/// ```
#[derive(Clone, Debug)]
pub struct Tokenizer<'a> {
    input: &'a [u8],
    pos: usize,
    /// Bit `d` set: the container at depth `d + 1` is an array.
    stack: u16,
    depth: u8,
    expect: Expect,
    last: usize,
    error: Option<JsonError>,
}

const _: () = assert!(MAX_DEPTH <= 16, "the container stack is a u16");

impl<'a> Tokenizer<'a> {
    /// A tokenizer at the start of `input`.
    pub const fn new(input: &'a [u8]) -> Self {
        Tokenizer {
            input,
            pos: 0,
            stack: 0,
            depth: 0,
            expect: Expect::Value,
            last: 0,
            error: None,
        }
    }

    /// Containers open after the last token (1 inside the top-level object).
    pub fn depth(&self) -> usize {
        usize::from(self.depth)
    }

    /// Byte offset where the last token returned starts.
    pub fn offset(&self) -> usize {
        self.last
    }

    #[cold]
    fn fail(&mut self, offset: usize, kind: JsonErrorKind) -> JsonError {
        let e = JsonError { offset, kind };
        self.error = Some(e);
        e
    }

    fn byte(&self, at: usize) -> Option<u8> {
        self.input.get(at).copied()
    }

    /// The next byte at or after `at` that is not an ignored one.
    fn significant_at(&self, mut at: usize) -> (usize, Option<u8>) {
        while let Some(b) = self.byte(at) {
            if !is_stripped(b) {
                return (at, Some(b));
            }
            at += 1;
        }
        (at, None)
    }

    fn in_array(&self) -> bool {
        self.depth > 0 && self.stack & (1 << (self.depth - 1)) != 0
    }

    fn after_value(&mut self) {
        self.expect = if self.depth == 0 {
            Expect::Done
        } else {
            Expect::CommaOrEnd
        };
    }

    fn open(&mut self, array: bool) -> Result<(), JsonError> {
        if usize::from(self.depth) >= MAX_DEPTH {
            return Err(self.fail(self.pos, JsonErrorKind::TooDeep));
        }
        let bit = 1u16 << self.depth;
        if array {
            self.stack |= bit;
        } else {
            self.stack &= !bit;
        }
        self.depth += 1;
        self.pos += 1;
        self.expect = if array {
            Expect::ValueOrEnd
        } else {
            Expect::KeyOrEnd
        };
        Ok(())
    }

    fn close(&mut self) {
        self.depth = self.depth.saturating_sub(1);
        self.pos += 1;
        self.after_value();
    }

    /// The next token; `Ok(None)` once the top-level value is complete and
    /// only whitespace follows.
    pub fn next_token(&mut self) -> Result<Option<Token<'a>>, JsonError> {
        if let Some(e) = self.error {
            return Err(e);
        }
        // Whitespace and separators in one loop with one dispatch per byte,
        // the position and state in locals until a token starts.
        let mut at = self.pos;
        let mut expect = self.expect;
        let b = loop {
            let Some(&b) = self.input.get(at) else {
                (self.pos, self.last, self.expect) = (at, at, expect);
                return self.end(at);
            };
            match b {
                space!() => at += 1,
                b':' if expect == Expect::Colon => {
                    at += 1;
                    expect = Expect::Value;
                }
                b',' if expect == Expect::CommaOrEnd => {
                    at += 1;
                    expect = if self.in_array() {
                        Expect::ValueOrEnd
                    } else {
                        Expect::KeyOrEnd
                    };
                }
                _ => break b,
            }
        };
        (self.pos, self.last, self.expect) = (at, at, expect);
        match b {
            b'"' if expect == Expect::KeyOrEnd => {
                let s = self.string()?;
                self.expect = Expect::Colon;
                Ok(Some(Token::Key(s)))
            }
            b'}' if matches!(expect, Expect::CommaOrEnd | Expect::KeyOrEnd) && !self.in_array() => {
                self.close();
                Ok(Some(Token::EndObject))
            }
            b']' if matches!(expect, Expect::CommaOrEnd | Expect::ValueOrEnd)
                && self.in_array() =>
            {
                self.close();
                Ok(Some(Token::EndArray))
            }
            _ if matches!(expect, Expect::Value | Expect::ValueOrEnd) => self.value(b).map(Some),
            _ => Err(self.fail(at, JsonErrorKind::UnexpectedByte(b))),
        }
    }

    /// The input ended where a token was expected.
    #[cold]
    fn end(&mut self, at: usize) -> Result<Option<Token<'a>>, JsonError> {
        match self.expect {
            Expect::Done => Ok(None),
            _ => Err(self.fail(at, JsonErrorKind::UnexpectedEnd)),
        }
    }

    fn value(&mut self, b: u8) -> Result<Token<'a>, JsonError> {
        let token = match b {
            b'{' => {
                self.open(false)?;
                return Ok(Token::BeginObject);
            }
            b'[' => {
                self.open(true)?;
                return Ok(Token::BeginArray);
            }
            b'"' => Token::Str(self.string()?),
            b'-' | b'0'..=b'9' => Token::Number(self.number()?),
            b't' => self.literal(b"true", Token::Bool(true))?,
            b'f' => self.literal(b"false", Token::Bool(false))?,
            b'n' => self.literal(b"null", Token::Null)?,
            _ => return Err(self.fail(self.pos, JsonErrorKind::UnexpectedByte(b))),
        };
        self.after_value();
        Ok(token)
    }

    /// A string starting at the `"` under `pos`; returns its contents.
    fn string(&mut self) -> Result<&'a [u8], JsonError> {
        let start = self.pos + 1;
        let mut i = start;
        loop {
            // Straight to the next quote or backslash: everything else in a
            // string is taken as it is.
            let rest = self.input.get(i..).unwrap_or(&[]);
            let Some(k) = scan::quote_or_backslash(rest) else {
                return Err(self.fail(self.input.len(), JsonErrorKind::UnexpectedEnd));
            };
            i += k;
            if self.byte(i) == Some(b'"') {
                break;
            }
            // An escape: check it, then go on after it.
            let (at, e) = self.significant_at(i + 1);
            i = at + 1;
            match e {
                None => return Err(self.fail(at, JsonErrorKind::UnexpectedEnd)),
                Some(b'"' | b'\\' | b'/' | b'b' | b'f' | b'n' | b'r' | b't') => {}
                Some(b'u') => {
                    for _ in 0..4 {
                        let (at, h) = self.significant_at(i);
                        match h {
                            Some(h) if h.is_ascii_hexdigit() => i = at + 1,
                            None => return Err(self.fail(at, JsonErrorKind::UnexpectedEnd)),
                            Some(_) => return Err(self.fail(at, JsonErrorKind::BadEscape)),
                        }
                    }
                }
                Some(_) => return Err(self.fail(at, JsonErrorKind::BadEscape)),
            }
        }
        let s = self.input.get(start..i).unwrap_or(&[]);
        self.pos = i + 1;
        Ok(s)
    }

    /// A number starting under `pos`: `-? digits (. digits)? ([eE] [+-]? digits)?`
    /// with ignored bytes anywhere in it.
    fn number(&mut self) -> Result<&'a [u8], JsonError> {
        let start = self.pos;
        let mut end = start;
        while self.byte(end).is_some_and(is_number_byte) {
            end += 1;
        }
        let raw = self.input.get(start..end).unwrap_or(&[]);
        if !is_json_number(significant(raw)) {
            return Err(self.fail(start, JsonErrorKind::BadNumber));
        }
        self.pos = end;
        Ok(raw)
    }

    fn literal(&mut self, word: &[u8], token: Token<'a>) -> Result<Token<'a>, JsonError> {
        let mut i = self.pos;
        for &want in word {
            let (at, got) = self.significant_at(i);
            if got != Some(want) {
                let kind = match got {
                    None => JsonErrorKind::UnexpectedEnd,
                    Some(_) => JsonErrorKind::BadLiteral,
                };
                return Err(self.fail(at, kind));
            }
            i = at + 1;
        }
        self.pos = i;
        Ok(token)
    }

    /// Skips the rest of the container whose `BeginObject` / `BeginArray`
    /// was the last token returned, up to and including its end token.
    /// Needs no recursion: the tokenizer tracks the depth.
    pub fn skip_container(&mut self) -> Result<(), JsonError> {
        let target = self.depth.saturating_sub(1);
        loop {
            match self.next_token()? {
                Some(Token::EndObject | Token::EndArray) if self.depth == target => return Ok(()),
                Some(_) => {}
                None => return Err(self.fail(self.pos, JsonErrorKind::UnexpectedEnd)),
            }
        }
    }
}

/// A byte that can be part of a number (ignored ones included).
fn is_number_byte(b: u8) -> bool {
    b.is_ascii_digit() || matches!(b, b'-' | b'+' | b'.' | b'e' | b'E') || is_stripped(b)
}

/// `-? digits (. digits)? ([eE] [+-]? digits)?`, leading zeros allowed.
fn is_json_number(mut it: impl Iterator<Item = u8>) -> bool {
    #[derive(PartialEq)]
    enum S {
        Start,
        Sign,
        Int,
        Point,
        Frac,
        E,
        ESign,
        Exp,
    }
    let mut s = S::Start;
    for b in it.by_ref() {
        s = match (s, b) {
            (S::Start, b'-') => S::Sign,
            (S::Start | S::Sign | S::Int, b'0'..=b'9') => S::Int,
            (S::Int, b'.') => S::Point,
            (S::Point | S::Frac, b'0'..=b'9') => S::Frac,
            (S::Int | S::Frac, b'e' | b'E') => S::E,
            (S::E, b'+' | b'-') => S::ESign,
            (S::E | S::ESign | S::Exp, b'0'..=b'9') => S::Exp,
            _ => return false,
        };
    }
    matches!(s, S::Int | S::Frac | S::Exp)
}

/// Writes compact JSON into a caller's buffer. Like the command writer it
/// keeps the first error (buffer too small) and makes later writes no-ops,
/// so the code per member is one call. Member names come from this crate's
/// tables and are written without escaping.
#[derive(Debug)]
pub(crate) struct Writer<'b> {
    buf: &'b mut [u8],
    len: usize,
    full: bool,
    /// A value or container was just completed at the current level.
    comma: bool,
}

impl<'b> Writer<'b> {
    pub(crate) fn new(buf: &'b mut [u8]) -> Self {
        Writer {
            buf,
            len: 0,
            full: false,
            comma: false,
        }
    }

    fn raw(&mut self, b: &[u8]) {
        if self.full {
            return;
        }
        let end = self.len.saturating_add(b.len());
        match self.buf.get_mut(self.len..end) {
            Some(dst) => {
                dst.copy_from_slice(b);
                self.len = end;
            }
            None => self.full = true,
        }
    }

    fn separate(&mut self) {
        if self.comma {
            self.raw(b",");
        }
    }

    pub(crate) fn begin_object(&mut self) {
        self.separate();
        self.raw(b"{");
        self.comma = false;
    }

    pub(crate) fn end_object(&mut self) {
        self.raw(b"}");
        self.comma = true;
    }

    pub(crate) fn begin_array(&mut self) {
        self.separate();
        self.raw(b"[");
        self.comma = false;
    }

    pub(crate) fn end_array(&mut self) {
        self.raw(b"]");
        self.comma = true;
    }

    /// `"name":`
    pub(crate) fn key(&mut self, name: &str) {
        self.separate();
        self.raw(b"\"");
        self.raw(name.as_bytes());
        self.raw(b"\":");
        self.comma = false;
    }

    /// A decimal exactly as it is, as a string (`"1.500"`) or a number.
    pub(crate) fn decimal(&mut self, v: &Decimal, quoted: bool) {
        self.separate();
        let mut b = [0u8; Decimal::MAX_TEXT];
        let n = v.write_to(&mut b).unwrap_or(0);
        if quoted {
            self.raw(b"\"");
        }
        self.raw(b.get(..n).unwrap_or(b""));
        if quoted {
            self.raw(b"\"");
        }
        self.comma = true;
    }

    /// An integer (`-5`).
    pub(crate) fn int(&mut self, v: i64) {
        self.separate();
        let mut b = itoa::Buffer::new();
        self.raw(b.format(v).as_bytes());
        self.comma = true;
    }

    /// An unsigned integer.
    pub(crate) fn uint(&mut self, v: u64) {
        self.separate();
        let mut b = itoa::Buffer::new();
        self.raw(b.format(v).as_bytes());
        self.comma = true;
    }

    /// Bytes written, or [`EncodeError::BufferTooSmall`].
    pub(crate) fn finish(self) -> Result<usize, EncodeError> {
        if self.full {
            Err(EncodeError::BufferTooSmall)
        } else {
            Ok(self.len)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    type Tokens<'a> = heapless::Vec<Token<'a>, 64>;

    fn tokens(input: &[u8]) -> Result<Tokens<'_>, JsonError> {
        let mut t = Tokenizer::new(input);
        let mut out = Tokens::new();
        while let Some(tok) = t.next_token()? {
            out.push(tok).unwrap();
        }
        Ok(out)
    }

    fn err(input: &[u8]) -> JsonError {
        tokens(input).unwrap_err()
    }

    #[test]
    fn full_grammar() {
        use Token::*;
        let t =
            tokens(b" {\"a\" : [1, -2.5e3, \"x\\\"y\", true, false, null, {}, []], \"b\":{}}\r\n")
                .unwrap();
        assert_eq!(
            &t[..],
            &[
                BeginObject,
                Key(b"a"),
                BeginArray,
                Number(b"1"),
                Number(b"-2.5e3"),
                Str(b"x\\\"y"),
                Bool(true),
                Bool(false),
                Null,
                BeginObject,
                EndObject,
                BeginArray,
                EndArray,
                EndArray,
                Key(b"b"),
                BeginObject,
                EndObject,
                EndObject,
            ]
        );
        assert_eq!(&tokens(b"42").unwrap()[..], &[Number(b"42")]);
        assert_eq!(&tokens(b"\"s\"").unwrap()[..], &[Str(b"s")]);
    }

    #[test]
    fn ignored_bytes_anywhere() {
        use Token::*;
        let t = tokens(b"\0{\"k\n\":\t1\n2, \"s\":\"0.\t5\", \"b\":tr\nue}\0").unwrap();
        assert_eq!(
            &t[..],
            &[
                BeginObject,
                Key(b"k\n"),
                Number(b"1\n2"),
                Key(b"s"),
                Str(b"0.\t5"),
                Key(b"b"),
                Bool(true),
                EndObject
            ]
        );
        assert!(significant(b"1\n2").eq(*b"12"));
    }

    #[test]
    fn trailing_commas_are_tolerated_but_not_empty_elements() {
        assert!(tokens(b"{\"a\":[1,],}").is_ok());
        assert_eq!(err(b"[,]").kind, JsonErrorKind::UnexpectedByte(b','));
        assert_eq!(err(b"[1,,2]").kind, JsonErrorKind::UnexpectedByte(b','));
        assert_eq!(err(b"{,}").kind, JsonErrorKind::UnexpectedByte(b','));
    }

    #[test]
    fn structure_errors_with_offsets() {
        assert_eq!(
            err(b""),
            JsonError {
                offset: 0,
                kind: JsonErrorKind::UnexpectedEnd
            }
        );
        assert_eq!(
            err(b"{\"a\":1"),
            JsonError {
                offset: 6,
                kind: JsonErrorKind::UnexpectedEnd
            }
        );
        assert_eq!(err(b"{\"a\" 1}").kind, JsonErrorKind::UnexpectedByte(b'1'));
        assert_eq!(err(b"{1:2}").kind, JsonErrorKind::UnexpectedByte(b'1'));
        assert_eq!(err(b"[1}").kind, JsonErrorKind::UnexpectedByte(b'}'));
        assert_eq!(err(b"{\"a\":1]").kind, JsonErrorKind::UnexpectedByte(b']'));
        assert_eq!(err(b"{} {}").offset, 3);
        assert_eq!(err(b"[1 2]").kind, JsonErrorKind::UnexpectedByte(b'2'));
        assert_eq!(err(b"\"abc").kind, JsonErrorKind::UnexpectedEnd);
        assert_eq!(err(b"\"a\\q\"").kind, JsonErrorKind::BadEscape);
        assert_eq!(err(b"\"\\u12g4\"").kind, JsonErrorKind::BadEscape);
        assert!(tokens(b"\"\\u12aF\\n\"").is_ok());
        assert_eq!(err(b"[tru]").kind, JsonErrorKind::BadLiteral);
        assert_eq!(err(b"[nul").kind, JsonErrorKind::UnexpectedEnd);
        assert_eq!(err(b"[truex]").kind, JsonErrorKind::UnexpectedByte(b'x'));
        for bad in [
            &b"-"[..],
            b"1.",
            b"1e",
            b"1e+",
            b"--1",
            b"1.2.3",
            b"1-2",
            b".5",
        ] {
            let mut input = heapless::Vec::<u8, 16>::new();
            input.push(b'[').unwrap();
            input.extend_from_slice(bad).unwrap();
            input.push(b']').unwrap();
            assert!(tokens(&input).is_err(), "{bad:?}");
        }
        assert!(tokens(b"[007, -0.000, 1E+2, 2e-5]").is_ok());
    }

    #[test]
    fn depth_is_bounded_and_errors_are_sticky() {
        let deep = [b'['; MAX_DEPTH + 1];
        let e = err(&deep);
        assert_eq!(
            e,
            JsonError {
                offset: MAX_DEPTH,
                kind: JsonErrorKind::TooDeep
            }
        );
        let mut ok = heapless::Vec::<u8, 64>::new();
        ok.extend_from_slice(&[b'['; MAX_DEPTH]).unwrap();
        ok.extend_from_slice(&[b']'; MAX_DEPTH]).unwrap();
        assert!(tokens(&ok).is_ok());
        let mut t = Tokenizer::new(b"[}");
        t.next_token().unwrap();
        let e = t.next_token().unwrap_err();
        assert_eq!(t.next_token(), Err(e));
    }

    #[test]
    fn skip_container_stops_at_its_own_end() {
        let mut t = Tokenizer::new(b"{\"x\":{\"y\":[1,{\"z\":[]}],\"w\":2},\"after\":3}");
        assert_eq!(t.next_token(), Ok(Some(Token::BeginObject)));
        assert_eq!(t.next_token(), Ok(Some(Token::Key(b"x"))));
        assert_eq!(t.next_token(), Ok(Some(Token::BeginObject)));
        t.skip_container().unwrap();
        assert_eq!(t.depth(), 1);
        assert_eq!(t.next_token(), Ok(Some(Token::Key(b"after"))));
        assert_eq!(t.offset(), 30);
        let mut t = Tokenizer::new(b"[[1,2");
        t.next_token().unwrap();
        t.next_token().unwrap();
        assert_eq!(
            t.skip_container().unwrap_err().kind,
            JsonErrorKind::UnexpectedEnd
        );
    }

    #[test]
    fn writer_output_tokenizes_back() {
        let mut buf = [0u8; 128];
        let mut w = Writer::new(&mut buf);
        w.begin_object();
        w.key("a");
        w.begin_array();
        w.decimal(&Decimal::parse("-0.000").unwrap(), true);
        w.decimal(&Decimal::parse("48.00").unwrap(), false);
        w.end_array();
        w.key("b");
        w.begin_object();
        w.key("c");
        w.int(-7);
        w.key("d");
        w.uint(u64::MAX);
        w.end_object();
        w.end_object();
        let n = w.finish().unwrap();
        assert_eq!(
            &buf[..n],
            b"{\"a\":[\"-0.000\",48.00],\"b\":{\"c\":-7,\"d\":18446744073709551615}}"
        );
        assert!(tokens(&buf[..n]).is_ok());
        let mut small = [0u8; 4];
        let mut w = Writer::new(&mut small);
        w.begin_object();
        w.key("abc");
        assert_eq!(w.finish(), Err(EncodeError::BufferTooSmall));
    }
}
