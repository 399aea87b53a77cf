//! The PLC watchdog: while a motion runs and `CFG_WATCHDOG_MS` > 0, the PLC
//! must change `PLC_HEARTBEAT` at least that often.
//!
//! The period counts from the later of the last heartbeat change and the
//! motion's start. When it expires, the engine sets the trip bit, counts the
//! trip and does `CFG_WATCHDOG_ACTION`:
//!
//! * 0, report only: nothing else. The motion is **not** stopped and its
//!   command runs to its end (Done, as any motion); the watchdog does not
//!   act on it again.
//! * 1, stop: `GrpStop`; the motion's command ends in Error 39602 and the
//!   motions waiting in the queue in CommandAborted (as a Stop).
//! * 2, pause: `GrpInterrupt`; the same outcomes (nothing may start behind
//!   a held motion).

use embassy_time::{Duration, Instant};

use super::motion::Motion;
use crate::clock::millis;
use crate::hub::Hub;

/// The PLC's heartbeat as the watchdog sees it: when it last changed, and
/// whether the PLC that owned the command inputs is gone (an EtherNet/IP
/// owner's connection closed: `PlcState::lost`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Beat {
    pub(crate) last: Instant,
    pub(crate) lost: bool,
}

/// The instant the watchdog expires for `motion`, if it watches it
/// (`period_ms` > 0 and it has not acted on it yet): the period after the
/// later of the last heartbeat and the motion's start, or at once when the
/// heartbeat is lost.
pub(crate) fn deadline(motion: &Motion, beat: Beat, period_ms: u16) -> Option<Instant> {
    if period_ms == 0 || motion.watchdog_fired {
        return None;
    }
    if beat.lost {
        return Some(motion.since);
    }
    // Strictly more than the period must pass.
    Some(beat.last.max(motion.since) + millis(period_ms) + Duration::from_ticks(1))
}

/// `true` when the watchdog expired at `now`.
pub(crate) fn expired(motion: &Motion, beat: Beat, period_ms: u16, now: Instant) -> bool {
    deadline(motion, beat, period_ms).is_some_and(|d| now >= d)
}

/// Records a trip in the audit log (feature `audit`; else nothing): the
/// period the heartbeat was missed for and what the watchdog does (`jog`:
/// a jog, which stops whatever the action says).
pub(crate) fn audit_trip(hub: &Hub, config: &crate::config::Config, jog: bool) {
    #[cfg(feature = "audit")]
    let period_ms = match config.watchdog_ms {
        0 if jog => super::jog::HEARTBEAT,
        p => p,
    };
    #[cfg(feature = "audit")]
    hub.audit.add(
        crate::audit::Kind::Watchdog,
        &crate::audit::Who::SYSTEM,
        |d| {
            use core::fmt::Write;
            let _ = write!(
                d,
                "PLC heartbeat unchanged for {period_ms} ms during a motion; "
            );
            if jog {
                d.push(b"jog stopped");
            } else {
                d.push(b"action ");
                let _ = crate::config::schema::WATCHDOG_ACTION.format(config, d);
            }
        },
    );
    #[cfg(not(feature = "audit"))]
    let _ = (hub, config, jog);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::job::Source;

    #[test]
    fn the_period_counts_from_the_later_of_beat_and_start() {
        let at = Instant::from_millis;
        let b = |t| Beat {
            last: at(t),
            lost: false,
        };
        let mut m = Motion::new(Source::Channel(0), at(1000));
        // A beat long before the motion: counted from the start.
        assert!(!expired(&m, b(0), 500, at(1500)));
        assert!(expired(&m, b(0), 500, at(1501)));
        // A beat during the motion moves it.
        assert!(!expired(&m, b(1400), 500, at(1800)));
        // A lost heartbeat (the owning PLC's connection closed): at once.
        let lost = Beat {
            last: at(1400),
            lost: true,
        };
        assert!(expired(&m, lost, 500, at(1401)));
        // Off, or already acted: never.
        assert!(!expired(&m, b(0), 0, at(99_999)));
        assert!(!expired(&m, lost, 0, at(99_999)));
        m.watchdog_fired = true;
        assert_eq!(deadline(&m, b(0), 500), None);
    }
}
