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
//! ([`Slots::claim`]). Each socket has an entry here, and a waker: one
//! future at a time waits on it (its newcomer's, or its session's
//! server); the listener's futures and whoever applies an allow-list share
//! the table, and none holds it across an await.
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
//! * A listener may reserve a slot for *protected* peers (the Modbus
//!   server: the PLC, [`Guard`]): while it does, the others hold at most
//!   `SLOTS - 1` slots, so one is always there for a protected newcomer;
//!   a protected session is never asked to close for a newcomer of
//!   another address (idle eviction is only among the others; a
//!   protected session idle that long gives way to its own address's
//!   newcomer: the PLC reconnecting while its old connection lingers); a
//!   protected newcomer waits behind no unprotected one, and takes the
//!   slot of the least recently active quiet unprotected session at once
//!   if the others hold more than their share (the reservation was just
//!   switched on). The others never hold the last socket either (their
//!   sessions and waiting newcomers): a newcomer that would is refused at
//!   once ([`Refusal::Full`]), so a socket always accepts, and the PLC's
//!   reconnection waits in the kernel's queue behind refusals, not behind
//!   newcomers waiting for a slot. So a busy client, from however many
//!   addresses, cannot keep a reconnecting PLC out, nor have its slow
//!   session closed.
//!   [`Slots::protect`] follows a new configuration.
//! * Allow-lists: the listener checks its list at accept (and counts the
//!   refusals: the list and the counters are its own), and
//!   [`Slots::close_unless`] asks every session and newcomer that a new
//!   list refuses to close ([`Close::NotAllowed`],
//!   [`Refusal::NotAllowed`]). A session asked to close, for either
//!   reason, is served nothing more: before each request the listener
//!   asks [`Session::check`] (with its list's verdict on the client, not
//!   only the one at accept), and it stops reading when
//!   [`Session::closing`] resolves.
//!
//! Who may take a slot is decided in one place, `Core::step`, and whose
//! slot a newcomer may take in another, `Core::evict`: a rule that keeps
//! a slot for some addresses, or some sessions from eviction, is added
//! there.
//!
//! # One compiled copy
//! Everything but the storage works on a `Table`, the table seen as a
//! slice of its sockets' entries whatever the listener's sizes, so that
//! the listeners share one copy of the rules and the waits in flash; only
//! [`Slots`], the storage (an array of the listener's size), is generic.
//! Each socket's entry has its own waker, for the one future that waits on
//! it at a time: no shared list of wakers to size (one too short makes
//! waiting futures of separate tasks wake each other in turn).

#[cfg(test)]
pub(crate) mod tests;

use core::cell::RefCell;
use core::future::{poll_fn, Future};
use core::net::SocketAddrV4;
use core::task::{Context, Poll};

use embassy_sync::waitqueue::WakerRegistration;
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

/// Why a session is asked to close.
// Numbered from 1, so that `None::<Close>` is 0 and a free entry all
// zeros: filled as such, not field by field.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u8)]
pub(crate) enum Close {
    /// A newcomer takes its slot (it was the longest idle, or the least
    /// recently active of the newcomer's own address).
    Evicted = 1,
    /// The allow-list in use no longer permits its address.
    NotAllowed = 2,
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

/// What a listener says of a newcomer ([`Slots::claim`]) and of its
/// table: whether a slot is reserved for protected peers, and whether
/// this one is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub(crate) struct Guard {
    /// A slot is reserved for protected peers (the listener's
    /// configuration names some).
    pub reserving: bool,
    /// This peer is protected.
    pub protected: bool,
}

impl Guard {
    /// No reservation: every peer alike (the page).
    pub(crate) const NONE: Guard = Guard {
        reserving: false,
        protected: false,
    };
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// The socket accepts (or is between connections).
    Free,
    /// A newcomer waits for a slot (its ticket says who came first).
    Waiting,
    /// A client is served.
    Serving,
}

/// One socket's session, as the others see it.
#[derive(Clone, Copy, Debug)]
struct Entry {
    phase: Phase,
    /// Who came first: the newcomers' order (this one's, while it waits).
    ticket: u32,
    peer: Option<SocketAddrV4>,
    /// When it last answered a request (or was given its slot).
    last: Instant,
    /// A request (or its answer) in progress: from its first byte until
    /// it is answered.
    busy: bool,
    /// Asked to close, and why.
    close: Option<Close>,
    /// A protected peer (the listener's reserved slot is for it; it is
    /// never closed for another address's newcomer).
    protected: bool,
}

