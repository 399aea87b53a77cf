//! The admission rules in virtual time: one suite of scenarios, each a
//! method of a [`Rig`] around a table of any shape, run by
//! [`admission_suite!`] for every listener's own sizes and limits
//! (`crate::modbus`, `crate::web`) and here for a third shape (more
//! sockets to spare, more waiting newcomers).
//!
//! A scenario drives real [`Slots::claim`] futures, each with a waker of
//! its own, on a [`VirtualClock`]: a newcomer is looked at again only when
//! the table wakes it or its deadline comes, as on the gateway.

use core::future::Future;
use core::net::{Ipv4Addr, SocketAddrV4};
use core::pin::Pin;
use core::task::{Context, Poll, Waker};
use std::boxed::Box;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::vec::Vec;

use embassy_time::{Duration, Instant};

use super::{Close, Guard, Limits, Refusal, Slots};
use crate::clock::Clock;
use crate::testkit::clock::VirtualClock;
use crate::testkit::world::Flag;

/// Runs every scenario below with the table `$slots` makes (an
/// expression, evaluated afresh for each), one `#[test]` each, in a
/// module `admission` of the caller's.
macro_rules! admission_suite {
    ($slots:expr) => {
        $crate::admission::tests::admission_suite!(@tests $slots;
            free_slots_are_taken_at_once,
            a_newcomer_takes_the_slot_of_the_longest_idle_session,
            a_session_in_the_middle_of_a_request_is_never_idle,
            an_answer_wakes_a_waiting_newcomer,
            at_the_end_of_its_wait_a_newcomer_evicts_nobody,
            an_address_at_its_cap_gives_way_to_its_newest,
            an_address_at_its_cap_with_every_session_busy,
            newcomers_are_served_first_come_first_served,
            a_new_allow_list_closes_whom_it_refuses,
            an_unknown_address_counts_for_no_address,
            the_reserved_slot_is_kept_for_a_protected_newcomer,
            a_protected_session_is_never_closed_for_another_address,
            a_protected_newcomer_waits_behind_no_unprotected_one,
            a_reservation_switched_on_makes_room_at_once,
            a_busy_flood_from_several_addresses_cannot_keep_the_plc_out,
            newcomers_queued_before_the_plc_cannot_hold_the_socket_it_reconnects_on
        );
    };
    (@tests $slots:expr; $($name:ident),*) => {
        /// The admission rules ([`crate::admission::tests`]) with these
        /// sizes and limits.
        mod admission {
            #[allow(unused_imports)]
            use super::*;
            $(
                #[test]
                fn $name() {
                    let clock = $crate::testkit::clock::VirtualClock::new();
                    let slots = $slots;
                    $crate::admission::tests::Rig::new(&clock, &slots).$name();
                }
            )*
        }
    };
}
pub(crate) use admission_suite;

/// A table with more sockets to spare and more waiting newcomers per
/// address than the listeners'.
mod third_shape {
    use super::*;

    const LIMITS: Limits = Limits {
        evict_idle: Duration::from_millis(500),
        claim_wait: Duration::from_millis(1500),
        waiting_per_address: 2,
    };

    admission_suite!(Slots::<6, 4, 2>::new(NAME, &LIMITS));
}

/// The tests' listener's name in log lines.
const NAME: &str = "test";

fn peer(host: u8, port: usize) -> Option<SocketAddrV4> {
    let port = u16::try_from(port).unwrap_or(u16::MAX);
    Some(SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, host), port))
}

/// Host `50 + k`, the `k`-th of several addresses.
fn host(k: usize) -> u8 {
    u8::try_from(50 + k).unwrap()
}

fn ms(v: u64) -> Duration {
    Duration::from_millis(v)
}

fn at(ms: u64) -> Instant {
    Instant::from_millis(ms)
}

type Claim<'a> = Pin<Box<dyn Future<Output = Result<(), Refusal>> + 'a>>;

/// A newcomer's claim in progress, with its own waker.
struct Newcomer<'a> {
    socket: usize,
    claim: Claim<'a>,
    flag: Arc<Flag>,
    waker: Waker,
}

