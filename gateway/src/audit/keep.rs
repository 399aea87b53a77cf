//! The storage task's side of the log: the kept records read back at
//! start, the records of a start, the stamper (which gives new records
//! their time), keeping records on the medium, and the last records
//! before a stop or a restart.

use core::convert::Infallible;
use core::fmt::Write;

use embassy_futures::select::{select, Either};
use embassy_time::{Duration, Instant};

use super::page::{Filled, Query, Window};
use super::{Interface, Kind, Log, Record, Who, RECORD_MAX};
use crate::clock::Clock;
use crate::config::Config;
use crate::state::inputs::{Text, TRIGGERS, TRIGGER_TEXT};
use crate::storage::{AuditStore, Medium};

/// Reads the records `storage` kept back into the log's ring (the newest
/// [`super::RING`]) and starts the log: the boot counter and the sequence
/// numbers go on from the newest kept record. Damaged records are skipped
/// (counted in the device log).
pub(crate) async fn restore<S: AuditStore>(log: &Log, storage: &mut S) -> u32 {
    let mut bad = 0u32;
    let read = storage
        .read(&mut |bytes| match Record::parse(bytes) {
            Ok((r, _)) => log.restore(r),
            Err(_) => bad += 1,
        })
        .await;
    if read.is_err() {
        warn!("audit: the kept records could not be read; the boot counter starts again");
    }
    if bad > 0 {
        warn!("audit: {} damaged records skipped", bad);
    }
    log.start(storage.persistent())
}

/// How the configuration was found at start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Loaded {
    /// A stored image (its CRC-32).
    Image(u32),
    /// Nothing stored: the defaults.
    Nothing,
    /// A stored image refused (why): the defaults.
    Refused(&'static str),
    /// The storage could not be read: the defaults.
    Unreadable,
}

/// What a start records (see [`started`]).
pub(crate) struct Start<'a> {
    /// The boot counter ([`restore`]).
    pub boot: u32,
    /// How the configuration was found.
    pub loaded: Loaded,
    /// A recovery start: the configuration loaded, and the one run with.
    pub recovery: Option<(&'a Config, &'a Config)>,
    /// The trigger table in use.
    pub triggers: &'a [Text<TRIGGER_TEXT>; TRIGGERS],
    /// Where the configuration is kept (a file people edit is named as the
    /// source of what was loaded).
    pub medium: Medium,
    /// The platform's wall clock (Linux), if it has one.
    pub wall_clock: Option<fn() -> Option<u64>>,
}

/// Records a start at `now`: `start`, `config-loaded`, and for a recovery
/// start `recovery` and a `config` record per setting it changed (interface
/// `button`).
pub(crate) fn started(log: &Log, s: &Start<'_>, now: Instant) {
    if let Some(f) = s.wall_clock {
        log.use_host_clock(f);
    }
    log.triggers_are(s.triggers);
    log.add(Kind::Start, &Who::SYSTEM, |d| {
        let _ = write!(
            d,
            "hans-gateway {}, boot {}",
            env!("CARGO_PKG_VERSION"),
            s.boot
        );
    });
    // On Linux the stored configuration is a file people edit.
    let from = Who {
        interface: if s.medium == Medium::File {
            Interface::File
        } else {
            Interface::System
        },
        ..Who::SYSTEM
    };
    log.add(Kind::ConfigLoaded, &from, |d| match s.loaded {
        Loaded::Image(crc) => {
            let _ = write!(d, "stored configuration, crc {crc:08x}");
        }
        Loaded::Nothing => d.push(b"nothing stored: defaults"),
        Loaded::Refused(why) => {
            let _ = write!(d, "stored configuration refused ({why}): defaults");
        }
        Loaded::Unreadable => d.push(b"storage unreadable: defaults"),
    });
    if let Some((loaded, running)) = s.recovery {
        let button = Who {
            interface: Interface::Button,
            ..Who::SYSTEM
        };
        log.add(Kind::Recovery, &button, |d| {
            d.push(b"factory network and access settings for this run")
        });
        log.config_changed(loaded, running, &button);
    }
    log.stamp(now);
}

