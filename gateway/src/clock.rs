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
//! (for `hans-gateway`); two drivers cannot be linked into one test binary.
//! Instants and durations are still embassy-time's types (plain numbers
//! that need no driver).
//!
//! On Linux the gateway runs on tokio, whose wakers embassy's timers and
//! signals cannot recognise: see [`steady_waker`].

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

/// Runs `fut` (the whole gateway, on a host executor) with a waker that is
/// `will_wake` its own clones.
///
/// embassy-time's generic timer queue (the std driver's) keeps one entry
/// per waker, and an embassy-sync `Signal` one waiter; both recognise the
/// waker of the next poll with `Waker::will_wake`. The waker tokio hands
/// `block_on`'s future and the clone these keep point to two copies of one
/// vtable in a release build, so `will_wake` was always `false`: every poll
/// of a waiting `Signal` woke the "other" waiter (the task itself), and
/// every poll of a pending `Timer` added a queue entry until the 64 were
/// full, then evicted one by waking it (the task again). An idle
/// `hans-gateway` woke itself during each poll and took a whole core.
///
/// Here the future sees one waker for its whole life, itself a clone, so
/// that its clones share its vtable; it forwards wakes to the executor's
/// current waker.
#[cfg(feature = "std")]
pub(crate) async fn steady_waker<F: Future>(fut: F) -> F::Output {
    use core::task::{Context, Waker};
    use std::sync::{Arc, Mutex};
    use std::task::Wake;

    /// The executor's waker of the latest poll.
    struct Forward(Mutex<Waker>);

    impl Wake for Forward {
        fn wake(self: Arc<Self>) {
            self.wake_by_ref();
        }
        fn wake_by_ref(self: &Arc<Self>) {
            if let Ok(w) = self.0.lock() {
                w.wake_by_ref();
            }
        }
    }

    let mut fut = core::pin::pin!(fut);
    let mut steady: Option<(Arc<Forward>, Waker)> = None;
    core::future::poll_fn(|cx| {
        let (forward, waker) = steady.get_or_insert_with(|| {
            let forward = Arc::new(Forward(Mutex::new(cx.waker().clone())));
            // A clone: the vtable its own clones carry.
            let waker = Waker::from(forward.clone()).clone();
            (forward, waker)
        });
        if let Ok(mut w) = forward.0.lock() {
            w.clone_from(cx.waker());
        }
        fut.as_mut().poll(&mut Context::from_waker(waker))
    })
    .await
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use core::cell::Cell;
    use core::future::poll_fn;
    use core::task::{Context, Poll, Waker};
    use std::sync::Arc;
    use std::task::Wake;

    use embassy_futures::select::select3;
    use embassy_sync::blocking_mutex::raw::NoopRawMutex;
    use embassy_sync::signal::Signal;

    use super::*;

    /// A waker that forwards to another.
    struct Forward(Waker);

    impl Wake for Forward {
        fn wake(self: Arc<Self>) {
            self.0.wake_by_ref();
        }
        fn wake_by_ref(self: &Arc<Self>) {
            self.0.wake_by_ref();
        }
    }

    /// Polls `fut` with a new waker at every poll.
    async fn fresh_wakers<F: Future>(fut: F) -> F::Output {
        let mut fut = core::pin::pin!(fut);
        poll_fn(|cx| {
            let waker = Waker::from(Arc::new(Forward(cx.waker().clone())));
            fut.as_mut().poll(&mut Context::from_waker(&waker))
        })
        .await
    }

    /// Polls of an idle future (two timers and a signal, as the gateway
    /// waits) in 300 ms on tokio, after a busy start of `busy` polls,
    /// under an executor whose waker is never `will_wake` its clone (as
    /// tokio's `block_on` in a release build; in a debug build its two
    /// vtables are one): here a new waker at every poll.
    fn idle_polls(steady: bool) -> u32 {
        /// Polls of the busy start: more than the 64 entries of
        /// embassy-time's generic timer queue.
        const BUSY: u32 = 100;
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .unwrap();
        let polls = Cell::new(0u32);
        let signal = Signal::<NoopRawMutex, ()>::new();
        let clock = SystemClock;
        let start = clock.now();
        let waits = select3(
            clock.sleep_until(start + Duration::from_millis(300)),
            clock.sleep_until(start + Duration::from_millis(400)),
            signal.wait(),
        );
        let mut waits = core::pin::pin!(waits);
        let idle = poll_fn(|cx| {
            polls.set(polls.get() + 1);
            if polls.get() <= BUSY {
                // A busy start (connects, PLC writes): polled again.
                cx.waker().wake_by_ref();
            }
            match waits.as_mut().poll(cx) {
                Poll::Ready(_) => Poll::Ready(()),
                Poll::Pending => Poll::Pending,
            }
        });
        if steady {
            rt.block_on(fresh_wakers(steady_waker(idle)));
        } else {
            rt.block_on(fresh_wakers(idle));
        }
        assert!(clock.now() >= start + Duration::from_millis(300));
        polls.get() - BUSY
    }

    /// An idle gateway on tokio is polled a few times, not in a loop; and
    /// the same task without `steady_waker` is polled in a loop (one test:
    /// the std driver's timer queue is global, and the loop fills it).
    #[test]
    fn an_idle_task_under_a_steady_waker_is_not_polled_in_a_loop() {
        let idle = idle_polls(true);
        assert!(idle <= 10, "polled {idle} times while idle");
        let idle = idle_polls(false);
        assert!(idle > 1000, "without: polled only {idle} times while idle");
    }
}
