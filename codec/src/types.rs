//! Parameter types of the command table and how each reads and writes.
//!
//! | type | wire fields | used for |
//! |---|---|---|
//! | `i32` | 1 | the document's `int` parameters; also reads `5.0` and `-0` |
//! | [`Decimal`] | 1 | `double` parameters, exact |
//! | `&str` | 1 | names (`TCP`, `Base`, track names, command ids) |
//! | [`RobotId`] | 1 | `nRbtID`; a message without it reads as robot 0 |
//! | `[T; N]` | N | poses (`[Decimal; 6]` = X, Y, Z mm, Rx, Ry, Rz °), joints, masks |
//! | `Option<T>` | 0 or width of T | trailing optional parameters (`MoveRelL`'s `nToolMotion`) |
//! | `heapless::Vec<T, N>` | 1..=N (rest of message) | bit-index lists, reply value lists |
//! | [`CountedList`] | count + count values | `WriteHoldingRegisters` data |
//! | [`PointList`] | count + 6 × count values | `PushMovePaths` points, borrowed |
//! | [`TextList`] | 0.. (rest of message) | `RunFunc` / `HRAppCmd` parameters, borrowed |
//! | [`ValueGroups`] | N × groups (rest of message) | `PushPathPoints` points, calibration samples, borrowed |
//! | [`FreeText`] | the rest of the message, commas included | `GetErrorCodeStr`'s text, borrowed |
//!
//! Lenient reading: an empty numeric field reads as 0 (the document sends
//! unused parameters as 0 and the Java SDK sends them empty).

use core::fmt;

use crate::error::{Expected, Got};
use crate::grammar::{Cursor, Fields};
use crate::number::Decimal;
use crate::writer::{is_carriable, Writer};

/// A Cartesian pose: X, Y, Z in mm, Rx, Ry, Rz in degrees.
pub type Pose = [Decimal; 6];
/// Six joint values J1..J6 (degrees, °/s, °/s², A, as the command says).
pub type Joints = [Decimal; 6];

/// Receives the typed values of a message, parameter by parameter, in wire
/// order. Used to print messages generically (`hansctl decode` writes JSON
/// with it); arrays and lists arrive between `begin_list` and `end_list`
/// with an empty name for each element.
pub trait Visitor {
    /// An integer parameter.
    fn int(&mut self, name: &str, v: i32);
    /// A decimal parameter.
    fn num(&mut self, name: &str, v: Decimal);
    /// A text parameter.
    fn text(&mut self, name: &str, v: &str);
    /// The start of an array or list parameter.
    fn begin_list(&mut self, name: &str);
    /// The end of the current array or list.
    fn end_list(&mut self);
}

/// The valid range of a parameter, from the document's tables.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Range {
    /// An integer in `min..=max`.
    Int {
        /// Smallest valid value.
        min: i32,
        /// Largest valid value.
        max: i32,
    },
    /// A number in `min..=max`.
    Num {
        /// Smallest valid value.
        min: Decimal,
        /// Largest valid value.
        max: Decimal,
    },
    /// A number of at least `min` (the document's `>=`).
    AtLeast(Decimal),
    /// A number strictly above `min` (the document's `>`).
    Above(Decimal),
    /// One of two numbers (the document's `2/3`).
    Either(Decimal, Decimal),
}

impl Range {
    /// `true` when `v` is inside the range.
    pub fn contains(&self, v: Decimal) -> bool {
        match *self {
            Range::Int { min, max } => {
                v >= Decimal::from(min) && v <= Decimal::from(max) && v.to_i64().is_some()
            }
            Range::Num { min, max } => v >= min && v <= max,
            Range::AtLeast(min) => v >= min,
            Range::Above(min) => v > min,
            Range::Either(a, b) => v == a || v == b,
        }
    }

    /// `true` when both are the same range, written the same; `const`, for
    /// the range table the compiler builds (`catalogue::packing`).
    pub(crate) const fn same(&self, other: &Range) -> bool {
        match (self, other) {
            (Range::Int { min: a, max: b }, Range::Int { min: c, max: d }) => *a == *c && *b == *d,
            (Range::Num { min: a, max: b }, Range::Num { min: c, max: d })
            | (Range::Either(a, b), Range::Either(c, d)) => a.is_identical(c) && b.is_identical(d),
            (Range::AtLeast(a), Range::AtLeast(c)) | (Range::Above(a), Range::Above(c)) => {
                a.is_identical(c)
            }
            _ => false,
        }
    }
}