/// One table, its newcomers and the clock: the scenarios are its
/// methods.
pub(crate) struct Rig<'a, const S: usize, const N: usize, const P: usize> {
    clock: &'a VirtualClock,
    slots: &'a Slots<S, N, P>,
    waiting: Vec<Newcomer<'a>>,
    /// Claims ended: socket, outcome (taken by [`Rig::outcome`]).
    ended: Vec<(usize, Result<(), Refusal>)>,
}

impl<'a, const S: usize, const N: usize, const P: usize> Rig<'a, S, N, P> {
    pub(crate) fn new(clock: &'a VirtualClock, slots: &'a Slots<S, N, P>) -> Self {
        Rig {
            clock,
            slots,
            waiting: Vec::new(),
            ended: Vec::new(),
        }
    }

    fn limits(&self) -> Limits {
        *self.slots.core.borrow().rules.limits
    }

    fn now(&self) -> Instant {
        self.clock.now()
    }

    /// Polls the newcomers that were woken until none is.
    fn poll(&mut self) {
        for _ in 0..1000 {
            let mut any = false;
            let mut i = 0;
            while i < self.waiting.len() {
                let n = &mut self.waiting[i];
                if !n.flag.0.swap(false, Ordering::Relaxed) {
                    i += 1;
                    continue;
                }
                any = true;
                let mut cx = Context::from_waker(&n.waker);
                if let Poll::Ready(r) = n.claim.as_mut().poll(&mut cx) {
                    let n = self.waiting.remove(i);
                    self.ended.push((n.socket, r));
                } else {
                    i += 1;
                }
            }
            if !any {
                return;
            }
        }
        panic!("the newcomers never settle");
    }

    /// Runs until `t`: each deadline in turn, the woken newcomers polled.
    fn run_until(&mut self, t: Instant) {
        loop {
            self.poll();
            match self.clock.next_deadline() {
                Some(d) if d <= t => self.clock.advance_to(d),
                _ => break,
            }
        }
        self.clock.advance_to(t);
        self.poll();
    }

    /// How the claim of socket `j` ended, if it has.
    fn outcome(&mut self, j: usize) -> Option<Result<(), Refusal>> {
        let i = self.ended.iter().position(|(s, _)| *s == j)?;
        Some(self.ended.remove(i).1)
    }

    /// Socket `j` accepts `peer`, which claims a slot: how it ended, if it
    /// did at once.
    fn arrive(&mut self, j: usize, peer: Option<SocketAddrV4>) -> Option<Result<(), Refusal>> {
        self.arrive_as(j, peer, Guard::NONE)
    }

    /// As [`Self::arrive`], the listener saying `guard` of the newcomer.
    fn arrive_as(
        &mut self,
        j: usize,
        peer: Option<SocketAddrV4>,
        guard: Guard,
    ) -> Option<Result<(), Refusal>> {
        let flag = Arc::new(Flag(AtomicBool::new(true)));
        self.waiting.push(Newcomer {
            socket: j,
            claim: Box::pin(self.slots.claim(j, peer, guard, self.clock)),
            waker: Waker::from(flag.clone()),
            flag,
        });
        self.poll();
        self.outcome(j)
    }

    /// Socket `j` accepts `peer`, which is served at once.
    fn serve(&mut self, j: usize, peer: Option<SocketAddrV4>) {
        assert_eq!(self.arrive(j, peer), Some(Ok(())), "socket {j} is served");
    }

    fn started(&mut self, j: usize) {
        self.slots.session(j).started();
        self.poll();
    }

    fn answered(&mut self, j: usize) {
        self.slots.session(j).answered(self.now());
        self.poll();
    }

    fn release(&mut self, j: usize) {
        self.slots.release(j);
        self.poll();
    }

    fn asked(&self, j: usize) -> Option<Close> {
        self.slots.session(j).check(true)
    }

    /// Every slot served (socket `k` from host `k`), each in the middle of
    /// a request if `busy`.
    fn fill(&mut self, busy: bool) {
        for k in 0..N {
            self.serve(k, peer(host(k), 1));
            if busy {
                self.started(k);
            }
        }
    }

