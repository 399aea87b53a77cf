//! The log the gateway writes to: the newest records in RAM, the ones
//! waiting to be kept, the refused connections being counted, and the time
//! of the records.
//!
//! Writing never blocks and never fails: a record goes into the ring of the
//! newest [`RING`] at once (under a blocking mutex held for the copy). The
//! ring is also the queue of records waiting for the storage task: a record
//! with a sequence number from `keep_from` on is not kept yet. When a new
//! record would push out one that is not kept yet (the medium is slower
//! than the events, for [`RING`] records), that one is lost and counted;
//! once a record is kept again, a [`Kind::Lost`] record says how many.
//!
//! Repeated failures are counted, not recorded one by one (a flood of them
//! must not push the evidence out of the medium, nor keep the medium
//! busy): per class ([`Class`]: refused connections per interface, failed
//! logins and setup codes, guesses refused unchecked (429), setting changes
//! over Modbus, refused changes of protected settings), over a period of
//! [`REFUSED_PERIOD`] that doubles while they go on, up to
//! [`REFUSED_PERIOD_MAX`], one record at its end says how many, from how
//! many addresses. Of the failed logins, the changes over Modbus and the
//! refused changes, the first of a period is recorded as it happens (with
//! its name or setting and its address); of refused connections and
//! unchecked guesses none is. Each class thus writes at most two records a
//! period: a storm of any length writes a few a day per class. A stop in
//! order or a restart ends the running periods first (`keep::closing`).
//!
//! Time: a record is made without its time, and the storage task's
//! stamper (which has the clock, see `keep`) stamps it with the uptime and
//! the wall time at once (it runs on the same executor, woken by the
//! record: the same instant in the tests' virtual time, microseconds on a
//! board). So a hook needs no clock, only the hub.

use core::cell::RefCell;
use core::fmt::Write;
use core::net::Ipv4Addr;

use embassy_sync::blocking_mutex::raw::NoopRawMutex;
use embassy_sync::blocking_mutex::Mutex;
use embassy_sync::signal::Signal;
use embassy_sync::waitqueue::MultiWakerRegistration;
use embassy_time::{Duration, Instant};

use super::record::{Interface, Kind, Record, Short, DETAIL_MAX, RECORD_MAX};
use super::{AccountChange, Event, Who};
use crate::config::{Config, SETTINGS};
use crate::crc::crc32;
use crate::state::inputs::{Text, TRIGGERS, TRIGGER_TEXT};

/// Records kept in RAM (the page's newest, and the queue of those waiting
/// to be kept): 64 of ~136 bytes.
pub(crate) const RING: usize = 64;
/// Bytes of each value (old, new) in a configuration change's detail: a
/// longer one is cut and ends in `...` (allow-lists, host names).
pub(crate) const VALUE_MAX: usize = 24;
/// The first period repeated failures are counted over, per class.
pub(crate) const REFUSED_PERIOD: Duration = Duration::from_secs(60);
/// The longest period: while the failures go on, each period is twice the
/// one before, up to this (a storm writes at most two records an hour per
/// class, and cannot push the other records out of the medium).
pub(crate) const REFUSED_PERIOD_MAX: Duration = Duration::from_secs(3600);
/// Requests that may wait at once for their records to be kept
/// ([`Log::wait_kept`]): one per web slot, and one more. A waiter beyond
/// this wakes the others, which register again (no waiter is lost).
const KEPT_WAITERS: usize = 4;
/// Distinct addresses a period's count tells apart; beyond, the record
/// says "more than" this many.
pub(crate) const TALLY_ADDRESSES: usize = 16;