impl Entry {
    const FREE: Entry = Entry {
        phase: Phase::Free,
        ticket: 0,
        peer: None,
        last: Instant::from_ticks(0),
        busy: false,
        close: None,
        protected: false,
    };

    fn serving(&self) -> bool {
        matches!(self.phase, Phase::Serving)
    }

    /// A newcomer that came before the one with `ticket`. Tickets wrap;
    /// compared as serial numbers (RFC 1982), they are right as long as
    /// the newcomers waiting at once came within 2^31 tickets of each
    /// other (a few seconds apart, at most a socket each).
    fn waiting_before(&self, ticket: u32) -> bool {
        self.phase == Phase::Waiting && (ticket.wrapping_sub(self.ticket) as i32) > 0
    }

    fn same_host(&self, peer: Option<SocketAddrV4>) -> bool {
        matches!((self.peer, peer), (Some(a), Some(b)) if a.ip() == b.ip())
    }

    /// Served, not asked to close, and no request in progress.
    fn quiet(&self) -> bool {
        self.serving() && self.close.is_none() && !self.busy
    }

    /// Quiet for `evict_idle` at `now`: the newcomer from `peer` may take
    /// its slot, unless it is protected and of another address (a
    /// protected session gives way only to its own address's newcomer: a
    /// PLC reconnecting while its old connection, half-open, lingers).
    fn idle(&self, now: Instant, evict_idle: Duration, peer: Option<SocketAddrV4>) -> bool {
        self.evictable_for(peer) && now.saturating_duration_since(self.last) >= evict_idle
    }

    /// Quiet, and not protected unless of the same address as `peer`.
    fn evictable_for(&self, peer: Option<SocketAddrV4>) -> bool {
        self.quiet() && (!self.protected || self.same_host(peer))
    }
}

/// A socket's entry, and the waker of the one future waiting on it.
struct Seat {
    entry: Entry,
    waker: WakerRegistration,
}

impl Seat {
    const FREE: Seat = Seat {
        entry: Entry::FREE,
        waker: WakerRegistration::new(),
    };
}

/// Whose slot a newcomer may take ([`Core::evict`]).
#[derive(Clone, Copy)]
enum Among {
    /// A session of its own address (at its cap): the newest connection
    /// wins.
    Host(Option<SocketAddrV4>),
    /// A session idle at that instant, for a newcomer from that address
    /// (a protected one only for its own address's).
    IdleAt(Instant, Option<SocketAddrV4>),
    /// An unprotected session (quiet, however briefly): for a protected
    /// newcomer while the others hold the reserved slot.
    Unprotected,
}

/// What a session's server reports.
#[derive(Clone, Copy)]
enum Mark {
    /// A request's first byte came.
    Started,
    /// A request was answered, then.
    Answered(Instant),
    /// The session ended (or its newcomer was refused).
    Released,
}

/// What becomes of a waiting newcomer.
enum Next {
    Done(Result<(), Refusal>),
    /// Look again at the next change, or then at the latest.
    Wait(Instant),
}

/// What a waiting newcomer does next, by the rules.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Step {
    Claimed,
    Refuse(Refusal),
    /// Wait for a change, or until then at the latest.
    Wait(Option<Instant>),
}

/// A table's sizes and limits, as the rules read them.
#[derive(Clone, Copy, Debug)]
struct Rules {
    slots: usize,
    per_address: usize,
    limits: &'static Limits,
}

/// A table: its rules and its seats `S` (an array of the listener's size,
/// seen as a slice by everything but [`Slots`]).
struct Core<S: ?Sized> {
    rules: Rules,
    /// A slot is reserved for protected peers ([`Guard::reserving`]).
    reserving: bool,
    tickets: u32,
    /// Changed since the waiting futures were last woken.
    changed: bool,
    seats: S,
}

impl Core<[Seat]> {
    fn entries(&self) -> impl Iterator<Item = &Entry> {
        self.seats.iter().map(|s| &s.entry)
    }

    fn entry(&self, j: usize) -> Option<&Entry> {
        self.seats.get(j).map(|s| &s.entry)
    }

    fn entry_mut(&mut self, j: usize) -> Option<&mut Entry> {
        self.seats.get_mut(j).map(|s| &mut s.entry)
    }

