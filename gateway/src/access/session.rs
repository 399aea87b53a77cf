//! Web sessions.
//!
//! A correct name and password opens a session of that account: a random
//! 128-bit token the page keeps in a cookie (`HttpOnly`,
//! `SameSite=Strict`: page scripts never see it); other clients may send
//! it as `Authorization: Bearer TOKEN`. Each account has at most
//! [`PER_ACCOUNT`] open (its new one replaces its own least recently
//! used): the table has room for every account's, so no account ends
//! another's session by logging in; one unused for [`IDLE`]
//! ends, and every one ends [`LIFETIME`] after it opened, used or not
//! (IEC 62443-4-2 CR 2.5/2.6). Changing an account's password or role, or
//! removing it, ends its sessions. The rate limit of wrong passwords is
//! [`super::limit`]'s.

use embassy_time::{Duration, Instant};

use super::accounts::Role;
use rand_chacha::rand_core::{Rng, SeedableRng};
use rand_chacha::ChaCha20Rng;
use subtle::ConstantTimeEq;

/// Sessions one account may have open at once (a browser or two and a
/// script).
pub(crate) const PER_ACCOUNT: usize = 3;
/// Sessions open at once: every account's share.
pub(crate) const SESSIONS: usize = super::accounts::ACCOUNTS * PER_ACCOUNT;
/// A session unused this long ends.
pub(crate) const IDLE: Duration = Duration::from_secs(15 * 60);
/// A session ends this long after it opened, however used.
pub(crate) const LIFETIME: Duration = Duration::from_secs(8 * 3600);
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
        let mut out = [0u8; TOKEN_CHARS];
        // TOKEN_CHARS is twice the token's bytes: always fits.
        let _ = crate::hex::encode(&self.0, &mut out);
        out
    }

    /// Reads 32 hex characters.
    pub(crate) fn from_hex(s: &[u8]) -> Option<Token> {
        let mut t = [0u8; 16];
        crate::hex::decode(s, &mut t)?;
        Some(Token(t))
    }

    fn same(&self, other: &Token) -> bool {
        // Constant time: the comparison does not reveal where a guess differs.
        bool::from(self.0.ct_eq(&other.0))
    }
}

/// Who a session is: the account (its index in `Accounts`) and its role
/// when the session opened.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Who {
    /// The account's index.
    pub(crate) account: usize,
    /// Its role.
    pub(crate) role: Role,
}

#[derive(Clone, Copy)]
struct Open {
    token: Token,
    who: Who,
    opened: Instant,
    used: Instant,
}

impl Open {
    fn live(&self, now: Instant) -> bool {
        now.saturating_duration_since(self.used) < IDLE
            && now.saturating_duration_since(self.opened) < LIFETIME
    }
}

/// The open sessions, and the random generator behind tokens and salts.
pub(crate) struct Sessions {
    open: [Option<Open>; SESSIONS],
    rng: ChaCha20Rng,
}

impl Sessions {
    /// No session open; tokens and salts come from a ChaCha20 generator
    /// seeded with `seed` (from the board's random source: it must be
    /// unpredictable for the tokens to be).
    pub(crate) fn new(seed: [u8; 32]) -> Self {
        Sessions {
            open: [None; SESSIONS],
            rng: ChaCha20Rng::from_seed(seed),
        }
    }

    /// Random bytes (salts).
    pub(crate) fn random<const N: usize>(&mut self) -> [u8; N] {
        let mut b = [0u8; N];
        self.rng.fill_bytes(&mut b);
        b
    }

    /// Opens a session of `who` at `now`: if its account has
    /// [`PER_ACCOUNT`] open, the least recently used of them ends; no other
    /// account's does.
    pub(crate) fn open(&mut self, who: Who, now: Instant) -> Token {
        let token = Token(self.random());
        self.expire(now);
        let mine = |o: &Option<Open>| o.is_some_and(|o| o.who.account == who.account);
        let own = self.open.iter().filter(|o| mine(o)).count();
        let slot = if own >= PER_ACCOUNT {
            (0..SESSIONS)
                .filter(|&i| self.open.get(i).is_some_and(mine))
                .min_by_key(|&i| {
                    self.open
                        .get(i)
                        .copied()
                        .flatten()
                        .map_or(Instant::from_ticks(0), |o| o.used)
                })
        } else {
            // Room for every account's share: a free one is there.
            self.open.iter().position(Option::is_none)
        }
        .unwrap_or(0);
        if let Some(s) = self.open.get_mut(slot) {
            *s = Some(Open {
                token,
                who,
                opened: now,
                used: now,
            });
        }
        token
    }

    /// Who `token` is, if it is an open session (and marks it used at
    /// `now`).
    pub(crate) fn check(&mut self, token: &Token, now: Instant) -> Option<Who> {
        self.expire(now);
        for o in self.open.iter_mut().flatten() {
            if o.token.same(token) {
                o.used = now;
                return Some(o.who);
            }
        }
        None
    }