/// The classes of repeated events counted over periods (see the module
/// documentation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Class {
    /// Connections refused by the Modbus allow-list.
    RefusedModbus = 0,
    /// Connections refused by the web allow-list.
    RefusedWeb = 1,
    /// Connections to the robot link's listen port not from the
    /// controller.
    RefusedRobot = 2,
    /// Failed logins (any name) and wrong setup codes.
    LoginFailed = 3,
    /// Settings and trigger texts changed over Modbus (but the protected
    /// ones, each always recorded).
    ModbusConfig = 4,
    /// Changes of protected settings refused.
    ConfigRefused = 5,
    /// Guesses (logins, setup codes, current passwords) refused without
    /// being checked: their address or account had to wait (429).
    LoginLimited = 6,
}

/// The classes, in the order of [`Inner::tallies`].
const CLASSES: [Class; 7] = [
    Class::RefusedModbus,
    Class::RefusedWeb,
    Class::RefusedRobot,
    Class::LoginFailed,
    Class::ModbusConfig,
    Class::ConfigRefused,
    Class::LoginLimited,
];

impl Class {
    /// The first event of a period is recorded as it happens.
    fn first_recorded(self) -> bool {
        matches!(
            self,
            Class::LoginFailed | Class::ModbusConfig | Class::ConfigRefused
        )
    }
}

/// Where wall time comes from.
#[derive(Clone, Copy)]
enum Wall {
    /// Not known (a board without a time server).
    Unknown,
    /// The host's clock (Linux): Unix seconds, or `None` if it is unset.
    Host(fn() -> Option<u64>),
    /// Set at instant `at` to `unix` (a time server, feature `sntp`).
    #[cfg(any(test, feature = "sntp"))]
    Set { unix: u64, at: Instant },
}

/// Repeated events of one class, counted over a period.
#[derive(Clone, Copy)]
struct Tally {
    /// A period runs (or starts at the next stamp).
    open: bool,
    /// Events counted in this period (not recorded one by one).
    count: u32,
    /// Of them, failed logins for a name no account has.
    unknown: u32,
    /// Their distinct addresses (the first [`TALLY_ADDRESSES`]).
    addrs: [Option<Ipv4Addr>; TALLY_ADDRESSES],
    /// More distinct addresses than that.
    more: bool,
    /// The last event's address.
    last: Option<Ipv4Addr>,
    /// What the last event was about (a setting's key), or empty.
    about: &'static str,
    /// When the period started (the first event's stamp); `None`: not
    /// started (or its first event not stamped yet).
    since: Option<Instant>,
    /// Its length.
    period: Duration,
    /// When the last period ended.
    ended: Option<Instant>,
}

impl Tally {
    const NONE: Tally = Tally {
        open: false,
        count: 0,
        unknown: 0,
        addrs: [None; TALLY_ADDRESSES],
        more: false,
        last: None,
        about: "",
        since: None,
        period: REFUSED_PERIOD,
        ended: None,
    };

    /// Counts one event from `from`.
    fn count(&mut self, from: Option<Ipv4Addr>) {
        self.count = self.count.saturating_add(1);
        self.last = from.or(self.last);
        let Some(ip) = from else { return };
        if self.addrs.contains(&Some(ip)) {
            return;
        }
        match self.addrs.iter_mut().find(|a| a.is_none()) {
            Some(slot) => *slot = Some(ip),
            None => self.more = true,
        }
    }

    /// Its distinct addresses.
    fn addresses(&self) -> usize {
        self.addrs.iter().flatten().count()
    }
}

struct Inner {
    ring: heapless::Deque<Record, RING>,
    next_seq: u32,
    boot: u32,
    /// The first record without its time.
    stamp_from: u32,
    /// The first record not kept yet.
    keep_from: u32,
    /// Records lost before they were kept, not reported yet.
    lost: u32,
    /// The storage keeps records (else nothing waits, nothing is lost).
    keeping: bool,
    wall: Wall,
    /// The repeated events of each [`Class`], counted.
    tallies: [Tally; CLASSES.len()],
    /// CRC of each trigger entry as last recorded.
    triggers: [u32; TRIGGERS],
    /// Who waits for records to be kept ([`Log::wait_kept`]).
    kept_waiters: MultiWakerRegistration<KEPT_WAITERS>,
}

