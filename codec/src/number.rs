//! Exact decimal numbers, as the protocol writes them.
//!
//! Controllers reply with fixed decimals (`10.759`, `-0.000`, `10000000.000`,
//! sometimes `1.500000`) and clients send whatever their language prints
//! (`420`, `420.0`, `0.5`, `1e-05`, `1.0E-4`). [`Decimal`] keeps the digits and
//! the number of decimals exactly as read, so text → value → text is
//! byte-identical for every form a controller sends, including the sign of
//! `-0.000`.
//!
//! # Precision
//! A `Decimal` holds up to 19 significant digits (an unsigned 64-bit
//! coefficient) and up to [`MAX_SCALE`] decimals. Reading never rounds integer
//! digits: a number whose integer part does not fit is an error. Fractional
//! digits beyond what fits are dropped (truncated toward zero); no controller
//! or SDK sends that many. Exponent forms are normalised to plain decimals
//! (`1e-05` is written back as `0.00001`).
//!
//! Why not `f64`: core's float formatting costs ~14 KiB and float parsing
//! ~20 KiB of flash on Cortex-M, Cortex-M4F has no double-precision FPU, and a
//! float cannot tell `-0.000` from `0` or `1.5` from `1.500000`. This type
//! costs well under a kilobyte.
//!
//! # Reading: the grammar and its fast path
//! The syntax, `[+-]? (digits ["." digits?] | "." digits) ([eE] [+-]? digits)?`,
//! is defined once, with nom's byte-level combinators (`syntax` below, `()`
//! as error type), and everything it accepts is read through it.
//!
//! Plain numbers, `-? digits ("." digits?)?` with at most 19 digits, the only
//! form controllers reply with, also have a fast path (`plain_prefix`): one
//! loop that computes the value while it finds the number's end, used by
//! [`Decimal::parse`] and by the typed readers, which read a whole pose this
//! way without leaving the loop. nom's combinators find the digit runs first
//! and compute the value in a second pass, which measured 1.6 times as long
//! on a 24-value reply (and the reply must be read 5 times faster than a
//! naive `str::parse::<f64>` reader, `host-tests/benches`). The fast path
//! decides nothing on its own: whatever it does not take goes to the
//! grammar, and the tests below check, on every string of up to 6 bytes over
//! the number alphabet (alone and followed by other bytes) and on a million
//! random longer ones, that whenever the fast path reads a number, the
//! grammar reads the same bytes to the identical value.

use core::cmp::Ordering;
use core::fmt;

/// The largest number of decimals a [`Decimal`] keeps.
pub const MAX_SCALE: u8 = 18;

/// Powers of ten that fit in a `u64` (10^0 .. 10^19). Built at compile time;
/// the indexing below never runs on input.
#[allow(clippy::indexing_slicing)]
const POW10: [u64; 20] = {
    let mut t = [1u64; 20];
    let mut i = 1;
    while i < 20 {
        t[i] = t[i - 1] * 10;
        i += 1;
    }
    t
};

fn pow10(n: u8) -> Option<u64> {
    POW10.get(usize::from(n)).copied()
}

/// `(v / 10^n, v % 10^n)` by repeated subtraction of powers of ten.
///
/// Written by hand because Cortex-M has no 64-bit divide instruction: `/`
/// on `u64` links ~1 KiB of runtime division code, this loop is a few dozen
/// bytes and at most 9 × 20 iterations.
fn div_pow10(mut v: u64, n: u8) -> (u64, u64) {
    let mut q = 0u64;
    for (k, &p) in POW10.iter().enumerate().rev() {
        let Some(step) = k.checked_sub(usize::from(n)).and_then(|e| POW10.get(e)) else {
            break;
        };
        while v >= p {
            v -= p;
            q += step;
        }
    }
    (q, v)
}

