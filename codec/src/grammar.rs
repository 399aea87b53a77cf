//! The message grammar of chapter 2: `Name,p1,...,pn,;`.
//!
//! Reading is lenient, writing is strict. [`RawMessage::parse`] accepts every
//! variation that controllers, SDKs and the document itself produce:
//!
//! | input | read as |
//! |---|---|
//! | `Name,p1,p2,;` (canonical) | `Name` + `[p1, p2]` |
//! | `OSCmd,1;` (comma missing before `;`) | `OSCmd` + `[1]` |
//! | `ReadBoxCO,OK,0,1,;;` (doubled `;`) | `ReadBoxCO` + `[OK, 0, 1]` |
//! | `SetJointMaxAcc,0,360, 360,;` (spaces) | every field trimmed |
//! | `ReadCIConfig,,;` (empty field) | `ReadCIConfig` + `[""]` |
//! | `Name` or `Name,p1` (no `;`, as a framer body) | same as with `;` |
//!
//! ## The grammar
//!
//! ```text
//! message    = ws name ws ( terminator | "," fields terminator )
//! name       = [A-Za-z0-9_]+
//! fields     = field ( "," field )*
//! field      = [^,]*                  read trimmed of ws
//! terminator = ","? filler* end       the longest such suffix
//! filler     = ws | ";"
//! ws         = " " | "\t" | "\r" | "\n"
//! ```
//!
//! So a `,` followed by nothing but fillers is the trailing comma of
//! `Name,p1,;`, and the last field without a comma ends where only fillers
//! are left (`OSCmd,1;`). Fields are split on `,` only; the protocol has no
//! quoting, so a text field can never contain `,` or `;` (the writer refuses
//! such text).
//!
//! The rules are written with nom's byte-level combinators in `syntax`
//! below (on `&[u8]`, with `()` as the error type, so a failed alternative
//! costs a branch and nothing else; nom's types stay inside this crate).
//! Fields are read one at a time, forward, straight from the message text:
//! nothing is counted, split or copied up front, so a typed reader makes one
//! pass over a message of fixed fields; a list that takes the rest of the
//! message counts that rest once more to check its length. The numbers inside
//! fields have their own grammar in [`crate::number`].
//!
//! The typed readers take plain numbers (`-12.345`, the form controllers
//! reply with) through a fast path in the same pass that finds the field's
//! end; see [`crate::number`] for why that pays and how it is tested
//! against the grammar.

use crate::catalogue::CommandId;
use crate::error::{Expected, Got, ParseError};
use crate::number::{self, Decimal};
use crate::types::Param;

/// The grammar above, in nom combinators over bytes.
pub(crate) mod syntax {
    use nom::bytes::complete::{take_till, take_while};
    use nom::combinator::{eof, opt};
    use nom::{IResult, Parser};

    /// Input of the grammar's parsers.
    pub(crate) type In<'a> = &'a [u8];
    /// A parser's result: no error details, a failed branch is all we need.
    pub(crate) type Res<'a, O> = IResult<In<'a>, O, ()>;

    /// `ws`: whitespace the reader trims around fields and messages.
    #[inline]
    pub(crate) fn is_space(b: u8) -> bool {
        matches!(b, b' ' | b'\t' | b'\r' | b'\n')
    }

    /// `filler`: what may follow the last field.
    #[inline]
    pub(crate) fn is_filler(b: u8) -> bool {
        is_space(b) || b == b';'
    }

    /// `A-Z a-z 0-9 _`, one bit per byte: bytes 0-63, then 64-127 (two
    /// 64-bit masks: a 128-bit shift costs several instructions). The
    /// indexing runs only in the compiler.
    #[allow(clippy::indexing_slicing)]
    const NAME_BYTES: [u64; 2] = {
        let mut m = [0u64; 2];
        let mut b = 0;
        while b < 128 {
            if (b as u8).is_ascii_alphanumeric() || b == b'_' as usize {
                m[b / 64] |= 1 << (b % 64);
            }
            b += 1;
        }
        m
    };

    #[inline]
    fn is_name_byte(b: u8) -> bool {
        match b {
            0..64 => NAME_BYTES[0] >> b & 1 == 1,
            64..128 => NAME_BYTES[1] >> (b - 64) & 1 == 1,
            _ => false,
        }
    }