    /// The sockets asked to close among `0..n`.
    fn asked_of(&self, n: usize) -> Vec<(usize, Close)> {
        (0..n)
            .filter_map(|j| self.asked(j).map(|c| (j, c)))
            .collect()
    }
}

/// The scenarios (see the module documentation).
impl<const S: usize, const N: usize, const P: usize> Rig<'_, S, N, P> {
    /// Newcomers take free slots at once; with every slot taken (none idle
    /// yet) the next waits, and takes the first slot freed, at once.
    pub(crate) fn free_slots_are_taken_at_once(&mut self) {
        self.fill(false);
        assert_eq!(
            self.arrive(N, peer(60, 1)),
            None,
            "every slot taken: it waits"
        );
        self.run_until(at(100));
        assert_eq!(self.outcome(N), None);
        self.release(0);
        assert_eq!(self.outcome(N), Some(Ok(())), "the freed slot, at once");
        assert_eq!(self.asked_of(S), [], "nobody was asked to close");
    }

    /// With no slot free, the newcomer waits until the longest-quiet session
    /// has been quiet for `evict_idle`, not a moment less; that one is asked
    /// to close (a busy one, however old, is not), and the newcomer takes its
    /// slot once it is free.
    pub(crate) fn a_newcomer_takes_the_slot_of_the_longest_idle_session(&mut self) {
        self.fill(false);
        // Session 0 is in the middle of a request from the start; the others
        // answer one after another, 1 first.
        self.started(0);
        for k in 1..N {
            self.run_until(at(100 * k as u64));
            self.answered(k);
        }
        assert_eq!(self.arrive(N, peer(60, 1)), None, "none idle yet: it waits");
        let due = at(100) + self.limits().evict_idle;
        self.run_until(due - ms(1));
        assert_eq!(self.outcome(N), None);
        assert_eq!(self.asked_of(N), [], "nobody asked before one is idle");
        self.run_until(due);
        assert_eq!(
            self.asked_of(N),
            [(1, Close::Evicted)],
            "session 1, idle longest, is asked; session 0, busy, is not"
        );
        assert_eq!(self.outcome(N), None, "it waits for the slot to be free");
        self.release(1);
        assert_eq!(self.outcome(N), Some(Ok(())));
    }

    /// Sessions that are all in the middle of a request are never idle: the
    /// newcomer is refused at the end of its wait, and nobody is asked.
    pub(crate) fn a_session_in_the_middle_of_a_request_is_never_idle(&mut self) {
        self.fill(true);
        assert_eq!(self.arrive(N, peer(60, 1)), None);
        let give_up = at(0) + self.limits().claim_wait;
        self.run_until(give_up - ms(1));
        assert_eq!(self.outcome(N), None, "it waits the whole claim wait");
        self.run_until(give_up);
        assert_eq!(self.outcome(N), Some(Err(Refusal::Full)));
        assert_eq!(self.asked_of(N), []);
        // Its socket is free again: the next newcomer waits as it did.
        assert_eq!(self.arrive(N, peer(61, 1)), None);
    }

    /// Every session busy when the newcomer comes: when one answers, the
    /// newcomer learns when it will be idle and takes its slot then, within
    /// its wait (it is not left asleep until the wait's end).
    pub(crate) fn an_answer_wakes_a_waiting_newcomer(&mut self) {
        let Limits {
            evict_idle,
            claim_wait,
            ..
        } = self.limits();
        assert!(evict_idle < claim_wait, "a newcomer outwaits an idle time");
        self.fill(true);
        assert_eq!(self.arrive(N, peer(60, 1)), None);
        let answer = at(0) + (claim_wait - evict_idle) / 2;
        self.run_until(answer);
        self.answered(N - 1);
        self.run_until(answer + evict_idle - ms(1));
        assert_eq!(self.asked_of(N), []);
        self.run_until(answer + evict_idle);
        assert_eq!(self.asked_of(N), [(N - 1, Close::Evicted)]);
        self.release(N - 1);
        assert_eq!(self.outcome(N), Some(Ok(())));
    }

    /// A session that becomes idle just as the newcomer's wait ends is left
    /// alone: the newcomer, refused, would not take its slot.
    pub(crate) fn at_the_end_of_its_wait_a_newcomer_evicts_nobody(&mut self) {
        let Limits {
            evict_idle,
            claim_wait,
            ..
        } = self.limits();
        self.fill(true);
        assert_eq!(self.arrive(N, peer(60, 1)), None);
        self.run_until(at(0) + (claim_wait - evict_idle));
        self.answered(0);
        self.run_until(at(0) + claim_wait);
        assert_eq!(self.outcome(N), Some(Err(Refusal::Full)));
        assert_eq!(
            self.asked_of(N),
            [],
            "session 0, idle only now, keeps its slot"
        );
    }

    /// A newcomer whose address has its cap of slots takes the slot of its
    /// address's least recently active session at once (quiet, not idle),
    /// and no other address's, however much longer that one has been quiet.
    pub(crate) fn an_address_at_its_cap_gives_way_to_its_newest(&mut self) {
        assert!(P < N && N < S, "the scenario needs another address's slot");
        // Sockets 0..P from 10.0.0.66, the others from elsewhere.
        for k in 0..N {
            let from = if k < P { peer(66, k) } else { peer(host(k), 1) };
            self.serve(k, from);
        }
        // Last answers: an other address's session first, then 66's socket
        // P - 1, then 66's others, then the rest.
        self.run_until(at(50));
        self.answered(P);
        self.run_until(at(100));
        self.answered(P - 1);
        self.run_until(at(200));
        for k in (0..P - 1).chain(P + 1..N) {
            self.answered(k);
        }
        self.run_until(at(300));
        assert!(at(50) + self.limits().evict_idle > at(300), "none idle yet");
        assert_eq!(self.arrive(N, peer(66, 99)), None);
        assert_eq!(
            self.asked_of(N),
            [(P - 1, Close::Evicted)],
            "66's least recently active, at once"
        );
        self.release(P - 1);
        assert_eq!(self.outcome(N), Some(Ok(())));
    }

    /// A newcomer whose address has its cap, all busy: up to
    /// `waiting_per_address` of them wait (and one more is refused at once),
    /// while another address's newcomer is served at once; when one of the
    /// address's sessions answers, the first waiting takes its slot.
    pub(crate) fn an_address_at_its_cap_with_every_session_busy(&mut self) {
        let waiting = self.limits().waiting_per_address;
        assert!(P < N && P + waiting < S, "the scenario needs its sockets");
        for k in 0..P {
            self.serve(k, peer(66, k));
            self.started(k);
        }
        for k in P..P + waiting {
            assert_eq!(self.arrive(k, peer(66, k)), None, "it waits for its own");
        }
        let more = P + waiting;
        assert_eq!(
            self.arrive(more, peer(66, more)),
            Some(Err(Refusal::PerAddress)),
            "one more is refused at once"
        );
        self.serve(more, peer(50, 1));
        assert_eq!(self.asked_of(S), []);
        if waiting == 0 {
            return;
        }
        self.run_until(at(10));
        self.answered(0);
        assert_eq!(self.asked(0), Some(Close::Evicted), "quiet: it gives way");
        assert_eq!(self.asked(1), None, "busy: it does not");
        self.release(0);
        assert_eq!(self.outcome(P), Some(Ok(())), "the first waiting is served");
    }

    /// Two newcomers wait; a slot freed goes to the one that came first, even
    /// if the other looks first.
    pub(crate) fn newcomers_are_served_first_come_first_served(&mut self) {
        self.fill(true);
        assert_eq!(self.arrive(N, peer(70, 1)), None);
        self.run_until(at(10));
        // Session 0 ends; before the first newcomer looks again, another
        // comes on its socket, and looks first.
        self.slots.release(0);
        assert_eq!(self.arrive(0, peer(71, 1)), None, "the first came first");
        assert_eq!(self.outcome(N), Some(Ok(())));
        assert_eq!(self.outcome(0), None, "the second waits on");
    }

    /// A new allow-list asks the sessions it refuses to close (and wakes
    /// those waiting for that), refuses the waiting newcomers it refuses,
    /// and leaves the others alone; the check before each request says
    /// so.
    pub(crate) fn a_new_allow_list_closes_whom_it_refuses(&mut self) {
        self.fill(true);
        let refused = peer(host(1), 2);
        assert_eq!(self.arrive(N, refused), None);
        let session = self.slots.session(1);
        let mut closing = Box::pin(session.closing());
        let flag = Arc::new(Flag(AtomicBool::new(false)));
        let waker = Waker::from(flag.clone());
        let mut cx = Context::from_waker(&waker);
        assert_eq!(closing.as_mut().poll(&mut cx), Poll::Pending);
        self.slots
            .close_unless(|p| p.is_some_and(|p| p.ip().octets()[3] != host(1)));
        self.poll();
        assert!(flag.0.load(Ordering::Relaxed), "its server is woken");
        assert_eq!(
            closing.as_mut().poll(&mut cx),
            Poll::Ready(Close::NotAllowed)
        );
        assert_eq!(self.asked_of(N), [(1, Close::NotAllowed)]);
        assert_eq!(self.outcome(N), Some(Err(Refusal::NotAllowed)));
        // Before each request the listener checks with its list's verdict:
        // an asked session is not served, whatever the verdict; another
        // is, unless the verdict is no.
        let (asked, other) = (self.slots.session(1), self.slots.session(0));
        assert_eq!(asked.check(true), Some(Close::NotAllowed));
        assert_eq!(other.check(true), None);
        assert_eq!(other.check(false), Some(Close::NotAllowed));
    }

    /// Peers whose address is unknown are not one address: the cap does not
    /// apply to them.
    pub(crate) fn an_unknown_address_counts_for_no_address(&mut self) {
        assert!(P < N, "more slots than one address may hold");
        for k in 0..N {
            self.serve(k, None);
        }
        assert_eq!(self.asked_of(S), []);
    }

    /// A slot is reserved: the unprotected hold at most all but one, even
    /// with that one free (a newcomer of theirs waits, and is refused at
    /// the end of its wait); a protected newcomer takes it at once.
    pub(crate) fn the_reserved_slot_is_kept_for_a_protected_newcomer(&mut self) {
        assert!(N < S, "a socket for the newcomers");
        for k in 0..N - 1 {
            self.arrive_as(k, peer(host(k), 1), RESERVING);
            self.started(k);
        }
        assert_eq!(
            self.arrive_as(N - 1, peer(60, 1), RESERVING),
            None,
            "the free slot is the reserved one: it waits"
        );
        self.run_until(at(0) + self.limits().claim_wait);
        assert_eq!(self.outcome(N - 1), Some(Err(Refusal::Full)));
        assert_eq!(
            self.arrive_as(N - 1, peer(PLC, 1), PLC_GUARD),
            Some(Ok(())),
            "the PLC takes it at once"
        );
        assert_eq!(self.asked_of(S), []);
    }

    /// The PLC's session, quiet far longer than the idle time, is never
    /// closed for another address's newcomer; an idle unprotected one is.
    pub(crate) fn a_protected_session_is_never_closed_for_another_address(&mut self) {
        assert!(N < S, "a socket for the newcomer");
        self.arrive_as(0, peer(PLC, 1), PLC_GUARD);
        for k in 1..N {
            self.arrive_as(k, peer(host(k), 1), RESERVING);
        }
        // All quiet since 0; the others answer at 100 ms.
        self.run_until(at(100));
        for k in 1..N {
            self.answered(k);
        }
        let idle = self.limits().evict_idle;
        self.run_until(at(100) + idle * 4);
        assert_eq!(self.arrive_as(N, peer(61, 1), RESERVING), None);
        assert_eq!(
            self.asked_of(N),
            [(1, Close::Evicted)],
            "the longest-idle unprotected session, not the PLC's"
        );
        // With every unprotected one busy, the newcomer is refused: the
        // PLC, idle longest, keeps its slot.
        self.release(1);
        assert_eq!(self.outcome(N), Some(Ok(())));
        for k in 2..=N {
            self.started(k);
        }
        assert_eq!(self.arrive_as(1, peer(62, 1), RESERVING), None);
        let end = self.now() + self.limits().claim_wait;
        self.run_until(end);
        assert_eq!(self.outcome(1), Some(Err(Refusal::Full)));
        assert_eq!(self.asked(0), None, "the PLC's session stays");
    }

    /// Unprotected newcomers wait for a slot; a protected one that comes
    /// after them takes the reserved slot first.
    pub(crate) fn a_protected_newcomer_waits_behind_no_unprotected_one(&mut self) {
        assert!(N + 1 < S || N >= 2, "sockets for two newcomers");
        // The unprotected hold their share, busy; one of them waits.
        for k in 0..N - 1 {
            self.arrive_as(k, peer(host(k), 1), RESERVING);
            self.started(k);
        }
        let waiting = N - 1;
        assert_eq!(self.arrive_as(waiting, peer(60, 1), RESERVING), None);
        let plc = if N < S { N } else { return };
        assert_eq!(
            self.arrive_as(plc, peer(PLC, 1), PLC_GUARD),
            Some(Ok(())),
            "not held up by the unprotected newcomer"
        );
        assert_eq!(self.outcome(waiting), None, "which waits on");
    }

    /// The reservation switched on while the unprotected hold every slot:
    /// a protected newcomer takes the slot of the least recently active
    /// quiet one at once, idle or not.
    pub(crate) fn a_reservation_switched_on_makes_room_at_once(&mut self) {
        assert!(N < S, "a socket for the newcomer");
        for k in 0..N {
            self.serve(k, peer(host(k), 1));
        }
        // Answered one after another, N - 1 first.
        for k in (0..N).rev() {
            self.run_until(at(50 + 10 * (N - k) as u64));
            self.answered(k);
        }
        self.slots
            .protect(true, |p| p.is_some_and(|p| p.ip().octets()[3] == PLC));
        self.poll();
        assert_eq!(self.asked_of(N), [], "nobody asked before the PLC comes");
        assert_eq!(self.arrive_as(N, peer(PLC, 1), PLC_GUARD), None);
        assert_eq!(
            self.asked_of(N),
            [(N - 1, Close::Evicted)],
            "the least recently active unprotected session, at once"
        );
        self.release(N - 1);
        assert_eq!(self.outcome(N), Some(Ok(())));
    }

    /// Issue 25, finding 2, the attack: every slot but the PLC's held by
    /// busy sessions from two addresses (which the per-address cap
    /// allows), and one more connection of theirs always waiting. The PLC
    /// polls at 1.5 times the idle time. Before the reserved slot the
    /// waiting attacker took the PLC's slot at its first idle moment, and
    /// when the PLC reconnected (its session closed: a reboot) the waiting
    /// attacker took the freed slot and the PLC got none. Now the PLC is
    /// never asked to close, every poll is served, and each reconnect is
    /// served at once.
    pub(crate) fn a_busy_flood_from_several_addresses_cannot_keep_the_plc_out(&mut self) {
        assert!(N < S, "a socket for the attackers' newcomer");
        let Limits { evict_idle, .. } = self.limits();
        let poll = evict_idle * 3 / 2;
        // The attackers: from two addresses, every slot but one.
        let attackers: Vec<usize> = (1..N).collect();
        for &k in &attackers {
            let from = peer(70 + (k % 2) as u8, k);
            assert_eq!(self.arrive_as(k, from, RESERVING), Some(Ok(())));
        }
        let plc = 0;
        assert_eq!(self.arrive_as(plc, peer(PLC, 1), PLC_GUARD), Some(Ok(())));
        // Their newcomer, on the spare socket, tries again whenever refused.
        let spare = N;
        let mut tries = 1;
        assert_eq!(self.arrive_as(spare, peer(70, 100), RESERVING), None);
        let mut polls = 0;
        let mut reconnects = 0;
        for round in 0..12u64 {
            let t0 = self.now();
            let mut t = t0;
            while t < t0 + poll {
                for &k in &attackers {
                    self.started(k);
                }
                t += ms(10);
                self.run_until(t);
                for &k in &attackers {
                    self.answered(k);
                }
                match self.outcome(spare) {
                    None => {}
                    Some(Ok(())) => panic!("round {round}: the attackers' newcomer got a slot"),
                    Some(Err(_)) => {
                        self.release(spare);
                        tries += 1;
                        let again = self.arrive_as(spare, peer(70, 100 + tries), RESERVING);
                        assert!(again.is_none_or(|r| r.is_err()), "round {round}: {again:?}");
                        if again.is_some() {
                            self.release(spare);
                        }
                    }
                }
                assert_eq!(
                    self.asked(plc),
                    None,
                    "round {round}: the PLC is asked to close"
                );
            }
            // The PLC polls: served by its session.
            self.started(plc);
            self.answered(plc);
            polls += 1;
            // Every third round it reconnects (its session closed: a
            // reboot) while the attackers' newcomer waits: served at once.
            if round % 3 == 2 {
                self.release(plc);
                let got = self.arrive_as(plc, peer(PLC, 2 + round as usize), PLC_GUARD);
                assert_eq!(
                    got,
                    Some(Ok(())),
                    "round {round}: the reconnecting PLC is served"
                );
                reconnects += 1;
            }
        }
        assert_eq!((polls, reconnects), (12, 4));
        assert!(tries > 1, "the attackers' newcomer kept trying");
    }

    /// The attack of the second security review, replayed over loopback
    /// (host-tests/attacks): busy clients hold every slot but the PLC's and
    /// their newcomers wait on the spare sockets; the PLC reconnects, and
    /// the socket its old session freed accepts what the kernel queued
    /// first: the attackers' reconnects. Each of those used to wait there
    /// for a slot (up to `claim_wait`), holding the only socket that could
    /// accept, so the PLC waited that long per queued connection. Now
    /// unprotected peers never hold the last socket while a slot is
    /// reserved: each is refused at once, and the PLC is served as soon as
    /// the queue reaches it.
    pub(crate) fn newcomers_queued_before_the_plc_cannot_hold_the_socket_it_reconnects_on(
        &mut self,
    ) {
        assert!(N < S, "a socket for the attackers' newcomers");
        let plc = 0;
        assert_eq!(self.arrive_as(plc, peer(PLC, 1), PLC_GUARD), Some(Ok(())));
        let attackers: Vec<usize> = (1..N).collect();
        for &k in &attackers {
            let from = peer(70 + (k % 2) as u8, k);
            assert_eq!(self.arrive_as(k, from, RESERVING), Some(Ok(())));
            self.started(k);
        }
        // Their newcomers on every spare socket: they may wait.
        for spare in N..S {
            let got = self.arrive_as(spare, peer(72 + (spare % 2) as u8, spare), RESERVING);
            assert_eq!(got, None, "newcomer on spare socket {spare}");
        }
        // The PLC reconnects: its socket is freed, and accepts the
        // attackers' queued reconnects first.
        self.release(plc);
        for queued in 0..5 {
            let from = peer(72 + (queued % 2) as u8, 200 + queued);
            let got = self.arrive_as(plc, from, RESERVING);
            assert!(
                matches!(got, Some(Err(Refusal::Full))),
                "queued attacker {queued} on the PLC's socket: {got:?} (it must be refused at once)"
            );
            self.release(plc);
        }
        assert_eq!(
            self.arrive_as(plc, peer(PLC, 2), PLC_GUARD),
            Some(Ok(())),
            "the reconnecting PLC is served when the queue reaches it"
        );
        for &k in &attackers {
            self.answered(k);
        }
    }
}

/// The PLC's host in the protection scenarios.
const PLC: u8 = 20;

/// A newcomer that is not the PLC, with a slot reserved.
const RESERVING: Guard = Guard {
    reserving: true,
    protected: false,
};

/// The PLC, with a slot reserved.
const PLC_GUARD: Guard = Guard {
    reserving: true,
    protected: true,
};