/// The audit log (see the module documentation). One lives in the hub.
pub(crate) struct Log {
    inner: Mutex<NoopRawMutex, RefCell<Inner>>,
    /// Wakes the stamper: something waits for its time.
    fresh: Signal<NoopRawMutex, ()>,
    /// Wakes the storage task: stamped records wait to be kept, or a
    /// refusal period started.
    stamped: Signal<NoopRawMutex, ()>,
    /// The page's requests for a page of the kept records.
    pub(crate) pages: super::page::Pages,
}

impl Default for Log {
    fn default() -> Self {
        Self::new()
    }
}

/// Writes a setting's value into a short text.
fn value(s: &crate::config::Setting, c: &Config) -> Short<VALUE_MAX> {
    let mut v = Short::EMPTY;
    let _ = s.format(c, &mut v);
    v
}

impl Log {
    /// An empty log (boot 0 until the start, see `keep::restore`).
    pub(crate) const fn new() -> Self {
        Log {
            inner: Mutex::new(RefCell::new(Inner {
                ring: heapless::Deque::new(),
                next_seq: 1,
                boot: 0,
                stamp_from: 1,
                keep_from: 1,
                lost: 0,
                keeping: false,
                wall: Wall::Unknown,
                tallies: [Tally::NONE; CLASSES.len()],
                triggers: [0; TRIGGERS],
                kept_waiters: MultiWakerRegistration::new(),
            })),
            fresh: Signal::new(),
            stamped: Signal::new(),
            pages: super::page::Pages::new(),
        }
    }

    fn with<R>(&self, f: impl FnOnce(&mut Inner) -> R) -> R {
        self.inner.lock(|i| f(&mut i.borrow_mut()))
    }

    /// Records an event of `kind` by `who`, with the detail `detail`
    /// writes (cut at [`DETAIL_MAX`] bytes).
    pub(crate) fn add(
        &self,
        kind: Kind,
        who: &Who<'_>,
        detail: impl FnOnce(&mut Short<DETAIL_MAX>),
    ) {
        let mut r = Record {
            kind,
            actor: Short::new(who.actor),
            interface: who.interface,
            from: who.from,
            ..Record::EMPTY
        };
        detail(&mut r.detail);
        self.with(|i| i.push(r));
        self.fresh.signal(());
    }

    /// Records `event` (the accounts' and the page's events: see the
    /// module documentation).
    pub(crate) fn record(&self, event: Event<'_>) {
        match event {
            Event::Login { name, ok, from } => {
                let kind = if ok { Kind::Login } else { Kind::LoginFailed };
                self.add(kind, &Who::web(name, from), |_| {});
            }
            Event::Logout { name, from } => self.add(Kind::Logout, &Who::web(name, from), |_| {}),
            Event::Account {
                name,
                change,
                by,
                from,
            } => {
                let kind = match change {
                    AccountChange::Created { .. } => Kind::AccountCreated,
                    AccountChange::Removed => Kind::AccountRemoved,
                    AccountChange::Role { .. } => Kind::AccountRole,
                    AccountChange::Password => Kind::AccountPassword,
                };
                self.add(kind, &Who::web(by, from), |d| {
                    d.push(name);
                    if let AccountChange::Created { role } | AccountChange::Role { role } = change {
                        let _ = write!(d, ", role {role}");
                    }
                });
            }
            Event::Restart { who } => self.add(Kind::Restart, &who, |_| {}),
            #[cfg(feature = "update")]
            Event::Firmware { who, detail } => {
                self.add(Kind::Firmware, &who, |d| d.push(detail.as_bytes()))
            }
        }
    }