    /// `ws`.
    #[inline]
    pub(crate) fn ws(i: In<'_>) -> Res<'_, In<'_>> {
        take_while(is_space).parse(i)
    }

    /// `name`, possibly empty (the caller tells an empty message from a bad
    /// name).
    pub(crate) fn name(i: In<'_>) -> Res<'_, In<'_>> {
        take_while(is_name_byte).parse(i)
    }

    /// `field`: the raw text up to the next `,` (or the end).
    #[inline]
    pub(crate) fn field(i: In<'_>) -> Res<'_, In<'_>> {
        take_till(|b| b == b',').parse(i)
    }

    /// `filler* end`.
    pub(crate) fn fillers_to_end(i: In<'_>) -> Res<'_, ()> {
        (take_while(is_filler), eof).map(|_| ()).parse(i)
    }

    /// `","`, as a primitive parser: nom's `char` slices through a method
    /// that is not inlined across crates, which costs a call per comma on
    /// hosts.
    #[inline]
    pub(crate) fn comma(i: In<'_>) -> Res<'_, u8> {
        match i.split_first() {
            Some((&b',', rest)) => Ok((rest, b',')),
            _ => Err(nom::Err::Error(())),
        }
    }

    /// `terminator`.
    pub(crate) fn terminator(i: In<'_>) -> Res<'_, ()> {
        (opt(comma), fillers_to_end).map(|_| ()).parse(i)
    }
}

use syntax::{is_filler, In};

/// `true` for the whitespace of the grammar (`ws`: space, tab, CR, LF): what
/// the reader trims around fields and messages, and what the [`Framer`]
/// skips between messages.
///
/// [`Framer`]: crate::Framer
#[inline]
pub fn is_space(b: u8) -> bool {
    syntax::is_space(b)
}

/// The rest of `text` after the parser left `rest` of it.
#[inline]
fn after<'a>(text: &'a str, rest: In<'_>) -> &'a str {
    // Every parser above stops next to an ASCII byte: a char boundary.
    text.get(text.len().saturating_sub(rest.len())..)
        .unwrap_or("")
}

/// `true` when `b` is nothing but fillers (`filler* end`). The first byte
/// decides in nearly every call, so that test is inline.
#[inline]
fn only_fillers(b: &[u8]) -> bool {
    match b.first() {
        None => true,
        Some(&c) if !is_filler(c) => false,
        Some(_) => syntax::fillers_to_end(b).is_ok(),
    }
}

/// `s` without the whitespace [`is_space`] at its ends.
#[cfg_attr(not(target_os = "none"), inline)]
pub(crate) fn trim(s: &str) -> &str {
    let b = s.as_bytes();
    // Nearly every field has no space at either end.
    match (b.first(), b.last()) {
        (Some(&f), Some(&l)) if is_space(f) || is_space(l) => trim_spaces(s),
        _ => s,
    }
}

fn trim_spaces(s: &str) -> &str {
    let b = s.as_bytes();
    let start = b.iter().position(|&c| !is_space(c)).unwrap_or(b.len());
    let end = b
        .iter()
        .rposition(|&c| !is_space(c))
        .map_or(start, |e| e + 1);
    // Both ends sit next to ASCII bytes, so they are character boundaries.
    s.get(start..end).unwrap_or("")
}

/// `s` without the fillers at its end: the last field without its
/// terminator.
fn strip_terminator(s: &str) -> &str {
    let end = s
        .as_bytes()
        .iter()
        .rposition(|&c| !is_filler(c))
        .map_or(0, |e| e + 1);
    s.get(..end).unwrap_or("")
}

/// Splits a field off a bounded body (no terminator in it): the raw field,
/// and the text after its `,` (`None` when it was the last).
#[inline]
fn split_plain(body: &str) -> (&str, Option<&str>) {
    let (rest, f) = syntax::field(body.as_bytes()).unwrap_or((&[], body.as_bytes()));
    let field = body.get(..f.len()).unwrap_or("");
    match rest.is_empty() {
        true => (field, None),
        false => (field, Some(after(body, rest.get(1..).unwrap_or(&[])))),
    }
}

/// Splits the next field off `rest`, the message text from a field's start
/// to its very end (terminator included): the raw field (for the last one,
/// without the terminator) and the text of the fields after it, `None` when
/// it was the last.
#[inline]
fn split_raw(rest: &str) -> (&str, Option<&str>) {
    match split_plain(rest) {
        (last, None) => (strip_terminator(last), None),
        (field, Some(next)) if only_fillers(next.as_bytes()) => (field, None),
        (field, next) => (field, next),
    }
}

/// The next field of `rest` (as in [`split_raw`]), trimmed.
#[cfg_attr(not(target_os = "none"), inline)]
pub(crate) fn next_field(rest: &str) -> (&str, Option<&str>) {
    let (f, next) = split_raw(rest);
    (trim(f), next)
}

/// The fields' text of `rest` (as in [`split_raw`]) without the terminator,
/// and how many fields there are.
fn bound(rest: &str) -> Result<(&str, u16), GrammarError> {
    let mut count: u16 = 0;
    let mut r = rest;
    loop {
        let (f, next) = split_raw(r);
        count = count.checked_add(1).ok_or(GrammarError::TooManyFields)?;
        match next {
            Some(n) => r = n,
            None => {
                let end = rest.len() - r.len() + f.len();
                return Ok((rest.get(..end).unwrap_or(""), count));
            }
        }
    }
}

/// `ws` skipped: the parser runs only when there is whitespace to skip (a
/// message usually has none, and a parser call is not free on hosts).
#[inline]
fn skip_ws(i: In<'_>) -> In<'_> {
    match i.first() {
        Some(&c) if is_space(c) => syntax::ws(i).map_or(i, |(r, _)| r),
        _ => i,
    }
}

/// Reads `ws name ws` and what follows: the name, and the text of the
/// fields (terminator included) if there are any.
pub(crate) fn head(text: &str) -> Result<(&str, Option<&str>), GrammarError> {
    let b = text.as_bytes();
    let start = skip_ws(b);
    let (rest, name) = syntax::name(start).unwrap_or((start, &[]));
    if name.is_empty() {
        return Err(match syntax::terminator(start) {
            Ok(_) => GrammarError::Empty,
            Err(_) => GrammarError::BadName,
        });
    }
    let name = after(text, start).get(..name.len()).unwrap_or("");
    let rest = skip_ws(rest);
    // `,` then more than fillers: the fields start after it. Anything else
    // must be the terminator.
    if let Ok((fields, _)) = syntax::comma(rest) {
        if !only_fillers(fields) {
            return Ok((name, Some(after(text, fields))));
        }
    }
    match syntax::terminator(rest) {
        Ok(_) => Ok((name, None)),
        Err(_) => Err(GrammarError::BadName),
    }
}

/// What kind of message a line is, judged from its shape alone.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Kind {
    /// A request: `Name,p1,...,;`.
    Request,
    /// A success reply: `Name,OK,...,;`.
    Ok,
    /// A failure reply: `Name,Fail,code,...;`.
    Fail,
    /// The controller's reply to a message it could not parse: `errorcmd,...`.
    ErrorCmd,
}

/// The kind of a message from its name and the first of its fields.
#[inline]
pub(crate) fn kind_of(name: &str, first: Option<&str>) -> Kind {
    if name.eq_ignore_ascii_case("errorcmd") {
        return Kind::ErrorCmd;
    }
    match first {
        Some(f) if f.eq_ignore_ascii_case("OK") => Kind::Ok,
        Some(f) if f.eq_ignore_ascii_case("Fail") => Kind::Fail,
        _ => Kind::Request,
    }
}

/// A message split into its name and fields, borrowed from the input.
///
/// This is the generic view used for unknown command names (newer firmware
/// keeps working), `errorcmd` replies and failure details.
///
/// Two messages are equal when they have the same name and the same fields
/// as read (trimmed): `A, 1 ,;` equals `A,1,;`, as its canonical encoding
/// does.
#[derive(Clone, Copy, Debug)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RawMessage<'a> {
    name: &'a str,
    /// The fields' text after the name: no leading `,`, no terminator.
    body: &'a str,
    count: u16,
}

impl PartialEq for RawMessage<'_> {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name && self.count == other.count && self.fields().eq(other.fields())
    }
}