impl fmt::Display for Range {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Range::Int { min, max } => write!(f, "{min}..={max}"),
            Range::Num { min, max } => write!(f, "{min}..={max}"),
            Range::AtLeast(m) => write!(f, ">= {m}"),
            Range::Above(m) => write!(f, "> {m}"),
            Range::Either(a, b) => write!(f, "{a} or {b}"),
        }
    }
}

/// Table shorthand: integers `min..=max`.
pub(crate) const fn int(min: i32, max: i32) -> Range {
    Range::Int { min, max }
}
/// Table shorthand: numbers `min..=max`.
pub(crate) const fn num(min: &str, max: &str) -> Range {
    Range::Num {
        min: Decimal::lit(min),
        max: Decimal::lit(max),
    }
}
/// Table shorthand: numbers `>= min`.
pub(crate) const fn at_least(min: &str) -> Range {
    Range::AtLeast(Decimal::lit(min))
}
/// Table shorthand: numbers `> min`.
pub(crate) const fn above(min: &str) -> Range {
    Range::Above(Decimal::lit(min))
}
/// Table shorthand: one of two numbers.
pub(crate) const fn either(a: &str, b: &str) -> Range {
    Range::Either(Decimal::lit(a), Decimal::lit(b))
}

/// A parameter of a command, as its position in the table: request
/// parameters count from 0, the reply's values follow them. Readers and
/// writers pass this one byte around instead of the parameter's name (a
/// pointer and a length at every one of ~1,200 call sites cost ~5 KiB of
/// flash); the name is looked up only when an error is reported (see
/// `catalogue::packing`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Param(pub(crate) u8);

impl Param {
    /// A field of a message this crate does not know (named `field`).
    pub(crate) const RAW: Param = Param(u8::MAX);
}

/// How one parameter type reads, writes and shows itself.
///
/// Reading and writing never return errors: the first error is recorded in
/// the [`Cursor`] / [`Writer`] (a default value is returned) and reported
/// once at the end of the message. That keeps the code the table generates
/// per parameter to one call, which is what makes 139 commands fit in a few
/// kilobytes of flash.
///
/// Range checks have no code of their own: a [`Writer`] in checking mode
/// walks the same `write` calls and checks each number against its
/// parameter's range from the table (`Request::validate`).
pub(crate) trait Field<'a>: Sized {
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self;
    /// The value of a field not read yet (zero, empty).
    const BLANK: Self;
    /// Reads the field into `self`, in place.
    #[inline]
    fn read_in(&mut self, c: &mut Cursor<'_, 'a>, param: Param) {
        *self = Self::read(c, param);
    }
    /// Reads `out.len()` values in a row (the elements of an array).
    fn read_slice(c: &mut Cursor<'_, 'a>, param: Param, out: &mut [Self]) {
        for slot in out.iter_mut() {
            *slot = Self::read(c, param);
        }
    }
    fn write(&self, w: &mut Writer<'_>, param: Param);
    fn visit(&self, name: &str, v: &mut dyn Visitor);
}

/// Reads a decimal: plain numbers through the cursor's fast path, the
/// rest (and every error) through the grammar.
#[inline(never)]
fn read_num<'a>(c: &mut Cursor<'_, 'a>, param: Param) -> Decimal {
    match c.take_plain() {
        Some(d) => d,
        None => read_num_general(c, param),
    }
}

#[inline(never)]
fn read_num_general<'a>(c: &mut Cursor<'_, 'a>, param: Param) -> Decimal {
    match c.next_field() {
        None => c.fail(param, Expected::Number, Got::End),
        Some("") => {}
        Some(f) => match Decimal::parse(f) {
            Ok(d) => return d,
            Err(_) => c.fail(param, Expected::Number, Got::Field(f)),
        },
    }
    Decimal::ZERO
}

/// Reads an integer: a whole number that fits an `i32`, also written with
/// decimals (`5.000`) or as `-0`.
#[inline(never)]
fn read_int<'a>(c: &mut Cursor<'_, 'a>, param: Param) -> i32 {
    // A plain number that is no i32 is left for the general reader, which
    // reports it with the field's text.
    match c.take_plain_as(|d| d.to_i64().and_then(|v| i32::try_from(v).ok())) {
        Some(v) => v,
        None => read_int_general(c, param),
    }
}