    /// Socket `j` accepted `peer`, which the listener says `guard` of: it
    /// waits for a slot from `now`.
    fn arrive(&mut self, j: usize, peer: Option<SocketAddrV4>, guard: Guard, now: Instant) {
        self.tickets = self.tickets.wrapping_add(1);
        self.reserving = guard.reserving;
        let ticket = self.tickets;
        if let Some(e) = self.entry_mut(j) {
            *e = Entry {
                phase: Phase::Waiting,
                ticket,
                peer,
                last: now,
                busy: false,
                close: None,
                protected: guard.protected,
            };
        }
    }

    /// Slots the unprotected sessions hold (those asked to close too:
    /// they hold theirs until they are released).
    fn unprotected_serving(&self) -> usize {
        self.entries()
            .filter(|e| e.serving() && !e.protected)
            .count()
    }

    /// Slots the unprotected may hold: all but one while a slot is
    /// reserved.
    fn unprotected_share(&self) -> usize {
        match self.reserving {
            true => self.rules.slots.saturating_sub(1),
            false => self.rules.slots,
        }
    }

    /// Asks the least recently active quiet session among `among` to
    /// close for a newcomer: `false` if there is none. (Which sessions a
    /// newcomer may take the slot of is decided here.)
    fn evict(&mut self, among: Among) -> bool {
        let evict_idle = self.rules.limits.evict_idle;
        let victim = self
            .seats
            .iter_mut()
            .map(|s| &mut s.entry)
            .filter(|e| {
                e.quiet()
                    && match among {
                        Among::Host(peer) => e.same_host(peer),
                        Among::IdleAt(now, peer) => e.idle(now, evict_idle, peer),
                        Among::Unprotected => !e.protected,
                    }
            })
            .min_by_key(|e| e.last);
        let Some(v) = victim else {
            return false;
        };
        v.close = Some(Close::Evicted);
        self.changed = true;
        true
    }

    /// Slots of waiting newcomer `j`'s address ahead of it (served, or
    /// waiting since earlier), not asked to close.
    fn mine(&self, j: usize) -> usize {
        let Some(me) = self.entry(j) else {
            return 0;
        };
        if me.phase != Phase::Waiting {
            return 0;
        }
        let ticket = me.ticket;
        self.entries()
            .filter(|e| e.serving() || e.waiting_before(ticket))
            .filter(|e| e.close.is_none() && e.same_host(me.peer))
            .count()
    }

    /// Newcomer `j` (waiting): may it take a slot now? It asks a session
    /// to close for it only if `may_evict` (not at the end of its wait).
    fn step(&mut self, j: usize, now: Instant, may_evict: bool) -> Step {
        let Rules {
            slots,
            per_address,
            limits,
            ..
        } = self.rules;
        let Some(me) = self.entry(j).copied() else {
            return Step::Refuse(Refusal::Full);
        };
        if me.close.is_some() {
            return Step::Refuse(Refusal::NotAllowed);
        }
        if me.phase != Phase::Waiting {
            return Step::Refuse(Refusal::Full);
        }
        let ticket = me.ticket;
        // Its address's cap first: the newest connection of an address
        // wins over the least recently active quiet one; with all of them
        // busy, a few may wait.
        if self.mine(j) >= per_address && !(may_evict && self.evict(Among::Host(me.peer))) {
            let waiting = self
                .entries()
                .filter(|e| e.waiting_before(ticket) && e.same_host(me.peer))
                .count();
            return match waiting < limits.waiting_per_address {
                // Woken when one of them answers.
                true => Step::Wait(None),
                false => Step::Refuse(Refusal::PerAddress),
            };
        }
        // While a slot is reserved, the others never hold the last socket:
        // it stays free to accept a protected newcomer (the PLC
        // reconnecting), which would otherwise wait in the kernel's queue
        // behind newcomers waiting here for a slot they may not take.
        if self.reserving && !me.protected {
            let held = self
                .entries()
                .filter(|e| !e.protected && (e.serving() || e.phase == Phase::Waiting))
                .count();
            if held >= self.seats.len() {
                return Step::Refuse(Refusal::Full);
            }
        }
        // First come, first served (a newcomer waiting for its own
        // address's sessions does not hold up the others; a protected one
        // waits behind protected ones only: the reserved slot is not the
        // others').
        let before = (0..self.seats.len()).any(|i| {
            self.entry(i)
                .is_some_and(|e| e.waiting_before(ticket) && (e.protected || !me.protected))
                && self.mine(i) < per_address
        });
        if before {
            return Step::Wait(None);
        }
        let serving = self.entries().filter(|e| e.serving()).count();
        let within_share = me.protected || self.unprotected_serving() < self.unprotected_share();
        if serving < slots && within_share {
            if let Some(e) = self.entry_mut(j) {
                e.phase = Phase::Serving;
                e.last = now;
            }
            self.changed = true;
            return Step::Claimed;
        }
        let closing = self
            .entries()
            .any(|e| e.serving() && e.close.is_some() && (me.protected || !e.protected));
        if closing {
            return Step::Wait(None);
        }
        // A protected newcomer while the others hold more than their
        // share (the reservation was just switched on): the least recently
        // active quiet one of them gives way at once.
        let over_share = self.unprotected_serving() > self.unprotected_share();
        if me.protected && over_share && may_evict && self.evict(Among::Unprotected) {
            return Step::Wait(None);
        }
        if may_evict && self.evict(Among::IdleAt(now, me.peer)) {
            return Step::Wait(None);
        }
        // None idle yet: wait until the first may be (a protected session
        // only for its own address).
        let next = self
            .entries()
            .filter(|e| e.evictable_for(me.peer))
            .map(|e| e.last + limits.evict_idle)
            .min();
        Step::Wait(next)
    }

