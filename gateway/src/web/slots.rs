//! Who the web server serves: its sockets, its slots, and who gives way
//! to a newcomer.
//!
//! The server has [`WEB_CONNECTIONS`] sockets but [`WEB_SLOTS`] slots: a
//! slot is what serving takes (an HTTP buffer and the request handler's
//! state, ~15 KiB), a socket only what accepting takes (its 3 KiB of
//! socket buffers). So one socket more than the slots costs a socket, and
//! it always accepts a newcomer while every slot is taken; the newcomer
//! then waits in this table for a slot (see `web/mod.rs` for the rules and
//! the bounds).
//!
//! A connection is *busy* from the first byte of a request until its
//! answer is written, and *idle* once it has been neither busy nor
//! accepted for [`EVICT_IDLE`]. Entries are per socket; a served entry
//! names its slot. Serving futures, accepting futures and the allow-list
//! warden share the table; none holds it across an await.

use core::cell::RefCell;
use core::future::poll_fn;
use core::net::SocketAddrV4;
use core::task::Poll;

use embassy_futures::select::select;
use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::waitqueue::MultiWakerRegistration;
use embassy_time::Instant;

use super::{CLAIM_WAIT, EVICT_IDLE, PER_ADDRESS, WEB_CONNECTIONS, WEB_SLOTS};
use crate::clock::Clock;

/// Why a connection is asked to close.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(crate) enum Close {
    /// A newcomer takes its slot (it was the longest idle, or the least
    /// recently active of the newcomer's own address).
    Evicted,
    /// The allow-list in use no longer permits its address.
    NotAllowed,
}

/// Why a newcomer is not served.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Refusal {
    /// Its address has [`PER_ADDRESS`] connections, all busy, and
    /// another newcomer of it waits already.
    PerAddress,
    /// Every slot stayed taken by a connection that is not idle, for
    /// [`CLAIM_WAIT`].
    Full,
    /// The allow-list changed while it waited.
    NotAllowed,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// The socket accepts (or is between connections).
    Free,
    /// A newcomer waits for a slot; the ticket says who came first.
    Waiting(u64),
    /// A client is served in this slot.
    Serving(usize),
}

/// One socket's connection, as the others see it.
#[derive(Clone, Copy, Debug)]
struct Entry {
    phase: Phase,
    peer: Option<SocketAddrV4>,
    /// When it last answered a request (or was given its slot).
    last: Instant,
    /// A request (or its answer) in progress, since its first byte.
    busy: Option<Instant>,
    /// Asked to close, and why.
    close: Option<Close>,
}

impl Entry {
    const FREE: Entry = Entry {
        phase: Phase::Free,
        peer: None,
        last: Instant::from_ticks(0),
        busy: None,
        close: None,
    };

    fn serving(&self) -> bool {
        matches!(self.phase, Phase::Serving(_))
    }

    fn same_host(&self, peer: Option<SocketAddrV4>) -> bool {
        matches!((self.peer, peer), (Some(a), Some(b)) if a.ip() == b.ip())
    }

    /// Served, not asked to close, and no request in progress.
    fn quiet(&self) -> bool {
        self.serving() && self.close.is_none() && self.busy.is_none()
    }

    /// Quiet for [`EVICT_IDLE`].
    fn idle(&self, now: Instant) -> bool {
        self.quiet() && now.saturating_duration_since(self.last) >= EVICT_IDLE
    }
}

/// What a waiting newcomer does next.
enum Step {
    Claimed(usize),
    Refuse(Refusal),
    /// Wait for a change, or until then at the latest.
    Wait(Option<Instant>),
}

/// Wakers: each future of the server may wait on the table (all of them
/// are one task on the gateway's executors, which takes one entry).
const WAKERS: usize = WEB_CONNECTIONS + WEB_SLOTS + 1;

struct Table {
    socks: [Entry; WEB_CONNECTIONS],
    tickets: u64,
    gen: u32,
    wakers: MultiWakerRegistration<WAKERS>,
}

impl Table {
    fn changed(&mut self) {
        self.gen = self.gen.wrapping_add(1);
        self.wakers.wake();
    }