/// The decimal digits of `v` (no leading zeros; `0` for zero), written into
/// `buf`. Coefficients that fit 32 bits (`-12345.678` and nearly every value
/// a robot sends) go through `itoa`'s `u32` path, which the writer links for
/// integer fields anyway and which divides in hardware on Cortex-M; larger
/// ones by subtracting powers of ten (see [`div_pow10`] for why).
fn write_digits(mut v: u64, buf: &mut [u8; 20]) -> &[u8] {
    if let Ok(small) = u32::try_from(v) {
        let mut b = itoa::Buffer::new();
        let digits = b.format(small).as_bytes();
        let out = buf.get_mut(..digits.len()).unwrap_or(&mut []);
        out.copy_from_slice(digits.get(..out.len()).unwrap_or(&[]));
        return out;
    }
    let mut n = 0;
    for (k, &p) in POW10.iter().enumerate().rev() {
        let mut d = b'0';
        while v >= p {
            v -= p;
            d += 1;
        }
        if d != b'0' || n > 0 || k == 0 {
            if let Some(slot) = buf.get_mut(n) {
                *slot = d;
            }
            n += 1;
        }
    }
    buf.get(..n).unwrap_or(&[])
}

/// An exact decimal number: sign, coefficient and number of decimals.
///
/// Equality and ordering are numeric (`1.5 == 1.500`, `-0.000 == 0`); use
/// [`Decimal::is_identical`] to compare the written form.
///
/// It occupies 12 bytes with 4-byte alignment: three words (coefficient low
/// and high, then scale and sign) keep copies of large replies cheap on
/// 32-bit targets.
#[derive(Clone, Copy, Default)]
pub struct Decimal {
    lo: u32,
    hi: u32,
    /// Bits 0-7: scale; bit 8: minus sign.
    meta: u32,
}

impl fmt::Debug for Decimal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "Decimal({self})")
    }
}

/// Why a text is not a number.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NumberError {
    /// Not of the form `[+-]digits[.digits][e[+-]digits]`.
    Syntax,
    /// The value does not fit (integer part over 19 digits, or an exponent
    /// that moves it out of range).
    OutOfRange,
    /// From [`Decimal::parse_exact`] only: the number has more significant
    /// fractional digits than a `Decimal` holds ([`Decimal::parse`] drops
    /// them).
    Inexact,
}

impl fmt::Display for NumberError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            NumberError::Syntax => f.write_str("not a number"),
            NumberError::OutOfRange => f.write_str("number out of range"),
            NumberError::Inexact => f.write_str("more digits than a Decimal holds"),
        }
    }
}

/// The pieces of a number as recognised by the grammar, still as text.
#[derive(Debug)]
pub(crate) struct Lexed<'a> {
    negative: bool,
    int: &'a [u8],
    frac: &'a [u8],
    exp_negative: bool,
    exp: &'a [u8],
}

/// The number grammar, in nom combinators over bytes:
///
/// ```text
/// number   = sign? mantissa exponent?
/// sign     = "+" | "-"
/// mantissa = digits ("." digits?)? | "." digits
/// exponent = ("e" | "E") sign? digits
/// ```
pub(crate) mod syntax {
    use nom::branch::alt;
    use nom::character::complete::{char, digit0, digit1};
    use nom::combinator::{all_consuming, opt};
    use nom::sequence::{pair, preceded};
    use nom::Parser;

    use super::Lexed;
    use crate::grammar::syntax::{In, Res};

