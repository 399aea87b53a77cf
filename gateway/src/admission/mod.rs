//! Who a listener serves: its sockets, its slots, and who gives way to a
//! newcomer. One policy against clients that hold what others need (a
//! flood, a slow client, a keep-alive connection left open), for every
//! listener; each sets its sizes (const generics of [`Slots`]) and its
//! times ([`Limits`]).
//!
//! A listener has `SOCKETS` sockets but `SLOTS` slots: a slot is what
//! serving a client takes, a socket only what accepting one takes. With
//! one socket more than slots, one always accepts a newcomer while every
//! slot is taken; the newcomer then waits in this table for a slot
//! ([`Slots::claim`]). Each socket has an entry here; the listener's
//! futures and whoever applies an allow-list share the table, and none
//! holds it across an await.
//!
//! # Rules
//! * A session is *busy* from the first byte of a request until its answer
//!   is written ([`Session::started`], [`Session::answered`]), *quiet*
//!   otherwise, and *idle* once it has been quiet for
//!   [`Limits::evict_idle`] since its last answer (or since it was given
//!   its slot).
//! * A newcomer takes a free slot. With none free, the longest-idle
//!   session is asked to close ([`Close::Evicted`]) and the newcomer takes
//!   its slot once it has. With none idle, the newcomer waits, at most
//!   [`Limits::claim_wait`], then is refused ([`Refusal::Full`]); at that
//!   moment it takes a free slot or is refused, and evicts nobody.
//!   Newcomers are served first come, first served, except that one
//!   waiting for its own address's sessions (below) holds up no other.
//! * An address has at most `PER_ADDRESS` slots (its sessions, and its
//!   newcomers waiting ahead): a newcomer whose address has them takes the
//!   slot of its address's least recently active quiet session, at once,
//!   however briefly quiet (the newest connection of an address wins: a
//!   client that reconnects before its old connection is seen closing, a
//!   browser that opens another). If every one of them is busy, up to
//!   [`Limits::waiting_per_address`] newcomers of that address wait for
//!   the first to be quiet; one more is refused at once
//!   ([`Refusal::PerAddress`]). An address never holds more than its cap,
//!   and evicts only its own sessions for it. A peer whose address is
//!   unknown (`None`) counts for no address.
//! * Allow-lists: the listener checks its list at accept (and counts the
//!   refusals: the list and the counters are its own), and
//!   [`Slots::close_unless`] asks every session and newcomer that a new
//!   list refuses to close ([`Close::NotAllowed`],
//!   [`Refusal::NotAllowed`]). A session asked to close, for either
//!   reason, is served nothing more: the listener checks
//!   [`Session::asked`] before each request and stops reading when
//!   [`Session::closing`] resolves.
//!
//! Who may take a slot is decided in one place, `Core::step`, and which
//! sessions may be taken for it in `Entry::idle` and the two eviction
//! calls in `step`: a rule that keeps some sessions from eviction or
//! keeps a slot for some addresses is added there.
//!
//! # One compiled copy
//! The rules work on a slice of entries (`Core<[Entry]>`), so that the
//! listeners' tables, arrays of their own sizes, share one copy of them in
//! flash; only the shell around them ([`Slots`]: the lock, the wakers, the
//! newcomer's wait) is generic.

#[cfg(test)]
pub(crate) mod tests;

use core::cell::RefCell;
use core::future::poll_fn;
use core::net::SocketAddrV4;
use core::task::Poll;

use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::waitqueue::MultiWakerRegistration;
use embassy_time::{Duration, Instant};

use crate::clock::{with_deadline, Clock};

/// A listener's times (and how patient it is with one address).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Limits {
    /// A session quiet this long is idle: a newcomer may take its slot.
    pub evict_idle: Duration,
    /// The longest a newcomer waits for a slot.
    pub claim_wait: Duration,
    /// Newcomers of an address that may wait while it has its cap of
    /// slots, all busy; one more is refused at once.
    pub waiting_per_address: usize,
}

/// How a listener's log lines name it and its allow-list.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Names {
    /// The lines' prefix: `modbus`, `web`.
    pub listener: &'static str,
    /// The allow-list's setting: `MODBUS_ALLOW`.
    pub allow_list: &'static str,
}

/// Why a session is asked to close.
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
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(crate) enum Refusal {
    /// Its address has its cap of slots, all busy, and as many of its
    /// newcomers as may wait wait already.
    PerAddress,
    /// Every slot stayed taken by a session that is not idle, for
    /// [`Limits::claim_wait`].
    Full,
    /// The allow-list refuses it (at accept, or changed while it waited).
    NotAllowed,
}

