//! Web sessions and the rate limit of wrong passwords.
//!
//! A correct password opens a session: a random 128-bit token the page
//! keeps in a cookie (`HttpOnly`, `SameSite=Strict`) and scripts send as
//! `Authorization: Bearer TOKEN`. At most [`SESSIONS`] are open (a new one
//! replaces the least recently used); one unused for [`IDLE`] ends.
//! Changing the password ends them all.
//!
//! Wrong passwords: the first [`FREE_TRIES`] in a row cost nothing, then
//! each one doubles the wait before the next attempt is even checked (1 s,
//! 2 s, 4 s, ... up to [`MAX_WAIT`]); a correct one resets the count. The
//! limit is for the whole device, not per client address (addresses are
//! easy to change on a plant network): a flood of wrong passwords delays
//! the rightful user too, which the allow-list prevents.

use embassy_time::{Duration, Instant};
use rand_chacha::rand_core::{Rng, SeedableRng};
use rand_chacha::ChaCha20Rng;

/// Sessions open at once.
pub(crate) const SESSIONS: usize = 4;
/// A session unused this long ends.
pub(crate) const IDLE: Duration = Duration::from_secs(15 * 60);
/// Wrong passwords in a row before the waits begin.
pub(crate) const FREE_TRIES: u32 = 3;
/// The longest wait between two attempts.
pub(crate) const MAX_WAIT: Duration = Duration::from_secs(300);
/// Characters of a token in text (hex).
pub(crate) const TOKEN_CHARS: usize = 32;

/// A session token.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) struct Token([u8; 16]);

impl core::fmt::Debug for Token {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        // Never in logs.
        f.write_str("Token(..)")
    }
}

impl Token {
    /// The token as 32 lowercase hex characters.
    pub(crate) fn to_hex(self) -> [u8; TOKEN_CHARS] {
        const HEX: &[u8; 16] = b"0123456789abcdef";
        let mut out = [0u8; TOKEN_CHARS];
        for (pair, b) in out.chunks_exact_mut(2).zip(self.0) {
            let digit = |n: u8| HEX.get(usize::from(n & 15)).copied().unwrap_or(b'0');
            if let [hi, lo] = pair {
                *hi = digit(b >> 4);
                *lo = digit(b);
            }
        }
        out
    }

    /// Reads 32 hex characters.
    pub(crate) fn from_hex(s: &[u8]) -> Option<Token> {
        if s.len() != TOKEN_CHARS {
            return None;
        }
        let nib = |c: u8| match c {
            b'0'..=b'9' => Some(c - b'0'),
            b'a'..=b'f' => Some(c - b'a' + 10),
            b'A'..=b'F' => Some(c - b'A' + 10),
            _ => None,
        };
        let mut t = [0u8; 16];
        for (b, pair) in t.iter_mut().zip(s.chunks_exact(2)) {
            *b = (nib(*pair.first()?)? << 4) | nib(*pair.get(1)?)?;
        }
        Some(Token(t))
    }

    fn same(&self, other: &Token) -> bool {
        // Constant time: the comparison does not reveal where a guess differs.
        self.0
            .iter()
            .zip(&other.0)
            .fold(0u8, |acc, (a, b)| acc | (a ^ b))
            == 0
    }
}

/// The open sessions, the random generator behind tokens and salts, and
/// the rate limit of wrong passwords.
pub(crate) struct Sessions {
    open: [Option<(Token, Instant)>; SESSIONS],
    rng: ChaCha20Rng,
    failures: u32,
    blocked_until: Instant,
}

impl Sessions {
    /// No session open; tokens and salts come from a ChaCha20 generator
    /// seeded with `seed` (from the board's random source: it must be
    /// unpredictable for the tokens to be).
    pub(crate) fn new(seed: [u8; 32]) -> Self {
        Sessions {
            open: [None; SESSIONS],
            rng: ChaCha20Rng::from_seed(seed),
            failures: 0,
            blocked_until: Instant::from_ticks(0),
        }
    }

    /// Random bytes (salts).
    pub(crate) fn random<const N: usize>(&mut self) -> [u8; N] {
        let mut b = [0u8; N];
        self.rng.fill_bytes(&mut b);
        b
    }

    /// Opens a session at `now` (replacing the least recently used one if
    /// all are open).
    pub(crate) fn open(&mut self, now: Instant) -> Token {
        let token = Token(self.random());
        self.expire(now);
        let slot = self
            .open
            .iter()
            .position(Option::is_none)
            .or_else(|| {
                (0..SESSIONS).min_by_key(|&i| {
                    self.open
                        .get(i)
                        .copied()
                        .flatten()
                        .map_or(Instant::from_ticks(0), |(_, t)| t)
                })
            })
            .unwrap_or(0);
        if let Some(s) = self.open.get_mut(slot) {
            *s = Some((token, now));
        }
        token
    }