#[inline(never)]
fn read_int_general<'a>(c: &mut Cursor<'_, 'a>, param: Param) -> i32 {
    match c.next_field() {
        None => c.fail(param, Expected::Integer, Got::End),
        Some("") => {}
        Some(f) => match Decimal::parse(f)
            .ok()
            .and_then(|d| d.to_i64())
            .and_then(|v| i32::try_from(v).ok())
        {
            Some(v) => return v,
            None => c.fail(param, Expected::Integer, Got::Field(f)),
        },
    }
    0
}

/// Reads a count field (`nRegCount`, `nPointsSize`): an integer in
/// `min..=max`. A count out of range is reported with its own text
/// (`at least 1, got "0"`), not as a list length.
#[inline(never)]
fn read_count<'a>(c: &mut Cursor<'_, 'a>, param: Param, min: u16, max: u16) -> Option<u16> {
    let Some(f) = c.next_field() else {
        c.fail(param, Expected::Integer, Got::End);
        return None;
    };
    match Decimal::parse(f).ok().and_then(|d| d.to_i64()) {
        None => c.fail(param, Expected::Integer, Got::Field(f)),
        Some(v) if v < i64::from(min) => c.fail(param, Expected::AtLeast(min), Got::Field(f)),
        Some(v) if v > i64::from(max) => c.fail(param, Expected::AtMost(max), Got::Field(f)),
        Some(v) => return u16::try_from(v).ok(),
    }
    None
}

impl<'a> Field<'a> for i32 {
    const BLANK: Self = 0;
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        read_int(c, param)
    }
    fn write(&self, w: &mut Writer<'_>, param: Param) {
        w.int_at(*self, param)
    }
    fn visit(&self, name: &str, v: &mut dyn Visitor) {
        v.int(name, *self)
    }
}

impl<'a> Field<'a> for Decimal {
    const BLANK: Self = Decimal::ZERO;
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        read_num(c, param)
    }
    #[cfg_attr(not(target_os = "none"), inline)]
    fn read_slice(c: &mut Cursor<'_, 'a>, param: Param, out: &mut [Self]) {
        let mut rest = out;
        loop {
            let plain = c.plain_numbers(rest);
            let Some((slot, tail)) = rest.get_mut(plain..).and_then(|r| r.split_first_mut()) else {
                break;
            };
            *slot = read_num_general(c, param);
            rest = tail;
        }
    }
    fn write(&self, w: &mut Writer<'_>, param: Param) {
        w.num_at(self, param)
    }
    fn visit(&self, name: &str, v: &mut dyn Visitor) {
        v.num(name, *self)
    }
}

impl<'a> Field<'a> for &'a str {
    const BLANK: Self = "";
    #[inline(never)]
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        match c.next_field() {
            Some(f) => f,
            None => {
                c.fail(param, Expected::Text, Got::End);
                ""
            }
        }
    }
    fn write(&self, w: &mut Writer<'_>, param: Param) {
        w.text_at(self, param)
    }
    fn visit(&self, name: &str, v: &mut dyn Visitor) {
        v.text(name, self)
    }
}

/// `nRbtID`, the robot (axis group) id, 0-5; 0 on single-arm controllers.
///
/// Some SDKs omit it (`ReadBoxInfo,;`): a message that ends where the robot id
/// should be reads as robot 0. It is always written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct RobotId(pub i32);

impl<'a> Field<'a> for RobotId {
    const BLANK: Self = RobotId(0);
    #[inline(never)]
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        if c.at_end() {
            return RobotId(0);
        }
        RobotId(read_int(c, param))
    }
    fn write(&self, w: &mut Writer<'_>, param: Param) {
        w.int_at(self.0, param)
    }
    fn visit(&self, name: &str, v: &mut dyn Visitor) {
        v.int(name, self.0)
    }
}