    /// Records each setting that differs between `before` and `after`:
    /// `key: old -> new` (each value cut at [`VALUE_MAX`] bytes).
    pub(crate) fn config_changed(&self, before: &Config, after: &Config, who: &Who<'_>) {
        if before == after {
            return;
        }
        for s in SETTINGS.iter().filter(|s| s.get(before) != s.get(after)) {
            self.setting_changed(s, before, after, who);
        }
    }

    /// Records that `s` changed from its value in `before` to that in
    /// `after`.
    fn setting_changed(
        &self,
        s: &crate::config::Setting,
        before: &Config,
        after: &Config,
        who: &Who<'_>,
    ) {
        let (old, new) = (value(s, before), value(s, after));
        self.add(Kind::Config, who, |d| {
            let _ = write!(d, "{}: {} -> {}", s.key, old.as_str(), new.as_str());
        });
    }

    /// A change of the protected setting `s` by `who` was refused
    /// (configuration over Modbus is off): the first of a period is
    /// recorded, the rest counted.
    pub(crate) fn config_refused(&self, s: &crate::config::Setting, who: &Who<'_>) {
        if self.repeated(Class::ConfigRefused, who.from, s.key, false) {
            self.add(Kind::ConfigRefused, who, |d| {
                let _ = write!(d, "{}: protected (configuration over Modbus is off)", s.key);
            });
        }
    }

    /// Takes `entries` as the trigger table in use without recording
    /// anything (at start).
    pub(crate) fn triggers_are(&self, entries: &[Text<TRIGGER_TEXT>; TRIGGERS]) {
        self.with(|i| {
            for (c, e) in i.triggers.iter_mut().zip(entries) {
                *c = crc32(e.bytes());
            }
        });
    }

    /// Records each trigger entry that changed since it was last recorded
    /// (`triggers.N = new text`, cut; the old text is not kept).
    pub(crate) fn triggers_changed(&self, entries: &[Text<TRIGGER_TEXT>; TRIGGERS], who: &Who<'_>) {
        for (n, e) in entries.iter().enumerate() {
            if self.trigger_moved(n, e) {
                self.trigger_recorded(n, e, who);
            }
        }
    }

    /// `true` if trigger entry `n` is not `e` as last seen (and takes `e`).
    fn trigger_moved(&self, n: usize, e: &Text<TRIGGER_TEXT>) -> bool {
        let crc = crc32(e.bytes());
        self.with(|i| match i.triggers.get_mut(n) {
            Some(c) if *c != crc => {
                *c = crc;
                true
            }
            _ => false,
        })
    }

    /// Records trigger entry `n`'s new text `e`.
    fn trigger_recorded(&self, n: usize, e: &Text<TRIGGER_TEXT>, who: &Who<'_>) {
        self.add(Kind::Config, who, |d| {
            let _ = write!(d, "triggers.{n} = ");
            d.push(e.bytes());
        });
    }

    /// A connection through `interface` (Modbus, web, the robot link's
    /// listen port) from `peer` was refused: counted, recorded once per
    /// period ([`REFUSED_PERIOD`]).
    pub(crate) fn refused(&self, interface: Interface, peer: Option<Ipv4Addr>) {
        let class = match interface {
            Interface::Web => Class::RefusedWeb,
            Interface::Robot => Class::RefusedRobot,
            _ => Class::RefusedModbus,
        };
        self.repeated(class, peer, "", false);
    }

    /// An event of `class` from `from` (about `about`: a setting's key;
    /// `unknown`: a failed login for a name no account has): counted in
    /// its period. `true` if it is the first of its period and its class
    /// records that one as it happens: the caller records it.
    fn repeated(
        &self,
        class: Class,
        from: Option<Ipv4Addr>,
        about: &'static str,
        unknown: bool,
    ) -> bool {
        let (first, start) = self.with(|i| {
            let Some(t) = i.tallies.get_mut(class as usize) else {
                return (false, false);
            };
            let start = !t.open;
            t.open = true;
            if start && class.first_recorded() {
                return (true, true);
            }
            t.count(from);
            t.about = about;
            if unknown {
                t.unknown = t.unknown.saturating_add(1);
            }
            (false, start)
        });
        if start {
            // The stamper starts the period.
            self.fresh.signal(());
        }
        first
    }

