//! The two readers behind [`DataSheet::parse`].
//!
//! * [`fast`]: one pass over the bytes, for JSON in the form controllers
//!   send: no escapes, bare numbers in the plain form `-?digits(.digits)?`,
//!   literals without ignored bytes inside, lists of at most 16 values;
//!   whitespace (and NUL/`\n`/`\t`) between tokens and trailing commas are
//!   fine. Keys are tried against the name expected next before any
//!   look-up. It never reports an error: on anything else, valid or not, it
//!   gives up.
//! * [`general`]: the [`Tokenizer`]'s tokens, for every payload the fast
//!   reader gives up on. It accepts everything the module documents and
//!   produces every error.
//!
//! [`parse`] runs the fast reader, then the general one on a fresh sheet if
//! the fast one gave up; on microcontrollers (`target_os = "none"`) it runs
//! the general one alone, as the flash the fast one takes matters more
//! there than its speed. The result is the general reader's in every case:
//! the fast reader accepts only payloads the tokenizer reads without error,
//! makes the same decisions for each member (group, field, unknown), and
//! hands each field the same values in the same order through the same
//! [`Member`] calls ([`Member::list`] is exactly those calls for a whole
//! list), with plain numbers already read by the crate's one fast number
//! reader ([`plain_prefix`], which is what [`Decimal::parse_bytes`] runs
//! first). `tests::fast_and_general_agree` and `host-tests/tests/datasheet.rs`
//! compare the two on many payloads.
//!
//! Why two: the general reader pays for its generality on every token (the
//! tokenizer's state machine, a call per token, values as text converted
//! afterwards); on the 2 KiB standby sample the fast one takes ~37k
//! instructions against ~105k. A payload the fast reader gives up on costs
//! the general reader's time plus the fast reader's up to where it gave up
//! (at most about a third more).
//!
//! [`DataSheet::parse`]: super::DataSheet::parse

use super::json::{is_space, JsonError, JsonErrorKind, Token, Tokenizer, MAX_DEPTH};
use super::scan;
use super::sheet::{
    decimal_of, DataSheet, DataSheetError, FieldExpected, Member, ReadField, Value, GROUP_NAMES,
    MAX_LIST, NAMES, READ, READ_NAMES,
};
use crate::number::{plain_prefix, Decimal};

/// Decodes a payload: see the module documentation.
pub(super) fn parse(payload: &[u8]) -> Result<DataSheet, DataSheetError> {
    // One sheet, returned from one place: built where the caller gets it.
    let mut ds = DataSheet::default();
    // Microcontrollers run the general reader alone: the fast one costs
    // ~2.5 KiB of flash there, to save well under 1 % of a Cortex-M7 at the
    // 10 Hz a gateway reads. The result is the same either way.
    if !cfg!(not(target_os = "none")) || fast(payload, &mut ds).is_none() {
        ds = DataSheet::default();
        general(payload, &mut ds)?;
    }
    Ok(ds)
}