    /// As [`Self::check`], without counting this as a use (a page that
    /// only looks must not keep a session alive).
    pub(crate) fn peek(&self, token: &Token, now: Instant) -> Option<Who> {
        self.open
            .iter()
            .flatten()
            .find(|o| o.token.same(token) && o.live(now))
            .map(|o| o.who)
    }

    /// Ends the session of `token`.
    pub(crate) fn close(&mut self, token: &Token) {
        for s in self.open.iter_mut() {
            if s.is_some_and(|o| o.token.same(token)) {
                *s = None;
            }
        }
    }

    /// Ends every session of account `account` (its password or role
    /// changed, or it was removed).
    pub(crate) fn close_account(&mut self, account: usize) {
        for s in self.open.iter_mut() {
            if s.is_some_and(|o| o.who.account == account) {
                *s = None;
            }
        }
    }

    /// Sessions open at `now`.
    #[cfg(test)]
    pub(crate) fn count(&mut self, now: Instant) -> usize {
        self.expire(now);
        self.open.iter().flatten().count()
    }

    fn expire(&mut self, now: Instant) {
        for s in self.open.iter_mut() {
            if s.is_some_and(|o| !o.live(now)) {
                *s = None;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(s: u64) -> Instant {
        Instant::from_secs(s)
    }

    const ADMIN: Who = Who {
        account: 0,
        role: Role::Admin,
    };
    const VIEWER: Who = Who {
        account: 1,
        role: Role::Viewer,
    };

    #[test]
    fn tokens_open_check_expire_and_close() {
        let mut s = Sessions::new([1; 32]);
        let a = s.open(ADMIN, at(0));
        let b = s.open(VIEWER, at(1));
        assert_ne!(a, b);
        assert_eq!(s.check(&a, at(10)), Some(ADMIN));
        assert_eq!(s.peek(&b, at(10)), Some(VIEWER));
        assert_eq!(Token::from_hex(&a.to_hex()), Some(a));
        assert_eq!(Token::from_hex(b"xyz"), None);
        assert_eq!(Token::from_hex(&[b'g'; 32]), None);
        // b idle for IDLE ends; a was used at 10.
        assert_eq!(s.check(&b, at(1) + IDLE), None);
        assert!(s.check(&a, at(9) + IDLE).is_some());
        s.close(&a);
        assert_eq!(s.check(&a, at(9) + IDLE), None);
        assert_eq!(s.count(at(9) + IDLE), 0);
    }

    #[test]
    fn a_session_ends_at_its_lifetime_however_used() {
        let mut s = Sessions::new([4; 32]);
        let a = s.open(ADMIN, at(0));
        let mut t = 0;
        while t + 600 < LIFETIME.as_secs() {
            t += 600;
            assert!(s.check(&a, at(t)).is_some(), "in use at {t} s");
        }
        assert_eq!(s.peek(&a, at(LIFETIME.as_secs())), None);
        assert_eq!(s.check(&a, at(LIFETIME.as_secs())), None);
    }

    #[test]
    fn a_new_session_replaces_its_accounts_least_recently_used_and_accounts_close_theirs() {
        let mut s = Sessions::new([2; 32]);
        let t: [Token; PER_ACCOUNT] = core::array::from_fn(|i| s.open(ADMIN, at(i as u64)));
        assert!(s.check(&t[0], at(100)).is_some());
        let extra = s.open(ADMIN, at(101));
        assert!(
            s.check(&t[1], at(102)).is_none(),
            "the least recently used went"
        );
        for k in [0, 2] {
            assert!(s.check(&t[k], at(102)).is_some());
        }
        let viewer = s.open(VIEWER, at(103));
        s.close_account(0);
        assert_eq!(s.count(at(103)), 1);
        assert_eq!(s.check(&viewer, at(103)), Some(VIEWER));
        assert_eq!(s.check(&extra, at(103)), None);
        s.close(&viewer);
        assert_eq!(s.count(at(103)), 0);
    }

    /// Issue 25: one viewer logging in four times ended the
    /// administrator's session (four sessions shared by all accounts).
    #[test]
    fn no_account_ends_another_accounts_session() {
        let mut s = Sessions::new([3; 32]);
        let admin = s.open(ADMIN, at(0));
        for k in 0..4 * SESSIONS as u64 {
            s.open(VIEWER, at(1 + k));
        }
        assert_eq!(s.check(&admin, at(100)), Some(ADMIN));
        // Every account its full share at once.
        let mut s = Sessions::new([4; 32]);
        let all: std::vec::Vec<(Token, Who)> = (0..super::super::accounts::ACCOUNTS)
            .flat_map(|a| (0..PER_ACCOUNT).map(move |_| a))
            .enumerate()
            .map(|(k, account)| {
                let who = Who {
                    account,
                    role: Role::Viewer,
                };
                (s.open(who, at(k as u64)), who)
            })
            .collect();
        for (t, who) in &all {
            assert_eq!(s.check(t, at(500)), Some(*who));
        }
    }
}