impl<'a, T: Field<'a> + Copy, const N: usize> Field<'a> for [T; N] {
    const BLANK: Self = [T::BLANK; N];
    #[inline(never)]
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        let mut out = [T::BLANK; N];
        T::read_slice(c, param, &mut out);
        out
    }
    #[cfg_attr(not(target_os = "none"), inline)]
    #[cfg_attr(target_os = "none", inline(never))]
    fn read_in(&mut self, c: &mut Cursor<'_, 'a>, param: Param) {
        T::read_slice(c, param, self)
    }
    #[inline(never)]
    fn write(&self, w: &mut Writer<'_>, param: Param) {
        self.iter().for_each(|e| e.write(w, param))
    }
    fn visit(&self, name: &str, v: &mut dyn Visitor) {
        v.begin_list(name);
        self.iter().for_each(|e| e.visit("", v));
        v.end_list();
    }
}

impl<'a, T: Field<'a>> Field<'a> for Option<T> {
    const BLANK: Self = None;
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        (!c.at_end()).then(|| T::read(c, param))
    }
    fn write(&self, w: &mut Writer<'_>, param: Param) {
        if let Some(t) = self {
            t.write(w, param)
        }
    }
    fn visit(&self, name: &str, v: &mut dyn Visitor) {
        if let Some(t) = self {
            t.visit(name, v)
        }
    }
}

/// Checks that a list of `n` fields may follow: what the reply must have
/// (from the request), at least one, at most `cap`.
fn list_len_ok(c: &mut Cursor<'_, '_>, param: Param, n: u16, cap: u16) -> bool {
    if let Some(want) = c.expected_len() {
        if n != want {
            c.fail(param, Expected::Exactly(want), Got::Count(n));
            return false;
        }
    }
    if n == 0 {
        c.fail(param, Expected::AtLeast(1), Got::End);
        return false;
    }
    if n > cap {
        c.fail(param, Expected::AtMost(cap), Got::Count(n));
        return false;
    }
    true
}

/// A list of 1..=N values taking the rest of the message. In a reply to a
/// request that says how many values come back (`ReadBoxDI,5,6,;` expects
/// two), exactly that many are required.
impl<'a, T: Field<'a>, const N: usize> Field<'a> for heapless::Vec<T, N> {
    const BLANK: Self = heapless::Vec::new();
    #[inline(never)]
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        let mut out = heapless::Vec::new();
        let n = c.remaining();
        if list_len_ok(c, param, n, u16::try_from(N).unwrap_or(u16::MAX)) {
            while !c.at_end() {
                // The length was checked against N above.
                let _ = out.push(T::read(c, param));
            }
        }
        out
    }
    #[inline(never)]
    fn write(&self, w: &mut Writer<'_>, param: Param) {
        self.iter().for_each(|e| e.write(w, param))
    }
    fn visit(&self, name: &str, v: &mut dyn Visitor) {
        v.begin_list(name);
        self.iter().for_each(|e| e.visit("", v));
        v.end_list();
    }
}

/// A count field followed by exactly that many values, 1..=N
/// (`WriteHoldingRegisters`: `nRegCount` then the register values).
///
/// The count is not stored: it is the length of the list, so the two can
/// never disagree.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct CountedList<T, const N: usize>(pub heapless::Vec<T, N>);

impl<T: Clone, const N: usize> CountedList<T, N> {
    /// A list from a slice; `None` if it holds more than N values.
    pub fn from_slice(values: &[T]) -> Option<Self> {
        heapless::Vec::from_slice(values).ok().map(CountedList)
    }

    /// The values.
    pub fn as_slice(&self) -> &[T] {
        &self.0
    }
}

impl<'a, T: Field<'a>, const N: usize> Field<'a> for CountedList<T, N> {
    const BLANK: Self = CountedList(heapless::Vec::new());
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        let mut out = heapless::Vec::new();
        let cap = u16::try_from(N).unwrap_or(u16::MAX);
        if let Some(n) = read_count(c, param, 1, cap) {
            let got = c.remaining();
            if got != n {
                c.fail(param, Expected::Exactly(n), Got::Count(got));
            } else {
                for _ in 0..n {
                    // At most `cap` = N values: the push cannot fail.
                    let _ = out.push(T::read(c, param));
                }
            }
        }
        CountedList(out)
    }
    fn write(&self, w: &mut Writer<'_>, param: Param) {
        if self.0.is_empty() {
            w.fail_list_too_long(param);
        }
        w.int(i32::try_from(self.0.len()).unwrap_or(i32::MAX));
        self.0.write(w, param)
    }
    fn visit(&self, name: &str, v: &mut dyn Visitor) {
        self.0.visit(name, v)
    }
}

