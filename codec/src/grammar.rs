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
//! Fields are split on `,` only; the protocol has no quoting, so a text field
//! can never contain `,` or `;` (the writer refuses such text). Splitting
//! borrows the input: nothing is copied. It is a byte loop rather than parser
//! combinators: this is the codec's hottest path and the grammar is one
//! separator (see `host-tests/benches`).

use crate::catalogue::CommandId;
use crate::error::{Expected, Got, ParseError};
use crate::number::Decimal;

/// Whitespace the reader trims around fields and messages.
pub(crate) fn is_space(b: u8) -> bool {
    matches!(b, b' ' | b'\t' | b'\r' | b'\n')
}

/// `s` without the whitespace [`is_space`] at its ends.
pub(crate) fn trim(s: &str) -> &str {
    let b = s.as_bytes();
    let start = b.iter().position(|&c| !is_space(c)).unwrap_or(b.len());
    let end = b
        .iter()
        .rposition(|&c| !is_space(c))
        .map_or(start, |e| e + 1);
    // Both ends sit next to ASCII bytes, so they are character boundaries.
    s.get(start..end).unwrap_or("")
}

/// Splits off the first field of `rest`; `None` when nothing is left.
/// (A plain byte loop: fields are a few bytes long, where `memchr`'s set-up
/// costs more than it saves.)
fn split_field(rest: &str) -> (&str, Option<&str>) {
    match rest.bytes().position(|b| b == b',') {
        // `,` is ASCII: both sides of it are character boundaries.
        Some(i) => (
            rest.get(..i).unwrap_or(""),
            Some(rest.get(i + 1..).unwrap_or("")),
        ),
        None => (rest, None),
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

/// A message split into its name and fields, borrowed from the input.
///
/// This is the generic view used for unknown command names (newer firmware
/// keeps working) and underneath every typed parse.
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
    /// Splits one message. `text` may carry the terminator (`...,;`) or not
    /// (a body as the framer delivers it), and surrounding whitespace.
    pub fn parse(text: &'a str) -> Result<Self, GrammarError> {
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
        let (name, rest) = split_field(t);
        let name = trim(name);
        if name.is_empty() || !name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_') {
            return Err(GrammarError::BadName);
        }
        let body = rest.unwrap_or("");
        let count = match rest {
            None => 0,
            Some(b) => b.bytes().filter(|&c| c == b',').count() + 1,
        };
        let count = u16::try_from(count).map_err(|_| GrammarError::TooManyFields)?;
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
        if self.name.eq_ignore_ascii_case("errorcmd") {
            return Kind::ErrorCmd;
        }
        match self.fields().next() {
            Some(f) if f.eq_ignore_ascii_case("OK") => Kind::Ok,
            Some(f) if f.eq_ignore_ascii_case("Fail") => Kind::Fail,
            _ => Kind::Request,
        }
    }

    /// This message without its first field (used to step past `OK`/`Fail`).
    pub(crate) fn skip_first(&self) -> RawMessage<'a> {
        match split_field(self.body) {
            (_, Some(rest)) => RawMessage {
                name: self.name,
                body: rest,
                count: self.count.saturating_sub(1),
            },
            (_, None) => RawMessage {
                name: self.name,
                body: "",
                count: 0,
            },
        }
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
        let r = self.rest?;
        let (f, rest) = split_field(r);
        self.rest = rest;
        Some(trim(f))
    }
}

/// Where a [`Cursor`] reads its fields from.
#[derive(Clone, Copy, Debug)]
enum Source<'s, 'a> {
    /// The message text, split lazily.
    Text(Option<&'a str>),
    /// Fields already split and reordered by a quirk handler.
    Slice(&'s [&'a str]),
}

/// Reads the fields of one message in order, for the typed parsers.
#[derive(Clone, Debug)]
pub struct Cursor<'s, 'a> {
    src: Source<'s, 'a>,
    pos: u16,
    total: u16,
    command: CommandId,
    /// In a reply: how many values a list must have, from the request.
    list_len: Option<u16>,
    /// The first error met; later reads return defaults and are ignored.
    err: Option<ParseError<'a>>,
}

impl<'s, 'a> Cursor<'s, 'a> {
    pub(crate) fn new(msg: &RawMessage<'a>, command: CommandId) -> Self {
        Cursor {
            src: Source::Text(if msg.count == 0 { None } else { Some(msg.body) }),
            pos: 0,
            total: msg.count,
            command,
            list_len: None,
            err: None,
        }
    }

