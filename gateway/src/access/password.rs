//! An account's password, kept as a salted PBKDF2-HMAC-SHA256 hash.
//!
//! The derivation is written here on top of the `hmac` and `sha2` crates
//! rather than taken from the `pbkdf2` crate, for one reason: it yields to
//! the executor every `YIELD_EVERY` rounds. The [`ITERATIONS`] rounds
//! take some 100 ms on a Cortex-M7 (more under QEMU), and the robot link,
//! the watchdog and the Modbus sessions share the executor: they must not
//! wait that long. The tests check it against the RFC 7914 vectors and the
//! `pbkdf2` crate.

use hmac::{KeyInit, Mac};
use subtle::ConstantTimeEq;

type HmacSha256 = hmac::Hmac<sha2::Sha256>;

/// Bytes of salt.
pub const SALT_LEN: usize = 16;
/// Bytes of the derived hash.
pub const HASH_LEN: usize = 32;
/// PBKDF2 rounds for new passwords (a stored hash keeps its own count).
pub const ITERATIONS: u32 = 10_000;
/// Rounds of a password set now. In fuzz builds (`cfg(fuzzing)`, set by
/// cargo-fuzz) 10, so that the web target tries thousands of requests a
/// second instead of spending them in the hash; the code is the same, and a
/// stored hash is always checked with its own round count.
const NEW_ITERATIONS: u32 = if cfg!(fuzzing) { 10 } else { ITERATIONS };
/// Rounds between two yields to the executor.
pub(crate) const YIELD_EVERY: u32 = 200;
/// Shortest password accepted (IEC 62443-4-2 CR 1.7: the policy's
/// minimum length).
#[cfg(feature = "web")]
pub(crate) const MIN_LEN: usize = 10;
/// Longest password accepted.
pub(crate) const MAX_LEN: usize = 64;
/// Bytes of [`PasswordHash::to_bytes`].
pub(crate) const STORED_LEN: usize = 4 + SALT_LEN + HASH_LEN;

/// Why a new password is refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg(feature = "web")]
pub(crate) enum PasswordError {
    /// Shorter than [`MIN_LEN`] characters.
    TooShort,
    /// Longer than [`MAX_LEN`] characters.
    TooLong,
    /// A character outside printable ASCII (space to `~`).
    NotPrintable,
    /// One character repeated (ten spaces, `aaaaaaaaaa`).
    Repeated,
    /// One of the most common passwords (a short deny-list: the first
    /// guesses of every attacker).
    Common,
    /// The account's own name is in it.
    Name,
}

#[cfg(feature = "web")]
impl PasswordError {
    /// A text for the page.
    pub(crate) fn as_str(self) -> &'static str {
        match self {
            PasswordError::TooShort => "at least 10 characters",
            PasswordError::TooLong => "at most 64 characters",
            PasswordError::NotPrintable => "printable ASCII characters only",
            PasswordError::Repeated => "not one character repeated",
            PasswordError::Common => "one of the most common passwords: choose another",
            PasswordError::Name => "the account's name may not be in it",
        }
    }
}

/// The most common passwords of 10 characters and more (from the public
/// lists of leaked passwords: the first guesses of any attacker), compared
/// ignoring case. Short on purpose: the policy's length, and the rate
/// limit of guesses, do the rest.
#[cfg(feature = "web")]
const COMMON: [&[u8]; 24] = [
    b"1234567890",
    b"0123456789",
    b"0987654321",
    b"12345678910",
    b"123456789a",
    b"1q2w3e4r5t",
    b"1qaz2wsx3edc",
    b"qwertyuiop",
    b"qwerty1234",
    b"qwerty123456",
    b"asdfghjkl;",
    b"password12",
    b"password123",
    b"password1!",
    b"password1234",
    b"passw0rd123",
    b"iloveyou12",
    b"letmein123",
    b"welcome123",
    b"changeme123",
    b"administrator",
    b"admin12345",
    b"adminadmin",
    b"abcdefghij",
];