    /// A login (or a current password, or the setup code) was refused for
    /// `name` (as typed; `known`: an account of that name exists) from
    /// `from`: the first of a period is recorded, the rest counted.
    pub(crate) fn login_failed(&self, name: &[u8], known: bool, from: Option<Ipv4Addr>) {
        if self.repeated(Class::LoginFailed, from, "", !known) {
            self.add(Kind::LoginFailed, &Who::web(name, from), |_| {});
        }
    }

    /// A guess (a login, a setup code, a current password) from `from`
    /// refused unchecked, with 429: it had to wait. Counted over a period,
    /// never recorded one by one (a flood of them is the attack the wait
    /// answers).
    pub(crate) fn login_limited(&self, from: Option<Ipv4Addr>) {
        self.repeated(Class::LoginLimited, from, "", false);
    }

    /// A wrong setup code from `from`: as a failed login for a name no
    /// account has.
    pub(crate) fn setup_failed(&self, from: Option<Ipv4Addr>) {
        if self.repeated(Class::LoginFailed, from, "", true) {
            self.add(Kind::LoginFailed, &Who::web(b"", from), |d| {
                d.push(b"wrong setup code")
            });
        }
    }

    /// A configuration applied over Modbus by `who` (trigger texts too:
    /// `triggers` is the table in use): each protected setting it changed
    /// is recorded; its other changes are recorded setting by setting if
    /// it is the first apply of its period, else the apply is counted (a
    /// PLC toggling a setting cannot flood the log).
    pub(crate) fn modbus_config_changed(
        &self,
        before: &Config,
        after: &Config,
        triggers: &[Text<TRIGGER_TEXT>; TRIGGERS],
        who: &Who<'_>,
    ) {
        let changed = || SETTINGS.iter().filter(|s| s.get(before) != s.get(after));
        for s in changed().filter(|s| s.protected()) {
            self.setting_changed(s, before, after, who);
        }
        let moved = self.triggers_moved(triggers);
        let about = changed()
            .find(|s| !s.protected())
            .map(|s| s.key)
            .or((moved != 0).then_some("triggers"));
        let Some(about) = about else { return };
        if self.repeated(Class::ModbusConfig, who.from, about, false) {
            for s in changed().filter(|s| !s.protected()) {
                self.setting_changed(s, before, after, who);
            }
            self.triggers_recorded(triggers, moved, who);
        }
    }

    /// Trigger texts written over Modbus by `who`: recorded if the first
    /// change of their period, else counted.
    pub(crate) fn modbus_triggers_changed(
        &self,
        entries: &[Text<TRIGGER_TEXT>; TRIGGERS],
        who: &Who<'_>,
    ) {
        let moved = self.triggers_moved(entries);
        if moved != 0 && self.repeated(Class::ModbusConfig, who.from, "triggers", false) {
            self.triggers_recorded(entries, moved, who);
        }
    }

    /// The trigger entries that are not as last seen (bit `n`: entry `n`),
    /// which are taken as seen.
    fn triggers_moved(&self, entries: &[Text<TRIGGER_TEXT>; TRIGGERS]) -> u32 {
        let mut moved = 0;
        for (n, e) in entries.iter().enumerate() {
            if self.trigger_moved(n, e) {
                moved |= 1 << n;
            }
        }
        moved
    }

    /// Records the trigger entries of `moved` (bit `n`: entry `n`).
    fn triggers_recorded(
        &self,
        entries: &[Text<TRIGGER_TEXT>; TRIGGERS],
        moved: u32,
        who: &Who<'_>,
    ) {
        for (n, e) in entries.iter().enumerate() {
            if moved & (1 << n) != 0 {
                self.trigger_recorded(n, e, who);
            }
        }
    }

