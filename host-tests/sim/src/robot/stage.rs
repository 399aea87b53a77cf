//! A power or connection stage of the bring-up chain (box, 48 V, master,
//! enable, free drive): off, rising for a while, on, falling.

use std::time::Duration;

use super::reached;

/// A power/connection stage of the bring-up chain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Stage {
    Off,
    Rising { done: f64 },
    On,
    Falling { done: f64 },
}

impl Stage {
    pub(super) fn settle(&mut self, now: f64) {
        match *self {
            Stage::Rising { done } if reached(now, done) => *self = Stage::On,
            Stage::Falling { done } if reached(now, done) => *self = Stage::Off,
            _ => {}
        }
    }

    pub(super) fn is_on(&self) -> bool {
        *self == Stage::On
    }

    /// On or on its way there.
    pub(super) fn coming(&self) -> bool {
        matches!(self, Stage::On | Stage::Rising { .. })
    }

    /// When it is (or will be) on.
    pub(super) fn ready_at(&self, now: f64) -> f64 {
        match *self {
            Stage::Rising { done } => done.max(now),
            _ => now,
        }
    }

    /// Starts rising after `after`, unless already on or rising.
    pub(super) fn raise(&mut self, after: f64, took: Duration) {
        if !self.coming() {
            *self = Stage::Rising {
                done: after + took.as_secs_f64(),
            };
        }
    }

    /// Starts falling now, unless already off or falling.
    pub(super) fn lower(&mut self, now: f64, took: Duration) {
        if matches!(self, Stage::On | Stage::Rising { .. }) {
            *self = Stage::Falling {
                done: now + took.as_secs_f64(),
            };
        }
    }
}