/// Checks a new password of the account named `name` against the rules:
/// 10 to 64 printable ASCII characters, not one character repeated (which
/// also refuses spaces only), not one of the most common passwords, and
/// not holding the account's name (ignoring case).
#[cfg(feature = "web")]
pub(crate) fn check_new(password: &[u8], name: &[u8]) -> Result<(), PasswordError> {
    if password.len() < MIN_LEN {
        return Err(PasswordError::TooShort);
    }
    if password.len() > MAX_LEN {
        return Err(PasswordError::TooLong);
    }
    if !password.iter().all(|b| (b' '..=b'~').contains(b)) {
        return Err(PasswordError::NotPrintable);
    }
    if password.iter().all(|b| Some(b) == password.first()) {
        return Err(PasswordError::Repeated);
    }
    if COMMON.iter().any(|c| c.eq_ignore_ascii_case(password)) {
        return Err(PasswordError::Common);
    }
    let holds_name = !name.is_empty()
        && password
            .windows(name.len())
            .any(|w| w.eq_ignore_ascii_case(name));
    if holds_name {
        return Err(PasswordError::Name);
    }
    Ok(())
}

/// A stored password: PBKDF2-HMAC-SHA256 of it with a random salt.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PasswordHash {
    /// PBKDF2 rounds.
    pub iterations: u32,
    /// Random salt.
    pub salt: [u8; SALT_LEN],
    /// The derived key.
    pub hash: [u8; HASH_LEN],
}

impl PasswordHash {
    /// Hashes `password` with `salt` (random: from the gateway's generator).
    pub async fn new(password: &[u8], salt: [u8; SALT_LEN]) -> PasswordHash {
        PasswordHash {
            iterations: NEW_ITERATIONS,
            salt,
            hash: derive(password, &salt, NEW_ITERATIONS).await,
        }
    }

    /// `true` if `password` is the one hashed. The comparison takes the
    /// same time wherever the first difference is.
    pub async fn verify(&self, password: &[u8]) -> bool {
        if password.len() > MAX_LEN {
            return false;
        }
        let h = derive(password, &self.salt, self.iterations).await;
        bool::from(h.ct_eq(&self.hash))
    }

    /// The stored form: rounds (little-endian), salt, hash.
    pub fn to_bytes(self) -> [u8; STORED_LEN] {
        let mut out = [0u8; STORED_LEN];
        let (it, rest) = out.split_at_mut(4);
        it.copy_from_slice(&self.iterations.to_le_bytes());
        let (salt, hash) = rest.split_at_mut(SALT_LEN);
        salt.copy_from_slice(&self.salt);
        hash.copy_from_slice(&self.hash);
        out
    }

    /// Reads the stored form; `None` if the rounds are 0 or out of reason
    /// (above 10 × the 10,000 rounds of a new password: a damaged image must not stall the
    /// gateway for minutes at each login).
    pub fn from_bytes(b: &[u8; STORED_LEN]) -> Option<PasswordHash> {
        let (it, rest) = b.split_at(4);
        let (salt, hash) = rest.split_at(SALT_LEN);
        let iterations = u32::from_le_bytes(it.try_into().ok()?);
        if iterations == 0 || iterations > 10 * ITERATIONS {
            return None;
        }
        Some(PasswordHash {
            iterations,
            salt: salt.try_into().ok()?,
            hash: hash.try_into().ok()?,
        })
    }
}

