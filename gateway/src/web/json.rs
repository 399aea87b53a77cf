//! A JSON writer with structure, for the API's answers.
//!
//! A document is written as one value: [`Value::object`] and
//! [`Value::array`] take a closure that writes the members through an
//! [`Object`] ([`Object::key`]) or an [`Array`] ([`Array::item`]), and
//! these place the commas, colons and brackets themselves; a key hands
//! out a [`Value`] (`#[must_use]`) that takes exactly one typed value:
//! [`Value::str`] (escaped), [`Value::uint`], [`Value::int`],
//! [`Value::fixed3`], [`Value::bool`], [`Value::null`], [`Value::ip`],
//! [`Value::endpoint`], [`Value::opt`] (`null` for `None`) or
//! [`Value::text`] (a string built from pieces). The nesting is the
//! closures' own: each level's "first member" flag lives in its
//! [`Object`]/[`Array`] on the call stack, so there is no depth limit to
//! check and no way to close a level twice or forget to.
//!
//! Why this design rather than serde-json-core's serializer (which the
//! crate has, to read posted JSON):
//!
//! * serde-json-core 0.6 writes floats with `ryu` (shortest round-trip,
//!   `1e12`), a second float formatter of several KiB of flash and another
//!   output than the API's fixed three decimals (`-999999995904.000`):
//!   numbers here are written from integers ([`itoa`]), no core float
//!   formatting (~30 KiB) either;
//! * serializing needs a value to serialize: `#[derive(Serialize)]`
//!   structs mirroring every document, a second copy of the field names and
//!   shapes beside the state, and code per struct; here the document is
//!   written straight from a snapshot of the state's own types;
//! * errors are sticky: a write after the first problem does nothing and
//!   [`Out::result`] reports it, so the writing code is free of `?`.
//!
//! Where the bytes go is [`Out`], one concrete type (no generic sink, so
//! the documents' code exists once in flash): a byte slice, filled from
//! byte `skip` of the document on while it has room, with every byte
//! counted. The same rendering code therefore
//!
//! * measures a document (an empty slice: only the count),
//! * writes one window of it (`skip` = what was sent already): the web
//!   server sends a document of any length from a fixed buffer by
//!   rendering it again per window from an unchanging snapshot
//!   (`web::api`), and knows its `Content-Length` before the first byte,
//! * and fills a small answer's fixed buffer ([`Json`]), where running
//!   out of room is an error ([`Full`]).
//!
//! Strings are ASCII: a byte outside printable ASCII is written as `?`, so
//! a string of `n` bytes takes at most `2n + 2` characters.

use core::net::{Ipv4Addr, SocketAddrV4};

/// Bytes of a small answer ([`Json`]).
pub(crate) const ANSWER: usize = 1024;

/// A buffer ran out (a small answer), or a value could not be written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Full;

/// Where a document's bytes go: from byte `skip` on into a slice while it
/// has room; all bytes are counted.
#[derive(Debug)]
pub(crate) struct Out<'b> {
    buf: &'b mut [u8],
    len: usize,
    skip: usize,
    total: usize,
    dropped: bool,
    failed: bool,
}

impl<'b> Out<'b> {
    /// Bytes go into `buf`, from the document's first byte on.
    pub(crate) fn new(buf: &'b mut [u8]) -> Self {
        Out::window(buf, 0)
    }

    /// Bytes from the document's byte `skip` on go into `buf`.
    pub(crate) fn window(buf: &'b mut [u8], skip: usize) -> Self {
        Out {
            buf,
            len: 0,
            skip,
            total: 0,
            dropped: false,
            failed: false,
        }
    }

    /// The document's value.
    pub(crate) fn value(&mut self) -> Value<'_, 'b> {
        Value { out: self }
    }

    /// The bytes that went into the slice.
    pub(crate) fn written(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or(&[])
    }

    /// Bytes of the document so far (those skipped, stored and dropped).
    pub(crate) fn total(&self) -> usize {
        self.total
    }

    /// Bytes after the window were dropped (the slice was full).
    #[cfg(test)]
    pub(crate) fn dropped(&self) -> bool {
        self.dropped
    }

