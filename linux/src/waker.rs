//! The waker the gateway runs with on tokio (see [`steady_waker`]).

use core::future::Future;

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

#[cfg(test)]
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
    use embassy_time::Duration;
    use hans_gateway::{Clock, SystemClock};

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
