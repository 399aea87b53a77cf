//! The grammar of a request's head, checked strictly (RFC 9112) on the
//! bytes as they arrive, before picoserve parses them.
//!
//! picoserve splits the request line on any run of whitespace, ends a line
//! at a bare LF (a bare CR stays inside a header value), removes NUL bytes
//! from the headers and takes any third word for the version. A proxy in
//! front of the device that reads the same bytes by the letter of RFC 9112
//! (or splits lines at a bare CR) would then see other requests than the
//! device: the ground of request smuggling. So every byte of a request's
//! head passes this checker first ([`Grammar::feed`], called by the socket's
//! read half, `web::io`), and a head that breaks the grammar goes no
//! further: the bytes before the first bad one are handed on, then the
//! stream ends, so picoserve answers 400 and closes the connection, and no
//! route ever sees the request.
//!
//! The grammar (RFC 9112 § 3, § 5; RFC 9110 § 5.6.2 for tokens):
//! * request line: `method SP request-target SP HTTP-version CRLF`, one
//!   space exactly between the parts; the method a token; the target
//!   visible ASCII (`!` to `~`); the version `HTTP/1.0` or `HTTP/1.1`;
//!   nothing before the request line (not even an empty line);
//! * each header line: `name ":" OWS value OWS CRLF`, the name a token (no
//!   space before the colon), the value visible characters, spaces and
//!   tabs (bytes 0x80-0xFF allowed, as obs-text); no bare CR, no bare LF,
//!   no NUL or other control character; no line folding (a line starting
//!   with a space or a tab);
//! * the head ends with an empty line (CRLF); then the body's
//!   `Content-Length` bytes are passed unchecked, and the next request's
//!   head begins.
//!
//! A head with `Transfer-Encoding`, or with a `Content-Length` that is not
//! one header of at most 9 digits, is passed on whole: its body cannot be
//! delimited, and the server answers it (`web::framing`) with
//! `Connection: close`, so nothing after it is read; the checker stops.
//!
//! Bounded: a few bytes of state per connection, whatever the lengths
//! (picoserve bounds the head by its buffer).

/// `content-length`, as a header's name is matched (lower case).
const CONTENT_LENGTH: &[u8] = b"content-length";
/// `transfer-encoding`.
const TRANSFER_ENCODING: &[u8] = b"transfer-encoding";
/// The versions served, but for their last digit.
const VERSION: &[u8] = b"HTTP/1.";
/// Digits of a `Content-Length` at most (as `web::framing` takes).
const LENGTH_DIGITS: u8 = 9;

/// Where the checker is in the stream.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    /// In the method (`len` characters so far).
    Method { len: u16 },
    /// In the request target (`len` characters so far).
    Target { len: u16 },
    /// In the version (`at` characters matched).
    Version { at: u8 },
    /// After the version's CR: its LF.
    LineLf,
    /// At the start of a header line, or of the empty line ending the
    /// head.
    FieldStart,
    /// In a header's name (`len` characters so far).
    FieldName { len: u8 },
    /// In a header's value.
    FieldValue,
    /// After a header line's CR: its LF.
    FieldLf,
    /// After the empty line's CR: its LF.
    HeadLf,
    /// In a body, `left` bytes to go.
    Body { left: u32 },
    /// The head cannot be delimited (see the module documentation): the
    /// connection closes after its answer; nothing is checked any more.
    Unchecked,
    /// A byte broke the grammar: nothing more is handed on.
    Broken,
}

/// What a header's name may be, as far as it was read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
struct Name {
    /// Still matches `content-length`.
    length: bool,
    /// Still matches `transfer-encoding`.
    encoding: bool,
}

/// The `Content-Length` value being read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Length {
    /// Before its first digit (spaces allowed).
    Before,
    /// In its digits.
    Digits,
    /// After them (spaces allowed).
    After,
    /// Not a length (another character, or too many digits).
    Bad,
}