    /// Everything fit into the slice, and every value could be written:
    /// the number of bytes stored.
    pub(crate) fn result(&self) -> Result<usize, Full> {
        if self.dropped || self.failed {
            Err(Full)
        } else {
            Ok(self.len)
        }
    }

    /// A value could not be written (the document is not what it should
    /// be): [`Out::result`] and [`Out::failed`] report it.
    pub(crate) fn fail(&mut self) {
        self.failed = true;
    }

    /// See [`Out::fail`].
    pub(crate) fn failed(&self) -> bool {
        self.failed
    }

    fn put(&mut self, s: &[u8]) {
        self.total += s.len();
        if self.dropped {
            return;
        }
        let skipped = self.skip.min(s.len());
        self.skip -= skipped;
        let s = s.get(skipped..).unwrap_or(&[]);
        let free = self.buf.get_mut(self.len..).unwrap_or(&mut []);
        let n = free.len().min(s.len());
        if let (Some(dst), Some(src)) = (free.get_mut(..n), s.get(..n)) {
            dst.copy_from_slice(src);
        }
        self.len += n;
        if n < s.len() {
            self.dropped = true;
        }
    }

    fn uint(&mut self, v: u64) {
        let mut b = itoa::Buffer::new();
        self.put(b.format(v).as_bytes());
    }

    /// String content (no quotes): printable ASCII, `"` and `\` escaped,
    /// other bytes as `?`.
    fn escaped(&mut self, s: &[u8]) {
        let mut rest = s;
        while !rest.is_empty() {
            let plain = rest
                .iter()
                .position(|&b| !(0x20..=0x7e).contains(&b) || b == b'"' || b == b'\\')
                .unwrap_or(rest.len());
            let (run, tail) = rest.split_at(plain);
            self.put(run);
            let Some((&b, tail)) = tail.split_first() else {
                break;
            };
            self.put(match b {
                b'"' => b"\\\"",
                b'\\' => b"\\\\",
                _ => b"?",
            });
            rest = tail;
        }
    }

    fn string(&mut self, s: &[u8]) {
        self.put(b"\"");
        self.escaped(s);
        self.put(b"\"");
    }

    fn ip(&mut self, ip: Ipv4Addr) {
        for (k, o) in ip.octets().into_iter().enumerate() {
            if k > 0 {
                self.put(b".");
            }
            self.uint(o.into());
        }
    }

    /// The separator before a member (none before the first).
    fn sep(&mut self, first: &mut bool) {
        if !core::mem::replace(first, false) {
            self.put(b",");
        }
    }
}

/// The place of one JSON value: a document's, a key's or an array item's.
/// Takes exactly one value.
#[must_use = "a key or item needs its value"]
pub(crate) struct Value<'o, 'b> {
    out: &'o mut Out<'b>,
}

impl<'o, 'b> Value<'o, 'b> {
    /// `null`.
    pub(crate) fn null(self) {
        self.out.put(b"null");
    }

    /// `true` or `false`.
    pub(crate) fn bool(self, v: bool) {
        self.out.put(if v { b"true" } else { b"false" });
    }

    /// An unsigned integer.
    pub(crate) fn uint(self, v: u64) {
        self.out.uint(v);
    }

    /// A signed integer.
    pub(crate) fn int(self, v: i64) {
        if v < 0 {
            self.out.put(b"-");
        }
        self.out.uint(v.unsigned_abs());
    }

    /// A number with three decimals (`null` for NaN and infinities,
    /// magnitudes above 1e12 clamped).
    pub(crate) fn fixed3(self, v: f32) {
        if !v.is_finite() {
            return self.null();
        }
        let thousandths = (f64::from(v) * 1000.0).clamp(-1e15, 1e15);
        // Round half away from zero without libm.
        let t = if thousandths < 0.0 {
            (thousandths - 0.5) as i64
        } else {
            (thousandths + 0.5) as i64
        };
        if t < 0 {
            self.out.put(b"-");
        }
        let t = t.unsigned_abs();
        self.out.uint(t / 1000);
        // The three decimals, zero-padded.
        let mut d = *b".000";
        let mut f = t % 1000;
        for slot in d.iter_mut().rev().take(3) {
            *slot = b'0' + (f % 10) as u8;
            f /= 10;
        }
        self.out.put(&d);
    }

