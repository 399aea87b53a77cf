//! Word-at-a-time byte work: the next quote or backslash in a JSON string,
//! and the deframer's copy that drops stripped bytes.
//!
//! Both are inner loops of the DataSheet path (a ~2 KiB payload at up to
//! 20 Hz per port), and a byte-per-iteration loop was a large share of the
//! decode time. Here a machine word (4 bytes on Cortex-M, 8 on a PC) is
//! tested per step with the classic "has a zero byte" bit trick, with no
//! `unsafe` and no table. The `memchr` crate searches the same way (and
//! with SIMD on a PC), but it is not a dependency of this crate, does not
//! copy, and what is needed here is a few lines.

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
#[inline]
pub(crate) fn quote_or_backslash(hay: &[u8]) -> Option<usize> {
    find(
        hay,
        |w| zero_bytes(w ^ splat(b'"')) | zero_bytes(w ^ splat(b'\\')),
        |b| b == b'"' || b == b'\\',
    )
}

/// Non-zero when a byte of `w` is below 11: a NUL, `\t` or `\n` (or another
/// control byte, which the byte-by-byte path then keeps). Three operations
/// where testing the three bytes exactly takes ten.
const fn below_11(w: usize) -> usize {
    w.wrapping_sub(splat(11)) & !w & HI
}

/// Copies the bytes of `src` that are not NUL, `\n` or `\t` to the start of
/// `dst` and returns how many; the copy stops early only if `dst` is full.
/// Bytes of `dst` after the returned length may be overwritten.
///
/// Two words at a time, then one: words with no byte below 11 (no possible
/// stripped byte, tested in three operations) are stored whole; any other
/// word is copied byte by byte (each byte stored, the length grown only for
/// kept ones). The next word's position never depends on this one's
/// contents, so the processor can overlap the steps.
// Out of line: one copy however many deframers (one per `N`) use it.
#[inline(never)]
pub(crate) fn copy_kept(dst: &mut [u8], src: &[u8]) -> usize {
    let mut n = 0;
    let mut pairs = src.chunks_exact(2 * W);
    for pair in &mut pairs {
        let (a, b) = pair.split_at(W);
        let (mut x, mut y) = ([0u8; W], [0u8; W]);
        x.copy_from_slice(a);
        y.copy_from_slice(b);
        let (x, y) = (usize::from_le_bytes(x), usize::from_le_bytes(y));
        if below_11(x) | below_11(y) == 0 {
            if let Some(out) = dst.get_mut(n..n + 2 * W) {
                out.copy_from_slice(pair);
                n += 2 * W;
                continue;
            }
        }
        n = copy_word(dst, n, a, x);
        n = copy_word(dst, n, b, y);
    }
    let mut words = pairs.remainder().chunks_exact(W);
    for word in &mut words {
        let mut bytes = [0u8; W];
        bytes.copy_from_slice(word);
        n = copy_word(dst, n, word, usize::from_le_bytes(bytes));
    }
    copy_bytes(dst, n, words.remainder())
}

/// One word of [`copy_kept`], `w` its value: whole when it has no byte
/// below 11, else byte by byte.
#[inline]
fn copy_word(dst: &mut [u8], n: usize, word: &[u8], w: usize) -> usize {
    if below_11(w) == 0 {
        if let Some(out) = dst.get_mut(n..n + W) {
            out.copy_from_slice(word);
            return n + W;
        }
    }
    copy_bytes(dst, n, word)
}

/// [`copy_kept`] a byte at a time, appending at `dst[n..]`; the new length.
#[inline]
fn copy_bytes(dst: &mut [u8], mut n: usize, src: &[u8]) -> usize {
    for &b in src {
        let Some(slot) = dst.get_mut(n) else {
            break;
        };
        *slot = b;
        n += usize::from(!super::deframer::is_stripped(b));
    }
    n
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
                    }
                }
            }
        }
    }

    /// `copy_kept` against a plain filter: every length up to three words
    /// and a bit (single words, pairs and the tail), every placement of up
    /// to two stripped bytes and many random patterns, with room to spare
    /// and with exactly the room needed. Kept bytes include other control
    /// bytes, which the word test cannot tell from stripped ones.
    #[test]
    fn copy_kept_is_a_filter() {
        const LEN: usize = 3 * 8 + 4;
        // Kept bytes: printable ones (words of these take the whole-word
        // paths) and, in the random patterns, control bytes the word test
        // cannot tell from stripped ones.
        let kept = [b'a', b'Z', 0x80, b' ', 0xFF, b'0', b'~'];
        let controls = [0x01u8, 0x08, 0x0B, 0x0C, 0x1F];
        let stripped = [0u8, b'\n', b'\t'];
        let check = |src: &[u8]| {
            let want: heapless::Vec<u8, LEN> = src
                .iter()
                .copied()
                .filter(|&b| !matches!(b, 0 | b'\n' | b'\t'))
                .collect();
            let mut roomy = [0xEEu8; 64];
            let n = copy_kept(&mut roomy, src);
            assert_eq!(&roomy[..n], &want[..], "{src:?}");
            let mut tight = [0xEEu8; 64];
            let n = copy_kept(&mut tight[..want.len()], src);
            assert_eq!(&tight[..n], &want[..], "{src:?}");
        };
        let mut seed = 0x2545_f491_u32;
        for len in 0..=(3 * W + 4).min(LEN) {
            let base: heapless::Vec<u8, LEN> = (0..len).map(|i| kept[i % kept.len()]).collect();
            check(&base);
            for i in 0..len {
                for j in i..len {
                    let mut src = base.clone();
                    src[i] = stripped[i % 3];
                    src[j] = stripped[j % 3];
                    check(&src);
                }
            }
            for _ in 0..500 {
                let mut src = base.clone();
                for b in src.iter_mut() {
                    seed ^= seed << 13;
                    seed ^= seed >> 17;
                    seed ^= seed << 5;
                    match seed % 8 {
                        0 | 1 => *b = stripped[(seed >> 8) as usize % 3],
                        2 => *b = controls[(seed >> 8) as usize % controls.len()],
                        _ => {}
                    }
                }
                check(&src);
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