    /// A slot is reserved for protected peers (`reserving`), and which are
    /// (`protected`): for every session and newcomer, as a new
    /// configuration says.
    fn protect(&mut self, reserving: bool, protected: &dyn Fn(Option<SocketAddrV4>) -> bool) {
        self.reserving = reserving;
        for s in self.seats.iter_mut() {
            let e = &mut s.entry;
            if !matches!(e.phase, Phase::Free) {
                e.protected = protected(e.peer);
            }
        }
        self.changed = true;
    }

    fn close_unless(&mut self, permits: &dyn Fn(Option<SocketAddrV4>) -> bool) {
        for s in self.seats.iter_mut() {
            let e = &mut s.entry;
            if !matches!(e.phase, Phase::Free) && e.close.is_none() && !permits(e.peer) {
                e.close = Some(Close::NotAllowed);
                self.changed = true;
            }
        }
    }

    fn mark(&mut self, j: usize, m: Mark) {
        let Some(e) = self.entry_mut(j) else {
            return;
        };
        match m {
            Mark::Started => e.busy = true,
            Mark::Answered(at) => {
                e.busy = false;
                e.last = at;
                // A newcomer waiting for a quiet session learns when it
                // may be idle (or, at its address's cap, that it is quiet
                // now).
                self.changed = true;
            }
            Mark::Released => {
                *e = Entry::FREE;
                self.changed = true;
            }
        }
    }

    fn asked(&self, j: usize) -> Option<Close> {
        self.entry(j).and_then(|e| e.close)
    }
}

/// Wakes every future waiting on the table (one function, not a loop in
/// each caller).
#[inline(never)]
fn wake_all(seats: &mut [Seat]) {
    for s in seats.iter_mut() {
        s.waker.wake();
    }
}

/// A listener's admission table (see the module documentation):
/// `SOCKETS` sockets, `SLOTS` of them served at once, at most
/// `PER_ADDRESS` of those for one address. Only the storage is generic:
/// every method works on its `Table`, the same type whatever the sizes.
pub(crate) struct Slots<const SOCKETS: usize, const SLOTS: usize, const PER_ADDRESS: usize> {
    core: RefCell<Core<[Seat; SOCKETS]>>,
    /// The listener's name in log lines: `modbus`, `web`.
    name: &'static str,
}