impl Eq for RawMessage<'_> {}

/// Why a text is not a message at all.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum GrammarError {
    /// Nothing but whitespace and terminators.
    Empty,
    /// The name is empty or has characters other than `A-Z a-z 0-9 _`
    /// (the document's garbled `Pose Trans,...` lands here).
    BadName,
    /// More than 65535 fields.
    TooManyFields,
}

impl<'a> RawMessage<'a> {
    /// A message without name or fields (a placeholder).
    pub(crate) const EMPTY: RawMessage<'static> = RawMessage {
        name: "",
        body: "",
        count: 0,
    };

    /// Splits one message. `text` may carry the terminator (`...,;`) or not
    /// (a body as the framer delivers it), and surrounding whitespace.
    pub fn parse(text: &'a str) -> Result<Self, GrammarError> {
        let (name, rest) = head(text)?;
        Self::from_parts(name, rest)
    }

    /// The message named `name` whose fields' text (terminator included) is
    /// `rest`, as [`head`] and [`next_field`] leave it.
    pub(crate) fn from_parts(name: &'a str, rest: Option<&'a str>) -> Result<Self, GrammarError> {
        let (body, count) = match rest {
            None => ("", 0),
            Some(r) => bound(r)?,
        };
        Ok(RawMessage { name, body, count })
    }

    /// The command name as written.
    pub fn name(&self) -> &'a str {
        self.name
    }

    /// The number of fields after the name.
    pub fn len(&self) -> usize {
        usize::from(self.count)
    }

    /// `true` when there are no fields after the name.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The fields after the name, each trimmed.
    pub fn fields(&self) -> Fields<'a> {
        Fields {
            rest: if self.count == 0 {
                None
            } else {
                Some(self.body)
            },
        }
    }

    /// The fields' text after the name, untrimmed, without terminator.
    pub fn body(&self) -> &'a str {
        self.body
    }

    /// The kind of message, from its shape: `errorcmd` as name, `OK` or
    /// `Fail` (any letter case) as first field, else a request.
    pub fn kind(&self) -> Kind {
        kind_of(self.name, self.fields().next())
    }
}

