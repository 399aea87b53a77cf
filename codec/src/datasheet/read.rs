//! The reader behind [`DataSheet::parse`]: one pass over the payload's
//! bytes, on every target.
//!
//! It reads the JSON the [`Tokenizer`] defines (its module documents the
//! grammar and the tolerances: ignored NUL/`\n`/`\t` bytes everywhere,
//! trailing commas, leading zeros) and drives the sheet's fields through
//! the [`Member`] calls their table defines, but as a recursive descent
//! over bytes rather than token by token: where it is in the grammar is
//! where it is in the code, not a state to dispatch on, and the forms
//! controllers send take short cuts that give the same result:
//!
//! * keys are first compared with the name the vendor's layout has next
//!   (the next group at the top level, the next field in a group); only
//!   another key is looked up in the name table ([`super::names`]);
//! * a plain number (`-?digits(.digits)?`, bare or the whole of a string)
//!   is read to its value in the pass that finds its end, by the crate's
//!   number reader ([`plain_prefix`]); any other number or string is
//!   converted as the field's table says ([`decimal_of`]).
//!
//! Errors are the tokenizer's and the fields': the same kinds at the same
//! offsets, first error first, as reading the tokenizer's tokens in order
//! would give. The tests below keep that reference reader (tokens in, the
//! same [`Member`] calls out) and compare both, results and errors, on
//! every sample, every cut and mutation of the vendor's layout, and
//! `host-tests/tests/datasheet.rs` on random payloads.
//!
//! Why not the tokenizer itself: its state machine, a call per token, and
//! values found as text and converted afterwards cost about four times as
//! much on the standby sample as the deframer delivers it (5.6 µs against
//! 1.4 µs on the build machine), which the benchmark's goal cannot afford;
//! and two readers (a fast one for hosts that gave up to the tokenizer's,
//! which boards ran alone) meant the hosts' tests ran another path than
//! the boards.
//!
//! What was measured on the way (same machine, the sample with its
//! whitespace): a plain number's value given back in registers
//! ([`Reader::plain`]) rather than in a `Result` in memory, which the
//! processor had to wait for, 2.8 to 1.9 µs; then lists read whole into
//! [`Reader::list`] and handed over in one [`Member::list`] call rather
//! than a call per element, 1.9 to 1.5 µs.
//! Then the forms most values take read in straight code
//! ([`common_form`]: a bare digit, `d.dd`/`dd.dd` bare, `"-ddd.ddd"`
//! quoted) rather than a digit per step: the benchmark's ratio to the
//! naive baseline from 5.4-5.5x to 5.8-6.0x in the same runs.
//! Tried and dropped as no faster: a byte set instead of the `match` in
//! `is_number_byte`, a hand-written loop for whole lists, the `:` taken
//! with a predicted key; digit runs read eight bytes at a time (SWAR:
//! slower, 2.5 to 3.3 µs, each value's end then waits for the arithmetic
//! where a predicted loop runs ahead); one form of one to three digits and
//! decimals for bare and quoted values alike (no faster than the loop);
//! the sheet built in the return slot (the compiler copies it anyway).
//!
//! [`DataSheet::parse`]: super::DataSheet::parse
//! [`Tokenizer`]: super::json::Tokenizer

use super::deframer::is_stripped;
use super::json::{is_space, JsonError, JsonErrorKind, Token, MAX_DEPTH};
use super::scan;
use super::sheet::{
    decimal_of, DataSheet, DataSheetError, Member, ReadField, Value, GROUP_NAMES, MAX_LIST, NAMES,
    READ, READ_NAMES,
};
use crate::number::{plain_prefix, Decimal};

type Result<T> = core::result::Result<T, DataSheetError>;

/// Decodes a payload: see the module documentation.
pub(super) fn parse(payload: &[u8]) -> Result<DataSheet> {
    // One sheet, returned from one place: built where the caller gets it.
    let mut ds = DataSheet::default();
    let mut r = Reader {
        input: payload,
        pos: 0,
        next_group: 0,
        next_field: 0,
        list: [Decimal::ZERO; MAX_LIST],
    };
    match r.first()? {
        b'{' => {
            r.pos += 1;
            r.object(&mut ds, 1)?;
        }
        b => {
            // A valid first token that is no object, or the error it has.
            r.scalar_token(b, 0)?;
            return Err(DataSheetError::NotAnObject);
        }
    }
    // Only whitespace may follow.
    match r.skip_space() {
        None => Ok(ds),
        Some(b) => Err(r.unexpected(b)),
    }
}

/// The field a key names, if any, and whether it names a group.
fn lookup(key: &[u8]) -> (Option<usize>, bool) {
    let found = NAMES.find(key);
    (found.field, found.group.is_some())
}

/// Field `i` of the table.
fn field(i: Option<usize>) -> Option<(ReadField, &'static str)> {
    let i = i?;
    Some((*READ.get(i)?, *READ_NAMES.get(i)?))
}

