//! Hex text, one implementation for the gateway and its platforms: session
//! tokens, the board's name from its MAC address, password hashes in the
//! Linux configuration file. Lowercase out, either case in. (The signed
//! image's key text is read by `hans_fw_image::key_from_hex`, a `const fn`
//! of the image crate, which depends on nothing of the gateway.)

/// The digit of the low four bits of `n`.
pub const fn digit(n: u8) -> u8 {
    match n & 15 {
        d @ 0..=9 => b'0' + d,
        d => b'a' + d - 10,
    }
}

/// The value of the hex digit `c`, `None` if it is none.
pub const fn value(c: u8) -> Option<u8> {
    match c {
        b'0'..=b'9' => Some(c - b'0'),
        b'a'..=b'f' => Some(c - b'a' + 10),
        b'A'..=b'F' => Some(c - b'A' + 10),
        _ => None,
    }
}

/// Writes `bytes` as hex into `out` (two digits a byte) and returns the
/// text; `None` when `out` is shorter than twice `bytes`.
pub fn encode<'a>(bytes: &[u8], out: &'a mut [u8]) -> Option<&'a str> {
    let out = out.get_mut(..bytes.len().checked_mul(2)?)?;
    for (pair, b) in out.chunks_exact_mut(2).zip(bytes) {
        if let [hi, lo] = pair {
            *hi = digit(b >> 4);
            *lo = digit(*b);
        }
    }
    core::str::from_utf8(out).ok()
}

/// Reads `text`, exactly two hex digits for each byte of `out`; `None` for
/// another length or a character that is not a hex digit.
pub fn decode(text: &[u8], out: &mut [u8]) -> Option<()> {
    if text.len() != out.len().checked_mul(2)? {
        return None;
    }
    for (b, pair) in out.iter_mut().zip(text.chunks_exact(2)) {
        let [hi, lo] = pair else { return None };
        *b = value(*hi)? << 4 | value(*lo)?;
    }
    Some(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_go_to_text_and_back() {
        let mut out = [0u8; 8];
        assert_eq!(
            encode(&[0x00, 0x9f, 0xa0, 0xff], &mut out),
            Some("009fa0ff")
        );
        assert_eq!(encode(&[1, 2, 3, 4, 5], &mut out), None, "too short");
        let mut back = [0u8; 4];
        assert_eq!(decode(b"009FA0ff", &mut back), Some(()));
        assert_eq!(back, [0x00, 0x9f, 0xa0, 0xff]);
        assert_eq!(decode(b"009fa0f", &mut back), None, "odd length");
        assert_eq!(decode(b"009fa0fg", &mut back), None, "not a digit");
        assert_eq!(decode(b"009fa0ff00", &mut back), None, "too long");
        for n in 0..=255u8 {
            assert_eq!(value(digit(n)), Some(n & 15));
        }
    }
}