    /// Asks the least recently active connection that `which` picks to
    /// close.
    fn evict_where(&mut self, which: impl Fn(&Entry) -> bool) -> bool {
        let victim = self
            .socks
            .iter_mut()
            .filter(|e| which(e))
            .min_by_key(|e| e.last);
        let Some(v) = victim else {
            return false;
        };
        v.close = Some(Close::Evicted);
        self.changed();
        true
    }

    /// A slot no connection is served in.
    fn free_slot(&self) -> Option<usize> {
        (0..WEB_SLOTS).find(|&k| self.socks.iter().all(|e| e.phase != Phase::Serving(k)))
    }

    /// Connections of waiting newcomer `j`'s address ahead of it (served,
    /// or waiting since earlier), not asked to close.
    fn mine(&self, j: usize) -> usize {
        let Some(me) = self.socks.get(j) else {
            return 0;
        };
        let Phase::Waiting(ticket) = me.phase else {
            return 0;
        };
        self.socks
            .iter()
            .filter(|e| match e.phase {
                Phase::Serving(_) => true,
                Phase::Waiting(t) => t < ticket,
                Phase::Free => false,
            })
            .filter(|e| e.close.is_none() && e.same_host(me.peer))
            .count()
    }

    /// Newcomer `j` (waiting): may it take a slot now?
    fn step(&mut self, j: usize, now: Instant) -> Step {
        let Some(me) = self.socks.get(j).copied() else {
            return Step::Refuse(Refusal::Full);
        };
        if me.close.is_some() {
            return Step::Refuse(Refusal::NotAllowed);
        }
        let Phase::Waiting(ticket) = me.phase else {
            return Step::Refuse(Refusal::Full);
        };
        // Its address's cap first: the newest connection of an address
        // wins, so its own least recently active connection not in the
        // middle of a request makes room (a browser opens another when its
        // others are busy, a script beside it on the same host too); with
        // all of them busy it waits for the first to finish, unless
        // another of its address waits already. One address never holds
        // more than its cap, nor more than one waiting socket.
        if self.mine(j) >= PER_ADDRESS && !self.evict_where(|e| e.quiet() && e.same_host(me.peer)) {
            let another = self.socks.iter().any(|e| {
                matches!(e.phase, Phase::Waiting(t) if t < ticket) && e.same_host(me.peer)
            });
            return match another {
                true => Step::Refuse(Refusal::PerAddress),
                // Woken when one of them is answered.
                false => Step::Wait(None),
            };
        }
        // First come, first served (a newcomer waiting for its own
        // address's connections does not hold up the others).
        let before = (0..WEB_CONNECTIONS).any(|i| {
            self.socks
                .get(i)
                .is_some_and(|e| matches!(e.phase, Phase::Waiting(t) if t < ticket))
                && self.mine(i) < PER_ADDRESS
        });
        if before {
            return Step::Wait(None);
        }
        if let Some(k) = self.free_slot() {
            if let Some(e) = self.socks.get_mut(j) {
                e.phase = Phase::Serving(k);
                e.last = now;
            }
            self.changed();
            return Step::Claimed(k);
        }
        let closing = self.socks.iter().any(|e| e.serving() && e.close.is_some());
        if closing || self.evict_where(|e| e.idle(now)) {
            return Step::Wait(None);
        }
        // None idle yet: wait until the first may be.
        let next = self
            .socks
            .iter()
            .filter(|e| e.quiet())
            .map(|e| e.last + EVICT_IDLE)
            .min();
        Step::Wait(next)
    }
}

/// The connections' table (see the module documentation).
pub(crate) struct Slots {
    table: Mutex<NoopRawMutex, RefCell<Table>>,
}

impl Slots {
    /// All free.
    pub(crate) const fn new() -> Self {
        Slots {
            table: Mutex::new(RefCell::new(Table {
                socks: [Entry::FREE; WEB_CONNECTIONS],
                tickets: 0,
                gen: 0,
                wakers: MultiWakerRegistration::new(),
            })),
        }
    }

    fn with<R>(&self, f: impl FnOnce(&mut Table) -> R) -> R {
        self.table.lock(|t| f(&mut t.borrow_mut()))
    }