/// Iterator over trimmed fields of a message.
#[derive(Clone, Debug)]
pub struct Fields<'a> {
    rest: Option<&'a str>,
}

impl<'a> Fields<'a> {
    /// The fields of `text` (a part of a message body: `a,b,c`).
    pub(crate) fn of(text: &'a str) -> Self {
        Fields { rest: Some(text) }
    }
}

impl<'a> Iterator for Fields<'a> {
    type Item = &'a str;
    fn next(&mut self) -> Option<&'a str> {
        let (f, rest) = split_plain(self.rest?);
        self.rest = rest;
        Some(trim(f))
    }
}

/// Where a [`Cursor`] reads its fields from.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Source<'s, 'a> {
    /// The message text from the next field to the end, terminator
    /// included; `None` when no field is left.
    Text(Option<&'a str>),
    /// Fields already split and reordered by a quirk handler.
    Slice(&'s [&'a str]),
}

/// Reads the fields of one message in order, for the typed parsers.
#[derive(Clone, Debug)]
pub struct Cursor<'s, 'a> {
    src: Source<'s, 'a>,
    pos: u16,
    command: CommandId,
    /// In a reply: how many values a list must have, from the request.
    list_len: Option<u16>,
    /// The first error met; later reads return defaults and are ignored.
    err: Option<ParseError<'a>>,
}

impl<'s, 'a> Cursor<'s, 'a> {
    /// A cursor on the fields' text `rest` (terminator included), as
    /// [`head`] and [`next_field`] leave it.
    #[inline]
    pub(crate) fn new(rest: Option<&'a str>, command: CommandId) -> Self {
        Cursor {
            src: Source::Text(rest),
            pos: 0,
            command,
            list_len: None,
            err: None,
        }
    }