/// A peer's address for logs (0.0.0.0 when unknown).
pub(crate) fn octets(peer: Option<SocketAddrV4>) -> [u8; 4] {
    peer.map_or([0; 4], |p| p.ip().octets())
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// The socket accepts (or is between connections).
    Free,
    /// A newcomer waits for a slot; the ticket says who came first.
    Waiting(u64),
    /// A client is served.
    Serving,
}

/// One socket's session, as the others see it.
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
        self.phase == Phase::Serving
    }

    /// A newcomer that came before the one with `ticket`.
    fn waiting_before(&self, ticket: u64) -> bool {
        matches!(self.phase, Phase::Waiting(t) if t < ticket)
    }

    fn same_host(&self, peer: Option<SocketAddrV4>) -> bool {
        matches!((self.peer, peer), (Some(a), Some(b)) if a.ip() == b.ip())
    }

    /// Served, not asked to close, and no request in progress.
    fn quiet(&self) -> bool {
        self.serving() && self.close.is_none() && self.busy.is_none()
    }

    /// Quiet for `evict_idle`: a newcomer may take its slot.
    fn idle(&self, now: Instant, evict_idle: Duration) -> bool {
        self.quiet() && now.saturating_duration_since(self.last) >= evict_idle
    }
}

/// What a waiting newcomer does next.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Step {
    Claimed,
    Refuse(Refusal),
    /// Wait for a change, or until then at the latest.
    Wait(Option<Instant>),
}

/// A table's sizes and limits, as the rules read them.
struct Rules {
    slots: usize,
    per_address: usize,
    limits: Limits,
}

/// The table without its wakers: entries `E` (an array of the listener's
/// size, seen by the rules as a slice).
struct Core<E: ?Sized> {
    tickets: u64,
    /// Counts changes: a waiting newcomer looks again when it moved.
    gen: u32,
    /// A change since the wakers were last woken.
    changed: bool,
    entries: E,
}

impl Core<[Entry]> {
    fn changed(&mut self) {
        self.gen = self.gen.wrapping_add(1);
        self.changed = true;
    }

    /// Socket `j` accepted `peer`: it waits for a slot from `now`.
    fn arrive(&mut self, j: usize, peer: Option<SocketAddrV4>, now: Instant) {
        self.tickets = self.tickets.wrapping_add(1);
        if let Some(e) = self.entries.get_mut(j) {
            *e = Entry {
                phase: Phase::Waiting(self.tickets),
                peer,
                last: now,
                busy: None,
                close: None,
            };
        }
    }

