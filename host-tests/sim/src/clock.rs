//! The simulator's own clock.
//!
//! Everything the robot does (bring-up steps, motion profiles, flag lags) is
//! a function of *simulated time*, so a test can make it run fast
//! ([`ClockMode::Scaled`] with a factor above 1) or completely
//! deterministic ([`ClockMode::Manual`]: time stands still until
//! [`Clock::advance`] moves it). Network behaviour (reply delays of fault
//! injection, the incomplete-message quiet period, refused connections) uses
//! real time.

use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How simulated time passes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ClockMode {
    /// Real time multiplied by this factor (1.0 = real time, 10.0 = ten
    /// times faster). Must be finite and above zero.
    Scaled(f64),
    /// Time stands still except when [`Clock::advance`] is called.
    Manual,
}

impl Default for ClockMode {
    fn default() -> Self {
        ClockMode::Scaled(1.0)
    }
}

#[derive(Debug)]
struct Inner {
    mode: ClockMode,
    /// Real instant of the last re-basing.
    base_real: Instant,
    /// Simulated time at `base_real`.
    base_sim: Duration,
}

/// The simulated clock: time since the simulator started.
#[derive(Debug)]
pub struct Clock {
    inner: Mutex<Inner>,
}

impl Clock {
    pub(crate) fn new(mode: ClockMode) -> Clock {
        Clock {
            inner: Mutex::new(Inner {
                mode: sanitize(mode),
                base_real: Instant::now(),
                base_sim: Duration::ZERO,
            }),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Inner> {
        self.inner.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Simulated time since start.
    pub fn now(&self) -> Duration {
        now_of(&self.lock())
    }

    /// The current mode.
    pub fn mode(&self) -> ClockMode {
        self.lock().mode
    }

    /// Switches mode; simulated time continues from where it is.
    pub fn set_mode(&self, mode: ClockMode) {
        let mut g = self.lock();
        g.base_sim = now_of(&g);
        g.base_real = Instant::now();
        g.mode = sanitize(mode);
    }

    /// Moves simulated time forward by `d` (in any mode; in scaled mode it
    /// is a jump on top of the running time).
    pub fn advance(&self, d: Duration) {
        let mut g = self.lock();
        g.base_sim = now_of(&g) + d;
        g.base_real = Instant::now();
    }

    /// The real time that `sim` of simulated time takes in the current mode
    /// (`None` in manual mode: it never passes by itself).
    pub fn real_for(&self, sim: Duration) -> Option<Duration> {
        match self.lock().mode {
            ClockMode::Scaled(f) => Some(sim.div_f64(f)),
            ClockMode::Manual => None,
        }
    }
}

fn sanitize(mode: ClockMode) -> ClockMode {
    match mode {
        ClockMode::Scaled(f) if f.is_finite() && f > 0.0 => ClockMode::Scaled(f.min(1e6)),
        ClockMode::Scaled(_) => ClockMode::Scaled(1.0),
        ClockMode::Manual => ClockMode::Manual,
    }
}

fn now_of(g: &Inner) -> Duration {
    match g.mode {
        ClockMode::Scaled(f) => g.base_sim + g.base_real.elapsed().mul_f64(f),
        ClockMode::Manual => g.base_sim,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn manual_time_moves_only_when_advanced() {
        let c = Clock::new(ClockMode::Manual);
        assert_eq!(c.now(), Duration::ZERO);
        c.advance(Duration::from_millis(250));
        assert_eq!(c.now(), Duration::from_millis(250));
        assert_eq!(c.real_for(Duration::from_secs(1)), None);
    }

    #[test]
    fn scaled_time_is_monotonic_and_switchable() {
        let c = Clock::new(ClockMode::Scaled(1000.0));
        let a = c.now();
        c.set_mode(ClockMode::Manual);
        let b = c.now();
        assert!(b >= a);
        assert_eq!(c.now(), b);
        assert_eq!(
            Clock::new(ClockMode::Scaled(-1.0)).mode(),
            ClockMode::Scaled(1.0)
        );
    }
}