    pub(crate) fn from_slice(fields: &'s [&'a str], command: CommandId) -> Self {
        Cursor {
            src: Source::Slice(fields),
            pos: 0,
            command,
            list_len: None,
            err: None,
        }
    }

    #[inline]
    pub(crate) fn with_list_len(mut self, n: Option<u16>) -> Self {
        self.list_len = n;
        self
    }

    /// In a reply, how many values its list must have (from the request).
    pub fn expected_len(&self) -> Option<u16> {
        self.list_len
    }

    /// The command being parsed.
    pub fn command(&self) -> CommandId {
        self.command
    }

    /// Fields not yet read (counted on each call: it walks them; `u16::MAX`
    /// for more than that, which every list reader then refuses).
    pub fn remaining(&self) -> u16 {
        match self.src {
            Source::Text(None) => 0,
            Source::Text(Some(r)) => bound(r).map_or(u16::MAX, |(_, n)| n),
            Source::Slice(s) => u16::try_from(s.len()).unwrap_or(u16::MAX),
        }
    }

    /// `true` when every field has been read.
    #[inline]
    pub fn at_end(&self) -> bool {
        match self.src {
            Source::Text(r) => r.is_none(),
            Source::Slice(s) => s.is_empty(),
        }
    }

    /// Index of the next field (0 = first after the name).
    pub fn position(&self) -> u16 {
        self.pos
    }

    /// The next field, trimmed, or `None` at the end.
    #[cfg_attr(not(target_os = "none"), inline)]
    pub fn next_field(&mut self) -> Option<&'a str> {
        let f = match &mut self.src {
            Source::Text(rest) => {
                let (f, tail) = next_field((*rest)?);
                *rest = tail;
                f
            }
            Source::Slice(s) => {
                let (first, tail) = s.split_first()?;
                *s = tail;
                trim(first)
            }
        };
        self.pos = self.pos.saturating_add(1);
        Some(f)
    }

    /// The typed readers' fast path: the next field if it is a plain number
    /// (see [`crate::number`]) directly followed by its `,` or the
    /// end of the text, read in the same pass that finds the field's end.
    /// Anything else (spaces, exponents, `;` right after the value, an empty
    /// field) is left unread for the grammar (`next_field`,
    /// `Decimal::parse`) to decide.
    #[cfg_attr(not(target_os = "none"), inline(always))]
    pub(crate) fn take_plain(&mut self) -> Option<Decimal> {
        self.take_plain_as(Some)
    }

    /// [`Cursor::take_plain`], taking the field only if `convert` gives
    /// its value a type (an integer that fits, say); else nothing is taken.
    ///
    /// So a caller need not save the cursor to read a field again: copying
    /// the cursor just after the previous field was stored made the
    /// processor wait for those stores (a third of `read_int`'s time).
    #[cfg_attr(not(target_os = "none"), inline(always))]
    pub(crate) fn take_plain_as<T>(
        &mut self,
        convert: impl FnOnce(Decimal) -> Option<T>,
    ) -> Option<T> {
        let Source::Text(Some(rest)) = self.src else {
            return None;
        };
        let (d, next) = number::plain_prefix(rest.as_bytes())?;
        let tail = match next {
            [] => None,
            [b',', next @ ..] => (!only_fillers(next)).then(|| after(rest, next)),
            _ => return None,
        };
        let v = convert(d)?;
        self.src = Source::Text(tail);
        self.pos = self.pos.saturating_add(1);
        Some(v)
    }

    /// Reads plain numbers (as `take_plain` does) into `out`, in
    /// order, while the fields are plain; returns how many were read. The
    /// position in the text stays in registers for the whole run: poses and
    /// joint lists, most of a reply's values, are read here.
    pub(crate) fn plain_numbers(&mut self, out: &mut [Decimal]) -> usize {
        let Source::Text(Some(text)) = self.src else {
            return 0;
        };
        let mut rest = text.as_bytes();
        let (mut n, mut end_of_text) = (0, false);
        for slot in out.iter_mut() {
            let Some((d, next)) = number::plain_prefix(rest) else {
                break;
            };
            match next {
                [b',', tail @ ..] => rest = tail,
                [] => end_of_text = true,
                _ => break,
            }
            *slot = d;
            n += 1;
            if end_of_text {
                break;
            }
        }
        // The fields end at the end of the text, or where only the
        // terminator is left after a `,` (checked once, here: a number
        // never starts with a filler, so the loop stops there).
        let done = end_of_text || only_fillers(rest);
        // `rest` starts just after a `,` (or is the whole text): a character
        // boundary.
        self.src = Source::Text(if done { None } else { Some(after(text, rest)) });
        self.pos = self
            .pos
            .saturating_add(u16::try_from(n).unwrap_or(u16::MAX));
        n
    }

    /// All remaining fields as one borrowed text (for variable lists), and
    /// their count. Only available on message text; a reordered cursor has no
    /// contiguous text and yields `None`.
    /// More fields than a count can say (over 65535) is an error recorded
    /// here, and nothing is taken.
    pub(crate) fn take_rest(&mut self) -> Option<(&'a str, u16)> {
        let Source::Text(rest) = &mut self.src else {
            return None;
        };
        let (text, n) = match rest.take().map(bound) {
            None => ("", 0),
            Some(Ok(bounded)) => bounded,
            Some(Err(e)) => {
                self.record(e.into());
                ("", 0)
            }
        };
        self.pos = self.pos.saturating_add(n);
        Some((text, n))
    }

    /// Records an error (the first one wins).
    pub(crate) fn record(&mut self, e: ParseError<'a>) {
        if self.err.is_none() {
            self.err = Some(e);
        }
    }

    /// Records a field error at the current position (the first one wins).
    #[cold]
    #[inline(never)]
    pub(crate) fn fail(&mut self, param: Param, expected: Expected, got: Got<'a>) {
        let e = self.error(param, expected, got);
        self.record(e);
    }

    /// A field error at the current position.
    pub(crate) fn error(&self, param: Param, expected: Expected, got: Got<'a>) -> ParseError<'a> {
        ParseError::Field {
            command: self.command,
            param: param.name(Some(self.command)),
            // A field just read is at pos - 1; the end or a list starts at pos.
            index: match got {
                Got::Field(_) => self.pos.saturating_sub(1),
                _ => self.pos,
            },
            expected,
            got,
        }
    }

    /// A command without parameters ignores one stray robot id or empty
    /// field (`ConnectToBox,0,;` in the document, `ReadRobotModel,0,;` and
    /// `StopScript,0,;` from SDKs).
    pub(crate) fn skip_stray_robot_id(&mut self) {
        if self.pos == 0 {
            let mut probe = self.clone();
            if let Some(f) = probe.next_field() {
                if probe.at_end() && (f.is_empty() || f.bytes().all(|b| b.is_ascii_digit())) {
                    *self = probe;
                }
            }
        }
    }

    /// The first error recorded, else an error if fields are left over.
    pub(crate) fn finish(&mut self) -> Result<(), ParseError<'a>> {
        if let Some(e) = self.err {
            return Err(e);
        }
        if self.at_end() {
            return Ok(());
        }
        self.too_many()
    }

    #[cold]
    #[inline(never)]
    fn too_many(&mut self) -> Result<(), ParseError<'a>> {
        let expected = self.pos;
        let left = match self.src {
            Source::Text(Some(r)) => bound(r)?.1,
            _ => self.remaining(),
        };
        let got = expected
            .checked_add(left)
            .ok_or(GrammarError::TooManyFields)?;
        match self.next_field() {
            None => Ok(()),
            Some(extra) => Err(ParseError::TooManyFields {
                command: self.command,
                expected,
                got,
                first_extra: extra,
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fields(m: &RawMessage<'_>) -> heapless::Vec<heapless::String<16>, 8> {
        m.fields()
            .map(|f| heapless::String::try_from(f).unwrap())
            .collect()
    }

    #[test]
    fn lenient_forms() {
        let m = RawMessage::parse("OSCmd,1;").unwrap();
        assert_eq!((m.name(), m.len()), ("OSCmd", 1));
        let m = RawMessage::parse("ReadBoxCO,OK,0,1,;;").unwrap();
        assert_eq!(fields(&m), ["OK", "0", "1"]);
        let m = RawMessage::parse(" SetJointMaxAcc ,0,360, 360 ,;\r\n").unwrap();
        assert_eq!(m.name(), "SetJointMaxAcc");
        assert_eq!(fields(&m), ["0", "360", "360"]);
        let m = RawMessage::parse("ReadCIConfig,,;").unwrap();
        assert_eq!(fields(&m), [""]);
        let m = RawMessage::parse("StartMaster,;").unwrap();
        assert!(m.is_empty());
        let m = RawMessage::parse("StartMaster").unwrap();
        assert!(m.is_empty());
    }

    #[test]
    fn kinds() {
        let k = |t| RawMessage::parse(t).unwrap().kind();
        assert_eq!(k("GrpEnable,0,;"), Kind::Request);
        assert_eq!(k("GrpEnable,OK,;"), Kind::Ok);
        assert_eq!(k("GrpEnable,Fail,20018,;"), Kind::Fail);
        assert_eq!(k("errorcmd,;"), Kind::ErrorCmd);
    }

    #[test]
    fn plain_number_fast_path_agrees_and_consumes_nothing_on_fallback() {
        let text = "M,10.759,-0.000,5.,.5,007,1e5, 3,,-,1.2.3,12345678901234567890,x,4;";
        let (_, rest) = head(text).unwrap();
        let mut c = Cursor::new(rest, CommandId::ReadActPos);
        let mut fast = 0;
        while !c.at_end() {
            let pos = c.position();
            match c.take_plain() {
                Some(d) => {
                    fast += 1;
                    assert_eq!(c.position(), pos + 1);
                    let mut again = Cursor::new(rest, CommandId::ReadActPos);
                    for _ in 0..pos {
                        again.next_field();
                    }
                    let f = again.next_field().unwrap();
                    assert!(d.is_identical(&Decimal::parse(f).unwrap()), "{f}");
                }
                None => {
                    assert_eq!(c.position(), pos);
                    c.next_field();
                }
            }
        }
        // 10.759, -0.000, 5., 007 take the fast path; the rest (`4;` too:
        // a `;` right after the value) does not.
        assert_eq!(fast, 4);
        assert_eq!(c.position(), 13);
    }

    #[test]
    fn bad_messages() {
        assert_eq!(RawMessage::parse(" ;; "), Err(GrammarError::Empty));
        assert_eq!(RawMessage::parse(",x,;"), Err(GrammarError::BadName));
        assert_eq!(RawMessage::parse(",;"), Err(GrammarError::Empty));
        assert_eq!(
            RawMessage::parse("Pose Trans, 0,1,;"),
            Err(GrammarError::BadName)
        );
    }

    /// The reader of the previous release, kept as the reference of what the
    /// grammar accepts: it strips the terminator from the end and splits the
    /// rest, where the grammar above reads forward.
    mod reference {
        use super::super::{trim, GrammarError};

        pub fn parse(text: &str) -> Result<(&str, &str, usize), GrammarError> {
            let mut t = trim(text);
            while let Some(s) = t.strip_suffix(';') {
                t = trim(s);
            }
            if let Some(s) = t.strip_suffix(',') {
                t = s;
            }
            if t.is_empty() {
                return Err(GrammarError::Empty);
            }
            let (name, rest) = match t.find(',') {
                Some(i) => (&t[..i], Some(&t[i + 1..])),
                None => (t, None),
            };
            let name = trim(name);
            if name.is_empty() || !name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_') {
                return Err(GrammarError::BadName);
            }
            let count = rest.map_or(0, |b| b.bytes().filter(|&c| c == b',').count() + 1);
            Ok((name, rest.unwrap_or(""), count))
        }
    }

    /// Compares the grammar with the reference on `text`: the same error, or
    /// the same name, body and fields, read both through [`RawMessage`] and
    /// through a [`Cursor`].
    fn check_against_reference(text: &str) {
        let got = RawMessage::parse(text);
        match reference::parse(text) {
            Err(e) => assert_eq!(got, Err(e), "{text:?}"),
            Ok((name, body, count)) => {
                let m = got.unwrap_or_else(|e| panic!("{text:?}: {e:?}"));
                assert_eq!(
                    (m.name(), m.body(), m.len()),
                    (name, body, count),
                    "{text:?}"
                );
                let (_, rest) = head(text).unwrap();
                let mut c = Cursor::new(rest, CommandId::ReadActPos);
                assert_eq!(c.remaining(), m.len() as u16, "{text:?}");
                let mut expected = m.fields();
                while let Some(f) = c.next_field() {
                    assert_eq!(Some(f), expected.next(), "{text:?}");
                }
                assert_eq!(expected.next(), None, "{text:?}");
            }
        }
    }

    #[test]
    fn grammar_reads_as_the_reference_does() {
        // Every string of up to 7 bytes over an alphabet that has each kind
        // of byte the grammar tells apart.
        const ALPHABET: &[u8] = b"A1, ;x\t";
        let mut buf = [0u8; 7];
        for len in 0..=buf.len() {
            let total = ALPHABET.len().pow(len as u32);
            for mut k in 0..total {
                for slot in buf[..len].iter_mut() {
                    *slot = ALPHABET[k % ALPHABET.len()];
                    k /= ALPHABET.len();
                }
                check_against_reference(core::str::from_utf8(&buf[..len]).unwrap());
            }
        }
        for t in [
            "ReadActPos,OK,10.759,-0.000,;",
            " SetJointMaxAcc ,0,360, 360 ,;\r\n",
            "A,x;y,;",
            "A,a, ,;",
            "A,1 ; 2 ;",
            "é,1,;",
            "A,é ,;",
        ] {
            check_against_reference(t);
        }
    }
}