impl<const SOCKETS: usize, const SLOTS: usize, const PER_ADDRESS: usize>
    Slots<SOCKETS, SLOTS, PER_ADDRESS>
{
    /// All free; the listener's log lines call it `name`.
    pub(crate) const fn new(name: &'static str, limits: &'static Limits) -> Self {
        const {
            assert!(
                0 < SLOTS && SLOTS <= SOCKETS,
                "one slot at least, and a socket for each"
            );
            assert!(
                0 < PER_ADDRESS && PER_ADDRESS <= SLOTS,
                "one address holds one slot at least, all at most"
            );
        }
        Slots {
            core: RefCell::new(Core {
                rules: Rules {
                    slots: SLOTS,
                    per_address: PER_ADDRESS,
                    limits,
                },
                reserving: false,
                tickets: 0,
                changed: false,
                seats: [Seat::FREE; SOCKETS],
            }),
            name,
        }
    }

    /// The table, whatever its sizes.
    fn table(&self) -> Table<'_> {
        Table { core: &self.core }
    }

    /// Socket `j` accepted `peer` (that the allow-list permits; `guard`:
    /// whether a slot is reserved, and whether it is protected): waits
    /// until it is given a slot, at most [`Limits::claim_wait`].
    pub(crate) fn claim<'a, C: Clock>(
        &'a self,
        j: usize,
        peer: Option<SocketAddrV4>,
        guard: Guard,
        clock: &'a C,
    ) -> impl Future<Output = Result<(), Refusal>> + 'a {
        self.table().claim(j, peer, guard, clock)
    }

    /// A new configuration: whether a slot is reserved for protected
    /// peers, and which peers are (for the sessions served and waiting).
    pub(crate) fn protect(
        &self,
        reserving: bool,
        protected: impl Fn(Option<SocketAddrV4>) -> bool,
    ) {
        let _ = self.table().with(|t| t.protect(reserving, &protected));
    }

    /// Socket `j`'s session ended (or its newcomer was refused): its slot,
    /// if it had one, is free.
    pub(crate) fn release(&self, j: usize) {
        self.table().release(j);
    }

    /// Asks every session (served or waiting) whose peer `permits` refuses
    /// to close; they do before anything more of theirs is served.
    pub(crate) fn close_unless(&self, permits: impl Fn(Option<SocketAddrV4>) -> bool) {
        self.table().close_unless(&permits);
    }

    /// Socket `j`'s session, as its server sees it.
    pub(crate) fn session(&self, j: usize) -> Session<'_> {
        Session {
            table: self.table(),
            j,
        }
    }

    /// Logs why the client at `peer` is not served.
    pub(crate) fn refused(&self, why: Refusal, peer: Option<SocketAddrV4>) {
        log(self.name, Said::Refused(why), peer);
    }

    /// Logs why the session of the client at `peer` was closed.
    pub(crate) fn closed(&self, why: Close, peer: Option<SocketAddrV4>) {
        log(self.name, Said::Closed(why), peer);
    }
}

/// A listener's table seen without its sizes: what the newcomers, the
/// sessions and whoever applies an allow-list share.
#[derive(Clone, Copy)]
struct Table<'a> {
    core: &'a RefCell<Core<[Seat]>>,
}

impl Table<'_> {
    /// Runs `f` on the table; if it changed, wakes every future waiting on
    /// it. `None` if the table is in use: it never is (nothing holds it
    /// across a call out of this module), but a failed borrow is no
    /// reason to panic.
    fn with<R>(self, f: impl FnOnce(&mut Core<[Seat]>) -> R) -> Option<R> {
        let mut core = self.core.try_borrow_mut().ok()?;
        let r = f(&mut core);
        if core::mem::take(&mut core.changed) {
            wake_all(&mut core.seats);
        }
        Some(r)
    }

    /// Socket `j` accepted `peer` (that the allow-list permits): waits
    /// until it is given a slot, at most [`Limits::claim_wait`].
    async fn claim<C: Clock>(
        self,
        j: usize,
        peer: Option<SocketAddrV4>,
        guard: Guard,
        clock: &C,
    ) -> Result<(), Refusal> {
        let give_up = self.arrive(j, peer, guard, clock.now());
        loop {
            let until = match self.next(j, clock.now(), give_up) {
                Next::Done(r) => return r,
                Next::Wait(until) => until,
            };
            // The next change of the table (it wakes this socket's
            // waker), or `until`: looked at again either way.
            let mut looked = false;
            let changed = poll_fn(|cx| self.poll_changed(j, &mut looked, cx));
            let _ = with_deadline(clock, until, changed).await;
        }
    }

    /// Newcomer `j` arrives at `now`, from `peer` (`guard` of it);
    /// returns when it gives up.
    fn arrive(self, j: usize, peer: Option<SocketAddrV4>, guard: Guard, now: Instant) -> Instant {
        let wait = self.with(|t| {
            t.arrive(j, peer, guard, now);
            t.rules.limits.claim_wait
        });
        now + wait.unwrap_or(Duration::from_ticks(0))
    }

    /// Newcomer `j`, at `now`, waiting until `give_up` at the latest: its
    /// slot, its refusal (its entry freed), or when to look again.
    fn next(self, j: usize, now: Instant, give_up: Instant) -> Next {
        let step = self.with(|t| match t.step(j, now, now < give_up) {
            Step::Wait(_) if now >= give_up => Step::Refuse(Refusal::Full),
            s => s,
        });
        match step.unwrap_or(Step::Refuse(Refusal::Full)) {
            Step::Claimed => Next::Done(Ok(())),
            Step::Refuse(r) => {
                self.release(j);
                Next::Done(Err(r))
            }
            Step::Wait(at) => Next::Wait(at.map_or(give_up, |a| a.min(give_up))),
        }
    }

    /// Ready once `looked` was set by an earlier poll and the table woke
    /// socket `j`'s waker since (or anything else polled it again).
    fn poll_changed(self, j: usize, looked: &mut bool, cx: &mut Context<'_>) -> Poll<()> {
        if core::mem::replace(looked, true) {
            return Poll::Ready(());
        }
        self.register(j, cx);
        Poll::Pending
    }

    /// Socket `j`'s waiting future is woken at the next change.
    fn register(self, j: usize, cx: &mut Context<'_>) {
        if let Ok(mut t) = self.core.try_borrow_mut() {
            if let Some(s) = t.seats.get_mut(j) {
                s.waker.register(cx.waker());
            }
        }
    }

    /// Ready with why socket `j`'s session is asked to close, once it is.
    fn poll_asked(self, j: usize, cx: &mut Context<'_>) -> Poll<Close> {
        match self.asked(j) {
            Some(why) => Poll::Ready(why),
            None => {
                self.register(j, cx);
                Poll::Pending
            }
        }
    }

    /// Socket `j`'s session ended (or its newcomer was refused): its slot,
    /// if it had one, is free.
    fn release(self, j: usize) {
        self.mark(j, Mark::Released);
    }

    /// Socket `j`'s session started a request, answered one, or ended.
    fn mark(self, j: usize, m: Mark) {
        let _ = self.with(|t| t.mark(j, m));
    }

    /// Why socket `j`'s session is asked to close, if it is.
    fn asked(self, j: usize) -> Option<Close> {
        self.core.try_borrow().ok()?.asked(j)
    }

    /// Asks every session (served or waiting) whose peer `permits` refuses
    /// to close; they do before anything more of theirs is served.
    fn close_unless(self, permits: &dyn Fn(Option<SocketAddrV4>) -> bool) {
        let _ = self.with(|t| t.close_unless(permits));
    }
}

