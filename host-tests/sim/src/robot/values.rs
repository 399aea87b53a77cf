//! Conversions between the codec's values (exact `Decimal`s, `i32` flags,
//! bounded lists) and the simulator's `f64` numbers, shared by the command
//! handlers.

use hans_codec::Decimal;

/// A number as the controller writes it: three decimals.
pub(super) fn dec(v: f64) -> Decimal {
    Decimal::from_f64(v, 3).unwrap_or(Decimal::ZERO)
}

/// [`dec`] of each value.
pub(super) fn decs<const N: usize>(v: [f64; N]) -> [Decimal; N] {
    v.map(dec)
}

/// A number from the wire.
pub(super) fn f(d: Decimal) -> f64 {
    d.to_f64()
}

/// [`f`] of each value.
pub(super) fn fs<const N: usize>(d: [Decimal; N]) -> [f64; N] {
    d.map(|x| x.to_f64())
}

/// A flag as the protocol writes it (0/1).
pub(super) fn b(v: bool) -> i32 {
    i32::from(v)
}

/// A bounded list of a reply from a slice (empty if it does not fit, which
/// the request's own bounds rule out).
pub(super) fn hv<T: Clone, const N: usize>(v: &[T]) -> heapless::Vec<T, N> {
    heapless::Vec::from_slice(v).unwrap_or_default()
}

/// An index from the wire (`usize::MAX` for a negative one, which every
/// lookup then misses).
pub(super) fn idx(v: i32) -> usize {
    usize::try_from(v).unwrap_or(usize::MAX)
}

/// Wraps an angle difference into -180..180.
pub(super) fn wrap(d: f64) -> f64 {
    (d + 180.0).rem_euclid(360.0) - 180.0
}
