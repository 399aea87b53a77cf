//! Section 4.12: servo streaming. After `StartServo`, each `PushServoJ` or
//! `PushServoP` is a move at constant speed that takes the servo time.
//!
//! Velocity control (V6 document 4.12.4-5, `SpeedJ`, `SpeedL`): the robot
//! accelerates to the velocities, keeps them for the run time (or until the
//! joint limits, or the end of the reachable space), then stops; not scaled
//! by the override, as the document says. A new one replaces the running
//! one from where the robot is; velocities of 0 stop it.

use hans_codec::request as rq;

use super::dispatch::{done, Outcome, PARAM, STATE};
use super::motion::Path;
use super::queue::Phase;
use super::values::{f, fs};
use super::{MoveKind, Planned, Robot, Speed};
use crate::kinematics::{self as k, Frame, Joints, PoseFrame, Vec3};

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

    /// Velocity control may start: in StandBy, or replacing the one
    /// running, which ends where the robot is now (`true`).
    fn take_over_velocity(&mut self, now: f64) -> Result<bool, i32> {
        let running = self
            .active
            .as_ref()
            .is_some_and(|s| (s.phase, s.plan.kind) == (Phase::Run, MoveKind::Velocity));
        if running && self.queue.is_empty() {
            self.rest = self.cmd_joints(now);
            self.active = None;
            return Ok(true);
        }
        self.need_standby(now).map(|()| false)
    }

    /// Starts a velocity move along `path` at `v`, `a` (path units),
    /// straight after the one it replaces.
    fn start_velocity(
        &mut self,
        path: Path,
        v: f64,
        a: f64,
        replaces: bool,
        now: f64,
    ) -> Outcome<'static> {
        if path.length() < 1e-9 {
            if replaces {
                self.idle_since = now;
            }
            return done();
        }
        let plan = Planned {
            path,
            speed: Speed::Trap { v, a },
            cmd_id: None,
            seek: None,
            kind: MoveKind::Velocity,
        };
        if replaces {
            self.start(plan, now, true);
            self.advance_motion(now);
            return done();
        }
        self.accept(plan, now)
    }

    pub(super) fn speed_j(&mut self, c: &rq::SpeedJ, now: f64) -> Outcome<'_> {
        let (vel, a, t) = (fs(c.velocities), f(c.acc), f(c.run_time));
        let v = vel.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        let accelerates = a > 0.0;
        if v > 0.0 && !accelerates {
            return Err(PARAM);
        }
        let replaces = self.take_over_velocity(now)?;
        let start = self.plan_start();
        // Each joint goes `v·t` (as far as its limits allow).
        let mut target = start;
        for i in 0..6 {
            target[i] = (start[i] + vel[i] * t).clamp(self.limits.min[i], self.limits.max[i]);
        }
        self.start_velocity(Path::joint_line(start, target), v, a, replaces, now)
    }

    pub(super) fn speed_l(&mut self, c: &rq::SpeedL, now: f64) -> Outcome<'_> {
        let (vel, t) = (fs(c.velocities), f(c.run_time));
        let linear = Vec3::new(vel[0], vel[1], vel[2]);
        let angular = Vec3::new(vel[3], vel[4], vel[5]);
        let (v, a) = if linear.norm() > 1e-9 {
            (linear.norm(), f(c.linear_acc))
        } else {
            (angular.norm(), f(c.angular_acc))
        };
        let accelerates = a > 0.0;
        if v > 0.0 && !accelerates {
            return Err(PARAM);
        }
        let replaces = self.take_over_velocity(now)?;
        // Along the base frame's axes, turning about the TCP point, in
        // steps of at most 10 mm or 10° so the turn goes the way asked.
        let tcp = self.tcp;
        let start = self.start_tcp_frame(&tcp);
        let (travel, turn) = (linear * t, angular * t);
        let steps = ((travel.norm() / 10.0).max(turn.norm() / 10.0).ceil() as usize).clamp(1, 500);
        let frames: Vec<Frame> = (1..=steps)
            .map(|i| {
                let k = i as f64 / steps as f64;
                let r = k::Rotation::from_scaled_axis((turn * k).map(f64::to_radians));
                k::frame_at(r * start.rotation, start.translation.vector + travel * k)
            })
            .collect();
        let path = Path::cartesian_reachable(
            self.plan_start(),
            &frames,
            &Frame::from_pose(&tcp),
            &self.limits,
        );
        self.start_velocity(path, v, a, replaces, now)
    }
}