/// What the log says of a client.
#[derive(Clone, Copy)]
enum Said {
    Refused(Refusal),
    Closed(Close),
}

/// Logs why the client at `peer` of the listener `name` is not served,
/// or was closed.
fn log(name: &str, said: Said, peer: Option<SocketAddrV4>) {
    let [a, b, c, d] = octets(peer);
    // A line each: a format string costs no flash (defmt keeps it on the
    // host), a string argument does.
    match said {
        Said::Refused(Refusal::PerAddress) => warn!(
            "{}: client {}.{}.{}.{} refused: its address has all the slots it may, all busy",
            name, a, b, c, d
        ),
        Said::Refused(Refusal::Full) => warn!(
            "{}: client {}.{}.{}.{} refused: every slot busy, none idle",
            name, a, b, c, d
        ),
        Said::Refused(Refusal::NotAllowed) => warn!(
            "{}: client {}.{}.{}.{} refused: not in the allow-list",
            name, a, b, c, d
        ),
        Said::Closed(Close::Evicted) => info!(
            "{}: client {}.{}.{}.{} idle, closed for a new client",
            name, a, b, c, d
        ),
        Said::Closed(Close::NotAllowed) => warn!(
            "{}: client {}.{}.{}.{} no longer in the allow-list, closed",
            name, a, b, c, d
        ),
    }
}

/// One served session's end of the table: what its server reports and
/// what it is asked.
#[derive(Clone, Copy)]
pub(crate) struct Session<'a> {
    table: Table<'a>,
    j: usize,
}

impl Session<'_> {
    /// A request's first byte came: busy until it is answered.
    pub(crate) fn started(&self) {
        self.table.mark(self.j, Mark::Started);
    }

    /// A request was answered at `at`: quiet from then.
    pub(crate) fn answered(&self, at: Instant) {
        self.table.mark(self.j, Mark::Answered(at));
    }

    /// Why it may not be served another request, if it may not: it was
    /// asked to close (for a newcomer, or by an allow-list applied since),
    /// or its client is not `permitted` by the allow-list in use (checked
    /// by the listener, whose list it is, before each request).
    pub(crate) fn check(&self, permitted: bool) -> Option<Close> {
        match self.table.asked(self.j) {
            None if !permitted => Some(Close::NotAllowed),
            asked => asked,
        }
    }

    /// Resolves when it is asked to close.
    pub(crate) fn closing(&self) -> impl Future<Output = Close> + '_ {
        poll_fn(|cx| self.table.poll_asked(self.j, cx))
    }
}