    /// Asks the least recently active session that `which` picks to
    /// close.
    fn evict(&mut self, which: impl Fn(&Entry) -> bool) -> bool {
        let victim = self
            .entries
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

    /// Slots of waiting newcomer `j`'s address ahead of it (served, or
    /// waiting since earlier), not asked to close.
    fn mine(&self, j: usize) -> usize {
        let Some(me) = self.entries.get(j) else {
            return 0;
        };
        let Phase::Waiting(ticket) = me.phase else {
            return 0;
        };
        self.entries
            .iter()
            .filter(|e| e.serving() || e.waiting_before(ticket))
            .filter(|e| e.close.is_none() && e.same_host(me.peer))
            .count()
    }

    /// Newcomer `j` (waiting): may it take a slot now? It asks a session
    /// to close for it only if `may_evict` (not at the end of its wait).
    fn step(&mut self, r: &Rules, j: usize, now: Instant, may_evict: bool) -> Step {
        let Some(me) = self.entries.get(j).copied() else {
            return Step::Refuse(Refusal::Full);
        };
        if me.close.is_some() {
            return Step::Refuse(Refusal::NotAllowed);
        }
        let Phase::Waiting(ticket) = me.phase else {
            return Step::Refuse(Refusal::Full);
        };
        // Its address's cap first: the newest connection of an address
        // wins over the least recently active quiet one; with all of them
        // busy, a few may wait.
        if self.mine(j) >= r.per_address
            && !(may_evict && self.evict(|e| e.quiet() && e.same_host(me.peer)))
        {
            let waiting = self
                .entries
                .iter()
                .filter(|e| e.waiting_before(ticket) && e.same_host(me.peer))
                .count();
            return match waiting < r.limits.waiting_per_address {
                // Woken when one of them answers.
                true => Step::Wait(None),
                false => Step::Refuse(Refusal::PerAddress),
            };
        }
        // First come, first served (a newcomer waiting for its own
        // address's sessions does not hold up the others).
        let before = (0..self.entries.len()).any(|i| {
            self.entries
                .get(i)
                .is_some_and(|e| e.waiting_before(ticket))
                && self.mine(i) < r.per_address
        });
        if before {
            return Step::Wait(None);
        }
        let serving = self.entries.iter().filter(|e| e.serving()).count();
        if serving < r.slots {
            if let Some(e) = self.entries.get_mut(j) {
                e.phase = Phase::Serving;
                e.last = now;
            }
            self.changed();
            return Step::Claimed;
        }
        let closing = self
            .entries
            .iter()
            .any(|e| e.serving() && e.close.is_some());
        let evict_idle = r.limits.evict_idle;
        if closing || (may_evict && self.evict(|e| e.idle(now, evict_idle))) {
            return Step::Wait(None);
        }
        // None idle yet: wait until the first may be.
        let next = self
            .entries
            .iter()
            .filter(|e| e.quiet())
            .map(|e| e.last + evict_idle)
            .min();
        Step::Wait(next)
    }

    /// Socket `j`'s session ended (or its newcomer was refused).
    fn release(&mut self, j: usize) {
        if let Some(e) = self.entries.get_mut(j) {
            *e = Entry::FREE;
        }
        self.changed();
    }

    fn close_unless(&mut self, permits: &dyn Fn(Option<SocketAddrV4>) -> bool) {
        let mut any = false;
        for e in self.entries.iter_mut() {
            if e.phase != Phase::Free && e.close.is_none() && !permits(e.peer) {
                e.close = Some(Close::NotAllowed);
                any = true;
            }
        }
        if any {
            self.changed();
        }
    }

    fn started(&mut self, j: usize, at: Instant) {
        if let Some(e) = self.entries.get_mut(j) {
            e.busy.get_or_insert(at);
        }
    }

    fn answered(&mut self, j: usize, at: Instant) {
        if let Some(e) = self.entries.get_mut(j) {
            e.busy = None;
            e.last = at;
        }
        // A newcomer waiting for a quiet session learns when it may be
        // idle (or, at its address's cap, that it is quiet now).
        self.changed();
    }

    fn asked(&self, j: usize) -> Option<Close> {
        self.entries.get(j).and_then(|e| e.close)
    }
}

struct Table<const SOCKETS: usize, const WAKERS: usize> {
    core: Core<[Entry; SOCKETS]>,
    wakers: MultiWakerRegistration<WAKERS>,
}

/// A listener's admission table (see the module documentation):
/// `SOCKETS` sockets, `SLOTS` of them served at once, at most
/// `PER_ADDRESS` of those for one address, and `WAKERS` wakers that may
/// wait on it at once. With more, registering one wakes the others (which
/// look again, and register again): it covers every accepting and serving
/// future of the listener, for executors that poll them as tasks of their
/// own; on the gateway's they are one task, which takes one.
pub(crate) struct Slots<
    const SOCKETS: usize,
    const SLOTS: usize,
    const PER_ADDRESS: usize,
    const WAKERS: usize,
> {
    table: Mutex<NoopRawMutex, RefCell<Table<SOCKETS, WAKERS>>>,
    names: Names,
    limits: Limits,
}

impl<const SOCKETS: usize, const SLOTS: usize, const PER_ADDRESS: usize, const WAKERS: usize>
    Slots<SOCKETS, SLOTS, PER_ADDRESS, WAKERS>
{
    /// All free.
    pub(crate) const fn new(names: Names, limits: Limits) -> Self {
        const {
            assert!(
                0 < SLOTS && SLOTS <= SOCKETS,
                "one slot at least, and a socket for each"
            );
            assert!(
                0 < PER_ADDRESS && PER_ADDRESS <= SLOTS,
                "one address holds one slot at least, all at most"
            );
            assert!(WAKERS > 0, "a waker at least");
        }
        Slots {
            table: Mutex::new(RefCell::new(Table {
                core: Core {
                    tickets: 0,
                    gen: 0,
                    changed: false,
                    entries: [Entry::FREE; SOCKETS],
                },
                wakers: MultiWakerRegistration::new(),
            })),
            names,
            limits,
        }
    }

    /// Runs `f` on the table; wakes whoever waits if it changed.
    fn with<R>(&self, f: impl FnOnce(&mut Core<[Entry]>) -> R) -> R {
        self.table.lock(|t| {
            let t = &mut *t.borrow_mut();
            let r = f(&mut t.core);
            if core::mem::take(&mut t.core.changed) {
                t.wakers.wake();
            }
            r
        })
    }

    /// Resolves when `f` gives a value (it is asked again at each change
    /// of the table).
    async fn until<R>(&self, mut f: impl FnMut(&Core<[Entry]>) -> Option<R>) -> R {
        poll_fn(|cx| {
            self.table.lock(|t| {
                let t = &mut *t.borrow_mut();
                match f(&t.core) {
                    Some(r) => Poll::Ready(r),
                    None => {
                        t.wakers.register(cx.waker());
                        Poll::Pending
                    }
                }
            })
        })
        .await
    }

    /// Socket `j` accepted `peer` (that the allow-list permits): waits
    /// until it is given a slot, at most [`Limits::claim_wait`].
    pub(crate) async fn claim<C: Clock>(
        &self,
        j: usize,
        peer: Option<SocketAddrV4>,
        clock: &C,
    ) -> Result<(), Refusal> {
        let start = clock.now();
        self.with(|t| t.arrive(j, peer, start));
        let give_up = start + self.limits.claim_wait;
        let rules = Rules {
            slots: SLOTS,
            per_address: PER_ADDRESS,
            limits: self.limits,
        };
        loop {
            let now = clock.now();
            let (step, gen) = self.with(|t| {
                let step = match t.step(&rules, j, now, now < give_up) {
                    Step::Wait(_) if now >= give_up => Step::Refuse(Refusal::Full),
                    s => s,
                };
                (step, t.gen)
            });
            let until = match step {
                Step::Claimed => return Ok(()),
                Step::Refuse(r) => {
                    self.release(j);
                    return Err(r);
                }
                Step::Wait(at) => at.map_or(give_up, |a| a.min(give_up)),
            };
            let changed = self.until(|t| (t.gen != gen).then_some(()));
            // Looked at again either way.
            let _ = with_deadline(clock, until, changed).await;
        }
    }

    /// Socket `j`'s session ended (or its newcomer was refused): its slot,
    /// if it had one, is free.
    pub(crate) fn release(&self, j: usize) {
        self.with(|t| t.release(j));
    }

    /// Asks every session (served or waiting) whose peer `permits` refuses
    /// to close; they do before anything more of theirs is served.
    pub(crate) fn close_unless(&self, permits: impl Fn(Option<SocketAddrV4>) -> bool) {
        self.with(|t| t.close_unless(&permits));
    }

    /// Socket `j`'s session, as its server sees it.
    pub(crate) fn session(&self, j: usize) -> Session<'_, SOCKETS, SLOTS, PER_ADDRESS, WAKERS> {
        Session { slots: self, j }
    }