    /// Resolves when `f` gives a value (it is asked again at each change of
    /// the table).
    async fn until<R>(&self, mut f: impl FnMut(&Table) -> Option<R>) -> R {
        poll_fn(|cx| {
            self.with(|t| match f(t) {
                Some(r) => Poll::Ready(r),
                None => {
                    t.wakers.register(cx.waker());
                    Poll::Pending
                }
            })
        })
        .await
    }

    /// Socket `j` accepted `peer` (that the allow-list permits): waits
    /// until it is given a slot (its index), at most [`CLAIM_WAIT`].
    pub(crate) async fn claim<C: Clock>(
        &self,
        j: usize,
        peer: Option<SocketAddrV4>,
        clock: &C,
    ) -> Result<usize, Refusal> {
        let start = clock.now();
        self.with(|t| {
            t.tickets = t.tickets.wrapping_add(1);
            if let Some(e) = t.socks.get_mut(j) {
                *e = Entry {
                    phase: Phase::Waiting(t.tickets),
                    peer,
                    last: start,
                    busy: None,
                    close: None,
                };
            }
        });
        let give_up = start + CLAIM_WAIT;
        loop {
            let now = clock.now();
            let (step, gen) = self.with(|t| {
                let step = match t.step(j, now) {
                    Step::Wait(_) if now >= give_up => Step::Refuse(Refusal::Full),
                    s => s,
                };
                (step, t.gen)
            });
            let until = match step {
                Step::Claimed(k) => return Ok(k),
                Step::Refuse(r) => {
                    self.release(j);
                    return Err(r);
                }
                Step::Wait(at) => at.map_or(give_up, |a| a.min(give_up)),
            };
            let changed = self.until(|t| (t.gen != gen).then_some(()));
            select(changed, clock.sleep_until(until)).await;
        }
    }

    /// Waits until a connection is given slot `k`: its socket and peer.
    pub(crate) async fn assigned(&self, k: usize) -> (usize, Option<SocketAddrV4>) {
        self.until(|t| {
            t.socks
                .iter()
                .position(|e| e.phase == Phase::Serving(k))
                .map(|j| (j, t.socks.get(j).and_then(|e| e.peer)))
        })
        .await
    }

    /// Waits until socket `j`'s connection is over (released).
    pub(crate) async fn released(&self, j: usize) {
        self.until(|t| {
            t.socks
                .get(j)
                .is_none_or(|e| e.phase == Phase::Free)
                .then_some(())
        })
        .await
    }

    /// Socket `j`'s connection ended (or was refused): its slot, if it had
    /// one, is free.
    pub(crate) fn release(&self, j: usize) {
        self.with(|t| {
            if let Some(e) = t.socks.get_mut(j) {
                *e = Entry::FREE;
            }
            t.changed();
        });
    }

    /// Asks every connection (served or waiting) whose peer `permits`
    /// refuses to close; they do before anything more of theirs is read.
    pub(crate) fn close_unless(&self, permits: impl Fn(Option<SocketAddrV4>) -> bool) {
        self.with(|t| {
            let mut any = false;
            for e in t.socks.iter_mut() {
                if e.phase != Phase::Free && e.close.is_none() && !permits(e.peer) {
                    e.close = Some(Close::NotAllowed);
                    any = true;
                }
            }
            if any {
                t.changed();
            }
        });
    }

    /// Socket `j`'s connection as its server sees it.
    pub(crate) fn session(&self, j: usize) -> Session<'_> {
        Session { slots: self, j }
    }
}

/// One served connection's end of the table: what its server reports and
/// what it is asked.
#[derive(Clone, Copy)]
pub(crate) struct Session<'a> {
    slots: &'a Slots,
    j: usize,
}