    /// `true` if `token` is an open session (and marks it used at `now`).
    pub(crate) fn check(&mut self, token: &Token, now: Instant) -> bool {
        self.expire(now);
        for (t, used) in self.open.iter_mut().flatten() {
            if t.same(token) {
                *used = now;
                return true;
            }
        }
        false
    }

    /// `true` if `token` is an open session at `now`, without counting
    /// this as a use (a page that only looks must not keep a session
    /// alive).
    pub(crate) fn peek(&self, token: &Token, now: Instant) -> bool {
        self.open
            .iter()
            .flatten()
            .any(|(t, used)| t.same(token) && now.saturating_duration_since(*used) < IDLE)
    }

    /// Ends the session of `token`.
    pub(crate) fn close(&mut self, token: &Token) {
        for s in self.open.iter_mut() {
            if s.is_some_and(|(t, _)| t.same(token)) {
                *s = None;
            }
        }
    }

    /// Ends every session (the password changed).
    pub(crate) fn close_all(&mut self) {
        self.open = [None; SESSIONS];
    }

    /// Sessions open at `now`.
    #[cfg(test)]
    pub(crate) fn count(&mut self, now: Instant) -> usize {
        self.expire(now);
        self.open.iter().flatten().count()
    }

    fn expire(&mut self, now: Instant) {
        for s in self.open.iter_mut() {
            if s.is_some_and(|(_, used)| now.saturating_duration_since(used) >= IDLE) {
                *s = None;
            }
        }
    }

    /// May a password be checked at `now`? `Err(wait)`: not before `wait`
    /// has passed.
    pub(crate) fn may_try(&self, now: Instant) -> Result<(), Duration> {
        if now < self.blocked_until {
            Err(self.blocked_until - now)
        } else {
            Ok(())
        }
    }

    /// A wrong password at `now`.
    pub(crate) fn failed(&mut self, now: Instant) {
        self.failures = self.failures.saturating_add(1);
        if self.failures > FREE_TRIES {
            let doublings = (self.failures - FREE_TRIES - 1).min(16);
            let wait = Duration::from_secs(1u64 << doublings).min(MAX_WAIT);
            self.blocked_until = now + wait;
        }
    }

    /// A correct password: the count starts again.
    pub(crate) fn succeeded(&mut self) {
        self.failures = 0;
        self.blocked_until = Instant::from_ticks(0);
    }

    /// Wrong passwords in a row.
    #[cfg(test)]
    pub(crate) fn failures(&self) -> u32 {
        self.failures
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(s: u64) -> Instant {
        Instant::from_secs(s)
    }

    #[test]
    fn tokens_open_check_expire_and_close() {
        let mut s = Sessions::new([1; 32]);
        let a = s.open(at(0));
        let b = s.open(at(1));
        assert_ne!(a, b);
        assert!(s.check(&a, at(10)));
        assert_eq!(Token::from_hex(&a.to_hex()), Some(a));
        assert_eq!(Token::from_hex(b"xyz"), None);
        assert_eq!(Token::from_hex(&[b'g'; 32]), None);
        // b idle for IDLE ends; a was used at 10.
        assert!(!s.check(&b, at(1) + IDLE));
        assert!(s.check(&a, at(9) + IDLE));
        s.close(&a);
        assert!(!s.check(&a, at(9) + IDLE));
        assert_eq!(s.count(at(9) + IDLE), 0);
    }

    #[test]
    fn a_new_session_replaces_the_least_recently_used() {
        let mut s = Sessions::new([2; 32]);
        let t: [Token; SESSIONS] = core::array::from_fn(|i| s.open(at(i as u64)));
        assert!(s.check(&t[0], at(100)));
        let extra = s.open(at(101));
        assert!(!s.check(&t[1], at(102)), "the least recently used went");
        for k in [0, 2, 3] {
            assert!(s.check(&t[k], at(102)));
        }
        assert!(s.check(&extra, at(102)));
        s.close_all();
        assert_eq!(s.count(at(102)), 0);
    }

    #[test]
    fn wrong_passwords_double_the_wait_after_the_free_tries() {
        let mut s = Sessions::new([3; 32]);
        for _ in 0..FREE_TRIES {
            assert_eq!(s.may_try(at(0)), Ok(()));
            s.failed(at(0));
        }
        assert_eq!(s.may_try(at(0)), Ok(()));
        s.failed(at(0));
        assert_eq!(s.may_try(at(0)), Err(Duration::from_secs(1)));
        assert_eq!(s.may_try(at(1)), Ok(()));
        s.failed(at(1));
        assert_eq!(s.may_try(at(1)), Err(Duration::from_secs(2)));
        for _ in 0..20 {
            s.failed(at(1000));
        }
        assert_eq!(s.may_try(at(1000)), Err(MAX_WAIT));
        s.succeeded();
        assert_eq!(s.may_try(at(1000)), Ok(()));
        assert_eq!(s.failures(), 0);
    }
}
