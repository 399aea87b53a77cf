//! Jogging and hold-to-move (V6 document 4.10.11-4.10.18).
//!
//! * `ShortJogJ` / `ShortJogL`: one step of 2° (joint) or 2 mm / 2° (along
//!   or about an axis of the user frame, or of the tool frame after
//!   `SetToolMotion,1`) at up to 10 °/s or 10 mm/s: an ordinary move (FSM
//!   25), in StandBy only.
//! * `LongJogJ` / `LongJogL` with state 1: a move towards the joint limit
//!   (joint) or along the axis for as long as the arm can follow it
//!   (Cartesian, up to 2 m or one turn), at up to 10 °/s (joint), 30 mm/s
//!   (Cartesian, the document's figure) or 10 °/s (Cartesian rotations,
//!   which the document does not give). It runs as FSM 26 LongJogMoving
//!   while `LongMoveEvent` keeps coming: each one (and the start itself)
//!   keeps it going for [`Timing::long_move_keepalive`] (200 ms, the
//!   document's period); when that lapses the robot brakes from that instant
//!   (FSM 27, then 33). State 0 brakes at once.
//! * `MoveJTo` / `MoveLTo` / `MoveAlignToZ`: the same keep-alive, to a
//!   target (jog speeds: 10 °/s of the joint that moves most, 30 mm/s).
//!   `MoveAlignToZ` turns the tool about its TCP until its Z axis is on the
//!   nearest axis of the user frame, and replies whether it already is and
//!   the joints where it will be.
//! * `LongMoveEvent` while none of these runs: `Fail,20018` (a client sees
//!   that its jog has ended, at a limit or because an event came late).
//!
//! Speeds are multiplied by the override as for every move; each ramp takes
//! 0.2 s at the full jog speed (the document gives no accelerations).
//!
//! [`Timing::long_move_keepalive`]: super::Timing::long_move_keepalive

use hans_codec::{request as rq, response as rs};

use super::dispatch::{done, values, Outcome, PARAM, STATE};
use super::motion::Path;
use super::queue::Phase;
use super::values::{decs, fs, idx};
use super::{MoveKind, Planned, Robot, Speed};
use crate::kinematics::{self as k, Frame, Pose, PoseFrame, Vec3};

/// A speed and an acceleration (°/s or mm/s, and per s).
#[derive(Clone, Copy, Debug)]
struct Rate {
    v: f64,
    a: f64,
}

/// Short jogs: 2 units at up to 10 per second.
const SHORT_STEP: f64 = 2.0;
const SHORT: Rate = Rate { v: 10.0, a: 50.0 };
/// Long joint jogs, `MoveJTo`, and Cartesian rotations.
const LONG_JOINT: Rate = Rate { v: 10.0, a: 50.0 };
/// Long Cartesian jogs (translations), `MoveLTo`.
const LONG_LINEAR: Rate = Rate { v: 30.0, a: 150.0 };
/// How far a long Cartesian jog is planned: legs of 100 mm up to 2 m (the
/// arm reaches ~1.2 m), or of 10° up to one turn.
const LONG_LEG: [f64; 2] = [100.0, 10.0];
const LONG_LEGS: [usize; 2] = [20, 36];

/// Which hold-to-move motion runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Hold {
    /// `LongJogJ`: joint, direction.
    JogJ(i32, i32),
    /// `LongJogL`: axis, direction.
    JogL(i32, i32),
    /// `MoveJTo`, `MoveLTo`, `MoveAlignToZ`.
    To,
}

impl Robot {
    /// The hold-to-move motion running now (not braking), if any.
    fn holding(&self) -> Option<Hold> {
        let seg = self.active.as_ref()?;
        if (seg.phase, seg.plan.kind) == (Phase::Run, MoveKind::Hold) {
            self.hold
        } else {
            None
        }
    }

    /// Keeps the hold-to-move motion going for another keep-alive period.
    fn keep_alive(&mut self, now: f64) {
        self.hold_until = now + self.timing.long_move_keepalive.as_secs_f64();
    }