/// The field a key names, if any, and whether it names a group.
fn lookup(key: &[u8]) -> (Option<(ReadField, &'static str)>, bool) {
    let found = NAMES.find(key);
    (field(found.field), found.group.is_some())
}

/// Field `i` of the table.
fn field(i: Option<usize>) -> Option<(ReadField, &'static str)> {
    let i = i?;
    Some((*READ.get(i)?, *READ_NAMES.get(i)?))
}

// ---------------------------------------------------------------- general

/// The general reader: see the module documentation.
pub(super) fn general(payload: &[u8], ds: &mut DataSheet) -> Result<(), DataSheetError> {
    let mut t = Tokenizer::new(payload);
    if !matches!(t.next_token()?, Some(Token::BeginObject)) {
        return Err(DataSheetError::NotAnObject);
    }
    object(&mut t, ds)?;
    // Only whitespace may follow; the tokenizer reports anything else.
    t.next_token()?;
    Ok(())
}

/// Reads the members of an object whose `{` was just taken, up to its `}`.
/// Recurses only into known groups, so at most [`MAX_DEPTH`] deep.
fn object(t: &mut Tokenizer<'_>, ds: &mut DataSheet) -> Result<(), DataSheetError> {
    loop {
        let key = match t.next_token()? {
            Some(Token::Key(k)) => k,
            // The tokenizer yields only keys and `}` inside an object.
            _ => return Ok(()),
        };
        let Some(value) = t.next_token()? else {
            return Err(DataSheetError::Json(JsonError {
                offset: t.offset(),
                kind: JsonErrorKind::UnexpectedEnd,
            }));
        };
        let (field, group) = lookup(key);
        if matches!(value, Token::BeginObject) && group {
            object(t, ds)?;
        } else if let Some((get, name)) = field {
            member(get(ds), value, t, name)?;
        } else if matches!(value, Token::BeginObject | Token::BeginArray) {
            t.skip_container()?;
        }
    }
}

/// Reads a field's value, whose first token `first` was just taken.
fn member(
    m: &mut dyn Member,
    first: Token<'_>,
    t: &mut Tokenizer<'_>,
    field: &'static str,
) -> Result<(), DataSheetError> {
    // Field errors point at the last token taken: the value, the element,
    // or the `]` for a list of the wrong length.
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
            // A nested array or object is refused here (it is no number),
            // so the `]` above is this list's.
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

// ---------------------------------------------------------------- fast

/// The fast reader: `Some` with `ds` filled as [`general`] would fill it, or
/// `None` (with `ds` partly filled) where it gives up.
pub(super) fn fast(payload: &[u8], ds: &mut DataSheet) -> Option<()> {
    let mut r = Fast {
        rest: payload,
        next_group: 0,
        next_field: 0,
    };
    r.expect(b'{')?;
    r.object(ds, 1)?;
    // Only whitespace may follow.
    match r.peek() {
        None => Some(()),
        Some(_) => None,
    }
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

/// A plain number, bare or quoted, at the start of `rest`: its value and
/// its length. `None` for anything else.
#[inline]
fn plain_at(rest: &[u8]) -> Option<(Decimal, usize)> {
    let (quotes, body) = match rest {
        [b'"', body @ ..] => (2, body),
        _ => (0, rest),
    };
    let (d, tail) = plain_prefix(body)?;
    let len = body.len() - tail.len();
    let whole = if quotes == 2 {
        tail.first() == Some(&b'"')
    } else {
        // JSON wants a digit after a `.`. (A byte after the number that
        // would continue it is refused by the caller, which wants a
        // separator next; ignored bytes there are whitespace either way.)
        body.get(len.wrapping_sub(1)) != Some(&b'.')
    };
    whole.then_some((d, len + quotes))
}

/// The cursor of the fast reader: what is left of the payload. Every method
/// returns `None` to give up.
struct Fast<'a> {
    rest: &'a [u8],
    /// The group expected next at the top level (an index into
    /// [`GROUP_NAMES`]).
    next_group: usize,
    /// The field expected next inside a group (an index into
    /// [`READ_NAMES`]).
    next_field: usize,
}

/// What a member's key names (see [`Fast::key`]).
struct Key {
    field: Option<usize>,
    group: Option<usize>,
}

impl<'a> Fast<'a> {
    /// Passes over `n` bytes (known to be there).
    #[inline]
    fn take(&mut self, n: usize) {
        self.rest = self.rest.get(n..).unwrap_or(&[]);
    }

    /// The next byte that is not whitespace between tokens (the
    /// tokenizer's set), without taking it; `None` at the end.
    #[inline]
    fn peek(&mut self) -> Option<u8> {
        loop {
            let (&c, tail) = self.rest.split_first()?;
            if !is_space(c) {
                return Some(c);
            }
            self.rest = tail;
        }
    }

    /// Takes `c`, the next byte that is not whitespace.
    #[inline]
    fn expect(&mut self, c: u8) -> Option<()> {
        if self.peek()? != c {
            return None;
        }
        self.take(1);
        Some(())
    }

    /// After an element or member: `true` at the end of the container
    /// (`close`, also after a trailing comma), `false` after a `,` with
    /// more to come.
    #[inline]
    fn next_or_end(&mut self, close: u8) -> Option<bool> {
        match self.peek()? {
            b',' => {
                self.take(1);
                if self.peek()? == close {
                    self.take(1);
                    return Some(true);
                }
                Some(false)
            }
            c if c == close => {
                self.take(1);
                Some(true)
            }
            _ => None,
        }
    }

    /// `true` (and the byte taken) when the container just opened is empty.
    #[inline]
    fn empty(&mut self, close: u8) -> Option<bool> {
        if self.peek()? == close {
            self.take(1);
            return Some(true);
        }
        Some(false)
    }

    /// A string with no escape, its `"` next: its contents.
    #[inline]
    fn string(&mut self) -> Option<&'a [u8]> {
        let body = self.rest.get(1..)?;
        let len = scan::quote_or_backslash(body)?;
        let (s, tail) = body.split_at_checked(len)?;
        let (b'"', after) = tail.split_first()? else {
            return None;
        };
        self.rest = after;
        Some(s)
    }

    /// A scalar value (not an array or object). Numbers only in the plain
    /// form; strings as they are (the field converts them).
    fn scalar(&mut self) -> Option<Value<'a>> {
        match self.peek()? {
            b'"' => Some(Value::Token(Token::Str(self.string()?))),
            b'-' | b'0'..=b'9' => self.plain().map(Value::Number),
            b't' => self.literal(b"true", Token::Bool(true)),
            b'f' => self.literal(b"false", Token::Bool(false)),
            b'n' => self.literal(b"null", Token::Null),
            _ => None,
        }
    }

    fn literal(&mut self, word: &[u8], token: Token<'a>) -> Option<Value<'a>> {
        self.rest = self.rest.strip_prefix(word)?;
        Some(Value::Token(token))
    }

    /// The members of an object whose `{` was taken, at nesting `depth`.
    fn object(&mut self, ds: &mut DataSheet, depth: usize) -> Option<()> {
        if self.empty(b'}')? {
            return Some(());
        }
        loop {
            if self.peek()? != b'"' {
                return None;
            }
            let (key, c) = self.key(depth)?;
            if let Some(g) = key.group {
                self.open(depth)?;
                self.object(ds, depth + 1)?;
                self.next_group = g + 1;
            } else if let Some((get, _)) = field(key.field) {
                self.member(get(ds), c, depth)?;
                self.next_field = key.field.map_or(0, |k| k + 1);
            } else {
                self.skip(depth)?;
            }
            // The usual `,` straight before the next key.
            if let [b',', b'"', ..] = self.rest {
                self.take(1);
            } else if self.next_or_end(b'}')? {
                return Some(());
            }
        }
    }

    /// A member's key, whose `"` is next, and the `:` after it: what the
    /// reader does with the member, and the value's first byte. `group` is
    /// set only when the value is an object (the only case where a group
    /// name matters).
    ///
    /// Controllers send the members in the table's order and spelling, so
    /// the name that would come next (the next group at the top level, the
    /// next field below) is tried first, by a plain comparison; only a
    /// key that is not that name is looked up. Both ways give the same
    /// answer: a key equal to the expected name is that name.
    #[inline]
    fn key(&mut self, depth: usize) -> Option<(Key, u8)> {
        let (names, next) = if depth == 1 {
            (GROUP_NAMES, self.next_group)
        } else {
            (READ_NAMES, self.next_field)
        };
        let guess = names.get(next).map_or(&b""[..], |n| n.as_bytes());
        let body = self.rest.get(1..)?;
        let predicted = !guess.is_empty()
            && body.get(guess.len()) == Some(&b'"')
            && body.get(..guess.len()).is_some_and(|k| same(k, guess));
        let raw = if predicted {
            self.take(guess.len() + 2);
            guess
        } else {
            self.string()?
        };
        self.expect(b':')?;
        let c = self.peek()?;
        let object = c == b'{';
        if predicted {
            // The expected group with an object, or the expected field with
            // anything else: the answer is known. (The other cases, a
            // field name with an object or a group name with a value, are
            // the names both kinds share: look them up.)
            if depth == 1 && object {
                let key = Key {
                    field: None,
                    group: Some(next),
                };
                return Some((key, c));
            }
            if depth > 1 && !object {
                let key = Key {
                    field: Some(next),
                    group: None,
                };
                return Some((key, c));
            }
        }
        let found = NAMES.find(raw);
        let key = Key {
            field: found.field,
            group: found.group.filter(|_| object),
        };
        Some((key, c))
    }

    /// Takes the `[` or `{` of a container that would be at `depth + 1`.
    #[inline]
    fn open(&mut self, depth: usize) -> Option<()> {
        if depth >= MAX_DEPTH {
            return None;
        }
        self.take(1);
        Some(())
    }

    /// A field's value, whose first byte `c` is next.
    fn member(&mut self, m: &mut dyn Member, c: u8, depth: usize) -> Option<()> {
        if c != b'[' {
            let v = match self.plain() {
                Some(d) => Value::Number(d),
                // An object here is a field error: `scalar` gives up on it.
                None => self.scalar()?,
            };
            return m.set(v).ok();
        }
        self.open(depth)?;
        // The numbers first, then the field takes them in one call. (More
        // than any field takes is an error the general reader reports.)
        let mut values = heapless::Vec::<Decimal, MAX_LIST>::new();
        if !self.empty(b']')? {
            loop {
                values.push(self.element()?).ok()?;
                // The usual `,` straight before the next element.
                match self.rest {
                    [b',', c, ..] if *c != b']' && !is_space(*c) => self.take(1),
                    _ => {
                        if self.next_or_end(b']')? {
                            break;
                        }
                    }
                }
            }
        }
        m.list(&values).ok()
    }

    /// The usual value, a plain number bare or quoted, read here: its value,
    /// or `None` with nothing taken.
    #[inline]
    fn plain(&mut self) -> Option<Decimal> {
        let (d, len) = plain_at(self.rest)?;
        self.take(len);
        Some(d)
    }

    /// A list element's number: [`Fast::plain`], or anything else by
    /// [`Fast::scalar`] and the conversion the general reader applies
    /// ([`decimal_of`]).
    #[inline]
    fn element(&mut self) -> Option<Decimal> {
        if let Some(d) = self.plain() {
            return Some(d);
        }
        match self.scalar()? {
            Value::Number(d) => Some(d),
            Value::Token(token) => decimal_of(&token).ok().flatten(),
        }
    }

    /// Checks and passes over any value (an unknown member's).
    fn skip(&mut self, depth: usize) -> Option<()> {
        match self.peek()? {
            b'{' => {
                self.open(depth)?;
                if self.empty(b'}')? {
                    return Some(());
                }
                loop {
                    if self.peek()? != b'"' {
                        return None;
                    }
                    self.string()?;
                    self.expect(b':')?;
                    self.skip(depth + 1)?;
                    if self.next_or_end(b'}')? {
                        return Some(());
                    }
                }
            }
            b'[' => {
                self.open(depth)?;
                if self.empty(b']')? {
                    return Some(());
                }
                loop {
                    self.skip(depth + 1)?;
                    if self.next_or_end(b']')? {
                        return Some(());
                    }
                }
            }
            _ => self.scalar().map(|_| ()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::fmt::Write;

    type Text = heapless::String<8192>;

    /// A sheet's exact contents: `Debug` prints each decimal as written
    /// (`-0.000`, not `0`), which `==` does not compare.
    fn exact(ds: &DataSheet) -> Text {
        let mut s = Text::new();
        write!(s, "{ds:?}").unwrap();
        s
    }

    /// The fast reader either gives up or agrees with the general one.
    /// Returns whether it took the payload.
    fn agree(payload: &[u8]) -> bool {
        let mut f = DataSheet::default();
        let took = fast(payload, &mut f).is_some();
        let mut g = DataSheet::default();
        let general = general(payload, &mut g);
        if took {
            assert_eq!(general, Ok(()), "{:?}", core::str::from_utf8(payload));
            assert_eq!(exact(&f), exact(&g), "{:?}", core::str::from_utf8(payload));
        }
        took
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

    #[test]
    fn the_vendor_layout_takes_the_fast_path() {
        assert!(agree(SAMPLE));
        let mut ds = DataSheet::default();
        fast(SAMPLE, &mut ds).unwrap();
        assert_eq!(ds.state.robot_state, Some(crate::FsmState::StandBy));
        assert_eq!(exact(&ds), exact(&DataSheet::parse(SAMPLE).unwrap()));
    }

    #[test]
    fn fast_and_general_agree() {
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
            br#"{"Actual_Position":null,"BoxDI":null,"EndAI":[]}"#,
            br#"{"BoxDI":[1,0,1],"BoxDI":[0]}"#,
            br#"{"EndAI":[1,2,3,4,5]}"#,
            br#"{"robotState":1.5}"#,
            br#"{"robotState":[1]}"#,
            br#"{"robotState":{}}"#,
            br#"{"Box48OUT_Voltage":"48.00","box48in voltage":" 1 "}"#,
            br#"{"robotState":5.}"#,
            br#"{"robotState":1e2}"#,
            br#"{"robotState":12345678901234567890}"#,
            br#"{"EtherCAT_TotalFrame":18446744073709551615}"#,
            br#"{"EtherCAT_TotalFrame":1844674407370955161}"#,
            br#"{"a\"b":1,"robotState":2}"#,
            br#"{"robotState":"\u0033"}"#,
            br#"{"robotState":tru}"#,
            br#"{"robotState":1 2}"#,
            br#"{"robotState":01}"#,
            br#"{"robotState":-}"#,
            br#"{"robotState":1}x"#,
            br#"[1]"#,
            br#""#,
            br#"{"#,
            br#"{"a":[1,2"#,
            b"{\"robotState\":3\n3}",
            b"{\"robot\tState\":33}",
            b"{\"robotState\":tr\nue}",
            b"\0{\"robotState\" :\t33 , }\0",
            br#"{"PosAndVel":{"EndIO":{"EndDI":[1,0]}},"FTData":{"FTData":[0,0,0,0,0,1]}}"#,
            br#"{"FTData":[0,0,0,0,0,1]}"#,
        ];
        for case in cases {
            agree(case);
        }
        // Nesting at and past the limit, known and unknown.
        for deep in [MAX_DEPTH - 1, MAX_DEPTH, MAX_DEPTH + 1] {
            let mut p = heapless::Vec::<u8, 256>::new();
            for _ in 0..deep {
                p.extend_from_slice(b"{\"PosAndVel\":").unwrap();
            }
            p.extend_from_slice(b"{\"robotState\":[1]").unwrap();
            for _ in 0..=deep {
                p.push(b'}').unwrap();
            }
            agree(&p);
            let mut q = heapless::Vec::<u8, 256>::new();
            q.extend_from_slice(b"{\"x\":").unwrap();
            for _ in 0..deep {
                q.push(b'[').unwrap();
            }
            for _ in 0..deep {
                q.push(b']').unwrap();
            }
            q.push(b'}').unwrap();
            agree(&q);
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
                b'"', b',', b':', b'[', b']', b'{', b'}', b'.', b'-', b'1', b' ', b'\\', 0,
            ] {
                buf.copy_from_slice(SAMPLE);
                buf[at] = b;
                agree(buf);
            }
        }
    }
}