    pub(crate) fn from_slice(fields: &'s [&'a str], command: CommandId) -> Self {
        Cursor {
            src: Source::Slice(fields),
            pos: 0,
            total: u16::try_from(fields.len()).unwrap_or(u16::MAX),
            command,
            list_len: None,
            err: None,
        }
    }

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

    /// Fields not yet read.
    pub fn remaining(&self) -> u16 {
        self.total.saturating_sub(self.pos)
    }

    /// Index of the next field (0 = first after the name).
    pub fn position(&self) -> u16 {
        self.pos
    }

    /// The next field, trimmed, or `None` at the end.
    pub fn next_field(&mut self) -> Option<&'a str> {
        let f = match &mut self.src {
            Source::Text(rest) => {
                let (f, tail) = split_field((*rest)?);
                *rest = tail;
                trim(f)
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
    /// (`[-]digits[.digits]`, at most 19 digits, no spaces), read in the same
    /// pass that finds its end, and the text after it. Anything else
    /// (spaces, exponents, an empty field, an error) is `None`: the general
    /// path (`next_field`, `Decimal::parse`) then decides.
    fn peek_plain_number(&self) -> Option<(Decimal, Option<&'a str>)> {
        let Source::Text(Some(rest)) = self.src else {
            return None;
        };
        let b = rest.as_bytes();
        let (negative, mut i) = match b.first() {
            Some(b'-') => (true, 1),
            _ => (false, 0),
        };
        let (mut coeff, mut digits, mut scale, mut point) = (0u64, 0u8, 0u8, false);
        while let Some(&c) = b.get(i) {
            match c {
                // 19 digits stay below 10^19 < u64::MAX.
                b'0'..=b'9' if digits < 19 => {
                    coeff = coeff * 10 + u64::from(c - b'0');
                    digits += 1;
                    scale += u8::from(point);
                }
                b'.' if !point => point = true,
                b',' => break,
                _ => return None,
            }
            i += 1;
        }
        if digits == 0 {
            return None;
        }
        // `,` is ASCII: the tail starts on a character boundary.
        let tail = match b.get(i) {
            Some(_) => Some(rest.get(i + 1..)?),
            None => None,
        };
        Some((Decimal::from_parts(negative, coeff, scale)?, tail))
    }

    fn advance(&mut self, tail: Option<&'a str>) {
        self.src = Source::Text(tail);
        self.pos = self.pos.saturating_add(1);
    }

    /// The next field if it is a plain number (see `peek_plain_number`);
    /// nothing is consumed otherwise.
    pub(crate) fn next_plain_number(&mut self) -> Option<Decimal> {
        let (d, tail) = self.peek_plain_number()?;
        self.advance(tail);
        Some(d)
    }

    /// The next field if it is a plain whole number that fits an `i32`;
    /// nothing is consumed otherwise.
    pub(crate) fn next_plain_int(&mut self) -> Option<i32> {
        let (d, tail) = self.peek_plain_number()?;
        let v = i32::try_from(d.to_i64()?).ok()?;
        self.advance(tail);
        Some(v)
    }

    /// All remaining fields as one borrowed text (for variable lists), and
    /// their count. Only available on message text; a reordered cursor has no
    /// contiguous text and yields `None`.
    pub(crate) fn take_rest(&mut self) -> Option<(&'a str, u16)> {
        match &mut self.src {
            Source::Text(rest) => {
                let n = self.total.saturating_sub(self.pos);
                let r = rest.take().unwrap_or("");
                self.pos = self.total;
                Some((r, n))
            }
            Source::Slice(_) => None,
        }
    }

    /// Records an error (the first one wins).
    pub(crate) fn record(&mut self, e: ParseError<'a>) {
        if self.err.is_none() {
            self.err = Some(e);
        }
    }

    /// Records a field error at the current position (the first one wins).
    pub(crate) fn fail(&mut self, param: &'static str, expected: Expected, got: Got<'a>) {
        let e = self.error(param, expected, got);
        self.record(e);
    }

    /// A field error at the current position.
    pub(crate) fn error(
        &self,
        param: &'static str,
        expected: Expected,
        got: Got<'a>,
    ) -> ParseError<'a> {
        ParseError::Field {
            command: self.command,
            param,
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
        if self.pos == 0 && self.total == 1 {
            let mut probe = self.clone();
            if let Some(f) = probe.next_field() {
                if f.is_empty() || f.bytes().all(|b| b.is_ascii_digit()) {
                    *self = probe;
                }
            }
        }
    }

    /// The first error recorded, else an error if fields are left over.
    pub(crate) fn finish(mut self) -> Result<(), ParseError<'a>> {
        if let Some(e) = self.err {
            return Err(e);
        }
        let expected = self.pos;
        match self.next_field() {
            None => Ok(()),
            Some(extra) => Err(ParseError::TooManyFields {
                command: self.command,
                expected,
                got: self.total,
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
        let text = "M,10.759,-0.000,5.,.5,007,1e5, 3,,-,1.2.3,12345678901234567890,x";
        let msg = RawMessage::parse(text).unwrap();
        let mut c = Cursor::new(&msg, CommandId::ReadActPos);
        let mut fast = 0;
        while c.remaining() > 0 {
            let pos = c.position();
            match c.next_plain_number() {
                Some(d) => {
                    fast += 1;
                    assert_eq!(c.position(), pos + 1);
                    let mut again = Cursor::new(&msg, CommandId::ReadActPos);
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
        // 10.759, -0.000, 5., .5, 007 take the fast path; the rest does not.
        assert_eq!(fast, 5);
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
}