/// Where a borrowed list's elements are: still in the message text, or in
/// the caller's slice when building a message to send.
#[derive(Clone, Copy)]
enum ListRepr<'a, T: 'a> {
    Wire { text: &'a str, count: u16 },
    Slice(&'a [T]),
}

/// Text parameters taking the rest of the message (`RunFunc`'s and
/// `HRAppCmd`'s parameter lists), borrowed: no copy, no capacity limit other
/// than the message buffer.
#[derive(Clone, Copy)]
pub struct TextList<'a>(ListRepr<'a, &'a str>);

impl<'a> TextList<'a> {
    /// A list to send, from the caller's texts.
    pub const fn new(items: &'a [&'a str]) -> Self {
        TextList(ListRepr::Slice(items))
    }

    /// The number of texts.
    pub fn len(&self) -> usize {
        match self.0 {
            ListRepr::Wire { count, .. } => usize::from(count),
            ListRepr::Slice(s) => s.len(),
        }
    }

    /// `true` when there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The texts, trimmed as the reader trims fields.
    pub fn iter(&self) -> impl Iterator<Item = &'a str> + 'a {
        let (mut wire, mut slice) = match self.0 {
            ListRepr::Wire { text, count } => ((count > 0).then(|| Fields::of(text)), [].iter()),
            ListRepr::Slice(s) => (None, s.iter()),
        };
        core::iter::from_fn(move || match &mut wire {
            Some(fields) => fields.next(),
            None => slice.next().copied(),
        })
    }
}

impl Default for TextList<'_> {
    fn default() -> Self {
        TextList(ListRepr::Slice(&[]))
    }
}

impl fmt::Debug for TextList<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl PartialEq for TextList<'_> {
    fn eq(&self, other: &Self) -> bool {
        self.len() == other.len() && self.iter().eq(other.iter())
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for TextList<'_> {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "[");
        for (i, t) in self.iter().enumerate() {
            if i > 0 {
                defmt::write!(f, ", ");
            }
            defmt::write!(f, "{=str}", t);
        }
        defmt::write!(f, "]");
    }
}

fn rest_text<'a>(c: &mut Cursor<'_, 'a>, param: Param) -> (&'a str, u16) {
    match c.take_rest() {
        Some(r) => r,
        None => {
            c.fail(param, Expected::Text, Got::End);
            ("", 0)
        }
    }
}

impl<'a> Field<'a> for TextList<'a> {
    const BLANK: Self = TextList(ListRepr::Slice(&[]));
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        let (text, count) = rest_text(c, param);
        TextList(ListRepr::Wire { text, count })
    }
    fn write(&self, w: &mut Writer<'_>, param: Param) {
        self.iter().for_each(|t| w.text_at(t, param))
    }
    fn visit(&self, name: &str, v: &mut dyn Visitor) {
        v.begin_list(name);
        self.iter().for_each(|t| v.text("", t));
        v.end_list();
    }
}

/// `PushMovePaths` points: `nPointsSize` followed by six values per point
/// (joints or a pose, as `nMoveType` says), borrowed from the message. Any
/// number of points up to what the message buffer holds; every value is
/// checked when the message is read.
#[derive(Clone, Copy)]
pub struct PointList<'a>(ListRepr<'a, [Decimal; 6]>);

impl<'a> PointList<'a> {
    /// A list to send, from the caller's points.
    pub const fn new(points: &'a [[Decimal; 6]]) -> Self {
        PointList(ListRepr::Slice(points))
    }

    /// The number of points.
    pub fn len(&self) -> usize {
        match self.0 {
            ListRepr::Wire { count, .. } => usize::from(count),
            ListRepr::Slice(s) => s.len(),
        }
    }

