//! The rate limit of password and setup-code guesses (IEC 62443-4-2 CR
//! 1.11), per client address and per account.
//!
//! * An attempt is **reserved before the hash is computed**: it counts as
//!   a failure from the moment it is accepted, and a correct one gives the
//!   count back. Guesses sent in parallel therefore see each other and
//!   gain nothing over guesses sent one after the other.
//! * Per address: the first [`FREE_TRIES`] failures in a row cost nothing,
//!   then each doubles the wait before the address may try again (1 s, 2 s,
//!   ... up to [`MAX_WAIT`]). [`ADDRESSES`] addresses are tracked; when the
//!   table is full, a new address takes the entry of the longest-quiet one
//!   that is not waiting, or else shares one entry with every other
//!   newcomer (a flood from many addresses then waits as one).
//! * Per account, over all addresses: after [`ACCOUNT_FREE_TRIES`]
//!   failures the account waits as an address does, **except for the
//!   addresses it last logged in from** ([`TRUSTED`] of them): a flood of
//!   wrong passwords from elsewhere cannot lock the administrator out at
//!   their own desk.

use core::net::Ipv4Addr;

use embassy_time::{Duration, Instant};

use super::accounts::ACCOUNTS;

/// Failures in a row from one address before the waits begin.
pub(crate) const FREE_TRIES: u32 = 3;
/// Failures against one account (all addresses) before its waits begin.
pub(crate) const ACCOUNT_FREE_TRIES: u32 = 10;
/// The longest wait.
pub(crate) const MAX_WAIT: Duration = Duration::from_secs(300);
/// Addresses tracked.
pub(crate) const ADDRESSES: usize = 16;
/// Addresses remembered per account as its own.
pub(crate) const TRUSTED: usize = 2;

#[derive(Clone, Copy)]
struct Count {
    failures: u32,
    until: Instant,
}

impl Count {
    const ZERO: Count = Count {
        failures: 0,
        until: Instant::from_ticks(0),
    };

    fn wait(&self, now: Instant) -> Option<Duration> {
        (now < self.until).then(|| self.until - now)
    }

    fn fail(&mut self, free: u32, now: Instant) {
        self.failures = self.failures.saturating_add(1);
        if self.failures > free {
            let doublings = (self.failures - free - 1).min(16);
            self.until = now + Duration::from_secs(1u64 << doublings).min(MAX_WAIT);
        }
    }
}

#[derive(Clone, Copy)]
struct AddrEntry {
    ip: Option<Ipv4Addr>,
    count: Count,
    last: Instant,
}

/// An attempt reserved by [`Limiter::reserve`]; settled by
/// [`Limiter::succeeded`] (a failure needs nothing more).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ticket {
    slot: usize,
    account: Option<usize>,
    ip: Option<Ipv4Addr>,
}

/// The counts.
pub(crate) struct Limiter {
    addrs: [Option<AddrEntry>; ADDRESSES],
    accounts: [Count; ACCOUNTS],
    trusted: [[Option<Ipv4Addr>; TRUSTED]; ACCOUNTS],
}

impl Limiter {
    /// Nothing counted.
    pub(crate) const fn new() -> Self {
        Limiter {
            addrs: [None; ADDRESSES],
            accounts: [Count::ZERO; ACCOUNTS],
            trusted: [[None; TRUSTED]; ACCOUNTS],
        }
    }

    /// The entry of `ip` (an unknown peer is `None`), made if need be.
    fn slot(&mut self, ip: Option<Ipv4Addr>, now: Instant) -> usize {
        if let Some(i) = self
            .addrs
            .iter()
            .position(|e| e.is_some_and(|e| e.ip == ip))
        {
            return i;
        }
        // A free entry, else the longest-quiet one not waiting, else the
        // shared one (entry 0 then stands for every newcomer).
        let free = self.addrs.iter().position(Option::is_none);
        let quiet = || {
            self.addrs
                .iter()
                .enumerate()
                .filter(|(_, e)| e.is_some_and(|e| e.count.wait(now).is_none()))
                .min_by_key(|(_, e)| e.map_or(Instant::from_ticks(0), |e| e.last))
                .map(|(i, _)| i)
        };
        match free.or_else(quiet) {
            Some(i) => {
                if let Some(e) = self.addrs.get_mut(i) {
                    *e = Some(AddrEntry {
                        ip,
                        count: Count::ZERO,
                        last: now,
                    });
                }
                i
            }
            None => 0,
        }
    }

    /// How long `ip` (and, if named, `account`) must wait before trying,
    /// without reserving.
    pub(crate) fn wait(
        &self,
        ip: Option<Ipv4Addr>,
        account: Option<usize>,
        now: Instant,
    ) -> Option<Duration> {
        let by_addr = self
            .addrs
            .iter()
            .flatten()
            .find(|e| e.ip == ip)
            .and_then(|e| e.count.wait(now));
        by_addr.or_else(|| account.and_then(|a| self.account_wait(a, ip, now)))
    }

    fn account_wait(&self, a: usize, ip: Option<Ipv4Addr>, now: Instant) -> Option<Duration> {
        let own = ip.is_some() && self.trusted.get(a).is_some_and(|t| t.contains(&ip));
        if own {
            return None;
        }
        self.accounts.get(a).and_then(|c| c.wait(now))
    }