/// The checker of one connection (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Grammar {
    state: State,
    /// The header being read.
    name: Name,
    /// Its name's characters read (for the names matched).
    name_len: u8,
    /// The `Content-Length` being read, if the header is one.
    length: Length,
    digits: u8,
    value: u32,
    /// `Content-Length` headers in this head.
    lengths: u8,
    /// The body's length, once one header of digits gave it.
    body: u32,
    /// The head cannot be delimited (`Transfer-Encoding`, a bad or second
    /// `Content-Length`).
    undelimited: bool,
}

impl Default for Grammar {
    fn default() -> Self {
        Self::NEW
    }
}

/// A token character (RFC 9110 § 5.6.2).
fn tchar(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b"!#$%&'*+-.^_`|~".contains(&b)
}

/// A character of a header's value: visible, space, tab, or obs-text.
fn field_char(b: u8) -> bool {
    matches!(b, b'!'..=b'~' | b' ' | b'\t' | 0x80..=0xFF)
}

impl Grammar {
    /// A connection's first request is next.
    pub(crate) const NEW: Grammar = Grammar {
        state: State::Method { len: 0 },
        name: Name {
            length: false,
            encoding: false,
        },
        name_len: 0,
        length: Length::Before,
        digits: 0,
        value: 0,
        lengths: 0,
        body: 0,
        undelimited: false,
    };

    /// Checks the next bytes of the stream: `Ok` if they keep to the
    /// grammar, else `Err(n)`: the first `n` do, the next does not (and
    /// every later call says `Err(0)`).
    pub(crate) fn feed(&mut self, bytes: &[u8]) -> Result<(), usize> {
        let mut at = 0;
        while let Some(rest) = bytes.get(at..).filter(|r| !r.is_empty()) {
            // A body is skipped whole, not byte by byte.
            if let State::Body { left } = self.state {
                let n = rest.len().min(left as usize);
                at += n;
                let left = left - n as u32;
                self.state = match left {
                    0 => Self::NEW.state,
                    _ => State::Body { left },
                };
                continue;
            }
            if matches!(self.state, State::Unchecked) {
                return Ok(());
            }
            let b = rest.first().copied().unwrap_or(0);
            if !self.step(b) {
                self.state = State::Broken;
                return Err(at);
            }
            at += 1;
        }
        Ok(())
    }

    /// A byte broke the grammar: nothing more is handed on.
    pub(crate) fn broken(&self) -> bool {
        matches!(self.state, State::Broken)
    }