    /// A string (ASCII; other bytes as `?`).
    pub(crate) fn str(self, s: &[u8]) {
        self.out.string(s);
    }

    /// A string written in pieces by `f` (`"HR5.50.3"`).
    pub(crate) fn text(self, f: impl FnOnce(&mut Text<'_, 'b>)) {
        self.out.put(b"\"");
        f(&mut Text { out: self.out });
        self.out.put(b"\"");
    }

    /// An address `"a.b.c.d"`.
    pub(crate) fn ip(self, ip: Ipv4Addr) {
        self.out.put(b"\"");
        self.out.ip(ip);
        self.out.put(b"\"");
    }

    /// An endpoint `"a.b.c.d:port"`.
    pub(crate) fn endpoint(self, e: SocketAddrV4) {
        self.out.put(b"\"");
        self.out.ip(*e.ip());
        self.out.put(b":");
        self.out.uint(e.port().into());
        self.out.put(b"\"");
    }

    /// `null` for `None`, else what `f` writes (`v.opt(age, Value::uint)`).
    pub(crate) fn opt<T>(self, v: Option<T>, f: impl FnOnce(Self, T)) {
        match v {
            Some(x) => f(self, x),
            None => self.null(),
        }
    }

    /// An object whose members `f` writes.
    pub(crate) fn object(self, f: impl FnOnce(&mut Object<'_, 'b>)) {
        self.out.put(b"{");
        f(&mut Object {
            out: self.out,
            first: true,
        });
        self.out.put(b"}");
    }

    /// An array whose items `f` writes.
    pub(crate) fn array(self, f: impl FnOnce(&mut Array<'_, 'b>)) {
        self.out.put(b"[");
        f(&mut Array {
            out: self.out,
            first: true,
        });
        self.out.put(b"]");
    }

    /// The writer, to report a value that cannot be written
    /// ([`Out::fail`]) in place of this one (`null` is written).
    pub(crate) fn fail(self) {
        self.out.fail();
        self.null();
    }
}

/// The members of an object being written.
pub(crate) struct Object<'o, 'b> {
    out: &'o mut Out<'b>,
    first: bool,
}

impl<'b> Object<'_, 'b> {
    /// The next member `"k":`; its value goes into what this returns.
    pub(crate) fn key(&mut self, k: &str) -> Value<'_, 'b> {
        self.out.sep(&mut self.first);
        self.out.string(k.as_bytes());
        self.out.put(b":");
        Value { out: self.out }
    }
}

/// The items of an array being written.
pub(crate) struct Array<'o, 'b> {
    out: &'o mut Out<'b>,
    first: bool,
}

impl<'b> Array<'_, 'b> {
    /// The next item; its value goes into what this returns.
    pub(crate) fn item(&mut self) -> Value<'_, 'b> {
        self.out.sep(&mut self.first);
        Value { out: self.out }
    }
}

/// The inside of a string being written in pieces ([`Value::text`]).
pub(crate) struct Text<'o, 'b> {
    out: &'o mut Out<'b>,
}

impl Text<'_, '_> {
    /// Characters (escaped as [`Value::str`]'s).
    pub(crate) fn str(&mut self, s: &[u8]) -> &mut Self {
        self.out.escaped(s);
        self
    }

    /// An unsigned integer's digits.
    pub(crate) fn uint(&mut self, v: u64) -> &mut Self {
        self.out.uint(v);
        self
    }
}

/// A small JSON answer in a fixed buffer of [`ANSWER`] bytes (errors,
/// session state, the results of a post).
#[derive(Debug)]
pub(crate) struct Json {
    buf: [u8; ANSWER],
    len: usize,
}

impl Default for Json {
    fn default() -> Self {
        Json::new()
    }
}

impl Json {
    /// An empty answer.
    pub(crate) const fn new() -> Self {
        Json {
            buf: [0; ANSWER],
            len: 0,
        }
    }

    /// The answer `f` writes as one value (`Err` if it does not fit).
    pub(crate) fn value(f: impl FnOnce(Value<'_, '_>)) -> Result<Json, Full> {
        let mut j = Json::new();
        j.append(|out| f(out.value()))?;
        Ok(j)
    }

    /// What was written.
    pub(crate) fn as_bytes(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or(&[])
    }