    /// The speed of `rate` after the override.
    fn scaled(&self, rate: Rate) -> Speed {
        let ov = self.override_ratio;
        Speed::Trap {
            v: (rate.v * ov).max(1e-3),
            a: (rate.a * ov).max(1e-3),
        }
    }

    /// Starts a hold-to-move motion along `path`.
    fn start_hold(&mut self, hold: Hold, path: Path, rate: Rate, now: f64) -> Outcome<'static> {
        let plan = Planned {
            path,
            speed: self.scaled(rate),
            cmd_id: None,
            seek: None,
            kind: MoveKind::Hold,
        };
        self.hold = Some(hold);
        self.keep_alive(now);
        self.accept(plan, now)
    }

    /// What `LongJogJ`/`LongJogL` with `state` do before a new jog starts:
    /// 0 brakes the running jog, 1 repeated for the jog that runs keeps it
    /// alive. `None`: a new jog is to start.
    fn jog_state(&mut self, hold: Hold, state: i32, now: f64) -> Option<Outcome<'static>> {
        if state == 0 {
            self.release(now);
        } else if self.holding() == Some(hold) {
            self.keep_alive(now);
        } else {
            return None;
        }
        Some(done())
    }

    /// Brakes the hold-to-move motion now, if one runs.
    fn release(&mut self, now: f64) {
        if self.holding().is_some() {
            if let Some(seg) = self.active.as_mut() {
                seg.brake(now, Phase::Stop);
            }
            self.advance_motion(now);
        }
    }

    /// `+1` or `-1` for `nDirection`.
    fn sign(direction: i32) -> f64 {
        if direction == 1 {
            1.0
        } else {
            -1.0
        }
    }

    /// A Cartesian path from where the robot is through `frames`, with
    /// the current tool; `Fail,20006` when the arm cannot follow it at all.
    fn jog_path(&self, frames: &[Frame], partial: bool) -> Result<Path, i32> {
        let tcp = Frame::from_pose(&self.tcp);
        let path = if partial {
            Path::cartesian_reachable(self.plan_start(), frames, &tcp, &self.limits)
        } else {
            Path::cartesian(self.plan_start(), frames, &tcp, &self.limits).map_err(|_| PARAM)?
        };
        if partial && path.length() < 1e-6 {
            return Err(PARAM);
        }
        Ok(path)
    }

    /// `delta` (one axis) applied to the current TCP frame, in the user or
    /// tool frame as `SetToolMotion` says.
    fn jog_target(&self, delta: &Pose) -> Frame {
        let start = self.start_tcp_frame(&self.tcp);
        self.shifted_frame(&start, delta, self.tool_motion)
    }

    pub(super) fn short_jog_j(&mut self, c: &rq::ShortJogJ, now: f64) -> Outcome<'_> {
        self.need_standby(now)?;
        let start = self.plan_start();
        let mut target = start;
        target[idx(c.axis)] += SHORT_STEP * Self::sign(c.direction);
        if !self.limits.contains(&target) {
            return Err(PARAM);
        }
        let plan = Planned {
            path: Path::joint_line(start, target),
            speed: self.scaled(SHORT),
            cmd_id: None,
            seek: None,
            kind: MoveKind::Move,
        };
        self.accept(plan, now)
    }

    pub(super) fn short_jog_l(&mut self, c: &rq::ShortJogL, now: f64) -> Outcome<'_> {
        self.need_standby(now)?;
        let mut delta = [0.0; 6];
        delta[idx(c.axis)] = SHORT_STEP * Self::sign(c.direction);
        let path = self.jog_path(&[self.jog_target(&delta)], false)?;
        let plan = Planned {
            path,
            speed: self.scaled(SHORT),
            cmd_id: None,
            seek: None,
            kind: MoveKind::Move,
        };
        self.accept(plan, now)
    }

    pub(super) fn long_jog_j(&mut self, c: &rq::LongJogJ, now: f64) -> Outcome<'_> {
        let hold = Hold::JogJ(c.axis, c.direction);
        if let Some(answered) = self.jog_state(hold, c.state, now) {
            return answered;
        }
        self.need_standby(now)?;
        let start = self.plan_start();
        let axis = idx(c.axis);
        let mut target = start;
        target[axis] = if c.direction == 1 {
            self.limits.max[axis]
        } else {
            self.limits.min[axis]
        };
        if (target[axis] - start[axis]).abs() < 1e-6 {
            return Err(PARAM);
        }
        self.start_hold(hold, Path::joint_line(start, target), LONG_JOINT, now)
    }

    pub(super) fn long_jog_l(&mut self, c: &rq::LongJogL, now: f64) -> Outcome<'_> {
        let hold = Hold::JogL(c.axis, c.direction);
        if let Some(answered) = self.jog_state(hold, c.state, now) {
            return answered;
        }
        self.need_standby(now)?;
        let axis = idx(c.axis);
        let rotation = usize::from(axis >= 3);
        let frames: Vec<Frame> = (1..=LONG_LEGS[rotation])
            .map(|i| {
                let mut delta = [0.0; 6];
                delta[axis] = LONG_LEG[rotation] * i as f64 * Self::sign(c.direction);
                self.jog_target(&delta)
            })
            .collect();
        let path = self.jog_path(&frames, true)?;
        let rate = if rotation == 1 {
            LONG_JOINT
        } else {
            LONG_LINEAR
        };
        self.start_hold(hold, path, rate, now)
    }

    pub(super) fn long_move_event(&mut self, now: f64) -> Outcome<'_> {
        if self.holding().is_none() {
            return Err(STATE);
        }
        self.keep_alive(now);
        done()
    }

    pub(super) fn move_j_to(&mut self, c: &rq::MoveJTo, now: f64) -> Outcome<'_> {
        self.need_standby(now)?;
        let target = fs(c.joints);
        if !self.limits.contains(&target) {
            return Err(PARAM);
        }
        let path = Path::joint_line(self.plan_start(), target);
        self.start_hold(Hold::To, path, LONG_JOINT, now)
    }

    pub(super) fn move_l_to(&mut self, c: &rq::MoveLTo, now: f64) -> Outcome<'_> {
        let tcp = self.tcp_named(c.tcp_name)?;
        let ucs = self.ucs_named(c.ucs_name)?;
        self.need_standby(now)?;
        let target = Frame::from_pose(&ucs) * Frame::from_pose(&fs(c.pose));
        let path = Path::cartesian(
            self.plan_start(),
            &[target],
            &Frame::from_pose(&tcp),
            &self.limits,
        )
        .map_err(|_| PARAM)?;
        self.start_hold(Hold::To, path, LONG_LINEAR, now)
    }

    pub(super) fn move_align_to_z(&mut self, c: &rq::MoveAlignToZ, now: f64) -> Outcome<'_> {
        let tcp = self.tcp_named(c.tcp_name)?;
        let ucs = Frame::from_pose(&self.ucs_named(c.ucs_name)?);
        self.need_standby(now)?;
        let start = self.start_tcp_frame(&tcp);
        let z = start.rotation * Vec3::z();
        // The axis of the user frame nearest to the tool's Z axis.
        let goal = [Vec3::x(), Vec3::y(), Vec3::z()]
            .iter()
            .flat_map(|a| [ucs.rotation * a, -(ucs.rotation * a)])
            .max_by(|a, b| a.dot(&z).total_cmp(&b.dot(&z)))
            .unwrap_or(z);
        let turn = k::Rotation::rotation_between(&z, &goal).unwrap_or_else(k::Rotation::identity);
        let target = k::frame_at(turn * start.rotation, start.translation.vector);
        let flange = target * Frame::from_pose(&tcp).inverse();
        let joints = k::inverse(&flange, &self.plan_start(), &self.limits).ok_or(PARAM)?;
        if k::rotation_angle(&turn) < 1e-3 {
            return values(rs::MoveAlignToZ {
                aligned: 1,
                joints: decs(self.plan_start()),
            });
        }
        let path = Path::cartesian(
            self.plan_start(),
            &[target],
            &Frame::from_pose(&tcp),
            &self.limits,
        )
        .map_err(|_| PARAM)?;
        self.start_hold(Hold::To, path, LONG_JOINT, now)?;
        values(rs::MoveAlignToZ {
            aligned: 0,
            joints: decs(joints),
        })
    }
}
