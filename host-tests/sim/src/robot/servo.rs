//! Section 4.12: servo streaming. After `StartServo`, each `PushServoJ` or
//! `PushServoP` is a move at constant speed that takes the servo time.

use hans_codec::request as rq;

use super::dispatch::{done, Outcome, PARAM, STATE};
use super::motion::Path;
use super::values::{f, fs};
use super::{MoveKind, Planned, Robot, Speed};
use crate::kinematics::{self as k, Joints};

impl Robot {
    pub(super) fn start_servo(&mut self, c: &rq::StartServo, now: f64) -> Outcome<'_> {
        self.need_motion(now)?;
        self.servo = Some(f(c.servo_time));
        done()
    }

    /// A servo step to `target`, taking the servo time.
    fn servo_step(&mut self, target: Joints, now: f64) -> Outcome<'static> {
        let Some(dur) = self.servo else {
            return Err(STATE);
        };
        let plan = Planned {
            path: Path::joint_line(self.plan_start(), target),
            speed: Speed::Timed(dur),
            cmd_id: None,
            seek: None,
            kind: MoveKind::Move,
        };
        self.accept(plan, now)
    }

    pub(super) fn push_servo_j(&mut self, c: &rq::PushServoJ, now: f64) -> Outcome<'_> {
        self.servo.ok_or(STATE)?;
        self.need_motion(now)?;
        let target = fs(c.joints);
        if !self.limits.contains(&target) {
            return Err(PARAM);
        }
        self.servo_step(target, now)
    }

    pub(super) fn push_servo_p(&mut self, c: &rq::PushServoP, now: f64) -> Outcome<'_> {
        self.servo.ok_or(STATE)?;
        self.need_motion(now)?;
        let flange = k::flange_of(&fs(c.pose), &fs(c.tcp), &fs(c.ucs));
        let target = k::inverse(&flange, &self.plan_start(), &self.limits).ok_or(PARAM)?;
        self.servo_step(target, now)
    }
}
