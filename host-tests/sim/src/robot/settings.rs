//! Section 4.5: settings (override, payload, limits) and the robot's state
//! (`ReadRobotState`, `ReadCurFSM`, errors, the current way point).

use hans_codec::{request as rq, response as rs};

use super::dispatch::{done, values, Outcome, FORMAT, PARAM, STATE};
use super::values::{b, dec, decs, f, fs, idx};
use super::{reached, Robot};
use crate::kinematics as k;

/// `ReadPointByName` of a point that does not exist (the document's
/// example code).
const NO_POINT: i32 = 20016;
/// Encoder counts per revolution, motor side and joint side (a 19-bit
/// absolute encoder behind a 101:1 gear).
const MOTOR_COUNTS: f64 = 524_288.0 * 101.0;
const JOINT_COUNTS: f64 = 524_288.0;

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

    /// `SetPayload`; the V6 document's `bUpdateDB` (3 = the mass only) is
    /// a field too many for HR-TCP's controllers (`Fail,20007`).
    pub(super) fn set_payload(&mut self, c: &rq::SetPayload) -> Outcome<'_> {
        if c.update_db.is_some() && !self.v6_replies() {
            return Err(FORMAT);
        }
        let mass = f(c.mass);
        if mass > MAX_PAYLOAD {
            return Err(PARAM);
        }
        let center = if c.update_db == Some(3) {
            self.payload.1
        } else {
            fs(c.center)
        };
        self.payload = (mass, center);
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

    // ------------------------------------------------ V6 document 4.5

    pub(super) fn read_payload(&self) -> Outcome<'_> {
        let (mass, center) = self.payload;
        values(rs::ReadPayload {
            mass: dec(mass),
            center: decs(center),
        })
    }

    pub(super) fn read_point_by_name(&self, c: &rq::ReadPointByName) -> Outcome<'_> {
        let (joints, tcp, ucs) = self.points.get(c.name).ok_or(NO_POINT)?;
        values(rs::ReadPointByName {
            joints: decs(*joints),
            pose: decs(k::forward_pose(joints, tcp, ucs)),
            tcp: decs(*tcp),
            ucs: decs(*ucs),
        })
    }

    pub(super) fn read_motor_and_joint_encode(&self, now: f64) -> Outcome<'_> {
        let q = self.act_joints(now);
        let counts = |per_turn: f64| q.map(|a| (a / 360.0 * per_turn).round() as i32);
        values(rs::ReadMotorAndJointEncode {
            motor: counts(MOTOR_COUNTS),
            joint: counts(JOINT_COUNTS),
        })
    }

    /// Whether payload identification runs at `now`.
    pub(super) fn load_identify_running(&self, now: f64) -> bool {
        self.load_identify.is_some_and(|id| {
            !id.stopped && !reached(now, id.start + self.timing.load_identify.as_secs_f64())
        })
    }

    /// Payload identification ends early (a stop, an error, power off).
    pub(super) fn stop_load_identify(&mut self, now: f64) {
        if self.load_identify_running(now) {
            if let Some(id) = &mut self.load_identify {
                id.stopped = true;
            }
        }
    }

    /// `LoadIdentify`: the arm runs its identification trajectories (FSM
    /// 41) for [`Timing::load_identify`](super::Timing::load_identify), in
    /// StandBy only.
    pub(super) fn start_load_identify(&mut self, now: f64) -> Outcome<'_> {
        self.need_standby(now)?;
        self.load_identify = Some(Identification {
            start: now,
            stopped: false,
        });
        done()
    }

    /// `GetLoadIdentifyResult`: 7 not started, 4 running (with its
    /// progress), 5 stopped early, 0 done: what it finds is the payload set
    /// with `SetPayload`.
    pub(super) fn get_load_identify_result(&self, now: f64) -> Outcome<'_> {
        let total = self.timing.load_identify.as_secs_f64().max(1e-9);
        let (status, progress) = match self.load_identify {
            None => (7, 0),
            Some(id) if id.stopped => (5, 0),
            Some(id) if self.load_identify_running(now) => (
                4,
                ((now - id.start) / total * 100.0).clamp(0.0, 99.0) as i32,
            ),
            Some(_) => (0, 100),
        };
        let (mass, center) = if status == 0 {
            self.payload
        } else {
            (0.0, [0.0; 3])
        };
        values(rs::GetLoadIdentifyResult {
            status,
            progress,
            mass: dec(mass),
            center: decs(center),
        })
    }
}

/// A payload identification (`LoadIdentify`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Identification {
    /// When it started.
    pub start: f64,
    /// Ended early.
    pub stopped: bool,
}
