//! Jogging from the PLC (codes 60-71 and 80-91; V6 `LongJogJ` /
//! `LongJogL`), with the hold semantics of PLCopen's MC_Jog.
//!
//! * The rising edge queues the jog like any motion; when it goes, the
//!   robot accepts `LongJogJ,…,1` and the command is Busy and Active.
//! * While Execute stays high the gateway sends `LongMoveEvent` every
//!   [`KEEP_ALIVE`] (the controller stops a long jog by itself when none
//!   came for 200 ms: V6 document 4.10.18). Nothing else ends it: a jog
//!   that reaches a joint limit stands still and stays Busy.
//! * Execute falls: `LongJogJ,…,0` goes out at once (after the one request
//!   in flight), and the command is Done once the robot stands still.
//! * The PLC heartbeat stops: after `CFG_WATCHDOG_MS` (or [`HEARTBEAT`]
//!   when the watchdog is off; whatever `CFG_WATCHDOG_ACTION` says) the
//!   jog is stopped and ends in Error 39602.
//! * The link drops: Error 39601; the controller stops the jog itself at
//!   most 200 ms after the last `LongMoveEvent`.
//! * A Stop (code 6) aborts it like any motion (CommandAborted).
//!
//! The bound: the robot stops at most `KEEP_ALIVE` + 200 ms + one reply
//! time after the gateway loses the PLC or the robot; after Execute falls,
//! the stop request leaves within one reply time.

use embassy_time::{Duration, Instant};

use crate::job::command::Jog;

/// Period of `LongMoveEvent` while a jog runs.
pub const KEEP_ALIVE: Duration = Duration::from_millis(100);

/// The PLC heartbeat period a jog needs when the watchdog is off \[ms\].
pub const HEARTBEAT: u16 = 1000;

/// A jog under way.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub(crate) struct JogRun {
    /// Which jog.
    pub jog: Jog,
    /// Its robot id.
    pub robot: u8,
    /// The stop was sent: the command ends once the robot stands still.
    pub stopping: bool,
    /// When the next `LongMoveEvent` is due.
    pub next_event: Instant,
}

impl JogRun {
    /// A jog the robot accepted at `now`.
    pub(crate) fn new(jog: Jog, robot: u8, now: Instant) -> Self {
        JogRun {
            jog,
            robot,
            stopping: false,
            next_event: now + KEEP_ALIVE,
        }
    }
}