    /// The wall clock is the host's (Linux): `now` gives Unix seconds.
    pub(crate) fn use_host_clock(&self, now: fn() -> Option<u64>) {
        self.with(|i| i.wall = Wall::Host(now));
    }

    /// The wall clock was set to `unix` (Unix seconds) at `at` (a time
    /// server): recorded when it was not known or moved by more than a
    /// second.
    #[cfg(any(test, feature = "sntp"))]
    pub(crate) fn set_wall_time(&self, unix: u64, at: Instant, source: Option<Ipv4Addr>) {
        let before = self.with(|i| {
            let before = i.wall_at(at);
            i.wall = Wall::Set { unix, at };
            before
        });
        let moved = before.map(|b| unix as i64 - i64::from(b));
        if moved.is_none_or(|m| m.abs() > 1) {
            let who = Who {
                from: source,
                ..Who::SYSTEM
            };
            self.add(Kind::Time, &who, |d| match moved {
                Some(m) => {
                    let _ = write!(d, "set by a time server, moved by {m} s");
                }
                None => d.push(b"set by a time server (was unknown)"),
            });
        }
    }

    /// Stamps the records (and the refusal periods) waiting for their time
    /// with `now`, and wakes the storage task.
    pub(crate) fn stamp(&self, now: Instant) {
        self.with(|i| {
            let wall = i.wall_at(now);
            let from = i.stamp_from;
            for r in i.ring.iter_mut().filter(|r| r.seq >= from) {
                r.uptime_ms = now.as_millis();
                r.wall = wall;
            }
            i.stamp_from = i.next_seq;
            for t in i.tallies.iter_mut().filter(|t| t.open && t.since.is_none()) {
                // Quiet for a whole period: back to the first period.
                if t.ended.is_none_or(|e| now >= e + t.period) {
                    t.period = REFUSED_PERIOD;
                }
                t.since = Some(now);
            }
        });
        self.stamped.signal(());
    }

    /// Waits until something waits for its time.
    pub(crate) async fn wait_fresh(&self) {
        self.fresh.wait().await
    }

    /// Waits until stamped records wait to be kept (or the refusal periods
    /// changed).
    pub(crate) async fn wait_stamped(&self) {
        self.stamped.wait().await
    }

    /// When the next counting period ends.
    pub(crate) fn refusals_due(&self) -> Option<Instant> {
        self.with(|i| {
            i.tallies
                .iter()
                .filter_map(|t| t.since.map(|s| s + t.period))
                .min()
        })
    }

    /// Ends the counting periods due at `now`, with a record each that
    /// counted something (stamped `now`).
    pub(crate) fn end_refusal_periods(&self, now: Instant) {
        self.end_periods(now, false);
    }

    /// Ends every counting period now, due or not, with a record each that
    /// counted something: before the gateway stops or restarts, so that
    /// what a period counted is kept instead of lost with the RAM.
    pub(crate) fn close_periods(&self, now: Instant) {
        self.end_periods(now, true);
    }

    /// Ends the periods due at `now` (all running ones if `all`).
    fn end_periods(&self, now: Instant, all: bool) {
        if all {
            // A period counted but not stamped yet starts now (and is
            // ended with the others).
            self.stamp(now);
        }
        for (n, class) in CLASSES.iter().enumerate() {
            let ended = self.with(|i| {
                let t = i.tallies.get_mut(n)?;
                let since = t.since.filter(|s| all || *s + t.period <= now)?;
                let ended = *t;
                *t = Tally {
                    ended: Some(now),
                    // Only a period that counted something makes the next
                    // one longer.
                    period: if ended.count > 0 {
                        (t.period * 2).min(REFUSED_PERIOD_MAX)
                    } else {
                        t.period
                    },
                    ..Tally::NONE
                };
                (ended.count > 0).then_some((ended, now - since))
            });
            if let Some((t, over)) = ended {
                self.tally_recorded(*class, &t, over);
            }
        }
        self.stamp(now);
    }

