//! The rate limit of password and setup-code guesses (IEC 62443-4-2 CR
//! 1.11), per client address, per account, and a budget of hashes for
//! the whole device.
//!
//! * An attempt is **reserved before the hash is computed**: it counts as
//!   a failure from the moment it is accepted, and a correct one gives the
//!   count back. Guesses sent in parallel therefore see each other and
//!   gain nothing over guesses sent one after the other.
//! * **An account's own addresses** (those it last logged in from,
//!   `access::accounts::TRUSTED` of them, kept with the accounts so that a
//!   restart forgets none) are counted apart from everything else: a
//!   guess for that account from one of them waits only for that
//!   address's own failures (the first [`FREE_TRIES`] free, then doubling
//!   waits as below). Failures from elsewhere, a full table of waiting
//!   addresses, its shared entry, the account's own wait and the budget
//!   below never make the owner wait at their desk.
//! * Per other address: the first [`FREE_TRIES`] failures in a row cost
//!   nothing, then each doubles the wait before the address may try again
//!   (1 s, 2 s, ... up to [`MAX_WAIT`]). [`ADDRESSES`] addresses are
//!   tracked; when the table is full, a new address takes the entry of the
//!   longest-quiet one that is not waiting, or else shares one entry with
//!   every other newcomer (a flood from many addresses then waits as one).
//! * Per account, over all other addresses: after [`ACCOUNT_FREE_TRIES`]
//!   failures the account waits as an address does (for everyone but its
//!   own addresses).
//! * **A budget of hashes** for guesses that name no account (an unknown
//!   name, or the setup code): [`BUDGET_PER_SECOND`] a second, up to
//!   [`BUDGET_BURST`] at once, for the whole device. Each such guess costs
//!   a PBKDF2 hash (an unknown name is checked against a hash that matches
//!   nothing, so that it takes as long as a wrong password); a flood from
//!   rotating addresses, each within its free tries, would otherwise keep
//!   a core busy (issue 25: 418 hashes a second, 74 % of a core on Linux,
//!   and the Modbus answers 10 times slower). Beyond it the guess waits
//!   (429) until the budget has a hash again. Guesses for a known account
//!   are bounded by that account's own wait instead.

use core::net::Ipv4Addr;

use embassy_time::{Duration, Instant};

use super::accounts::{ACCOUNTS, TRUSTED};

/// Failures in a row from one address before the waits begin.
pub(crate) const FREE_TRIES: u32 = 3;
/// Failures against one account (all other addresses) before its waits
/// begin.
pub(crate) const ACCOUNT_FREE_TRIES: u32 = 10;
/// The longest wait.
pub(crate) const MAX_WAIT: Duration = Duration::from_secs(300);
/// Addresses tracked.
pub(crate) const ADDRESSES: usize = 16;
/// Hashes a second for guesses that name no account (unknown names, the
/// setup code), for the whole device: on Linux some 4 ms of a core a
/// second, on a Cortex-M7 some 20 % of it while a flood goes on.
pub(crate) const BUDGET_PER_SECOND: u64 = 2;
/// Hashes of that budget that may be spent at once (after a quiet time).
pub(crate) const BUDGET_BURST: u64 = 4;

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

/// The budget of hashes: a token bucket, its credit kept as time (a hash
/// costs [`Budget::EACH`] of it; it grows with time, up to the burst).
#[derive(Clone, Copy)]
struct Budget {
    /// The credit at `at`.
    credit: Duration,
    at: Instant,
}

impl Budget {
    /// The time one hash of the budget takes to come back.
    const EACH: Duration = Duration::from_micros(1_000_000 / BUDGET_PER_SECOND);
    /// The credit of a full bucket.
    const FULL: Duration = Duration::from_micros(BUDGET_BURST * 1_000_000 / BUDGET_PER_SECOND);
    /// A full bucket.
    const NEW: Budget = Budget {
        credit: Self::FULL,
        at: Instant::from_ticks(0),
    };

    /// Takes a hash at `now`, or says how long until one comes back.
    fn take(&mut self, now: Instant) -> Result<(), Duration> {
        let credit = (self.credit + now.saturating_duration_since(self.at)).min(Self::FULL);
        self.at = now;
        self.credit = credit;
        if credit < Self::EACH {
            return Err(Self::EACH - credit);
        }
        self.credit = credit - Self::EACH;
        Ok(())
    }
}

/// Who a guess counts against ([`Limiter::reserve`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Guess {
    /// An account, from its own address number `own` (the index among
    /// its own addresses).
    Own {
        /// The account's index.
        account: usize,
        /// Which of its own addresses.
        own: usize,
    },
    /// An account, from another address.
    Account(usize),
    /// No account: an unknown name, or the setup code.
    Nobody,
}

/// An attempt reserved by [`Limiter::reserve`]; settled by
/// [`Limiter::succeeded`] (a failure needs nothing more).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ticket {
    /// The address's entry, for a guess not from an own address.
    slot: Option<usize>,
    guess: Guess,
}