/// `a == b`, for the lengths of names: eight bytes at a time (the last
/// eight overlapping the ones before), without a call to `memcmp`.
#[inline]
fn same(a: &[u8], b: &[u8]) -> bool {
    let n = a.len();
    if n != b.len() {
        return false;
    }
    if n < 8 {
        return a.iter().zip(b).all(|(x, y)| x == y);
    }
    let word = |s: &[u8], at: usize| {
        let mut w = [0u8; 8];
        w.copy_from_slice(s.get(at..at + 8).unwrap_or(&[0; 8]));
        u64::from_le_bytes(w)
    };
    let mut at = 0;
    while at + 8 < n {
        if word(a, at) != word(b, at) {
            return false;
        }
        at += 8;
    }
    word(a, n - 8) == word(b, n - 8)
}

/// A byte that can be part of a number (ignored ones included): where the
/// tokenizer's number token ends.
#[inline]
fn is_number_byte(b: u8) -> bool {
    b.is_ascii_digit() || matches!(b, b'-' | b'+' | b'.' | b'e' | b'E') || is_stripped(b)
}

/// `-? digits (. digits)? ([eE] [+-]? digits)?`, leading zeros allowed,
/// over the significant bytes of a number token.
fn is_json_number(raw: &[u8]) -> bool {
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
    for &b in raw.iter().filter(|&&b| !is_stripped(b)) {
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

/// The bytes [`common_form`] looks at: the longest form it reads,
/// `"-999.999"` after the opening quote, with the byte after it.
const WINDOW: usize = 10;

/// The digit `w[i]` stands for, if it is one.
#[inline(always)]
fn digit_at(w: &[u8; WINDOW], i: usize) -> Option<u64> {
    let d = w.get(i)?.wrapping_sub(b'0');
    (d <= 9).then_some(u64::from(d))
}

/// The two forms most of a payload's values take, read without a loop:
/// a bare digit followed by `,`, `]` or `}` (`0`, `1`: I/O and states),
/// and a string of one to three integer digits and three decimals
/// (`"-420.000"`, as controllers write positions). The value and the
/// length taken (quotes included), as [`Reader::plain`] reads them the
/// general way; `None` for any other form, or fewer than [`WINDOW`] bytes
/// left, which the general way then reads.
///
/// The general way takes a digit per step (the processor predicting each
/// run's end); here the digits are tested in straight code on a window of
/// fixed size and the value added up from independent products, with
/// about half the instructions.
#[inline(always)]
fn common_form(body: &[u8], quoted: bool) -> Option<(Decimal, usize)> {
    let w: &[u8; WINDOW] = body.get(..WINDOW)?.try_into().ok()?;
    if !quoted {
        let d = digit_at(w, 0)?;
        // The whole token: the byte after it is none of a number's.
        if matches!(w[1], b',' | b']' | b'}') {
            return Some((Decimal::from_parts(false, d, 0)?, 1));
        }
        // `0.00`, `48.12`: one or two digits and two decimals.
        let (int, at) = match digit_at(w, 1) {
            Some(d1) => (d * 10 + d1, 2),
            None => (d, 1),
        };
        let tail: [u8; 4] = w.get(at..at + 4)?.try_into().ok()?;
        let [point, f0, f1, end] = tail;
        let [f0, f1] = [f0, f1].map(|f| f.wrapping_sub(b'0'));
        if point != b'.' || (f0 > 9) | (f1 > 9) || !matches!(end, b',' | b']' | b'}') {
            return None;
        }
        let coeff = int * 100 + u64::from(f0) * 10 + u64::from(f1);
        return Some((Decimal::from_parts(false, coeff, 2)?, at + 3));
    }
    let negative = w[0] == b'-';
    let s = usize::from(negative);
    let d0 = digit_at(w, s)?;
    let (int, k) = match digit_at(w, s + 1) {
        None => (d0, 1),
        Some(d1) => match digit_at(w, s + 2) {
            None => (d0 * 10 + d1, 2),
            Some(d2) if digit_at(w, s + 3).is_none() => (d0 * 100 + d1 * 10 + d2, 3),
            Some(_) => return None,
        },
    };
    let at = s + k;
    let tail: [u8; 5] = w.get(at..at + 5)?.try_into().ok()?;
    let [point, f0, f1, f2, quote] = tail;
    let [f0, f1, f2] = [f0, f1, f2].map(|f| f.wrapping_sub(b'0'));
    if point != b'.' || quote != b'"' || (f0 > 9) | (f1 > 9) | (f2 > 9) {
        return None;
    }
    let frac = u64::from(f0) * 100 + u64::from(f1) * 10 + u64::from(f2);
    // The opening quote, the digits, `.ddd` and the closing quote.
    Some((Decimal::from_parts(negative, int * 1000 + frac, 3)?, at + 6))
}

/// A scalar value: a plain number already read, or a token to convert.
enum Scalar<'a> {
    Number(Decimal),
    Token(Token<'a>),
}

impl<'a> Scalar<'a> {
    fn value(self) -> Value<'a> {
        match self {
            Scalar::Number(d) => Value::Number(d),
            Scalar::Token(t) => Value::Token(t),
        }
    }

    /// The number of a list element, as [`decimal_of`] gives it.
    fn decimal(self) -> core::result::Result<Option<Decimal>, ()> {
        match self {
            Scalar::Number(d) => Ok(Some(d)),
            Scalar::Token(t) => decimal_of(&t),
        }
    }
}

/// The reader's position in the payload, and its guesses of the names that
/// come next.
struct Reader<'a> {
    input: &'a [u8],
    pos: usize,
    /// The group expected next at the top level (an index into
    /// [`GROUP_NAMES`]).
    next_group: usize,
    /// The field expected next inside a group (an index into
    /// [`READ_NAMES`]).
    next_field: usize,
    /// The elements of the list being read.
    list: [Decimal; MAX_LIST],
}