    /// `false` when `b` breaks the grammar here.
    fn step(&mut self, b: u8) -> bool {
        self.state = match self.state {
            State::Method { len } => match b {
                b' ' if len > 0 => State::Target { len: 0 },
                _ if tchar(b) => State::Method {
                    len: len.saturating_add(1),
                },
                _ => return false,
            },
            State::Target { len } => match b {
                b' ' if len > 0 => State::Version { at: 0 },
                b'!'..=b'~' => State::Target {
                    len: len.saturating_add(1),
                },
                _ => return false,
            },
            State::Version { at } => {
                let at = usize::from(at);
                match VERSION.get(at) {
                    Some(&want) if b == want => State::Version { at: at as u8 + 1 },
                    Some(_) => return false,
                    None if at == VERSION.len() && matches!(b, b'0' | b'1') => {
                        State::Version { at: at as u8 + 1 }
                    }
                    None if at == VERSION.len() + 1 && b == b'\r' => State::LineLf,
                    None => return false,
                }
            }
            State::LineLf | State::FieldLf => match b {
                b'\n' => {
                    if matches!(self.state, State::LineLf) {
                        self.lengths = 0;
                        self.body = 0;
                        self.undelimited = false;
                    }
                    State::FieldStart
                }
                _ => return false,
            },
            State::FieldStart => match b {
                b'\r' => State::HeadLf,
                _ if tchar(b) => {
                    self.name = Name {
                        length: true,
                        encoding: true,
                    };
                    self.name_len = 0;
                    self.name_char(b);
                    State::FieldName { len: 1 }
                }
                // Line folding (a space or a tab first), or anything else.
                _ => return false,
            },
            State::FieldName { len } => match b {
                b':' => {
                    let n = usize::from(self.name_len);
                    let length = self.name.length && n == CONTENT_LENGTH.len();
                    let encoding = self.name.encoding && n == TRANSFER_ENCODING.len();
                    self.name = Name { length, encoding };
                    if encoding {
                        self.undelimited = true;
                    }
                    if length {
                        self.lengths = self.lengths.saturating_add(1);
                        self.length = Length::Before;
                        self.digits = 0;
                        self.value = 0;
                    }
                    State::FieldValue
                }
                _ if tchar(b) => {
                    self.name_char(b);
                    State::FieldName {
                        len: len.saturating_add(1),
                    }
                }
                // A space before the colon, or anything else.
                _ => return false,
            },
            State::FieldValue => match b {
                b'\r' => {
                    if self.name.length {
                        self.end_length();
                    }
                    State::FieldLf
                }
                _ if field_char(b) => {
                    if self.name.length {
                        self.length_char(b);
                    }
                    State::FieldValue
                }
                _ => return false,
            },
            State::HeadLf => match b {
                b'\n' => {
                    if self.undelimited || self.lengths > 1 {
                        State::Unchecked
                    } else if self.body > 0 {
                        State::Body { left: self.body }
                    } else {
                        Self::NEW.state
                    }
                }
                _ => return false,
            },
            // Handled by `feed`.
            State::Body { .. } | State::Unchecked => self.state,
            State::Broken => return false,
        };
        true
    }

    /// One more character of a header's name: the names it can still be.
    fn name_char(&mut self, b: u8) {
        let i = usize::from(self.name_len);
        let lower = b.to_ascii_lowercase();
        self.name.length &= CONTENT_LENGTH.get(i) == Some(&lower);
        self.name.encoding &= TRANSFER_ENCODING.get(i) == Some(&lower);
        self.name_len = self.name_len.saturating_add(1);
    }

    /// One more character of a `Content-Length` value.
    fn length_char(&mut self, b: u8) {
        self.length = match (self.length, b) {
            (Length::Before, b' ' | b'\t') => Length::Before,
            (Length::Before | Length::Digits, b'0'..=b'9') if self.digits < LENGTH_DIGITS => {
                self.digits += 1;
                self.value = self.value * 10 + u32::from(b - b'0');
                Length::Digits
            }
            (Length::Digits | Length::After, b' ' | b'\t') => Length::After,
            _ => Length::Bad,
        };
    }

