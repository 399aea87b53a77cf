//! Section 4.5: settings (override, payload, limits) and the robot's state
//! (`ReadRobotState`, `ReadCurFSM`, errors, the current way point).

use hans_codec::{request as rq, response as rs};

use super::dispatch::{done, values, Outcome, PARAM, STATE};
use super::values::{b, dec, f, fs, idx};
use super::Robot;
use crate::kinematics as k;

/// Largest payload of the simulated model (kg).
pub(super) const MAX_PAYLOAD: f64 = 5.0;

impl Robot {
    pub(super) fn set_override(&mut self, c: &rq::SetOverride) -> Outcome<'_> {
        if self.active.is_some() || !self.queue.is_empty() {
            return Err(STATE);
        }
        self.override_ratio = f(c.ratio);
        done()
    }

    pub(super) fn set_payload(&mut self, c: &rq::SetPayload) -> Outcome<'_> {
        if f(c.mass) > MAX_PAYLOAD {
            return Err(PARAM);
        }
        done()
    }

    pub(super) fn set_max_acs_range(&mut self, c: &rq::SetMaxAcsRange) -> Outcome<'_> {
        let (max, min) = (fs(c.max), fs(c.min));
        if (0..6).any(|i| min[i] >= max[i]) {
            return Err(PARAM);
        }
        self.limits = k::Limits { max, min };
        done()
    }

    pub(super) fn set_max_pcs_range(&mut self, c: &rq::SetMaxPcsRange) -> Outcome<'_> {
        let (max, min) = (fs(c.max), fs(c.min));
        if (0..3).any(|i| min[i] > max[i]) {
            return Err(PARAM);
        }
        done()
    }

    pub(super) fn read_linear_max_vel(&self) -> Outcome<'_> {
        values(rs::ReadLinearMaxVel {
            max_vel: dec(self.linear_max[0]),
            max_acc: dec(self.linear_max[1]),
            max_jerk: dec(self.linear_max[2]),
        })
    }

    pub(super) fn read_emergency_info(&self) -> Outcome<'_> {
        values(rs::ReadEmergencyInfo {
            estop_error: 0,
            estop: b(self.estop),
            safety_guard_error: 0,
            safety_guard: b(self.guard),
        })
    }

    pub(super) fn read_robot_state(&self, now: f64) -> Outcome<'_> {
        let fl = self.flags(now);
        values(rs::ReadRobotState {
            moving: b(fl.moving),
            enabled: b(fl.enabled),
            error: b(fl.error),
            error_code: fl.error_code,
            error_axis: fl.error_axis,
            brake_released: b(fl.brake_released),
            paused: b(fl.paused),
            emergency_stop: b(fl.emergency_stop),
            safety_guard: b(fl.safety_guard),
            powered: b(fl.powered),
            box_connected: b(fl.box_connected),
            blending_done: b(fl.blending_done),
            in_position: b(fl.in_position),
        })
    }

    pub(super) fn read_axis_error_code(&self) -> Outcome<'_> {
        let mut axes = [0; 6];
        let code = self.error.map_or(0, |e| {
            if let Some(a) = axes.get_mut(idx(e.axis)) {
                *a = e.code;
            }
            e.code
        });
        values(rs::ReadAxisErrorCode { code, axes })
    }
}