/// PBKDF2-HMAC-SHA256 with one 32-byte block (RFC 8018, 5.2), yielding
/// every [`YIELD_EVERY`] rounds.
pub(crate) async fn derive(password: &[u8], salt: &[u8], iterations: u32) -> [u8; HASH_LEN] {
    // HMAC accepts keys of any length (longer ones are hashed first).
    let Ok(prf) = HmacSha256::new_from_slice(password) else {
        return [0; HASH_LEN];
    };
    let mut mac = prf.clone();
    mac.update(salt);
    mac.update(&1u32.to_be_bytes());
    let mut u: [u8; HASH_LEN] = mac.finalize().into_bytes().into();
    let mut t = u;
    for round in 1..iterations {
        let mut mac = prf.clone();
        mac.update(&u);
        u = mac.finalize().into_bytes().into();
        for (t, u) in t.iter_mut().zip(&u) {
            *t ^= u;
        }
        if round % YIELD_EVERY == 0 {
            embassy_futures::yield_now().await;
        }
    }
    t
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use embassy_futures::block_on;

    fn hex(b: &[u8]) -> std::string::String {
        b.iter().map(|b| std::format!("{b:02x}")).collect()
    }

    #[test]
    fn derivation_matches_the_published_vectors() {
        // RFC 7914, section 11 (PBKDF2-HMAC-SHA256 test vectors), and the
        // widely used "password"/"salt" vectors.
        assert_eq!(
            hex(&block_on(derive(b"passwd", b"salt", 1))),
            "55ac046e56e3089fec1691c22544b605f94185216dde0465e68b9d57c20dacbc"
        );
        assert_eq!(
            hex(&block_on(derive(b"password", b"salt", 1))),
            "120fb6cffcf8b32c43e7225256c4f837a86548c92ccc35480805987cb70be17b"
        );
        assert_eq!(
            hex(&block_on(derive(b"password", b"salt", 4096))),
            "c5e478d59288c841aa530db6845c4c8d962893a001ce4e11a4963873aa98134a"
        );
    }

    #[test]
    fn derivation_agrees_with_the_pbkdf2_crate() {
        for (pw, salt, n) in [
            (&b"x"[..], &b"0123456789abcdef"[..], 3u32),
            (
                b"a much longer password than sixty-four bytes, to be hashed first by HMAC!",
                b"s",
                201,
            ),
            (b"", b"", 2),
        ] {
            let mut want = [0u8; HASH_LEN];
            pbkdf2::pbkdf2_hmac::<sha2::Sha256>(pw, salt, n, &mut want);
            assert_eq!(block_on(derive(pw, salt, n)), want);
        }
    }

    #[test]
    fn a_hash_verifies_its_password_only_and_survives_storage() {
        let h = block_on(PasswordHash::new(b"correct horse", [7; SALT_LEN]));
        assert!(block_on(h.verify(b"correct horse")));
        assert!(!block_on(h.verify(b"correct hors")));
        assert!(!block_on(h.verify(b"Correct horse")));
        let other_salt = block_on(PasswordHash::new(b"correct horse", [8; SALT_LEN]));
        assert_ne!(h.hash, other_salt.hash);
        assert_eq!(PasswordHash::from_bytes(&h.to_bytes()), Some(h));
        let mut bad = h.to_bytes();
        bad[..4].copy_from_slice(&0u32.to_le_bytes());
        assert_eq!(PasswordHash::from_bytes(&bad), None);
    }

    #[test]
    fn new_passwords_follow_the_rules() {
        let check = |p: &[u8]| check_new(p, b"op");
        assert_eq!(check(b"short"), Err(PasswordError::TooShort));
        assert_eq!(check(&[b'x'; 65]), Err(PasswordError::TooLong));
        assert_eq!(
            check("pässwörd!".as_bytes()),
            Err(PasswordError::NotPrintable)
        );
        assert_eq!(check(b"nine char"), Err(PasswordError::TooShort));
        assert_eq!(check(b"ten chars!"), Ok(()));
    }

    /// Issue 25: `aaaaaaaaaa` and ten spaces were accepted.
    #[test]
    fn trivial_passwords_are_refused() {
        for (pw, why) in [
            (&b"aaaaaaaaaa"[..], PasswordError::Repeated),
            (b"          ", PasswordError::Repeated),
            (b"0000000000000", PasswordError::Repeated),
            (b"1234567890", PasswordError::Common),
            (b"Password123", PasswordError::Common),
            (b"QWERTYUIOP", PasswordError::Common),
            (b"alice-2026-x", PasswordError::Name),
            (b"my ALICE pass", PasswordError::Name),
        ] {
            assert_eq!(
                check_new(pw, b"alice"),
                Err(why),
                "{}",
                std::string::String::from_utf8_lossy(pw)
            );
        }
        assert_eq!(check_new(b"aaaaaaaaab", b"alice"), Ok(()));
        assert_eq!(check_new(b"correct horse", b"alice"), Ok(()));
        // Every entry of the deny-list is one the length alone lets through.
        for c in COMMON {
            assert!(c.len() >= MIN_LEN && c.len() <= MAX_LEN);
        }
    }
}