/// The counts.
pub(crate) struct Limiter {
    addrs: [Option<AddrEntry>; ADDRESSES],
    accounts: [Count; ACCOUNTS],
    /// Each account's own addresses' failures (by the index among them).
    own: [[Count; TRUSTED]; ACCOUNTS],
    budget: Budget,
}

impl Limiter {
    /// Nothing counted.
    pub(crate) const fn new() -> Self {
        Limiter {
            addrs: [None; ADDRESSES],
            accounts: [Count::ZERO; ACCOUNTS],
            own: [[Count::ZERO; TRUSTED]; ACCOUNTS],
            budget: Budget::NEW,
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

    fn own_count(&mut self, account: usize, own: usize) -> Option<&mut Count> {
        self.own.get_mut(account)?.get_mut(own)
    }

    /// How long `ip` must wait before its next guess (of no account in
    /// particular: the page shows it), without reserving.
    pub(crate) fn wait(&self, ip: Option<Ipv4Addr>, now: Instant) -> Option<Duration> {
        self.addrs
            .iter()
            .flatten()
            .find(|e| e.ip == ip)
            .and_then(|e| e.count.wait(now))
    }

    /// How long account `account`'s own address number `own` must wait
    /// before its next guess (its count is apart from [`Self::wait`]'s).
    pub(crate) fn wait_own(&self, account: usize, own: usize, now: Instant) -> Option<Duration> {
        self.own.get(account)?.get(own)?.wait(now)
    }

    /// Reserves a guess of `ip` (`guess`: against whom) at `now`, counted
    /// as a failure until [`Self::succeeded`]; `Err(wait)` if it must wait
    /// first (then nothing is counted).
    pub(crate) fn reserve(
        &mut self,
        ip: Option<Ipv4Addr>,
        guess: Guess,
        now: Instant,
    ) -> Result<Ticket, Duration> {
        if let Guess::Own { account, own } = guess {
            // Apart from everything else: only this address's own count.
            if let Some(c) = self.own_count(account, own) {
                if let Some(w) = c.wait(now) {
                    return Err(w);
                }
                c.fail(FREE_TRIES, now);
            }
            return Ok(Ticket { slot: None, guess });
        }
        let slot = self.slot(ip, now);
        if let Some(w) = self
            .addrs
            .get(slot)
            .and_then(|e| e.as_ref())
            .and_then(|e| e.count.wait(now))
        {
            return Err(w);
        }
        match guess {
            Guess::Account(a) => {
                if let Some(w) = self.accounts.get(a).and_then(|c| c.wait(now)) {
                    return Err(w);
                }
                if let Some(c) = self.accounts.get_mut(a) {
                    c.fail(ACCOUNT_FREE_TRIES, now);
                }
            }
            _ => self.budget.take(now)?,
        }
        if let Some(e) = self.addrs.get_mut(slot).and_then(Option::as_mut) {
            e.last = now;
            e.count.fail(FREE_TRIES, now);
        }
        Ok(Ticket {
            slot: Some(slot),
            guess,
        })
    }

    /// The attempt of `t` was right: its counts start again. (The caller
    /// makes the address one of the account's own.)
    pub(crate) fn succeeded(&mut self, t: Ticket) {
        if let Some(e) = t
            .slot
            .and_then(|s| self.addrs.get_mut(s))
            .and_then(Option::as_mut)
        {
            e.count = Count::ZERO;
        }
        match t.guess {
            Guess::Own { account, own } => {
                if let Some(c) = self.own_count(account, own) {
                    *c = Count::ZERO;
                }
            }
            Guess::Account(a) => {
                if let Some(c) = self.accounts.get_mut(a) {
                    *c = Count::ZERO;
                }
            }
            Guess::Nobody => {}
        }
    }

    /// Account `a` has one more own address, the first
    /// (`Accounts::trust`: the others move one down, the oldest goes): the
    /// counts follow their addresses, the new one starts at nothing. (Its
    /// other addresses' waits are kept: a login from a new desk does not
    /// lift the wait of a guessing one.)
    pub(crate) fn own_changed(&mut self, a: usize) {
        if let Some(o) = self.own.get_mut(a) {
            o.rotate_right(1);
            if let Some(first) = o.first_mut() {
                *first = Count::ZERO;
            }
        }
    }

    /// Account `a` was removed, added, or its password set: forget its
    /// counts.
    pub(crate) fn forget_account(&mut self, a: usize) {
        if let Some(c) = self.accounts.get_mut(a) {
            *c = Count::ZERO;
        }
        if let Some(o) = self.own.get_mut(a) {
            *o = [Count::ZERO; TRUSTED];
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
    const ADMIN: Guess = Guess::Account(0);
    const ADMIN_AT_DESK: Guess = Guess::Own { account: 0, own: 0 };

    #[test]
    fn parallel_guesses_are_counted_before_they_are_checked() {
        let mut l = Limiter::new();
        // Ten guesses arrive together: each is reserved before any hash is
        // computed, so only FREE_TRIES + 1 get through.
        let through = (0..10)
            .filter(|_| l.reserve(A, ADMIN, at(0)).is_ok())
            .count();
        assert_eq!(through, FREE_TRIES as usize + 1);
        assert_eq!(l.wait(A, at(0)), Some(Duration::from_secs(1)));
        // Another address is not affected.
        assert!(l.reserve(B, ADMIN, at(0)).is_ok());
    }

    #[test]
    fn waits_double_and_a_success_resets() {
        let mut l = Limiter::new();
        for _ in 0..=FREE_TRIES {
            l.reserve(A, ADMIN, at(0)).unwrap();
        }
        assert_eq!(
            l.reserve(A, ADMIN, at(0)).unwrap_err(),
            Duration::from_secs(1)
        );
        l.reserve(A, ADMIN, at(1)).unwrap();
        assert_eq!(l.wait(A, at(1)), Some(Duration::from_secs(2)));
        for s in 0..30 {
            let _ = l.reserve(A, Guess::Account(1), at(1000 * s));
        }
        assert!(l.wait(A, at(29_000)).is_some_and(|w| w <= MAX_WAIT));
        let t = l.reserve(A, Guess::Account(1), at(40_000)).unwrap();
        l.succeeded(t);
        assert_eq!(l.wait(A, at(40_000)), None);
    }

    #[test]
    fn guesses_from_elsewhere_do_not_lock_the_owner_out() {
        let mut l = Limiter::new();
        // Many addresses guess the admin's password.
        for k in 0..40u8 {
            let ip = Some(Ipv4Addr::new(10, 9, 0, k));
            let _ = l.reserve(ip, ADMIN, at(1));
        }
        let stranger = Some(Ipv4Addr::new(10, 9, 1, 1));
        assert!(
            l.reserve(stranger, ADMIN, at(1)).is_err(),
            "the account waits for others"
        );
        assert!(
            l.reserve(A, ADMIN_AT_DESK, at(1)).is_ok(),
            "but not for its own address"
        );
    }

    /// Issue 25: sixteen waiting addresses filled the table, and the
    /// administrator's own address got the shared entry's wait.
    #[test]
    fn a_full_table_of_waiting_addresses_does_not_block_an_own_address() {
        let mut l = Limiter::new();
        // Guesses for accounts 1-7, spread so that each stays within its
        // account's free tries.
        let mut n = 0;
        for k in 0..ADDRESSES as u8 {
            let ip = Some(Ipv4Addr::new(10, 1, 0, k));
            for _ in 0..=FREE_TRIES {
                let other = Guess::Account(1 + n % (ACCOUNTS - 1));
                l.reserve(ip, other, at(0)).unwrap();
                n += 1;
            }
        }
        // All waiting: newcomers share entry 0, which waits too.
        let fresh = Some(Ipv4Addr::new(10, 2, 0, 1));
        assert!(l.reserve(fresh, Guess::Account(1), at(0)).is_err());
        // The administrator at their desk is counted apart.
        let t = l.reserve(A, ADMIN_AT_DESK, at(0)).unwrap();
        l.succeeded(t);
        // Its own address's failures still count: 3 free, then it waits.
        for _ in 0..=FREE_TRIES {
            l.reserve(A, ADMIN_AT_DESK, at(0)).unwrap();
        }
        assert!(l.reserve(A, ADMIN_AT_DESK, at(0)).is_err());
        // Once the waits pass, a newcomer gets an entry of its own.
        assert!(l.reserve(fresh, Guess::Account(1), at(10)).is_ok());
    }

    #[test]
    fn guesses_of_no_account_share_a_budget_of_hashes() {
        let mut l = Limiter::new();
        let ip = |k: u8| Some(Ipv4Addr::new(10, 3, k / 100, k % 100));
        // A burst, then the rate: from rotating addresses, each within its
        // free tries.
        let at_ms = Instant::from_millis;
        let mut through = 0;
        for k in 0..20u8 {
            through += usize::from(l.reserve(ip(k), Guess::Nobody, at_ms(10_000)).is_ok());
        }
        assert_eq!(through, BUDGET_BURST as usize);
        let wait = l.reserve(ip(50), Guess::Nobody, at_ms(10_000)).unwrap_err();
        assert_eq!(wait, Duration::from_millis(1000 / BUDGET_PER_SECOND));
        // Over the next 10 s: the rate, not more.
        let mut k = 60u8;
        let mut through = 0;
        for t in (10_010..20_000).step_by(10) {
            k = k.wrapping_add(1);
            through += usize::from(l.reserve(ip(k), Guess::Nobody, at_ms(t)).is_ok());
        }
        assert_eq!(through as u64, 10 * BUDGET_PER_SECOND - 1);
        // A refused guess counts nowhere; known accounts are not in it.
        assert!(l.reserve(ip(200), ADMIN, at_ms(20_000)).is_ok());
        assert!(l.reserve(A, ADMIN_AT_DESK, at_ms(20_000)).is_ok());
    }
}
