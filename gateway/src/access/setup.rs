//! The setup code: proof of presence for creating the first administrator.
//!
//! A device without an administrator is not open to whoever reaches it
//! first. The first administrator account is created with a one-time code
//! that only someone at the device can read:
//!
//! * Linux: printed at start on the terminal (the journal) and written to a
//!   file readable by its owner only (`hans-gateway --setup-code-file`);
//! * the QEMU board: handed in by the host at start, as the random seed is;
//! * the NUCLEO board: printed in the probe's log (RTT), which only someone
//!   with a debug probe on the board reads.
//!
//! The code is never served on any network port. It is valid while no
//! administrator exists, and a wrong one counts against the same rate limit
//! as a wrong password.

use core::fmt;

use subtle::ConstantTimeEq;

/// Characters of a code (without the dashes shown between groups of 4).
pub const SETUP_CODE_LEN: usize = 12;

/// The alphabet: digits and capitals without the ones read as each other
/// (0/O, 1/I/L), 32 symbols: a code carries 60 random bits.
const ALPHABET: &[u8; 32] = b"23456789ABCDEFGHJKMNPQRSTUVWXYZ_";

/// A one-time setup code.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct SetupCode([u8; SETUP_CODE_LEN]);

impl fmt::Debug for SetupCode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // Never in logs by accident (the platform prints it on purpose with
        // `Display`).
        f.write_str("SetupCode(..)")
    }
}

impl fmt::Display for SetupCode {
    /// `ABCD-EFGH-JKMN`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, group) in self.0.chunks(4).enumerate() {
            if i > 0 {
                f.write_str("-")?;
            }
            for &c in group {
                fmt::Write::write_char(f, char::from(c))?;
            }
        }
        Ok(())
    }
}

impl SetupCode {
    /// A code from random bytes (from the platform's random source: the
    /// operating system, the board's RNG, the host through semihosting).
    pub fn from_random(random: [u8; SETUP_CODE_LEN]) -> SetupCode {
        SetupCode(random.map(|b| ALPHABET.get(usize::from(b & 31)).copied().unwrap_or(b'2')))
    }

    /// Reads a code as typed: dashes and spaces are ignored, letters may be
    /// lower case. `None` unless 12 characters of the alphabet remain.
    pub fn parse(s: &[u8]) -> Option<SetupCode> {
        let mut out = [0u8; SETUP_CODE_LEN];
        let mut n = 0;
        for &c in s {
            if c == b'-' || c == b' ' {
                continue;
            }
            let c = c.to_ascii_uppercase();
            if !ALPHABET.contains(&c) {
                return None;
            }
            *out.get_mut(n)? = c;
            n += 1;
        }
        (n == SETUP_CODE_LEN).then_some(SetupCode(out))
    }

    /// The code as shown (`ABCD-EFGH-JKMN`), for logs without `core::fmt`
    /// (defmt).
    pub fn to_text(&self) -> heapless::String<{ SETUP_CODE_LEN + 2 }> {
        let mut s = heapless::String::new();
        for (i, &c) in self.0.iter().enumerate() {
            if i > 0 && i % 4 == 0 {
                let _ = s.push('-');
            }
            let _ = s.push(char::from(c));
        }
        s
    }

    /// `true` if `other` is this code; takes the same time wherever they
    /// differ.
    pub fn matches(&self, other: &SetupCode) -> bool {
        bool::from(self.0.ct_eq(&other.0))
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::string::ToString;

    #[test]
    fn a_code_reads_back_as_shown_and_as_typed() {
        let c = SetupCode::from_random(core::array::from_fn(|i| (i * 37) as u8));
        let shown = c.to_string();
        assert_eq!(shown.len(), 14);
        assert_eq!(shown.matches('-').count(), 2);
        assert_eq!(c.to_text().as_str(), shown);
        assert_eq!(SetupCode::parse(shown.as_bytes()), Some(c));
        let typed = shown.to_lowercase().replace('-', " ");
        assert!(SetupCode::parse(typed.as_bytes()).is_some_and(|t| t.matches(&c)));
        assert_eq!(std::format!("{c:?}"), "SetupCode(..)");
    }

    #[test]
    fn malformed_codes_are_refused() {
        assert_eq!(SetupCode::parse(b""), None);
        assert_eq!(SetupCode::parse(b"ABCD-EFGH-JKM"), None);
        assert_eq!(SetupCode::parse(b"ABCD-EFGH-JKMNP"), None);
        assert_eq!(
            SetupCode::parse(b"ABCD-EFGH-JKM0"),
            None,
            "0 is not in the alphabet"
        );
        let a = SetupCode::parse(b"ABCD-EFGH-JKMN").unwrap();
        let b = SetupCode::parse(b"ABCD-EFGH-JKMP").unwrap();
        assert!(!a.matches(&b));
    }
}