impl Session<'_> {
    /// A request's first byte came at `at`.
    pub(crate) fn started(&self, at: Instant) {
        self.slots.with(|t| {
            if let Some(e) = t.socks.get_mut(self.j) {
                e.busy.get_or_insert(at);
            }
        });
    }

    /// A request was answered at `at`: the connection is quiet from then
    /// (a newcomer waiting for an idle one learns when that may be).
    pub(crate) fn answered(&self, at: Instant) {
        self.slots.with(|t| {
            if let Some(e) = t.socks.get_mut(self.j) {
                e.busy = None;
                e.last = at;
            }
            t.changed();
        });
    }

    /// Why it was asked to close, if it was.
    pub(crate) fn asked(&self) -> Option<Close> {
        self.slots
            .with(|t| t.socks.get(self.j).and_then(|e| e.close))
    }

    /// Resolves when it is asked to close.
    pub(crate) async fn closing(&self) -> Close {
        self.slots
            .until(|t| t.socks.get(self.j).and_then(|e| e.close))
            .await
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::net::Ipv4Addr;

    fn peer(last: u8, port: u16) -> Option<SocketAddrV4> {
        Some(SocketAddrV4::new(Ipv4Addr::new(10, 0, 0, last), port))
    }

    fn at(ms: u64) -> Instant {
        Instant::from_millis(ms)
    }

    /// Socket `j` waits as `peer`, at `now`.
    fn wait(t: &mut Table, j: usize, p: Option<SocketAddrV4>, now: Instant) {
        t.tickets += 1;
        t.socks[j] = Entry {
            phase: Phase::Waiting(t.tickets),
            peer: p,
            last: now,
            busy: None,
            close: None,
        };
    }

    fn table() -> Table {
        Table {
            socks: [Entry::FREE; WEB_CONNECTIONS],
            tickets: 0,
            gen: 0,
            wakers: MultiWakerRegistration::new(),
        }
    }

    #[test]
    fn newcomers_take_free_slots_then_the_longest_idle() {
        let mut t = table();
        for j in 0..WEB_SLOTS {
            wait(&mut t, j, peer(50 + j as u8, 1), at(0));
            assert!(matches!(t.step(j, at(j as u64)), Step::Claimed(k) if k == j));
        }
        // All quiet, none idle yet: wait until the first is.
        wait(&mut t, WEB_SLOTS, peer(60, 1), at(10));
        assert!(
            matches!(t.step(WEB_SLOTS, at(10)), Step::Wait(Some(w)) if w == at(0) + EVICT_IDLE)
        );
        // Slot 1 is busy; at the deadline, slot 0 (idle longest) goes.
        t.socks[1].busy = Some(at(500));
        let later = at(0) + EVICT_IDLE + EVICT_IDLE;
        assert!(matches!(t.step(WEB_SLOTS, later), Step::Wait(None)));
        assert_eq!(t.socks[0].close, Some(Close::Evicted));
        assert_eq!(t.socks[1].close, None);
        // Its slot freed, the newcomer takes it.
        t.socks[0] = Entry::FREE;
        assert!(matches!(t.step(WEB_SLOTS, later), Step::Claimed(0)));
    }

    #[test]
    fn an_address_at_its_cap_gives_way_to_its_newest_or_is_refused() {
        let mut t = table();
        for j in 0..PER_ADDRESS {
            wait(&mut t, j, peer(66, j as u16), at(0));
            assert!(matches!(t.step(j, at(j as u64)), Step::Claimed(_)));
        }
        // Both busy: a third from 66 waits, a fourth is refused at once,
        // and another address is not held up by them.
        t.socks[0].busy = Some(at(5));
        t.socks[1].busy = Some(at(5));
        wait(&mut t, 2, peer(66, 9), at(10));
        assert!(matches!(t.step(2, at(10)), Step::Wait(None)));
        wait(&mut t, 3, peer(66, 10), at(10));
        assert!(matches!(
            t.step(3, at(10)),
            Step::Refuse(Refusal::PerAddress)
        ));
        wait(&mut t, 3, peer(50, 1), at(10));
        assert!(matches!(t.step(3, at(10)), Step::Claimed(2)));
        // One of 66's quiet (however briefly): it makes room for the
        // newest, which takes its slot once it is freed.
        t.socks[1].busy = None;
        t.socks[1].last = at(9);
        assert!(matches!(t.step(2, at(10)), Step::Wait(None)));
        assert_eq!(t.socks[1].close, Some(Close::Evicted));
        assert_eq!(t.socks[0].close, None);
        t.socks[1] = Entry::FREE;
        assert!(matches!(t.step(2, at(10)), Step::Claimed(1)));
    }
}