/// How long a stop or a restart waits for its last records to be kept
/// (a flash sector erase takes up to ~2 s on the NUCLEO; a stuck medium
/// must not keep the device from stopping).
pub(crate) const CLOSING_WAIT: Duration = Duration::from_secs(5);

/// Before the gateway stops or restarts: ends every counting period now
/// (what it counted is recorded, not lost with the RAM), records the stop
/// (`why`, if any: a restart has its own record), and waits until
/// the storage task kept these records and every one before them, at most
/// [`CLOSING_WAIT`]. The storage task must run meanwhile (this is joined
/// or selected with the gateway's run). `true`: all kept (or nothing is
/// kept on this device); `false`: the wait ended first.
pub(crate) async fn closing<C: Clock>(log: &Log, clock: &C, why: Option<&str>) -> bool {
    let now = clock.now();
    log.close_periods(now);
    // The stop is the run's last record: what the periods counted before it.
    if let Some(why) = why {
        log.add(Kind::Stop, &Who::SYSTEM, |d| d.push(why.as_bytes()));
        log.stamp(now);
    }
    let end = log.next_seq();
    matches!(
        select(log.wait_kept(end), clock.sleep(CLOSING_WAIT)).await,
        Either::First(())
    )
}

/// Gives new records their time: runs beside the storage task's work (so
/// that a slow flash operation does not delay a stamp), forever.
pub(crate) async fn stamper<C: Clock>(log: &Log, clock: &C) -> Infallible {
    loop {
        log.wait_fresh().await;
        log.stamp(clock.now());
    }
}

/// Waits until the log has work for the storage task: stamped records to
/// keep, a refusal period that ended, or a page asked for (returned: the
/// storage task reads it after keeping what waits, [`page`]).
pub(crate) async fn wait_work<C: Clock>(log: &Log, clock: &C) -> Option<(u32, Query)> {
    let due = async {
        match log.refusals_due() {
            Some(at) => {
                select(log.wait_stamped(), clock.sleep_until(at)).await;
            }
            None => log.wait_stamped().await,
        }
    };
    match select(due, log.pages.asked()).await {
        Either::First(()) => None,
        Either::Second(asked) => Some(asked),
    }
}

/// Reads the page `query` asks for (request `id`) into the log's window:
/// from the medium, or from the RAM ring where nothing is kept; answers
/// the request.
pub(crate) async fn page<S: AuditStore>(log: &Log, storage: &mut S, id: u32, query: Query) {
    let pages = &log.pages;
    pages.with(|w| *w = Window::new(query));
    let filled = if storage.persistent() {
        match storage.read(&mut |b| pages.with(|w| w.feed(b))).await {
            Ok(()) => Filled::Page(id),
            Err(_) => {
                warn!("audit: the kept records could not be read for a page");
                Filled::Failed(id)
            }
        }
    } else {
        let (newest, _, _) = log.summary();
        if let Some(last) = newest {
            let mut next = 0;
            while let Some(r) = log.copy(next, last) {
                pages.with(|w| w.offer(r));
                if r.seq >= last {
                    break;
                }
                next = r.seq.wrapping_add(1);
            }
        }
        Filled::Page(id)
    };
    pages.answer(filled);
}

/// Ends the refusal periods that are due, and keeps the stamped records
/// that wait, oldest first; stops at the first the medium fails on (it is
/// counted as lost).
pub(crate) async fn keep<S: AuditStore, C: Clock>(log: &Log, clock: &C, storage: &mut S) {
    let now = clock.now();
    if log.refusals_due().is_some_and(|t| t <= now) {
        log.end_refusal_periods(now);
    }
    let mut buf = [0u8; RECORD_MAX];
    while let Some((seq, n)) = log.next_to_keep(&mut buf) {
        let ok = storage.append(buf.get(..n).unwrap_or(&[])).await.is_ok();
        if !log.kept(seq, ok) {
            warn!("audit: record {} could not be kept", seq);
            break;
        }
    }
}