    /// `true` when there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The points.
    pub fn iter(&self) -> impl Iterator<Item = [Decimal; 6]> + 'a {
        let (wire, slice) = match self.0 {
            ListRepr::Wire { text, count } => {
                let mut values = Fields::of(text).map(|f| match f {
                    "" => Decimal::ZERO,
                    t => Decimal::parse(t).unwrap_or(Decimal::ZERO),
                });
                let points = core::iter::from_fn(move || {
                    let mut p = [Decimal::ZERO; 6];
                    for slot in p.iter_mut() {
                        *slot = values.next()?;
                    }
                    Some(p)
                })
                .take(usize::from(count));
                (Some(points), None)
            }
            ListRepr::Slice(s) => (None, Some(s.iter().copied())),
        };
        wire.into_iter()
            .flatten()
            .chain(slice.into_iter().flatten())
    }
}

impl Default for PointList<'_> {
    fn default() -> Self {
        PointList(ListRepr::Slice(&[]))
    }
}

impl fmt::Debug for PointList<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl PartialEq for PointList<'_> {
    fn eq(&self, other: &Self) -> bool {
        self.len() == other.len() && self.iter().eq(other.iter())
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for PointList<'_> {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "{=usize} points", self.len());
    }
}

impl<'a> Field<'a> for PointList<'a> {
    const BLANK: Self = PointList(ListRepr::Slice(&[]));
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        let Some(count) = read_count(c, param, 0, u16::MAX) else {
            return PointList::default();
        };
        let want = u32::from(count) * 6;
        let got = c.remaining();
        if u32::from(got) != want {
            c.fail(
                param,
                Expected::Exactly(u16::try_from(want).unwrap_or(u16::MAX)),
                Got::Count(got),
            );
            return PointList::default();
        }
        // Check every value now, so that iterating later cannot meet garbage.
        let mut probe = c.clone();
        while !probe.at_end() {
            read_num(&mut probe, param);
        }
        if let Err(e) = probe.finish() {
            c.record(e);
            return PointList::default();
        }
        let (text, _) = rest_text(c, param);
        PointList(ListRepr::Wire { text, count })
    }
    fn write(&self, w: &mut Writer<'_>, param: Param) {
        match i32::try_from(self.len()) {
            Ok(n) => w.int(n),
            Err(_) => w.fail_list_too_long(param),
        }
        self.iter().for_each(|p| p.write(w, param))
    }
    fn visit(&self, name: &str, v: &mut dyn Visitor) {
        v.begin_list(name);
        self.iter().for_each(|p| p.visit("", v));
        v.end_list();
    }
}

/// Numbers taking the rest of the message in groups of `N`, without a count
/// field, borrowed from the message (`PushPathPoints`: six values per point;
/// `SetFTCalibration`: twelve per sample; `MovePathJOL`: nineteen per
/// point). At least one group; every value is checked when the message is
/// read.
#[derive(Clone, Copy)]
pub struct ValueGroups<'a, const N: usize>(ListRepr<'a, [Decimal; N]>);

impl<'a, const N: usize> ValueGroups<'a, N> {
    /// A list to send, from the caller's groups.
    pub const fn new(groups: &'a [[Decimal; N]]) -> Self {
        ValueGroups(ListRepr::Slice(groups))
    }

    /// The number of groups.
    pub fn len(&self) -> usize {
        match self.0 {
            ListRepr::Wire { count, .. } => usize::from(count),
            ListRepr::Slice(s) => s.len(),
        }
    }

    /// `true` when there are none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The groups.
    pub fn iter(&self) -> impl Iterator<Item = [Decimal; N]> + 'a {
        let (wire, slice) = match self.0 {
            ListRepr::Wire { text, count } => {
                let mut values = Fields::of(text).map(|f| match f {
                    "" => Decimal::ZERO,
                    t => Decimal::parse(t).unwrap_or(Decimal::ZERO),
                });
                let groups = core::iter::from_fn(move || {
                    let mut g = [Decimal::ZERO; N];
                    for slot in g.iter_mut() {
                        *slot = values.next()?;
                    }
                    Some(g)
                })
                .take(usize::from(count));
                (Some(groups), None)
            }
            ListRepr::Slice(s) => (None, Some(s.iter().copied())),
        };
        wire.into_iter()
            .flatten()
            .chain(slice.into_iter().flatten())
    }
}

impl<const N: usize> Default for ValueGroups<'_, N> {
    fn default() -> Self {
        ValueGroups(ListRepr::Slice(&[]))
    }
}

impl<const N: usize> fmt::Debug for ValueGroups<'_, N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

