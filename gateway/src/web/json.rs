//! A JSON writer into a fixed buffer, for the API's answers.
//!
//! Written here rather than taken from serde-json-core because the answers
//! are streamed in parts straight from the gateway's state (each part
//! written under the state's lock into one small buffer, then sent as an
//! HTTP chunk): there is no value to serialize, and no room for a copy of
//! the state. Numbers are written without core's float formatting (which
//! would cost ~30 KiB of flash): fixed-point with three decimals.
//!
//! Strings are ASCII: a byte outside printable ASCII is written as `?`, so
//! a string of `n` bytes takes at most `2n + 2` characters.

use core::fmt::Write;
use core::net::{Ipv4Addr, SocketAddrV4};

/// Bytes of one part.
pub const PART: usize = 1024;

/// The buffer of a part ran out: the part is not sent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Full;

/// One part of a JSON document being written.
#[derive(Debug)]
pub struct Json {
    buf: heapless::String<PART>,
}

impl Default for Json {
    fn default() -> Self {
        Json::new()
    }
}

impl Json {
    /// An empty part.
    pub const fn new() -> Self {
        Json {
            buf: heapless::String::new(),
        }
    }

    /// What was written.
    pub fn as_bytes(&self) -> &[u8] {
        self.buf.as_bytes()
    }

    /// Starts again.
    pub fn clear(&mut self) {
        self.buf.clear();
    }

    /// Literal JSON (punctuation, keys written by the caller).
    pub fn raw(&mut self, s: &str) -> Result<&mut Self, Full> {
        self.buf.push_str(s).map_err(|_| Full)?;
        Ok(self)
    }

    /// `"key":`.
    pub fn key(&mut self, k: &str) -> Result<&mut Self, Full> {
        self.raw("\"")?.raw(k)?.raw("\":")
    }

    /// A string value (ASCII; other bytes as `?`).
    pub fn str(&mut self, s: &[u8]) -> Result<&mut Self, Full> {
        self.raw("\"")?;
        for &b in s {
            let escaped: &str = match b {
                b'"' => "\\\"",
                b'\\' => "\\\\",
                0x20..=0x7e => {
                    self.buf.push(char::from(b)).map_err(|_| Full)?;
                    continue;
                }
                _ => "?",
            };
            self.raw(escaped)?;
        }
        self.raw("\"")
    }

    /// An unsigned integer.
    pub fn uint(&mut self, v: u64) -> Result<&mut Self, Full> {
        write!(self.buf, "{v}").map_err(|_| Full)?;
        Ok(self)
    }

    /// A signed integer.
    pub fn int(&mut self, v: i64) -> Result<&mut Self, Full> {
        write!(self.buf, "{v}").map_err(|_| Full)?;
        Ok(self)
    }

    /// `true` or `false`.
    pub fn bool(&mut self, v: bool) -> Result<&mut Self, Full> {
        self.raw(if v { "true" } else { "false" })
    }

    /// A number with three decimals (`null` for NaN and infinities,
    /// magnitudes above 1e12 clamped).
    pub fn fixed3(&mut self, v: f32) -> Result<&mut Self, Full> {
        if !v.is_finite() {
            return self.raw("null");
        }
        let thousandths = (f64::from(v) * 1000.0).clamp(-1e15, 1e15);
        // Round half away from zero without libm.
        let t = if thousandths < 0.0 {
            (thousandths - 0.5) as i64
        } else {
            (thousandths + 0.5) as i64
        };
        let (sign, t) = if t < 0 { ("-", -t) } else { ("", t) };
        write!(self.buf, "{sign}{}.{:03}", t / 1000, t % 1000).map_err(|_| Full)?;
        Ok(self)
    }

    /// An address `"a.b.c.d"`.
    pub fn ip(&mut self, ip: Ipv4Addr) -> Result<&mut Self, Full> {
        let [a, b, c, d] = ip.octets();
        write!(self.buf, "\"{a}.{b}.{c}.{d}\"").map_err(|_| Full)?;
        Ok(self)
    }

    /// An endpoint `"a.b.c.d:port"`.
    pub fn endpoint(&mut self, e: SocketAddrV4) -> Result<&mut Self, Full> {
        let [a, b, c, d] = e.ip().octets();
        write!(self.buf, "\"{a}.{b}.{c}.{d}:{}\"", e.port()).map_err(|_| Full)?;
        Ok(self)
    }

    /// `null`.
    pub fn null(&mut self) -> Result<&mut Self, Full> {
        self.raw("null")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_written_as_json() {
        let mut j = Json::new();
        j.raw("{")
            .and_then(|j| j.key("a"))
            .and_then(|j| j.str(b"Move\"L\\,\x01\xff;"))
            .and_then(|j| j.raw(","))
            .and_then(|j| j.key("n"))
            .and_then(|j| j.fixed3(-0.0004))
            .and_then(|j| j.raw(","))
            .and_then(|j| j.fixed3(-12.3456))
            .and_then(|j| j.raw(","))
            .and_then(|j| j.fixed3(f32::NAN))
            .and_then(|j| j.raw(","))
            .and_then(|j| j.fixed3(420.0))
            .and_then(|j| j.raw(","))
            .and_then(|j| j.ip(Ipv4Addr::new(10, 0, 0, 7)))
            .and_then(|j| j.raw("}"))
            .unwrap();
        assert_eq!(
            core::str::from_utf8(j.as_bytes()).unwrap(),
            r#"{"a":"Move\"L\\,??;","n":0.000,-12.346,null,420.000,"10.0.0.7"}"#
        );
    }

    #[test]
    fn a_full_part_is_an_error_not_a_panic() {
        let mut j = Json::new();
        let long = [b'"'; PART];
        assert_eq!(j.str(&long).err(), Some(Full));
    }
}
