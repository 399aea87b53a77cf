//! Time, as the gateway sees it: a [`Clock`] that tells the time and sleeps
//! until an instant.
//!
//! Every part of the gateway that runs in time (the engine, the robot link,
//! the watchdog, the Modbus idle timeout, the DataSheet reader, the storage
//! task) takes its time from a `Clock` instead of calling embassy-time
//! directly. Boards and Linux use [`SystemClock`] (embassy-time's driver);
//! tests use the virtual clock of [`crate::testkit`], which only moves when
//! the test moves it, so a test plays minutes of robot and PLC in
//! microseconds, with no sleeps, and the same seed gives the same run.
//!
//! Why not embassy-time's `mock-driver`: a time driver is one global symbol
//! per binary, and the host workspace links embassy-time's `std` driver
//! (for the Linux gateway); two drivers cannot be linked into one test
//! binary.
//! Instants and durations are still embassy-time's types (plain numbers
//! that need no driver).

use core::future::Future;

use embassy_futures::select::{select, Either};
pub(crate) use embassy_time::{Duration, Instant, TimeoutError};

/// A source of time for the gateway.
pub trait Clock {
    /// The current instant.
    fn now(&self) -> Instant;

    /// Completes at `at` (at once if `at` has passed).
    fn sleep_until(&self, at: Instant) -> impl Future<Output = ()>;

    /// Completes `d` from now.
    fn sleep(&self, d: Duration) -> impl Future<Output = ()> {
        self.sleep_until(self.now() + d)
    }
}

/// The clock of boards and Linux: embassy-time's driver (SysTick, a
/// hardware timer, or the std driver).
#[derive(Clone, Copy, Debug, Default)]
pub struct SystemClock;

impl Clock for SystemClock {
    fn now(&self) -> Instant {
        Instant::now()
    }

    fn sleep_until(&self, at: Instant) -> impl Future<Output = ()> {
        embassy_time::Timer::at(at)
    }
}

/// Runs `fut` until `at`: its output, or [`TimeoutError`] if `at` came first.
pub(crate) async fn with_deadline<C: Clock, F: Future>(
    clock: &C,
    at: Instant,
    fut: F,
) -> Result<F::Output, TimeoutError> {
    match select(fut, clock.sleep_until(at)).await {
        Either::First(out) => Ok(out),
        Either::Second(()) => Err(TimeoutError),
    }
}

/// Runs `fut` for at most `d`.
pub(crate) async fn with_timeout<C: Clock, F: Future>(
    clock: &C,
    d: Duration,
    fut: F,
) -> Result<F::Output, TimeoutError> {
    let at = clock.now() + d;
    with_deadline(clock, at, fut).await
}

/// `ms` milliseconds (the configuration's unit).
pub(crate) fn millis(ms: u16) -> Duration {
    Duration::from_millis(u64::from(ms))
}