    /// Appends what `f` writes, all of it or (`Err`) nothing.
    fn append(&mut self, f: impl FnOnce(&mut Out<'_>)) -> Result<&mut Self, Full> {
        let mut out = Out::new(self.buf.get_mut(self.len..).unwrap_or(&mut []));
        f(&mut out);
        let n = out.result()?;
        self.len += n;
        Ok(self)
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::vec::Vec;

    fn doc(f: impl Fn(Value<'_, '_>)) -> std::string::String {
        let mut buf = [0u8; 4096];
        let mut out = Out::new(&mut buf);
        f(out.value());
        let n = out.result().expect("fits");
        std::string::String::from_utf8(buf[..n].to_vec()).unwrap()
    }

    #[test]
    fn values_are_written_as_json() {
        let s = doc(|v| {
            v.object(|o| {
                o.key("a").str(b"Move\"L\\,\x01\xff;");
                o.key("n").array(|a| {
                    a.item().fixed3(-0.0004);
                    a.item().fixed3(-12.3456);
                    a.item().fixed3(f32::NAN);
                    a.item().fixed3(420.0);
                    a.item().fixed3(0.05);
                    a.item().fixed3(-1.0e12);
                });
                o.key("ip").ip(Ipv4Addr::new(10, 0, 0, 7));
                o.key("ep")
                    .endpoint(SocketAddrV4::new(Ipv4Addr::new(255, 1, 0, 9), 65535));
                o.key("i").int(i64::MIN);
                o.key("u").uint(u64::MAX);
                o.key("t").text(|t| {
                    t.str(b"HR").uint(5).str(b".").uint(50);
                });
                o.key("none").opt(None::<u64>, Value::uint);
                o.key("some").opt(Some(3), Value::uint);
                o.key("empty").object(|_| {});
                o.key("nested").array(|a| {
                    a.item().array(|_| {});
                    a.item().object(|o| o.key("k\"").bool(false));
                    a.item().null();
                });
            })
        });
        assert_eq!(
            s,
            r#"{"a":"Move\"L\\,??;","n":[0.000,-12.346,null,420.000,0.050,-999999995904.000],"ip":"10.0.0.7","ep":"255.1.0.9:65535","i":-9223372036854775808,"u":18446744073709551615,"t":"HR5.50","none":null,"some":3,"empty":{},"nested":[[],{"k\"":false},null]}"#
        );
    }

    #[test]
    fn windows_cut_the_same_document_anywhere() {
        let write = |v: Value<'_, '_>| {
            v.array(|a| {
                for i in 0..40u64 {
                    a.item().object(|o| {
                        o.key("i").uint(i * 7919);
                        o.key("s").str(b"\"\\x");
                    });
                }
            })
        };
        let mut counter = Out::new(&mut []);
        write(counter.value());
        let whole = doc(write);
        assert_eq!(counter.total(), whole.len());
        for w in [1, 7, 64, 511] {
            let mut joined = Vec::new();
            let mut buf = std::vec![0u8; w];
            loop {
                let mut out = Out::window(&mut buf, joined.len());
                write(out.value());
                assert_eq!(out.total(), whole.len());
                if out.written().is_empty() {
                    break;
                }
                assert_eq!(
                    out.dropped(),
                    joined.len() + out.written().len() < whole.len()
                );
                joined.extend_from_slice(out.written());
            }
            assert_eq!(std::str::from_utf8(&joined).unwrap(), whole, "window {w}");
        }
    }

    #[test]
    fn a_full_answer_is_an_error() {
        let long = [b'"'; ANSWER];
        assert_eq!(Json::value(|v| v.str(&long)).err(), Some(Full));
        let j = Json::value(|v| v.object(|o| o.key("ok").bool(true))).unwrap();
        assert_eq!(j.as_bytes(), br#"{"ok":true}"#);
    }

    #[test]
    fn a_failed_value_is_an_error() {
        let mut buf = [0u8; 64];
        let mut out = Out::new(&mut buf);
        out.value().object(|o| o.key("x").fail());
        assert!(out.failed());
        assert_eq!(out.result(), Err(Full));
        assert_eq!(out.written(), br#"{"x":null}"#);
    }
}