    /// Reserves an attempt of `ip` against `account` (`None`: an unknown
    /// name, or the setup code) at `now`, counted as a failure until
    /// [`Self::succeeded`]; `Err(wait)` if it must wait first.
    pub(crate) fn reserve(
        &mut self,
        ip: Option<Ipv4Addr>,
        account: Option<usize>,
        now: Instant,
    ) -> Result<Ticket, Duration> {
        let slot = self.slot(ip, now);
        let entry = self.addrs.get_mut(slot).and_then(Option::as_mut);
        if let Some(e) = entry {
            if let Some(w) = e.count.wait(now) {
                return Err(w);
            }
            e.last = now;
            e.count.fail(FREE_TRIES, now);
        }
        if let Some(a) = account {
            if let Some(w) = self.account_wait(a, ip, now) {
                return Err(w);
            }
            if let Some(c) = self.accounts.get_mut(a) {
                c.fail(ACCOUNT_FREE_TRIES, now);
            }
        }
        Ok(Ticket { slot, account, ip })
    }

    /// The attempt of `t` was right: its counts start again, and its
    /// address becomes one of the account's own.
    pub(crate) fn succeeded(&mut self, t: Ticket) {
        if let Some(e) = self.addrs.get_mut(t.slot).and_then(Option::as_mut) {
            e.count = Count::ZERO;
        }
        if let Some(a) = t.account {
            if let Some(c) = self.accounts.get_mut(a) {
                *c = Count::ZERO;
            }
            if let (Some(list), Some(ip)) = (self.trusted.get_mut(a), t.ip) {
                if !list.contains(&Some(ip)) {
                    list.rotate_right(1);
                    if let Some(first) = list.first_mut() {
                        *first = Some(ip);
                    }
                }
            }
        }
    }

    /// Account `a` was removed (or its index reused): forget its counts.
    pub(crate) fn forget_account(&mut self, a: usize) {
        if let Some(c) = self.accounts.get_mut(a) {
            *c = Count::ZERO;
        }
        if let Some(t) = self.trusted.get_mut(a) {
            *t = [None; TRUSTED];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(s: u64) -> Instant {
        Instant::from_secs(s)
    }
    const A: Option<Ipv4Addr> = Some(Ipv4Addr::new(10, 0, 0, 1));
    const B: Option<Ipv4Addr> = Some(Ipv4Addr::new(10, 0, 0, 2));

    #[test]
    fn parallel_guesses_are_counted_before_they_are_checked() {
        let mut l = Limiter::new();
        // Ten guesses arrive together: each is reserved before any hash is
        // computed, so only FREE_TRIES + 1 get through.
        let through = (0..10)
            .filter(|_| l.reserve(A, None, at(0)).is_ok())
            .count();
        assert_eq!(through, FREE_TRIES as usize + 1);
        assert_eq!(l.wait(A, None, at(0)), Some(Duration::from_secs(1)));
        // Another address is not affected.
        assert!(l.reserve(B, None, at(0)).is_ok());
    }

    #[test]
    fn waits_double_and_a_success_resets() {
        let mut l = Limiter::new();
        for _ in 0..=FREE_TRIES {
            l.reserve(A, None, at(0)).unwrap();
        }
        assert_eq!(
            l.reserve(A, None, at(0)).unwrap_err(),
            Duration::from_secs(1)
        );
        l.reserve(A, None, at(1)).unwrap();
        assert_eq!(l.wait(A, None, at(1)), Some(Duration::from_secs(2)));
        for s in 0..30 {
            let _ = l.reserve(A, None, at(1000 * s));
        }
        assert!(l.wait(A, None, at(29_000)).is_some_and(|w| w <= MAX_WAIT));
        let t = l.reserve(A, None, at(40_000)).unwrap();
        l.succeeded(t);
        assert_eq!(l.wait(A, None, at(40_000)), None);
    }

    #[test]
    fn guesses_from_elsewhere_do_not_lock_the_owner_out() {
        let mut l = Limiter::new();
        let t = l.reserve(A, Some(0), at(0)).unwrap();
        l.succeeded(t); // A is the admin's own address now.
                        // Many addresses guess the admin's password.
        for k in 0..40u8 {
            let ip = Some(Ipv4Addr::new(10, 9, 0, k));
            let _ = l.reserve(ip, Some(0), at(1));
        }
        let stranger = Some(Ipv4Addr::new(10, 9, 1, 1));
        assert!(
            l.reserve(stranger, Some(0), at(1)).is_err(),
            "the account waits for others"
        );
        assert!(
            l.reserve(A, Some(0), at(1)).is_ok(),
            "but not for its own address"
        );
    }

    #[test]
    fn a_full_table_shares_one_entry_among_newcomers() {
        let mut l = Limiter::new();
        for k in 0..ADDRESSES as u8 {
            let ip = Some(Ipv4Addr::new(10, 1, 0, k));
            for _ in 0..=FREE_TRIES {
                l.reserve(ip, None, at(0)).unwrap();
            }
        }
        // All waiting: newcomers share entry 0, which waits too.
        let fresh = Some(Ipv4Addr::new(10, 2, 0, 1));
        assert!(l.reserve(fresh, None, at(0)).is_err());
        // Once the waits pass, a newcomer gets an entry of its own.
        assert!(l.reserve(fresh, None, at(10)).is_ok());
    }
}