    /// Records what the period of `class` counted (`t`, over `over`).
    fn tally_recorded(&self, class: Class, t: &Tally, over: Duration) {
        let interface = match class {
            Class::RefusedWeb | Class::LoginFailed | Class::LoginLimited => Interface::Web,
            Class::RefusedRobot => Interface::Robot,
            _ => Interface::Modbus,
        };
        let who = Who {
            actor: b"",
            interface,
            from: t.last,
        };
        let (count, secs, addrs) = (t.count, over.as_secs(), t.addresses());
        let more = if t.more { "more than " } else { "" };
        let kind = match class {
            Class::LoginFailed | Class::LoginLimited => Kind::LoginFailed,
            Class::ModbusConfig => Kind::Config,
            Class::ConfigRefused => Kind::ConfigRefused,
            _ => Kind::Refused,
        };
        self.add(kind, &who, |d| {
            let _ = match class {
                Class::RefusedModbus | Class::RefusedWeb => write!(
                    d,
                    "{count} connections refused in {secs} s (allow-list)"
                ),
                Class::RefusedRobot => write!(
                    d,
                    "{count} connections refused in {secs} s (not the controller)"
                ),
                Class::LoginFailed => write!(
                    d,
                    "{count} more failed logins in {secs} s ({} unknown names), {more}{addrs} addresses",
                    t.unknown
                ),
                Class::LoginLimited => write!(
                    d,
                    "{count} guesses not checked in {secs} s (429: wait), {more}{addrs} addresses"
                ),
                Class::ModbusConfig => write!(
                    d,
                    "{count} more applied in {secs} s from {more}{addrs} addresses, last {}",
                    t.about
                ),
                Class::ConfigRefused => write!(
                    d,
                    "{count} more refused in {secs} s from {more}{addrs} addresses, last {}",
                    t.about
                ),
            };
        });
    }

    /// The oldest stamped record not kept yet, written into `out`: its
    /// sequence number and length.
    pub(crate) fn next_to_keep(&self, out: &mut [u8; RECORD_MAX]) -> Option<(u32, usize)> {
        self.with(|i| {
            let (from, to) = (i.keep_from, i.stamp_from);
            let r = i.ring.iter().find(|r| r.seq >= from && r.seq < to)?;
            Some((r.seq, r.emit(out)))
        })
    }

    /// Record `seq` was kept (`ok`) or could not be (then it is counted as
    /// lost, and `false` says: stop for now, the medium fails). After a
    /// record is kept, records lost before are reported (a
    /// [`Kind::Lost`] record).
    pub(crate) fn kept(&self, seq: u32, ok: bool) -> bool {
        let lost = self.with(|i| {
            i.keep_from = i.keep_from.max(seq.wrapping_add(1));
            i.kept_waiters.wake();
            if !ok {
                i.lost = i.lost.saturating_add(1);
                return 0;
            }
            core::mem::take(&mut i.lost)
        });
        if lost > 0 {
            self.add(Kind::Lost, &Who::SYSTEM, |d| {
                let _ = write!(d, "{lost} records lost (the medium was full or failed)");
            });
        }
        ok
    }

    /// Starts the log once the kept records were read back (`restore`):
    /// the boot counter follows the newest kept record's, and so does the
    /// sequence number; records are kept from now on if `keeping`. Returns
    /// the boot counter.
    pub(crate) fn start(&self, keeping: bool) -> u32 {
        self.with(|i| {
            let newest = i.ring.iter().map(|r| (r.boot, r.seq)).max();
            i.boot = newest.map_or(1, |(b, _)| b.wrapping_add(1));
            let seq = i
                .ring
                .iter()
                .map(|r| r.seq)
                .max()
                .map_or(1, |s| s.wrapping_add(1));
            i.next_seq = seq;
            i.stamp_from = seq;
            i.keep_from = seq;
            i.keeping = keeping;
            i.kept_waiters.wake();
            i.boot
        })
    }