    /// Logs why the client at `peer` is not served.
    pub(crate) fn refused(&self, why: Refusal, peer: Option<SocketAddrV4>) {
        log_refused(&self.names, why, peer, SLOTS, PER_ADDRESS);
    }

    /// Logs why the session of the client at `peer` was closed.
    pub(crate) fn closed(&self, why: Close, peer: Option<SocketAddrV4>) {
        log_closed(&self.names, why, peer);
    }
}

fn log_refused(
    names: &Names,
    why: Refusal,
    peer: Option<SocketAddrV4>,
    slots: usize,
    per_address: usize,
) {
    let [a, b, c, d] = octets(peer);
    let n = names.listener;
    match why {
        Refusal::PerAddress => warn!(
            "{}: client {}.{}.{}.{} refused: {} slots from that address, all busy",
            n, a, b, c, d, per_address
        ),
        Refusal::Full => warn!(
            "{}: client {}.{}.{}.{} refused: all {} slots busy, none idle",
            n, a, b, c, d, slots
        ),
        Refusal::NotAllowed => warn!(
            "{}: client {}.{}.{}.{} refused (not in {})",
            n, a, b, c, d, names.allow_list
        ),
    }
}

fn log_closed(names: &Names, why: Close, peer: Option<SocketAddrV4>) {
    let [a, b, c, d] = octets(peer);
    let n = names.listener;
    match why {
        Close::Evicted => info!(
            "{}: client {}.{}.{}.{} idle, closed for a new client",
            n, a, b, c, d
        ),
        Close::NotAllowed => warn!(
            "{}: client {}.{}.{}.{} no longer in {}, closed",
            n, a, b, c, d, names.allow_list
        ),
    }
}

/// One served session's end of the table: what its server reports and
/// what it is asked.
#[derive(Clone, Copy)]
pub(crate) struct Session<
    'a,
    const SOCKETS: usize,
    const SLOTS: usize,
    const PER_ADDRESS: usize,
    const WAKERS: usize,
> {
    slots: &'a Slots<SOCKETS, SLOTS, PER_ADDRESS, WAKERS>,
    j: usize,
}

impl<const SOCKETS: usize, const SLOTS: usize, const PER_ADDRESS: usize, const WAKERS: usize>
    Session<'_, SOCKETS, SLOTS, PER_ADDRESS, WAKERS>
{
    /// A request's first byte came at `at`: busy until it is answered.
    pub(crate) fn started(&self, at: Instant) {
        self.slots.with(|t| t.started(self.j, at));
    }

    /// A request was answered at `at`: quiet from then.
    pub(crate) fn answered(&self, at: Instant) {
        self.slots.with(|t| t.answered(self.j, at));
    }

    /// Why it was asked to close, if it was.
    pub(crate) fn asked(&self) -> Option<Close> {
        self.slots.with(|t| t.asked(self.j))
    }

    /// Resolves when it is asked to close.
    pub(crate) async fn closing(&self) -> Close {
        self.slots.until(|t| t.asked(self.j)).await
    }
}
