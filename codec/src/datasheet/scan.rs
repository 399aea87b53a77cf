//! Word-at-a-time byte search: the next quote or backslash in a JSON string,
//! the next stripped byte in a payload.
//!
//! Both searches are the inner loops of the DataSheet path (a ~2 KiB payload
//! at up to 20 Hz per port), and a byte-per-iteration loop was a large share
//! of the decode time. Here a machine word (4 bytes on Cortex-M, 8 on a PC)
//! is tested per step with the classic "has a zero byte" bit trick, with no
//! `unsafe` and no table. The `memchr` crate does the same (and SIMD on a
//! PC), but it is not a dependency of this crate and the two searches
//! needed here are a few lines.

use core::mem::size_of;

/// Bytes per word.
const W: usize = size_of::<usize>();
/// `0x0101…01`.
const LO: usize = usize::MAX / 0xFF;
/// `0x8080…80`.
const HI: usize = LO << 7;

/// The high bit of each byte of `w` that is zero is set, and no bit below
/// the lowest zero byte: so `trailing_zeros() / 8` of a non-zero result is
/// the index (little-endian) of the first zero byte. (Bytes above the first
/// zero byte may be flagged wrongly; only the lowest flag is used.)
const fn zero_bytes(w: usize) -> usize {
    w.wrapping_sub(LO) & !w & HI
}

/// `b` in every byte of a word.
const fn splat(b: u8) -> usize {
    LO * b as usize
}

/// Index of the first byte of `hay` for which `hit` flags a word or `is`
/// holds, searching a word at a time; `hit` and `is` must agree.
#[inline(always)]
fn find(hay: &[u8], hit: impl Fn(usize) -> usize, is: impl Fn(u8) -> bool) -> Option<usize> {
    let mut chunks = hay.chunks_exact(W);
    let mut offset = 0;
    for chunk in &mut chunks {
        let Ok(bytes) = <[u8; W]>::try_from(chunk) else {
            break;
        };
        let m = hit(usize::from_le_bytes(bytes));
        if m != 0 {
            return Some(offset + (m.trailing_zeros() / 8) as usize);
        }
        offset += W;
    }
    let tail = hay.get(offset..).unwrap_or(&[]);
    tail.iter().position(|&b| is(b)).map(|i| offset + i)
}

/// Index of the first `"` or `\` in `hay`.
pub(crate) fn quote_or_backslash(hay: &[u8]) -> Option<usize> {
    find(
        hay,
        |w| zero_bytes(w ^ splat(b'"')) | zero_bytes(w ^ splat(b'\\')),
        |b| b == b'"' || b == b'\\',
    )
}

/// Index of the first NUL, `\n` or `\t` in `hay` (the bytes official
/// readers strip).
pub(crate) fn stripped(hay: &[u8]) -> Option<usize> {
    find(
        hay,
        |w| zero_bytes(w) | zero_bytes(w ^ splat(b'\n')) | zero_bytes(w ^ splat(b'\t')),
        super::deframer::is_stripped,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every position, every neighbour byte, every length around a word or
    /// two: the word search agrees with the plain one.
    #[test]
    fn agrees_with_a_plain_search() {
        let fillers = [b'a', 0x80, 0xFF, 0x01, b'"' ^ 1, b'\n' + 1, 0x7F];
        let targets = [b'"', b'\\', 0, b'\n', b'\t'];
        for len in 0..3 * W + 2 {
            for &fill in &fillers {
                for at in 0..=len {
                    for &t in &targets {
                        let mut hay = [fill; 3 * W + 2];
                        if let Some(slot) = hay.get_mut(at) {
                            *slot = t;
                        }
                        // A second target later, which must not win.
                        if let Some(slot) = hay.get_mut(at + 1 + at % 3) {
                            *slot = if t == b'"' { b'\\' } else { b'"' };
                        }
                        let hay = &hay[..len];
                        let q = hay.iter().position(|&b| b == b'"' || b == b'\\');
                        assert_eq!(quote_or_backslash(hay), q, "{hay:?}");
                        let s = hay.iter().position(|&b| matches!(b, 0 | b'\n' | b'\t'));
                        assert_eq!(stripped(hay), s, "{hay:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn zero_bytes_flags_the_first_zero_exactly() {
        // A 0x01 above a zero byte is flagged falsely by the trick; the
        // lowest flag is still the real zero.
        let w = usize::from_le_bytes({
            let mut b = [0x01u8; W];
            b[1] = 0;
            b
        });
        assert_eq!(zero_bytes(w).trailing_zeros() / 8, 1);
        assert_eq!(zero_bytes(splat(0x80)), 0);
        assert_eq!(zero_bytes(splat(0xFF)), 0);
    }
}