    /// The sequence number the next record gets: the records made from
    /// now on have this one or later.
    pub(crate) fn next_seq(&self) -> u32 {
        self.with(|i| i.next_seq)
    }

    /// Waits until every record before `end` (a [`Self::next_seq`]) was
    /// kept on the medium, or given up (lost: the medium failed, or was
    /// slower than [`RING`] records); at once when nothing is kept
    /// (no persistent storage). The page answers a change only then: the
    /// record of a change is on the medium when its answer arrives.
    pub(crate) async fn wait_kept(&self, end: u32) {
        core::future::poll_fn(|cx| {
            self.with(|i| {
                // Sequence numbers wrap: "before end" is within half the
                // range behind it.
                let waiting = end.wrapping_sub(i.keep_from) as i32 > 0;
                if !i.keeping || !waiting {
                    return core::task::Poll::Ready(());
                }
                i.kept_waiters.register(cx.waker());
                core::task::Poll::Pending
            })
        })
        .await
    }

    /// Puts a kept record (read back at start) into the ring, as kept.
    pub(crate) fn restore(&self, r: Record) {
        self.with(|i| {
            if i.ring.is_full() {
                i.ring.pop_front();
            }
            let _ = i.ring.push_back(r);
        });
    }

    /// The oldest stamped record with a sequence number from `from` to
    /// `to` (a copy: the page reads the ring one record at a time).
    pub(crate) fn copy(&self, from: u32, to: u32) -> Option<Record> {
        self.with(|i| {
            let stamped = i.stamp_from;
            i.ring
                .iter()
                .find(|r| r.seq >= from && r.seq <= to && r.seq < stamped)
                .copied()
        })
    }

    /// The newest stamped record's sequence number, the boot counter, and
    /// how many records the ring holds.
    pub(crate) fn summary(&self) -> (Option<u32>, u32, usize) {
        self.with(|i| {
            let newest = i
                .ring
                .iter()
                .rev()
                .find(|r| r.seq < i.stamp_from)
                .map(|r| r.seq);
            (newest, i.boot, i.ring.len())
        })
    }

    /// Wall time at `now` (Unix seconds), if known.
    pub(crate) fn wall_at(&self, now: Instant) -> Option<u32> {
        self.with(|i| i.wall_at(now))
    }
}

impl Inner {
    /// Adds a record: its sequence number and boot counter are given here;
    /// the oldest goes when the ring is full (lost if it was not kept).
    fn push(&mut self, mut r: Record) {
        r.seq = self.next_seq;
        r.boot = self.boot;
        self.next_seq = self.next_seq.wrapping_add(1);
        if self.ring.is_full() {
            if let Some(old) = self.ring.pop_front() {
                if self.keeping && old.seq >= self.keep_from {
                    self.lost = self.lost.saturating_add(1);
                    self.keep_from = old.seq.wrapping_add(1);
                    self.kept_waiters.wake();
                }
            }
        }
        if !self.keeping {
            // Nothing is kept: nothing waits.
            self.keep_from = self.next_seq;
        }
        // Cannot fail: there is room now.
        let _ = self.ring.push_back(r);
    }

    /// Wall time at `now` (Unix seconds, up to 2106), if known.
    fn wall_at(&self, now: Instant) -> Option<u32> {
        // Only a time server's setting counts from an instant.
        #[cfg(not(any(test, feature = "sntp")))]
        let _ = now;
        let unix = match self.wall {
            Wall::Unknown => None,
            Wall::Host(f) => f(),
            #[cfg(any(test, feature = "sntp"))]
            Wall::Set { unix, at } => {
                Some(unix.saturating_add(now.saturating_duration_since(at).as_secs()))
            }
        }?;
        u32::try_from(unix).ok().filter(|&u| u != 0)
    }
}
