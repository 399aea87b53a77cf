//! A clock that only moves when the test moves it.

use core::cell::RefCell;
use core::future::Future;
use core::pin::Pin;
use core::task::{Context, Poll, Waker};
use std::collections::BTreeMap;

use embassy_time::{Duration, Instant};

use crate::clock::Clock;

#[derive(Default)]
struct State {
    now: u64,
    next_id: u64,
    /// Sleeping futures: id → (deadline, waker).
    timers: BTreeMap<u64, (u64, Waker)>,
    /// Sleeps that had to wait (registered a waker): see
    /// [`VirtualClock::sleeps`].
    sleeps: u64,
    /// Polls of sleeping futures.
    sleep_polls: u64,
}

/// Virtual time, starting at 0. [`VirtualClock::advance_to`] moves it and
/// wakes the sleepers whose time has come.
#[derive(Default)]
pub struct VirtualClock {
    state: RefCell<State>,
}

impl VirtualClock {
    /// A clock at instant 0.
    pub fn new() -> Self {
        Self::default()
    }

    /// The earliest deadline of a sleeping future.
    pub fn next_deadline(&self) -> Option<Instant> {
        let s = self.state.borrow();
        s.timers
            .values()
            .map(|(at, _)| *at)
            .min()
            .map(Instant::from_ticks)
    }

    /// Moves time to `t` (never back) and wakes every sleeper due by then.
    pub fn advance_to(&self, t: Instant) {
        let due: std::vec::Vec<Waker> = {
            let mut s = self.state.borrow_mut();
            s.now = s.now.max(t.as_ticks());
            let now = s.now;
            let ids: std::vec::Vec<u64> = s
                .timers
                .iter()
                .filter(|(_, (at, _))| *at <= now)
                .map(|(id, _)| *id)
                .collect();
            ids.iter()
                .filter_map(|id| s.timers.remove(id).map(|(_, w)| w))
                .collect()
        };
        for w in due {
            w.wake();
        }
    }

    /// Moves time forward by `d`.
    pub fn advance(&self, d: Duration) {
        self.advance_to(self.now() + d);
    }

    /// How many sleeps so far had to wait (were not due when first
    /// polled): each is one wake-up of whoever slept, a measure of how
    /// often a task that waits for time wakes.
    pub fn sleeps(&self) -> u64 {
        self.state.borrow().sleeps
    }

    /// How many times a sleep was polled so far (also when not due).
    pub fn sleep_polls(&self) -> u64 {
        self.state.borrow().sleep_polls
    }
}

impl Clock for VirtualClock {
    fn now(&self) -> Instant {
        Instant::from_ticks(self.state.borrow().now)
    }

    fn sleep_until(&self, at: Instant) -> impl Future<Output = ()> {
        Sleep {
            clock: self,
            at: at.as_ticks(),
            id: None,
        }
    }
}

/// A future that completes when the virtual clock reaches `at`.
struct Sleep<'a> {
    clock: &'a VirtualClock,
    at: u64,
    id: Option<u64>,
}

impl Future for Sleep<'_> {
    type Output = ();

    fn poll(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<()> {
        let this = &mut *self;
        let mut s = this.clock.state.borrow_mut();
        s.sleep_polls += 1;
        if s.now >= this.at {
            if let Some(id) = this.id.take() {
                s.timers.remove(&id);
            }
            return Poll::Ready(());
        }
        let id = match this.id {
            Some(id) => id,
            None => {
                s.sleeps += 1;
                s.next_id += 1;
                let id = s.next_id;
                this.id = Some(id);
                id
            }
        };
        s.timers.insert(id, (this.at, cx.waker().clone()));
        Poll::Pending
    }
}

impl Drop for Sleep<'_> {
    fn drop(&mut self) {
        if let Some(id) = self.id {
            self.clock.state.borrow_mut().timers.remove(&id);
        }
    }
}