    /// The end of a `Content-Length` header.
    fn end_length(&mut self) {
        match self.length {
            Length::Digits | Length::After => self.body = self.value,
            _ => self.undelimited = true,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Feeds `bytes` in pieces of `step`: where the first bad byte is.
    fn check(bytes: &[u8], step: usize) -> Result<(), usize> {
        let mut g = Grammar::NEW;
        let mut at = 0;
        for piece in bytes.chunks(step) {
            g.feed(piece).map_err(|n| at + n)?;
            at += piece.len();
        }
        Ok(())
    }

    fn all_steps(bytes: &[u8]) -> Result<(), usize> {
        let whole = check(bytes, bytes.len().max(1));
        for step in 1..8 {
            assert_eq!(check(bytes, step), whole, "pieces of {step}");
        }
        whole
    }

    #[test]
    fn requests_that_keep_to_the_grammar_pass() {
        for ok in [
            &b"GET / HTTP/1.1\r\nHost: 10.0.0.1\r\n\r\n"[..],
            b"GET /api/status?x=1 HTTP/1.0\r\n\r\n",
            b"POST /api/login HTTP/1.1\r\nHost: a\r\nContent-Type: application/json\r\ncontent-length:  5 \r\n\r\n{\"a\"}GET / HTTP/1.1\r\nX-Tab:\tv\talue\r\nX-Empty:\r\nX-Utf8: caf\xc3\xa9\r\n\r\n",
            b"HEAD / HTTP/1.1\r\nHost: a\r\n\r\nPOST /x HTTP/1.1\r\nContent-Length: 2\r\n\r\n\r\n",
        ] {
            assert_eq!(all_steps(ok), Ok(()), "{}", String::from_utf8_lossy(ok));
        }
    }

    /// Issue 25: a bare CR or a NUL in a header value, `HTTP/2.0` and a
    /// double space in the request line were accepted.
    #[test]
    fn what_breaks_the_grammar_is_found_at_its_first_byte() {
        for (bad, at) in [
            (&b"GET / HTTP/1.1\r\nHost: a\rX-Smuggled: 1\r\n\r\n"[..], 24),
            (b"GET / HTTP/1.1\r\nHost: a\0b\r\n\r\n", 23),
            (b"GET / HTTP/2.0\r\n\r\n", 11),
            (b"GET / HTTP/1.2\r\n\r\n", 13),
            (b"GET  / HTTP/1.1\r\n\r\n", 4),
            (b"GET / HTTP/1.1 \r\n\r\n", 14),
            (b"GET /a b HTTP/1.1\r\n\r\n", 7),
            (b"GET / http/1.1\r\n\r\n", 6),
            (b"GET / HTTP/1.1\n\r\n", 14),
            (b"GET / HTTP/1.1\r\nHost: a\n\r\n", 23),
            (b"\r\nGET / HTTP/1.1\r\n\r\n", 0),
            (b"G(T / HTTP/1.1\r\n\r\n", 1),
            (b"GET / HTTP/1.1\r\nHost : a\r\n\r\n", 20),
            (b"GET / HTTP/1.1\r\nHost: a\r\n folded\r\n\r\n", 25),
            (b"GET / HTTP/1.1\r\n: a\r\n\r\n", 16),
            (b"GET / HTTP/1.1\r\nX: \x7f\r\n\r\n", 19),
            (
                b"GET / HTTP/1.1\r\n\r\nGET / HTTP/1.1\r\nA: \x01\r\n\r\n",
                37,
            ),
            // After a body of its length, the next head is checked.
            (b"POST / HTTP/1.1\r\nContent-Length: 3\r\n\r\nabcGET  /", 45),
        ] {
            assert_eq!(
                all_steps(bad),
                Err(at),
                "{}",
                String::from_utf8_lossy(bad).escape_debug()
            );
        }
        // Broken once, broken for good.
        let mut g = Grammar::NEW;
        assert_eq!(g.feed(b"GET  /"), Err(4));
        assert_eq!(g.feed(b"GET / HTTP/1.1\r\n"), Err(0));
    }

    #[test]
    fn a_head_that_cannot_be_delimited_is_passed_on_and_the_checker_stops() {
        for undelimited in [
            &b"POST / HTTP/1.1\r\nTransfer-Encoding: chunked\r\n\r\n"[..],
            b"POST / HTTP/1.1\r\nContent-Length: 3\r\nContent-Length: 3\r\n\r\n",
            b"POST / HTTP/1.1\r\nContent-Length: 3,3\r\n\r\n",
            b"POST / HTTP/1.1\r\nContent-Length: +3\r\n\r\n",
            b"POST / HTTP/1.1\r\nContent-Length: 1234567890\r\n\r\n",
        ] {
            let mut g = Grammar::NEW;
            assert_eq!(g.feed(undelimited), Ok(()));
            assert_eq!(g.state, State::Unchecked);
            // Whatever follows: the server closes the connection after
            // its answer, and reads nothing of it.
            assert_eq!(g.feed(b"\0\r\x01 anything"), Ok(()));
        }
    }
}
