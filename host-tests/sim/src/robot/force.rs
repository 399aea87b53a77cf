//! Section 4.9: force control. Switching it on counts as motion (FSM 25,
//! moving flag); `ReadFTControlState` searches (1) for
//! [`Timing::force_search`](super::Timing::force_search), then reports
//! search done (2). Force-control free drive is FSM 44 → 46 → 45. The
//! tuning parameters are accepted and not modelled; commands that need
//! force control on get `Fail,40020` without it.

use hans_codec::{request as rq, response as rs};

use super::dispatch::{done, values, Outcome, PARAM};
use super::values::{dec, decs, f, fs};
use super::Robot;

/// A force-control command outside force control.
const NOT_IN_FORCE_CONTROL: i32 = 40020;

impl Robot {
    pub(super) fn set_force_control_state(
        &mut self,
        c: &rq::SetForceControlState,
        now: f64,
    ) -> Outcome<'_> {
        if c.state == 1 {
            if self.ft_on.is_none() {
                self.need_motion(now)?;
                self.ft_on = Some(now);
            }
        } else if self.ft_on.take().is_some() {
            self.ft_free.lower(now, self.timing.free_drive);
            if self.active.is_none() {
                self.idle_since = self.idle_since.max(now);
            }
        }
        done()
    }

    pub(super) fn read_ft_control_state(&self, now: f64) -> Outcome<'_> {
        values(rs::ReadFTControlState {
            state: self.ft_state(now),
        })
    }

    /// `GrpFCInterrupt`, `GrpFCContinue`: only in force control.
    pub(super) fn need_force_control(&self) -> Outcome<'_> {
        if self.ft_on.is_none() {
            return Err(NOT_IN_FORCE_CONTROL);
        }
        done()
    }

    pub(super) fn set_force_zero(&mut self) -> Outcome<'_> {
        self.ft_data = [0.0; 6];
        done()
    }

    pub(super) fn hr_set_force_data_limit(&mut self, c: &rq::HRSetForceDataLimit) -> Outcome<'_> {
        let (max, min) = (fs(c.max), fs(c.min));
        if (0..6).any(|i| min[i] > max[i]) {
            return Err(PARAM);
        }
        done()
    }

    /// Force-control free drive on (`true`) or off.
    pub(super) fn force_free_drive(&mut self, on: bool, now: f64) -> Outcome<'_> {
        if on {
            if !self.ft_free.coming() {
                self.need_standby(now)?;
                self.ft_free.raise(now, self.timing.free_drive);
            }
        } else {
            self.ft_free.lower(now, self.timing.free_drive);
        }
        done()
    }

    pub(super) fn read_ft_cab_data(&self) -> Outcome<'_> {
        values(rs::ReadFTCabData {
            data: decs(self.ft_data),
        })
    }

    // ------------------------------------------------ V6 document 4.9

    pub(super) fn read_ft_free_factor(&self) -> Outcome<'_> {
        let (linear, angular) = self.stored.ft_free_factor;
        values(rs::ReadFTFreeFactor {
            linear: dec(linear),
            angular: dec(angular),
        })
    }

    /// `SetTangentForceBounds`: the smallest force above the largest is
    /// refused.
    pub(super) fn set_tangent_force_bounds(
        &mut self,
        c: &rq::SetTangentForceBounds,
    ) -> Outcome<'_> {
        if f(c.min) > f(c.max) {
            return Err(PARAM);
        }
        done()
    }

    /// `SetFTCalibration`: 8 to 16 samples (the document's bounds).
    pub(super) fn set_ft_calibration(&mut self, c: &rq::SetFTCalibration) -> Outcome<'_> {
        if !(8..=16).contains(&c.samples.len()) {
            return Err(PARAM);
        }
        done()
    }

    /// `ReadForceData`: the raw sensor data, as the calibrated data here.
    pub(super) fn read_force_data(&self) -> Outcome<'_> {
        values(rs::ReadForceData {
            data: decs(self.ft_data),
        })
    }
}