    /// `sign?`: `true` for a minus sign.
    fn sign(i: In<'_>) -> Res<'_, bool> {
        opt(alt((char('-'), char('+'))))
            .map(|s| s == Some('-'))
            .parse(i)
    }

    /// `mantissa`: the integer and the fraction digits.
    fn mantissa(i: In<'_>) -> Res<'_, (In<'_>, In<'_>)> {
        alt((
            pair(digit1, opt(preceded(char('.'), digit0)))
                .map(|(int, frac): (In<'_>, Option<In<'_>>)| (int, frac.unwrap_or(&[]))),
            preceded(char('.'), digit1).map(|frac| (&b""[..], frac)),
        ))
        .parse(i)
    }

    /// `exponent?`: its sign and digits (none when absent).
    fn exponent(i: In<'_>) -> Res<'_, (bool, In<'_>)> {
        opt(preceded(alt((char('e'), char('E'))), pair(sign, digit1)))
            .map(|e| e.unwrap_or((false, &b""[..])))
            .parse(i)
    }

    /// `number`, at the start of `i`.
    pub(crate) fn number(i: In<'_>) -> Res<'_, Lexed<'_>> {
        (sign, mantissa, exponent)
            .map(|(negative, (int, frac), (exp_negative, exp))| Lexed {
                negative,
                int,
                frac,
                exp_negative,
                exp,
            })
            .parse(i)
    }

    /// `number`, the whole of `i` or nothing.
    pub(crate) fn whole(i: In<'_>) -> Option<Lexed<'_>> {
        all_consuming(number).parse(i).ok().map(|(_, l)| l)
    }
}

/// The fast path: a plain number `-? digits ("." digits?)?` at the start of
/// `b`, with at most 19 digits and [`MAX_SCALE`] decimals; its value and
/// length. `None` for anything else (`+`, a leading `.`, more digits, a sign
/// alone), which [`syntax`] then reads.
///
/// Controllers reply with such numbers only (`-0.000`, `970.143`), and a
/// 24-value reply spends most of its time here: nom's combinators find the
/// digit runs first and the value is computed in a second pass, which took
/// about 1.6 times as long as this path on the 24 values of the benchmark's
/// `ReadActPos` reply (a stand-alone timing of both). On every
/// input this path accepts, [`syntax::number`] reads the same bytes to the
/// identical value: `fast_path_agrees_with_the_grammar` below checks every
/// string of up to 6 bytes over the number alphabet (alone and followed by
/// more bytes) and a million random longer ones.
#[inline]
pub(crate) fn plain_prefix(b: &[u8]) -> Option<(Decimal, &[u8])> {
    let (negative, b) = match b {
        [b'-', rest @ ..] => (true, rest),
        _ => (false, b),
    };
    let (int, rest) = digit_run(0, b);
    let int_len = b.len() - rest.len();
    if int_len == 0 {
        return None;
    }
    let (coeff, rest, scale) = match rest {
        [b'.', frac @ ..] => {
            let (coeff, rest) = digit_run(int, frac);
            (coeff, rest, frac.len() - rest.len())
        }
        _ => (int, rest, 0),
    };
    // Checked before the value is used: with at most 19 digits the
    // wrapping arithmetic of `digit_run` never wrapped, and as there is at
    // least one integer digit, at most 18 of them are decimals (MAX_SCALE).
    if int_len + scale > 19 {
        return None;
    }
    Some((Decimal::make(negative, coeff, scale as u8), rest))
}

/// The digits at the start of `b` appended to `value` (wrapping beyond 19
/// digits), and what follows them. One byte per step: runs are short
/// (`970.143`), and a loop whose exit the processor predicts lets it start
/// on the next field before this one is done; classifying eight bytes at
/// once (SWAR) measured slower, as each step then waits for the previous
/// run's length.
#[inline]
fn digit_run(mut value: u64, mut b: &[u8]) -> (u64, &[u8]) {
    while let [c, rest @ ..] = b {
        let d = c.wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        value = value.wrapping_mul(10).wrapping_add(u64::from(d));
        b = rest;
    }
    (value, b)
}

impl Decimal {
    #[inline]
    const fn make(negative: bool, coeff: u64, scale: u8) -> Self {
        Decimal {
            lo: coeff as u32,
            hi: (coeff >> 32) as u32,
            meta: scale as u32 | if negative { 0x100 } else { 0 },
        }
    }

    #[inline]
    const fn coeff(&self) -> u64 {
        self.coefficient()
    }

    #[inline]
    const fn negative(&self) -> bool {
        self.is_sign_negative()
    }

    /// Zero, written `0`.
    pub const ZERO: Decimal = Decimal::make(false, 0, 0);

    /// Builds a decimal from its parts: `(-1)^negative × coeff × 10^-scale`.
    ///
    /// Returns `None` when `scale` exceeds [`MAX_SCALE`].
    pub const fn from_parts(negative: bool, coeff: u64, scale: u8) -> Option<Self> {
        if scale > MAX_SCALE {
            return None;
        }
        Some(Decimal::make(negative, coeff, scale))
    }

    /// An integer, written without decimals.
    pub const fn from_int(v: i64) -> Self {
        Decimal::make(v < 0, v.unsigned_abs(), 0)
    }

    /// A value in thousandths, written with three decimals as controllers do
    /// (`from_milli(-1181)` is `-1.181`).
    pub const fn from_milli(v: i64) -> Self {
        Decimal::make(v < 0, v.unsigned_abs(), 3)
    }

    /// Parses one number in any of the forms clients send: `420`, `-0`,
    /// `420.0`, `.5`, `5.`, `+1`, `1e-05`, `1.0E-4`. Surrounding spaces are
    /// not accepted here (the grammar trims fields before).
    pub fn parse(text: &str) -> Result<Self, NumberError> {
        Self::parse_bytes(text.as_bytes())
    }

    /// Like [`Decimal::parse`], on bytes.
    pub fn parse_bytes(text: &[u8]) -> Result<Self, NumberError> {
        match plain_prefix(text) {
            Some((d, [])) => Ok(d),
            _ => Self::parse_general(text),
        }
    }

    /// Like [`Decimal::parse`], but a number whose digits do not all fit
    /// (see the module's Precision section) is [`NumberError::Inexact`]
    /// instead of being truncated: for tools that must say when a value
    /// was not kept exactly.
    pub fn parse_exact(text: &str) -> Result<Self, NumberError> {
        match plain_prefix(text.as_bytes()) {
            Some((d, [])) => Ok(d),
            _ => match Self::lexed(text.as_bytes())? {
                (d, true) => Ok(d),
                (_, false) => Err(NumberError::Inexact),
            },
        }
    }

    /// The grammar's path, for everything the fast path leaves.
    #[inline(never)]
    fn parse_general(text: &[u8]) -> Result<Self, NumberError> {
        Self::lexed(text).map(|(d, _)| d)
    }

    /// The grammar's reading of `text`, and whether every digit was kept.
    fn lexed(text: &[u8]) -> Result<(Self, bool), NumberError> {
        let lexed = syntax::whole(text).ok_or(NumberError::Syntax)?;
        Self::from_lexed(&lexed)
    }

    /// The value, and `false` if nonzero digits were dropped to fit it.
    fn from_lexed(l: &Lexed<'_>) -> Result<(Self, bool), NumberError> {
        // Exponent: anything beyond four digits is out of range for us.
        let mut exp: i32 = 0;
        for &d in l.exp {
            exp = exp * 10 + i32::from(d - b'0');
            if exp > 9999 {
                return Err(NumberError::OutOfRange);
            }
        }
        if l.exp_negative {
            exp = -exp;
        }
        let mut coeff: u64 = 0;
        let mut overflowed = false;
        for &d in l.int {
            coeff = coeff
                .checked_mul(10)
                .and_then(|c| c.checked_add(u64::from(d - b'0')))
                .ok_or(NumberError::OutOfRange)?;
        }
        // Decimals written, before the exponent shifts them.
        let mut frac_kept: i32 = 0;
        let mut exact = true;
        for &d in l.frac {
            match coeff
                .checked_mul(10)
                .and_then(|c| c.checked_add(u64::from(d - b'0')))
            {
                Some(c) if !overflowed => {
                    coeff = c;
                    frac_kept += 1;
                }
                _ => {
                    overflowed = true;
                    exact &= d == b'0';
                }
            }
        }
        // value = coeff × 10^(exp - frac_kept)
        let mut scale = frac_kept - exp;
        while scale < 0 {
            coeff = coeff.checked_mul(10).ok_or(NumberError::OutOfRange)?;
            scale += 1;
        }
        while scale > i32::from(MAX_SCALE) {
            if coeff == 0 {
                scale = i32::from(MAX_SCALE);
                break;
            }
            // Dropping a digit that is not there would change the value.
            if scale - i32::from(MAX_SCALE) > 19 {
                return Err(NumberError::OutOfRange);
            }
            let (q, dropped) = div_pow10(coeff, 1);
            exact &= dropped == 0;
            coeff = q;
            scale -= 1;
        }
        Ok((Decimal::make(l.negative, coeff, scale as u8), exact))
    }

    /// `true` when the number is written with a minus sign (also `-0.000`).
    #[inline]
    pub const fn is_sign_negative(&self) -> bool {
        self.meta & 0x100 != 0
    }

    /// The coefficient: the written digits without sign and decimal point.
    #[inline]
    pub const fn coefficient(&self) -> u64 {
        (self.hi as u64) << 32 | self.lo as u64
    }

    /// The number of decimals written.
    #[inline]
    pub const fn scale(&self) -> u8 {
        (self.meta & 0xff) as u8
    }

    /// `true` when the value is zero (`0`, `-0`, `0.000`).
    pub const fn is_zero(&self) -> bool {
        self.coeff() == 0
    }

    /// `true` when both are written identically (same sign, digits and number
    /// of decimals), unlike `==` which compares values.
    pub const fn is_identical(&self, other: &Decimal) -> bool {
        self.coeff() == other.coeff()
            && self.scale() == other.scale()
            && self.negative() == other.negative()
    }

    /// The value as an `f64` (nearest representable).
    pub fn to_f64(&self) -> f64 {
        let div = pow10(self.scale()).unwrap_or(1) as f64;
        let v = self.coeff() as f64 / div;
        if self.negative() {
            -v
        } else {
            v
        }
    }

    /// The value as an `f32` (nearest representable, computed in single
    /// precision on the FPU of a Cortex-M4F for values under 2^24).
    pub fn to_f32(&self) -> f32 {
        let div = pow10(self.scale()).unwrap_or(1) as f32;
        let v = self.coeff() as f32 / div;
        if self.negative() {
            -v
        } else {
            v
        }
    }

    /// The value if it is a whole number that fits an `i64` (`5`, `5.000`,
    /// `-0`).
    #[inline]
    pub fn to_i64(&self) -> Option<i64> {
        // Integers as written (`5`, `-0`) need no division.
        let (whole, frac) = match self.scale() {
            0 => (self.coeff(), 0),
            s => div_pow10(self.coeff(), s),
        };
        if frac != 0 {
            return None;
        }
        let whole = i64::try_from(whole).ok()?;
        Some(if self.negative() { -whole } else { whole })
    }

    /// The value in units of 10^-`scale`, rounded half away from zero
    /// (`to_scaled(3)` gives thousandths). `None` if it does not fit.
    pub fn to_scaled(&self, scale: u8) -> Option<i64> {
        let c = if scale >= self.scale() {
            self.coeff().checked_mul(pow10(scale - self.scale())?)?
        } else {
            let div = pow10(self.scale() - scale)?;
            let (q, r) = div_pow10(self.coeff(), self.scale() - scale);
            if r.checked_mul(2)? >= div {
                q + 1
            } else {
                q
            }
        };
        let v = i64::try_from(c).ok()?;
        Some(if self.negative() { -v } else { v })
    }

    /// Rounds `v` to `scale` decimals (half away from zero). `None` for NaN,
    /// infinities, values over ~1.8e19 at that scale, or `scale` over
    /// [`MAX_SCALE`]. Negative values that round to zero keep their sign
    /// (`-0.000`), as controllers print them.
    pub fn from_f64(v: f64, scale: u8) -> Option<Self> {
        if !v.is_finite() || scale > MAX_SCALE {
            return None;
        }
        let scaled = (if v < 0.0 { -v } else { v }) * pow10(scale)? as f64 + 0.5;
        if scaled >= 18_446_744_073_709_551_615.0 {
            return None;
        }
        Some(Decimal::make(v.is_sign_negative(), scaled as u64, scale))
    }

    /// Like [`Decimal::from_f64`], for `f32` (single-precision arithmetic).
    pub fn from_f32(v: f32, scale: u8) -> Option<Self> {
        if !v.is_finite() || scale > MAX_SCALE {
            return None;
        }
        let scaled = (if v < 0.0 { -v } else { v }) * pow10(scale)? as f32 + 0.5;
        if scaled >= 18_446_744_073_709_551_615.0 {
            return None;
        }
        Some(Decimal::make(v.is_sign_negative(), scaled as u64, scale))
    }

    /// This value written with exactly `scale` decimals (rounding half away
    /// from zero when decimals are removed). `None` if it does not fit.
    pub fn rescale(&self, scale: u8) -> Option<Self> {
        if scale > MAX_SCALE {
            return None;
        }
        let scaled = self.to_scaled(scale)?;
        Some(Decimal::make(self.negative(), scaled.unsigned_abs(), scale))
    }

    /// Writes the canonical text (`-0.000`, `10.759`, `420`) into `out` and
    /// returns the number of bytes written, or `None` if `out` is too small.
    /// At most [`Decimal::MAX_TEXT`] bytes are ever needed.
    pub fn write_to(&self, out: &mut [u8]) -> Option<usize> {
        let mut digit_buf = [0u8; 20];
        let d = write_digits(self.coeff(), &mut digit_buf);
        let scale = usize::from(self.scale());
        // Leading zeros needed so that there is one digit before the point.
        let pad = (scale + 1).saturating_sub(d.len());
        let int_len = d.len() + pad - scale;
        let total = usize::from(self.negative()) + d.len() + pad + usize::from(scale > 0);
        let out = out.get_mut(..total)?;
        let mut w = 0;
        let mut put = |b: u8| {
            if let Some(slot) = out.get_mut(w) {
                *slot = b;
            }
            w += 1;
        };
        if self.negative() {
            put(b'-');
        }
        let mut all = core::iter::repeat_n(b'0', pad).chain(d.iter().copied());
        for _ in 0..int_len {
            put(all.next().unwrap_or(b'0'));
        }
        if scale > 0 {
            put(b'.');
            for b in all {
                put(b);
            }
        }
        Some(total)
    }

    /// The longest text [`Decimal::write_to`] produces.
    pub const MAX_TEXT: usize = 1 + 20 + 1 + MAX_SCALE as usize;

    /// Parses a literal at compile time; used for the ranges of the command
    /// table. Invalid literals fail the build, never a running program
    /// (every call site is a `const`).
    #[allow(clippy::indexing_slicing)]
    pub(crate) const fn lit(s: &str) -> Decimal {
        let b = s.as_bytes();
        let mut i = 0;
        let negative = !b.is_empty() && b[0] == b'-';
        if negative {
            i = 1;
        }
        let mut coeff: u64 = 0;
        let mut scale: u8 = 0;
        let mut seen_point = false;
        while i < b.len() {
            let c = b[i];
            if c == b'.' {
                seen_point = true;
            } else {
                assert!(c.is_ascii_digit(), "invalid decimal literal");
                coeff = coeff * 10 + (c - b'0') as u64;
                if seen_point {
                    scale += 1;
                }
            }
            i += 1;
        }
        Decimal::make(negative, coeff, scale)
    }

    fn cmp_value(&self, other: &Decimal) -> Ordering {
        let a_neg = self.negative() && self.coeff() != 0;
        let b_neg = other.negative() && other.coeff() != 0;
        match (a_neg, b_neg) {
            (false, true) => return Ordering::Greater,
            (true, false) => return Ordering::Less,
            _ => {}
        }
        // Compare magnitudes at a common scale: a coefficient below 2^64
        // times at most 10^18 fits a u128 exactly.
        let s = self.scale().max(other.scale());
        let at =
            |d: &Decimal| u128::from(d.coeff()) * u128::from(pow10(s - d.scale()).unwrap_or(1));
        let mag = at(self).cmp(&at(other));
        if a_neg {
            mag.reverse()
        } else {
            mag
        }
    }
}

impl PartialEq for Decimal {
    fn eq(&self, other: &Self) -> bool {
        self.cmp_value(other) == Ordering::Equal
    }
}

impl Eq for Decimal {}

impl PartialOrd for Decimal {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Decimal {
    fn cmp(&self, other: &Self) -> Ordering {
        self.cmp_value(other)
    }
}

impl fmt::Display for Decimal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut buf = [0u8; Decimal::MAX_TEXT];
        let n = self.write_to(&mut buf).unwrap_or(0);
        // Only ASCII digits, '-' and '.' are ever written.
        f.write_str(core::str::from_utf8(buf.get(..n).unwrap_or(b"")).unwrap_or(""))
    }
}

impl core::str::FromStr for Decimal {
    type Err = NumberError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Decimal::parse(s)
    }
}

impl From<i32> for Decimal {
    fn from(v: i32) -> Self {
        Decimal::from_int(i64::from(v))
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Decimal {
    fn format(&self, f: defmt::Formatter<'_>) {
        let mut buf = [0u8; Decimal::MAX_TEXT];
        let n = self.write_to(&mut buf).unwrap_or(0);
        defmt::write!(
            f,
            "{=str}",
            core::str::from_utf8(buf.get(..n).unwrap_or(b"")).unwrap_or("")
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn text(d: Decimal) -> heapless::String<48> {
        let mut s = heapless::String::new();
        let _ = core::fmt::write(&mut s, format_args!("{d}"));
        s
    }

    #[test]
    fn controller_forms_round_trip_exactly() {
        for t in [
            "10.759",
            "-0.000",
            "10000000.000",
            "1.500000",
            "0",
            "-12.50",
            "0.05",
            "420",
            "18446744073709551615",
        ] {
            assert_eq!(text(Decimal::parse(t).unwrap()).as_str(), t);
        }
    }

    #[test]
    fn client_forms_are_read() {
        let cases = [
            ("420.0", "420.0"),
            ("1e-05", "0.00001"),
            ("1.0E-4", "0.00010"),
            ("+5", "5"),
            (".5", "0.5"),
            ("5.", "5"),
            ("2.5e2", "250"),
            ("-0", "-0"),
        ];
        for (i, o) in cases {
            assert_eq!(text(Decimal::parse(i).unwrap()).as_str(), o, "{i}");
        }
    }

    #[test]
    fn bad_numbers_are_errors() {
        for t in [
            "", "-", ".", "e5", "1e", "1.2.3", "0x10", "inf", "NaN", " 1", "1 ",
        ] {
            assert_eq!(Decimal::parse(t), Err(NumberError::Syntax), "{t:?}");
        }
        assert_eq!(
            Decimal::parse("123456789012345678901"),
            Err(NumberError::OutOfRange)
        );
        assert_eq!(Decimal::parse("1e99999"), Err(NumberError::OutOfRange));
        assert_eq!(Decimal::parse("1e-40"), Err(NumberError::OutOfRange));
        assert_eq!(Decimal::parse("0e-40"), Ok(Decimal::ZERO));
    }

    #[test]
    fn parse_exact_refuses_what_parse_truncates() {
        // Kept exactly: both agree.
        for t in [
            "10.759",
            "-0.000",
            "1e-05",
            "0.100000000000000000000000",
            "0e-40",
        ] {
            assert_eq!(Decimal::parse_exact(t), Decimal::parse(t), "{t:?}");
        }
        // Digits dropped: parse truncates, parse_exact says so.
        for (t, truncated) in [
            ("1.23456789012345678901", "1.234567890123456789"),
            ("0.0000000000000000015", "0.000000000000000001"),
            ("123e-20", "0.000000000000000001"),
        ] {
            assert_eq!(
                Decimal::parse(t).map(text),
                Ok(text(Decimal::parse(truncated).unwrap_or(Decimal::ZERO))),
                "{t:?}"
            );
            assert_eq!(Decimal::parse_exact(t), Err(NumberError::Inexact), "{t:?}");
        }
        // Other errors are the same.
        assert_eq!(Decimal::parse_exact("x"), Err(NumberError::Syntax));
        assert_eq!(
            Decimal::parse_exact("1e99999"),
            Err(NumberError::OutOfRange)
        );
    }

    /// What the grammar makes of `b`: the length of the number at its start
    /// and its value.
    fn by_grammar(b: &[u8]) -> Option<(usize, Result<Decimal, NumberError>)> {
        let (rest, lexed) = syntax::number(b).ok()?;
        Some((
            b.len() - rest.len(),
            Decimal::from_lexed(&lexed).map(|(d, _)| d),
        ))
    }

    /// Checks the fast path on `b` against the grammar: whenever it reads a
    /// number, the grammar reads the same bytes to the identical value, or
    /// (after `5.`/`5`) goes on with an exponent, which the fast path's
    /// callers refuse because the next byte is neither `,` nor the end.
    fn check_agreement(b: &[u8]) {
        let Some((fast, rest)) = plain_prefix(b) else {
            return;
        };
        let n = b.len() - rest.len();
        let (m, general) = by_grammar(b).unwrap_or_else(|| panic!("{:?}", b));
        if m != n {
            assert!(matches!(b.get(n), Some(b'e' | b'E')), "{:?}: {n} vs {m}", b);
        } else {
            assert!(general.unwrap().is_identical(&fast), "{:?}", b);
        }
        let (len, whole) = by_grammar(&b[..n]).unwrap();
        assert_eq!(len, n, "{:?}", b);
        assert!(whole.unwrap().is_identical(&fast), "{:?}", b);
        // And through the public entry point, which takes the fast path.
        assert!(Decimal::parse_bytes(&b[..n]).unwrap().is_identical(&fast));
    }

    #[test]
    fn fast_path_agrees_with_the_grammar() {
        // Every string of up to 6 bytes over the number alphabet (and `,`,
        // which ends a field), alone and followed by digits or other bytes.
        const ALPHABET: &[u8] = b"-+.e09,1";
        let mut buf = [0u8; 6 + 9];
        for len in 0..=6 {
            let total = ALPHABET.len().pow(len as u32);
            for mut k in 0..total {
                for slot in buf[..len].iter_mut() {
                    *slot = ALPHABET[k % ALPHABET.len()];
                    k /= ALPHABET.len();
                }
                check_agreement(&buf[..len]);
                for pad in [b"123456789", b",x;123456", b".12345678"] {
                    buf[len..len + 9].copy_from_slice(pad);
                    check_agreement(&buf[..len + 9]);
                }
            }
        }
        // A million random longer ones, mostly digits (xorshift: the same
        // inputs on every run).
        let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        let mut long = [0u8; 26];
        for _ in 0..1_000_000 {
            let len = (next() % 27) as usize;
            for slot in long[..len].iter_mut() {
                let r = next();
                *slot = match r % 16 {
                    0 => b'-',
                    1 => b'.',
                    2 => ALPHABET[(r >> 8) as usize % ALPHABET.len()],
                    _ => b'0' + (r >> 8) as u8 % 10,
                };
            }
            check_agreement(&long[..len]);
        }
    }

    #[test]
    fn fast_path_takes_what_controllers_send() {
        for t in [
            "10.759",
            "-0.000",
            "10000000.000",
            "1.500000",
            "0",
            "420",
            "5.",
        ] {
            let (_, rest) = plain_prefix(t.as_bytes()).unwrap();
            assert!(rest.is_empty(), "{t}");
        }
        for t in [
            "+5",
            ".5",
            "-",
            "",
            "12345678901234567890",
            "0.1234567890123456789",
        ] {
            assert!(plain_prefix(t.as_bytes()).is_none(), "{t}");
        }
    }

    #[test]
    fn equality_is_numeric() {
        assert_eq!(
            Decimal::parse("1.5").unwrap(),
            Decimal::parse("1.500").unwrap()
        );
        assert_eq!(Decimal::parse("-0.000").unwrap(), Decimal::ZERO);
        assert!(Decimal::parse("-1").unwrap() < Decimal::parse("-0.5").unwrap());
        assert!(!Decimal::parse("-0.000")
            .unwrap()
            .is_identical(&Decimal::ZERO));
    }

    #[test]
    fn conversions() {
        let d = Decimal::parse("-1.181").unwrap();
        assert_eq!(d.to_scaled(3), Some(-1181));
        assert_eq!(d.to_scaled(1), Some(-12));
        assert_eq!(d.to_f64(), -1.181);
        assert_eq!(
            Decimal::from_f64(-0.0004, 3).map(text).unwrap().as_str(),
            "-0.000"
        );
        assert_eq!(
            Decimal::from_f64(445.0, 3).map(text).unwrap().as_str(),
            "445.000"
        );
        assert_eq!(Decimal::from_f64(f64::NAN, 3), None);
        assert_eq!(Decimal::parse("5.000").unwrap().to_i64(), Some(5));
        assert_eq!(Decimal::parse("5.5").unwrap().to_i64(), None);
        assert_eq!(text(Decimal::from_milli(-1181)).as_str(), "-1.181");
        assert_eq!(text(Decimal::lit("0.01")).as_str(), "0.01");
    }
}