impl<const N: usize> PartialEq for ValueGroups<'_, N> {
    fn eq(&self, other: &Self) -> bool {
        self.len() == other.len() && self.iter().eq(other.iter())
    }
}

#[cfg(feature = "defmt")]
impl<const N: usize> defmt::Format for ValueGroups<'_, N> {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "{=usize} groups of {=usize}", self.len(), N);
    }
}

impl<'a, const N: usize> Field<'a> for ValueGroups<'a, N> {
    const BLANK: Self = ValueGroups(ListRepr::Slice(&[]));
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        let got = c.remaining();
        let n = u16::try_from(N).unwrap_or(u16::MAX);
        if got == 0 {
            c.fail(param, Expected::AtLeast(n), Got::End);
            return ValueGroups::default();
        }
        if !got.is_multiple_of(n) {
            c.fail(param, Expected::MultipleOf(n), Got::Count(got));
            return ValueGroups::default();
        }
        // Check every value now, so that iterating later cannot meet garbage.
        let mut probe = c.clone();
        while !probe.at_end() {
            read_num(&mut probe, param);
        }
        if let Err(e) = probe.finish() {
            c.record(e);
            return ValueGroups::default();
        }
        let (text, _) = rest_text(c, param);
        ValueGroups(ListRepr::Wire {
            text,
            count: got / n,
        })
    }
    fn write(&self, w: &mut Writer<'_>, param: Param) {
        if self.is_empty() {
            w.fail_list_too_long(param);
        }
        self.iter().for_each(|g| g.write(w, param))
    }
    fn visit(&self, name: &str, v: &mut dyn Visitor) {
        v.begin_list(name);
        self.iter().for_each(|g| g.visit("", v));
        v.end_list();
    }
}

/// A text taking the rest of the message, commas included, borrowed
/// (`GetErrorCodeStr`'s reply: the controller's own explanation of an
/// error code, which may contain commas). Trimmed at its ends; empty when
/// the message ends first. Written as read (an empty text as one empty
/// field).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct FreeText<'a>(&'a str);

impl<'a> FreeText<'a> {
    /// A text to send: printable ASCII without `;` and without spaces at
    /// its ends (checked when written).
    pub const fn new(text: &'a str) -> Self {
        FreeText(text)
    }

    /// The text.
    pub const fn as_str(&self) -> &'a str {
        self.0
    }
}

impl fmt::Display for FreeText<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.0)
    }
}

impl<'a> Field<'a> for FreeText<'a> {
    const BLANK: Self = FreeText("");
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        let (text, _) = rest_text(c, param);
        FreeText(crate::grammar::trim(text))
    }
    fn write(&self, w: &mut Writer<'_>, param: Param) {
        let t = self.0;
        let ok = t.bytes().all(|b| (0x20..0x7f).contains(&b) && b != b';')
            && !t.starts_with(' ')
            && !t.ends_with(' ');
        if ok {
            // An empty text is one empty field, as an empty name is.
            w.raw_field(t);
        } else {
            w.fail_invalid_text(param);
        }
    }
    fn visit(&self, name: &str, v: &mut dyn Visitor) {
        v.text(name, self.0)
    }
}

/// An error code as a parameter (`GetErrorCodeStr` request, path states).
impl<'a> Field<'a> for crate::error::ErrorCode {
    const BLANK: Self = crate::error::ErrorCode::Unknown(0);
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        Self::from(read_int(c, param))
    }
    fn write(&self, w: &mut Writer<'_>, param: Param) {
        w.int_at(self.code(), param)
    }
    fn visit(&self, name: &str, v: &mut dyn Visitor) {
        v.int(name, self.code())
    }
}

/// The FSM state as a parameter (`ReadCurFSM` reply).
impl<'a> Field<'a> for crate::fsm::FsmState {
    const BLANK: Self = crate::fsm::FsmState::UnInitialize;
    fn read(c: &mut Cursor<'_, 'a>, param: Param) -> Self {
        Self::from(read_int(c, param))
    }
    fn write(&self, w: &mut Writer<'_>, _: Param) {
        w.int(self.code())
    }
    fn visit(&self, name: &str, v: &mut dyn Visitor) {
        v.int(name, self.code())
    }
}

/// `true` if the text is acceptable as a text parameter on output.
pub fn is_valid_text(s: &str) -> bool {
    is_carriable(s)
}
