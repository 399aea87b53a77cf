//! Typed values of a message as one line of text, for test vectors.
//!
//! Format: `name=value` pairs separated by spaces, in wire order. Integers and
//! decimals are written as the codec holds them (`420`, `-0.000`,
//! `0.00001`), texts quoted with Rust's escaping (`"TCP"`), arrays and lists
//! in brackets with their elements separated by spaces (`[0 1]`, nested for
//! point lists). Because decimals keep their written form, the line shows
//! exactly what the codec read.

use std::fmt::Write;

use hans_codec::{Decimal, Failure, Reply, Request, Response, Visitor};

/// A [`Visitor`] that writes the values it is shown.
#[derive(Debug, Default)]
pub struct Dump {
    out: String,
    /// One entry per open list: `true` until its first element.
    lists: Vec<bool>,
}

impl Dump {
    /// The text written so far.
    pub fn finish(self) -> String {
        self.out
    }

    fn sep(&mut self, name: &str) {
        let first = match self.lists.last_mut() {
            Some(first) => std::mem::replace(first, false),
            None => self.out.is_empty(),
        };
        if !first {
            self.out.push(' ');
        }
        if !name.is_empty() {
            self.out.push_str(name);
            self.out.push('=');
        }
    }
}

impl Visitor for Dump {
    fn int(&mut self, name: &str, v: i32) {
        self.sep(name);
        let _ = write!(self.out, "{v}");
    }
    fn num(&mut self, name: &str, v: Decimal) {
        self.sep(name);
        let _ = write!(self.out, "{v}");
    }
    fn text(&mut self, name: &str, v: &str) {
        self.sep(name);
        let _ = write!(self.out, "{v:?}");
    }
    fn begin_list(&mut self, name: &str) {
        self.sep(name);
        self.out.push('[');
        self.lists.push(true);
    }
    fn end_list(&mut self) {
        self.out.push(']');
        self.lists.pop();
    }
}

/// The values of a request.
pub fn request(r: &Request<'_>) -> String {
    let mut d = Dump::default();
    r.visit(&mut d);
    d.finish()
}

/// The values of a success reply.
pub fn response(r: &Response<'_>) -> String {
    let mut d = Dump::default();
    r.visit(&mut d);
    d.finish()
}

/// A failure reply: `name="..." code=<ErrorCode> detail="..."`.
pub fn failure(f: &Failure<'_>) -> String {
    format!("name={:?} code={:?} detail={:?}", f.name, f.code, f.detail)
}

/// Any reply: the values of a success, the parts of a failure, or the
/// fields of an `errorcmd` reply (`name="errorcmd" fields=["..."]`).
pub fn reply(r: &Reply<'_>) -> String {
    match r {
        Reply::Ok(resp) => response(resp),
        Reply::Fail(f) => failure(f),
        Reply::ErrorCmd(raw) => {
            let fields: Vec<String> = raw.fields().map(|f| format!("{f:?}")).collect();
            format!("name={:?} fields=[{}]", raw.name(), fields.join(" "))
        }
    }
}