impl<'a> Reader<'a> {
    fn rest(&self) -> &'a [u8] {
        self.input.get(self.pos..).unwrap_or(&[])
    }

    #[cold]
    fn error(&self, offset: usize, kind: JsonErrorKind) -> DataSheetError {
        DataSheetError::Json(JsonError { offset, kind })
    }

    /// The byte under the cursor cannot come here.
    #[cold]
    fn unexpected(&self, b: u8) -> DataSheetError {
        self.error(self.pos, JsonErrorKind::UnexpectedByte(b))
    }

    /// The input ended where more was needed.
    #[cold]
    fn end(&self) -> DataSheetError {
        self.error(self.pos, JsonErrorKind::UnexpectedEnd)
    }

    /// Skips whitespace between tokens; the next byte, `None` at the end.
    #[inline]
    fn skip_space(&mut self) -> Option<u8> {
        loop {
            let b = *self.input.get(self.pos)?;
            if !is_space(b) {
                return Some(b);
            }
            self.pos += 1;
        }
    }

    /// The next byte after whitespace; the end is an error.
    #[inline]
    fn next(&mut self) -> Result<u8> {
        self.skip_space().ok_or_else(|| self.end())
    }

    /// The first byte of the payload's value.
    fn first(&mut self) -> Result<u8> {
        self.next()
    }

    /// Opens the container whose bracket is under the cursor, the
    /// `depth`-th one.
    #[inline]
    fn open(&mut self, depth: usize) -> Result<()> {
        if depth > MAX_DEPTH {
            return Err(self.error(self.pos, JsonErrorKind::TooDeep));
        }
        self.pos += 1;
        Ok(())
    }

    /// After a member or element: `true` at the container's end (`close`,
    /// also after a trailing comma), `false` after a `,` with more to come.
    #[inline]
    fn next_or_end(&mut self, close: u8) -> Result<bool> {
        match self.next()? {
            b',' => {
                self.pos += 1;
                Ok(false)
            }
            b if b == close => {
                self.pos += 1;
                Ok(true)
            }
            b => Err(self.unexpected(b)),
        }
    }

    /// `true` (and the bracket taken) when the next byte closes the
    /// container just opened, or closes it after a trailing comma.
    #[inline]
    fn closes(&mut self, close: u8) -> Result<bool> {
        if self.next()? == close {
            self.pos += 1;
            return Ok(true);
        }
        Ok(false)
    }

    /// A string whose `"` is under the cursor: its raw contents (escapes
    /// checked, not decoded).
    fn string(&mut self) -> Result<&'a [u8]> {
        let start = self.pos + 1;
        let mut i = start;
        loop {
            let rest = self.input.get(i..).unwrap_or(&[]);
            let Some(k) = scan::quote_or_backslash(rest) else {
                return Err(self.error(self.input.len(), JsonErrorKind::UnexpectedEnd));
            };
            i += k;
            if self.input.get(i) == Some(&b'"') {
                break;
            }
            i = self.escape(i)?;
        }
        let s = self.input.get(start..i).unwrap_or(&[]);
        self.pos = i + 1;
        Ok(s)
    }

    /// The significant byte at or after `at`, and where it is.
    fn significant_at(&self, mut at: usize) -> (usize, Option<u8>) {
        while let Some(&b) = self.input.get(at) {
            if !is_stripped(b) {
                return (at, Some(b));
            }
            at += 1;
        }
        (at, None)
    }

    /// Checks the escape whose `\` is at `at`; returns where the string
    /// goes on.
    #[cold]
    fn escape(&self, at: usize) -> Result<usize> {
        let (at, e) = self.significant_at(at + 1);
        let mut i = at + 1;
        match e {
            None => return Err(self.error(at, JsonErrorKind::UnexpectedEnd)),
            Some(b'"' | b'\\' | b'/' | b'b' | b'f' | b'n' | b'r' | b't') => {}
            Some(b'u') => {
                for _ in 0..4 {
                    let (at, h) = self.significant_at(i);
                    match h {
                        Some(h) if h.is_ascii_hexdigit() => i = at + 1,
                        None => return Err(self.error(at, JsonErrorKind::UnexpectedEnd)),
                        Some(_) => return Err(self.error(at, JsonErrorKind::BadEscape)),
                    }
                }
            }
            Some(_) => return Err(self.error(at, JsonErrorKind::BadEscape)),
        }
        Ok(i)
    }

    /// The plain number (`-?digits(.digits)?`) whose first byte `b` is
    /// under the cursor, bare or the whole of a string, read and taken;
    /// `None` (nothing taken) for any other value, which the general way
    /// ([`Reader::scalar_token`]) then reads.
    ///
    /// The common case of every value and element, so on hosts it stays
    /// inline and gives its number in registers, not through a `Result` in
    /// memory; on boards it is not copied, for flash.
    #[cfg_attr(not(target_os = "none"), inline(always))]
    fn plain(&mut self, b: u8) -> Option<Decimal> {
        let quoted = b == b'"';
        let body = self.input.get(self.pos + usize::from(quoted)..)?;
        if let Some((d, len)) = common_form(body, quoted) {
            self.pos += len;
            return Some(d);
        }
        let (d, tail) = plain_prefix(body)?;
        let len = body.len() - tail.len();
        if quoted {
            // The whole string, up to its closing quote.
            if tail.first() != Some(&b'"') {
                return None;
            }
            self.pos += len + 2;
        } else {
            // The whole token only if no number byte follows (an exponent,
            // an ignored byte) and it does not end in a `.` (JSON wants a
            // digit after it): else the general way.
            if tail.first().is_some_and(|&b| is_number_byte(b))
                || body.get(len.wrapping_sub(1)) == Some(&b'.')
            {
                return None;
            }
            self.pos += len;
        }
        Some(d)
    }

    /// A number token in any form, as the tokenizer reads it.
    #[cold]
    fn general_number(&mut self) -> Result<Scalar<'a>> {
        let rest = self.rest();
        let len = rest.iter().take_while(|&&b| is_number_byte(b)).count();
        let raw = rest.get(..len).unwrap_or(&[]);
        if !is_json_number(raw) {
            return Err(self.error(self.pos, JsonErrorKind::BadNumber));
        }
        self.pos += len;
        Ok(Scalar::Token(Token::Number(raw)))
    }

    /// `true`, `false` or `null` under the cursor (ignored bytes allowed
    /// inside).
    fn literal(&mut self, word: &[u8], token: Token<'a>) -> Result<Scalar<'a>> {
        let mut i = self.pos;
        for &want in word {
            let (at, got) = self.significant_at(i);
            if got != Some(want) {
                let kind = match got {
                    None => JsonErrorKind::UnexpectedEnd,
                    Some(_) => JsonErrorKind::BadLiteral,
                };
                return Err(self.error(at, kind));
            }
            i = at + 1;
        }
        self.pos = i;
        Ok(Scalar::Token(token))
    }

    /// A scalar value whose first byte `b` is under the cursor, or the
    /// tokenizer's error for a byte that starts none. A bracket is opened
    /// (the `depth`-th container) and comes back as its token.
    fn scalar_token(&mut self, b: u8, depth: usize) -> Result<Scalar<'a>> {
        if let Some(d) = self.plain(b) {
            return Ok(Scalar::Number(d));
        }
        match b {
            b'"' => self.string().map(|s| Scalar::Token(Token::Str(s))),
            b'-' | b'0'..=b'9' => self.general_number(),
            b't' => self.literal(b"true", Token::Bool(true)),
            b'f' => self.literal(b"false", Token::Bool(false)),
            b'n' => self.literal(b"null", Token::Null),
            b'{' => {
                self.open(depth + 1)?;
                Ok(Scalar::Token(Token::BeginObject))
            }
            b'[' => {
                self.open(depth + 1)?;
                Ok(Scalar::Token(Token::BeginArray))
            }
            _ => Err(self.unexpected(b)),
        }
    }

    /// The members of an object whose `{` was taken, the `depth`-th
    /// container, up to its `}`.
    fn object(&mut self, ds: &mut DataSheet, depth: usize) -> Result<()> {
        loop {
            match self.next()? {
                b'"' => {}
                b'}' => {
                    self.pos += 1;
                    return Ok(());
                }
                b => return Err(self.unexpected(b)),
            }
            let (raw, predicted) = self.key(depth)?;
            match self.next()? {
                b':' => self.pos += 1,
                b => return Err(self.unexpected(b)),
            }
            let b = self.next()?;
            let object = b == b'{';
            // The predicted name with the kind of value it has in the
            // vendor's layout (an object for a group, anything else for a
            // field) is known; any other case, a name both kinds share
            // (`FTData`) among them, is looked up.
            let (field_index, group) = match predicted {
                Some(_) if depth == 1 && object => (None, true),
                Some(next) if depth > 1 && !object => (Some(next), false),
                _ => lookup(raw),
            };
            if object && group {
                self.open(depth + 1)?;
                self.object(ds, depth + 1)?;
                if let Some(next) = predicted.filter(|_| depth == 1) {
                    self.next_group = next + 1;
                }
            } else if let Some((get, name)) = field(field_index) {
                self.member(get(ds), b, depth, name)?;
                self.next_field = field_index.map_or(0, |k| k + 1);
            } else if matches!(b, b'{' | b'[') {
                self.open(depth + 1)?;
                self.skip(b, depth + 1)?;
            } else {
                self.scalar_token(b, depth)?;
            }
            if self.next_or_end(b'}')? || self.closes(b'}')? {
                return Ok(());
            }
        }
    }

    /// A member's key, whose `"` is under the cursor: its raw text, and
    /// whether it is the name the vendor's layout has next (the next group
    /// at the top level, the next field in a group), as that name's index.
    ///
    /// Controllers send the members in the table's order and spelling, so
    /// that name is tried first, by a plain comparison; only another key
    /// needs the name table. A key equal to the expected name is that name
    /// either way.
    #[inline]
    fn key(&mut self, depth: usize) -> Result<(&'a [u8], Option<usize>)> {
        let (names, next) = if depth == 1 {
            (GROUP_NAMES, self.next_group)
        } else {
            (READ_NAMES, self.next_field)
        };
        let guess = names.get(next).map_or(&b""[..], |n| n.as_bytes());
        let body = self.input.get(self.pos + 1..).unwrap_or(&[]);
        if !guess.is_empty()
            && body.get(guess.len()) == Some(&b'"')
            && body.get(..guess.len()).is_some_and(|k| same(k, guess))
        {
            self.pos += guess.len() + 2;
            return Ok((guess, Some(next)));
        }
        Ok((self.string()?, None))
    }

    /// A field's value, whose first byte `b` is under the cursor.
    fn member(
        &mut self,
        m: &mut dyn Member,
        b: u8,
        depth: usize,
        field: &'static str,
    ) -> Result<()> {
        // Field errors point at the last token taken: the value, the
        // element, or the `]` for a list of the wrong length.
        let at = |offset, expected| DataSheetError::Field {
            field,
            expected,
            offset,
        };
        let start = self.pos;
        if b != b'[' {
            let v = match self.plain(b) {
                Some(d) => Value::Number(d),
                None => self.scalar_token(b, depth)?.value(),
            };
            return m.set(v).map_err(|e| at(start, e));
        }
        self.open(depth + 1)?;
        let first = self.pos;
        if let Some(n) = self.plain_list() {
            if m.list(self.list.get(..n).unwrap_or(&[])).is_ok() {
                return Ok(());
            }
        }
        // Another form or a field error: element by element.
        self.pos = first;
        m.begin().map_err(|e| at(start, e))?;
        let mut n = 0;
        loop {
            let b = self.next()?;
            let element = self.pos;
            if b == b']' {
                self.pos += 1;
                return m.end(n).map_err(|e| at(element, e));
            }
            // A nested array or object is opened and refused here (it is
            // no number), as the tokenizer's token would be.
            let d = match self.plain(b) {
                Some(d) => d,
                None => match self.scalar_token(b, depth + 1)?.decimal() {
                    Ok(Some(d)) => d,
                    Ok(None) | Err(()) => return Err(at(element, m.expected())),
                },
            };
            m.push(n, d).map_err(|e| at(element, e))?;
            n += 1;
            match self.next()? {
                b',' => self.pos += 1,
                b']' => {
                    let end = self.pos;
                    self.pos += 1;
                    return m.end(n).map_err(|e| at(end, e));
                }
                b => return Err(self.unexpected(b)),
            }
        }
    }

    /// The elements of a list whose `[` was taken, when all are plain
    /// numbers (at most [`MAX_LIST`]): how many, in [`Reader::list`], the
    /// list taken up to its `]`; `None` otherwise, with the cursor anywhere
    /// in the list.
    #[inline]
    fn plain_list(&mut self) -> Option<usize> {
        let mut n = 0;
        loop {
            let b = self.skip_space()?;
            if b == b']' {
                self.pos += 1;
                return Some(n);
            }
            let d = self.plain(b)?;
            *self.list.get_mut(n)? = d;
            n += 1;
            match self.skip_space()? {
                b',' => self.pos += 1,
                b']' => {
                    self.pos += 1;
                    return Some(n);
                }
                _ => return None,
            }
        }
    }

    /// Passes over the rest of the container whose bracket `open` was
    /// taken, the `depth`-th container, checking it.
    fn skip(&mut self, open: u8, depth: usize) -> Result<()> {
        let close = if open == b'{' { b'}' } else { b']' };
        if self.closes(close)? {
            return Ok(());
        }
        loop {
            if open == b'{' {
                match self.next()? {
                    b'"' => {
                        self.string()?;
                    }
                    b => return Err(self.unexpected(b)),
                }
                match self.next()? {
                    b':' => self.pos += 1,
                    b => return Err(self.unexpected(b)),
                }
            }
            let b = self.next()?;
            if matches!(b, b'{' | b'[') {
                self.open(depth + 1)?;
                self.skip(b, depth + 1)?;
            } else {
                self.scalar_token(b, depth)?;
            }
            if self.next_or_end(close)? || self.closes(close)? {
                return Ok(());
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::fmt::Write;

    /// The reference reader: the tokenizer's tokens in order, each member
    /// driven through the same [`Member`] calls. What [`parse`] must give,
    /// results and errors alike.
    mod reference {
        use super::super::*;
        use crate::datasheet::json::Tokenizer;
        use crate::datasheet::sheet::FieldExpected;

        pub(super) fn parse(payload: &[u8]) -> Result<DataSheet> {
            let mut ds = DataSheet::default();
            let mut t = Tokenizer::new(payload);
            if !matches!(t.next_token()?, Some(Token::BeginObject)) {
                return Err(DataSheetError::NotAnObject);
            }
            object(&mut t, &mut ds)?;
            t.next_token()?;
            Ok(ds)
        }

        fn object(t: &mut Tokenizer<'_>, ds: &mut DataSheet) -> Result<()> {
            loop {
                let key = match t.next_token()? {
                    Some(Token::Key(k)) => k,
                    _ => return Ok(()),
                };
                let Some(value) = t.next_token()? else {
                    return Err(DataSheetError::Json(JsonError {
                        offset: t.offset(),
                        kind: JsonErrorKind::UnexpectedEnd,
                    }));
                };
                let (field_index, group) = lookup(key);
                if matches!(value, Token::BeginObject) && group {
                    object(t, ds)?;
                } else if let Some((get, name)) = field(field_index) {
                    member(get(ds), value, t, name)?;
                } else if matches!(value, Token::BeginObject | Token::BeginArray) {
                    t.skip_container()?;
                }
            }
        }

        fn member(
            m: &mut dyn Member,
            first: Token<'_>,
            t: &mut Tokenizer<'_>,
            field: &'static str,
        ) -> Result<()> {
            let at = |t: &Tokenizer<'_>, expected| DataSheetError::Field {
                field,
                expected,
                offset: t.offset(),
            };
            if !matches!(first, Token::BeginArray) {
                return m.set(Value::Token(first)).map_err(|e| at(t, e));
            }
            m.begin().map_err(|e| at(t, e))?;
            let mut n = 0;
            loop {
                match t.next_token()? {
                    Some(Token::EndArray) => break,
                    Some(token) => match decimal_of(&token) {
                        Ok(Some(d)) => m.push(n, d).map_err(|e| at(t, e))?,
                        Ok(None) | Err(()) => return Err(at(t, m.expected())),
                    },
                    None => return Err(at(t, FieldExpected::List)),
                }
                n += 1;
            }
            m.end(n).map_err(|e| at(t, e))
        }
    }

    type Text = heapless::String<8192>;

    /// A result's exact contents: `Debug` prints each decimal as written
    /// (`-0.000`, not `0`), which `==` does not compare.
    fn exact(r: &Result<DataSheet>) -> Text {
        let mut s = Text::new();
        write!(s, "{r:?}").unwrap();
        s
    }

    /// The reader and the reference give the same result or error.
    fn agree(payload: &[u8]) {
        assert_eq!(
            exact(&parse(payload)),
            exact(&reference::parse(payload)),
            "{:?}",
            core::str::from_utf8(payload)
        );
    }

    /// The vendor's layout in short: groups, quoted and bare decimals,
    /// integer lists, skipped members, tab/newline indentation.
    const SAMPLE: &[u8] = b"{\n\t\"PosAndVel\":{\n\t\t\"Actual_Position\":[\"0.000\",\"-0.000\",\
\"90.000\",\"0.000\",\"90.000\",\"0.000\",\"420.000\",\"0.000\",\"445.000\",\"180.000\",\
\"-0.000\",\"180.000\"],\n\t\t\"Actual_Override\":\"0.500\"\n\t},\n\t\"EndIO\":{\"EndDI\":[0,0,1,0],\
\"EndAI\":[0.00,12.50]},\"StateAndError\":{\"robotState\":33,\"robotMoving\":0,\
\"BrakeState\":[1,1,1,1,1,1],\"nResetSafeSpace\":[1]},\"HardLoad\":{\"EtherCAT_TotalFrame\":48211972,\
\"Box48IN_Voltage\":48.12,\"Slave_Voltage\":[47.90,47.88]},\"Script\":{\"errorCode\":0,\
\"cmdid\":[\"\",\"\"],\"GlobalVar\":[]},\"pluginsdata\":{\"g\":{\"on\":true,\"p\":\"1.5\",\
\"s\":[0,1,null,false]}}\n}";

    #[test]
    fn same_is_equality() {
        let text = b"Actual_Joint_Acceleration_and_more_bytes";
        for len in 0..text.len() {
            let a = &text[..len];
            assert!(same(a, a));
            assert!(!same(a, &text[..len + 1]));
            for at in 0..len {
                let mut b = [0u8; 64];
                b[..len].copy_from_slice(a);
                b[at] ^= 0x20;
                assert!(!same(a, &b[..len]), "{len} {at}");
            }
        }
    }

    /// Where [`common_form`] reads a value, it is the value and length the
    /// general way ([`plain_prefix`] and the checks of [`Reader::plain`])
    /// gives: every string of up to six bytes over the bytes that matter,
    /// bare and quoted, followed by bytes that end a value.
    #[test]
    fn common_forms_read_as_the_general_way() {
        const ALPHABET: &[u8] = b"-019.\",]} e";
        let mut read = 0;
        let mut body = [0u8; 16];
        for len in 1..=6u32 {
            for mut code in 0..ALPHABET.len().pow(len) {
                for slot in body.iter_mut().take(len as usize) {
                    *slot = ALPHABET[code % ALPHABET.len()];
                    code /= ALPHABET.len();
                }
                for (i, slot) in body.iter_mut().enumerate().skip(len as usize) {
                    *slot = b",]}\""[i % 4];
                }
                for quoted in [false, true] {
                    let Some((d, taken)) = common_form(&body, quoted) else {
                        continue;
                    };
                    read += 1;
                    let (g, tail) = plain_prefix(&body).unwrap();
                    let n = body.len() - tail.len();
                    if quoted {
                        assert_eq!(tail.first(), Some(&b'"'), "{body:?}");
                        assert_eq!(taken, n + 2, "{body:?}");
                    } else {
                        assert!(!is_number_byte(tail[0]) && body[n - 1] != b'.');
                        assert_eq!(taken, n, "{body:?}");
                    }
                    assert!(d.is_identical(&g), "{body:?}: {d} {g}");
                }
            }
        }
        // Bare digits, `d.dd`, `dd.dd` and the quoted `d.ddd` forms at least.
        assert!(read > 1000, "{read}");
    }

    #[test]
    fn the_vendor_layout() {
        agree(SAMPLE);
        let ds = parse(SAMPLE).unwrap();
        assert_eq!(ds.state.robot_state, Some(crate::FsmState::StandBy));
    }

    #[test]
    fn every_form_as_the_reference_reads_it() {
        let cases: &[&[u8]] = &[
            br#"{}"#,
            br#" { } "#,
            br#"{"robotState":33,"robotMoving":"1","InPos":true,"robotPaused":null}"#,
            br#"{"StateAndError":{"robotState":"33","Error_Code":-0},"x":[[],{}],}"#,
            br#"{"Actual_PCS_TCP":["-0.000","1.50",2,3e0,4,5]}"#,
            br#"{"Actual_PCS_TCP":["-0.000","1.50",2,3,4,5,]}"#,
            br#"{"Actual_Position":[1,2,3,4,5,6]}"#,
            br#"{"Actual_Position":[1,2,3,4,5,6,7,8,9,10,11,12]}"#,
            br#"{"Actual_Position":[1,2,3,4,5,6,7]}"#,
            br#"{"Actual_Position":[1,2,3,4,5,6,7,8,9,10,11,12,13,14,15,16,17,18]}"#,
            br#"{"Actual_Position":null,"BoxDI":null,"EndAI":[]}"#,
            br#"{"BoxDI":[1,0,1],"BoxDI":[0]}"#,
            br#"{"EndAI":[1,2,3,4,5]}"#,
            br#"{"EndAI":[1,2,3,x]}"#,
            br#"{"EndAI":[1,[2],3]}"#,
            br#"{"EndAI":[1,{"a":2},3]}"#,
            br#"{"EndAI":[1,,2]}"#,
            br#"{"EndAI":[,]}"#,
            br#"{"robotState":1.5}"#,
            br#"{"robotState":[1]}"#,
            br#"{"robotState":{}}"#,
            br#"{"robotState":{"a":1}}"#,
            br#"{"Box48OUT_Voltage":"48.00","box48in voltage":" 1 "}"#,
            br#"{"robotState":5.}"#,
            br#"{"robotState":"5."}"#,
            br#"{"robotState":1e2}"#,
            br#"{"robotState":12345678901234567890}"#,
            br#"{"EtherCAT_TotalFrame":18446744073709551615}"#,
            br#"{"EtherCAT_TotalFrame":1844674407370955161}"#,
            br#"{"a\"b":1,"robotState":2}"#,
            br#"{"robotState":"\u0033"}"#,
            br#"{"robotState":"\x"}"#,
            br#"{"robotState":tru}"#,
            br#"{"robotState":1 2}"#,
            br#"{"robotState":01}"#,
            br#"{"robotState":-}"#,
            br#"{"robotState":1}x"#,
            br#"{"robotState":1,,"x":2}"#,
            br#"{,}"#,
            br#"{"a" 1}"#,
            br#"{"a":}"#,
            br#"{"a":1]"#,
            br#"[1]"#,
            br#"1x"#,
            br#""a"x"#,
            br#"x"#,
            br#""#,
            br#"{"#,
            br#"{"a":[1,2"#,
            br#"{"a":"#,
            br#"{"a"#,
            b"{\"robotState\":3\n3}",
            b"{\"robotState\":33\n}",
            b"{\"robot\tState\":33}",
            b"{\"robotState\":tr\nue}",
            b"\0{\"robotState\" :\t33 , }\0",
            br#"{"PosAndVel":{"EndIO":{"EndDI":[1,0]}},"FTData":{"FTData":[0,0,0,0,0,1]}}"#,
            br#"{"FTData":[0,0,0,0,0,1]}"#,
            br#"{"FTData":{"FTData":{"x":1}}}"#,
            br#"{"StateAndError":{"PosAndVel":{"robotState":2}}}"#,
            br#"{"StateAndError":{"robotState":2},"StateAndError":{"robotState":3}}"#,
        ];
        for case in cases {
            agree(case);
        }
        // Nesting at and past the limit, known and unknown, in lists too.
        for deep in [MAX_DEPTH - 2, MAX_DEPTH - 1, MAX_DEPTH, MAX_DEPTH + 1] {
            let mut p = heapless::Vec::<u8, 512>::new();
            for _ in 0..deep {
                p.extend_from_slice(b"{\"PosAndVel\":").unwrap();
            }
            p.extend_from_slice(b"{\"robotState\":[1]").unwrap();
            for _ in 0..=deep {
                p.push(b'}').unwrap();
            }
            agree(&p);
            for open in [b'[', b'{'] {
                let mut q = heapless::Vec::<u8, 512>::new();
                q.extend_from_slice(b"{\"x\":").unwrap();
                for _ in 0..deep {
                    q.push(open).unwrap();
                    if open == b'{' {
                        q.extend_from_slice(b"\"k\":").unwrap();
                    }
                }
                q.push(b'1').unwrap();
                for _ in 0..deep {
                    q.push(if open == b'[' { b']' } else { b'}' }).unwrap();
                }
                q.push(b'}').unwrap();
                agree(&q);
            }
            let mut l = heapless::Vec::<u8, 512>::new();
            l.extend_from_slice(b"{\"EndAI\":").unwrap();
            for _ in 0..deep {
                l.push(b'[').unwrap();
            }
            agree(&l);
        }
    }

    /// Every prefix of the sample, and the sample with each byte changed
    /// to one that matters to the grammar.
    #[test]
    fn agree_on_cut_and_mutated_samples() {
        for cut in 0..SAMPLE.len() {
            agree(&SAMPLE[..cut]);
        }
        let mut buf = [0u8; 1024];
        let buf = &mut buf[..SAMPLE.len()];
        for at in 0..SAMPLE.len() {
            for b in [
                b'"', b',', b':', b'[', b']', b'{', b'}', b'.', b'-', b'1', b' ', b'\\', 0, b'\n',
                b'e', b't', b'n',
            ] {
                buf.copy_from_slice(SAMPLE);
                buf[at] = b;
                agree(buf);
            }
        }
    }

    /// The sample and written sheets with random edits: insertions,
    /// deletions and replacements from the bytes the grammar tells apart.
    #[test]
    fn agree_on_randomly_edited_payloads() {
        const ALPHABET: &[u8] = b"\"{}[]:,.-+eE0123456789 \n\t\0\\truefalsnl_xA";
        let mut seed: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut rand = move |n: usize| {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed % n as u64) as usize
        };
        let mut written = [0u8; 4096];
        let mut sheet = DataSheet::default();
        sheet.state.robot_state = Some(crate::FsmState::StandBy);
        sheet.pos_and_vel.pcs_tcp = Some([Decimal::from_int(-1); 6]);
        let n = sheet.write_json(&mut written).unwrap();
        let sources: [&[u8]; 2] = [SAMPLE, &written[..n]];
        let mut buf = heapless::Vec::<u8, 4096>::new();
        for round in 0..20_000 {
            buf.clear();
            buf.extend_from_slice(sources[round % 2]).unwrap();
            for _ in 0..1 + rand(4) {
                let at = rand(buf.len() + 1);
                let b = ALPHABET[rand(ALPHABET.len())];
                match rand(3) {
                    0 if at < buf.len() => buf[at] = b,
                    1 if at < buf.len() => {
                        buf.remove(at);
                    }
                    _ => {
                        let _ = buf.insert(at, b);
                    }
                }
            }
            agree(&buf);
        }
    }
}
