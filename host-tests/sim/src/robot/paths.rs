//! Section 4.11: stored paths ([`Track`]). Joint paths
//! (`StartPushMovePath`, `PushMovePathJ`, `EndPushMovePath`, `MovePath`)
//! compute for [`Timing::path_compute`] after their last point (state 2 →
//! 3, or 5 when a point is outside the limits); Cartesian paths
//! (`InitMovePathL`, `PushMovePathL`/`PushMovePaths`, `MovePathL`) compute
//! for [`Timing::path_l_compute`] when they are run, counted as motion. At
//! most [`MAX_PATHS`] paths of [`MAX_PATH_POINTS`] points (`Fail,20006`).
//!
//! [`Timing::path_compute`]: super::Timing::path_compute
//! [`Timing::path_l_compute`]: super::Timing::path_l_compute

use hans_codec::{request as rq, response as rs, Decimal};

use super::dispatch::{done, values, Outcome, PARAM, STATE};
use super::motion::Path;
use super::values::{f, fs};
use super::{reached, MoveKind, Planned, Robot, Speed, MAX_PATHS, MAX_PATH_POINTS, MAX_QUEUE};
use crate::kinematics::{self as k, Frame, Joints, Pose, PoseFrame};

/// A path that is not ready to run.
pub(super) const PATH_NOT_READY: i32 = 20042;

/// One computation of a path (V6 document 4.11: a path is computed for
/// `MovePathJ` and for `MovePathL`, each with its own state).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Computation {
    /// 0 not taught, 1 teaching, 2 computing, 3 ready, 4 teaching ended,
    /// 5 error.
    pub state: i32,
    /// The error when `state` is 5.
    pub error: i32,
    /// While computing: when it ends, and the state and error it ends in.
    pub until: f64,
    pub outcome: (i32, i32),
}

impl Computation {
    /// In `state`, with no computation pending.
    pub fn at(state: i32) -> Computation {
        Computation {
            state,
            error: 0,
            until: 0.0,
            outcome: (state, 0),
        }
    }

    /// Computing from `now` for `took` s, ending in `outcome` (done at once
    /// when `took` is 0).
    pub fn compute(now: f64, took: f64, outcome: (i32, i32)) -> Computation {
        let mut c = Computation {
            state: 2,
            error: 0,
            until: now + took,
            outcome,
        };
        c.settle(now);
        c
    }

    /// Brings the computation to `now`.
    pub fn settle(&mut self, now: f64) {
        if self.state == 2 && reached(now, self.until) {
            (self.state, self.error) = self.outcome;
        }
    }
}

/// A stored path of section 4.11 (both documents' commands share them, as
/// on the controller: `InitPath` replaces `StartPushMovePath` and
/// `InitMovePathL`).
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Track {
    /// Joint points (`false`) or Cartesian points (`true`).
    pub cartesian: bool,
    pub points: Vec<[f64; 6]>,
    /// The joint computation (`MovePath`, `MovePathJ`); for a Cartesian
    /// path of HR-TCP (`InitMovePathL`) its teaching state.
    pub j: Computation,
    /// The Cartesian computation of a path made by `InitPath`
    /// (`MovePathL` runs it when ready); `None` for HR-TCP's paths.
    pub l: Option<Computation>,
    /// Joint targets of the joint computation (a Cartesian path's points
    /// solved by inverse kinematics).
    pub joint_targets: Vec<[f64; 6]>,
    pub speed_ratio: f64,
    pub radius: f64,
    pub vel: f64,
    pub acc: f64,
    pub jerk: f64,
    pub tcp: Pose,
    pub ucs: Pose,
    /// `SetPathRefJoints`: where inverse kinematics starts.
    pub ref_joints: Option<Joints>,
}

impl Track {
    /// Brings its computations to `now`.
    pub fn settle(&mut self, now: f64) {
        self.j.settle(now);
        if let Some(l) = &mut self.l {
            l.settle(now);
        }
    }
}

impl Robot {
    fn track_mut(&mut self, name: &str, cartesian: bool) -> Result<&mut Track, i32> {
        match self.tracks.get_mut(name) {
            Some(t) if t.cartesian == cartesian => Ok(t),
            _ => Err(PARAM),
        }
    }

    /// Stores `t` as path `name` (replacing one of that name).
    pub(super) fn new_track(&mut self, name: &str, t: Track) -> Result<(), i32> {
        if !self.tracks.contains_key(name) && self.tracks.len() >= MAX_PATHS {
            return Err(PARAM);
        }
        self.tracks.insert(name.to_string(), t);
        Ok(())
    }

    /// A path without points, in the current frames.
    pub(super) fn blank_track(&self, cartesian: bool) -> Track {
        Track {
            cartesian,
            points: Vec::new(),
            j: Computation::at(0),
            l: None,
            joint_targets: Vec::new(),
            speed_ratio: 1.0,
            radius: 0.0,
            vel: 100.0,
            acc: 2500.0,
            jerk: 10_000_000.0,
            tcp: self.tcp,
            ucs: self.ucs,
            ref_joints: None,
        }
    }

    fn push_points(&mut self, name: &str, cartesian: bool, pts: &[[f64; 6]]) -> Outcome<'static> {
        if !self.tracks.contains_key(name) {
            let t = self.blank_track(cartesian);
            self.new_track(name, t)?;
        }
        let t = self.track_mut(name, cartesian)?;
        if !matches!(t.j.state, 0 | 1) || t.points.len() + pts.len() > MAX_PATH_POINTS {
            return Err(PARAM);
        }
        t.points.extend_from_slice(pts);
        t.j = Computation::at(1);
        done()
    }

    pub(super) fn start_push_move_path(&mut self, c: &rq::StartPushMovePath) -> Outcome<'_> {
        let mut t = self.blank_track(false);
        t.speed_ratio = f(c.speed_ratio);
        self.new_track(c.track, t)?;
        done()
    }

    pub(super) fn push_move_path_j(&mut self, c: &rq::PushMovePathJ) -> Outcome<'_> {
        if !self.tracks.contains_key(c.track) {
            return Err(PARAM);
        }
        self.push_points(c.track, false, &[fs(c.joints)])
    }

    pub(super) fn end_push_move_path(&mut self, c: &rq::EndPushMovePath, now: f64) -> Outcome<'_> {
        let limits = self.limits;
        let took = self.timing.path_compute.as_secs_f64();
        let tr = self.tracks.get_mut(c.track).ok_or(PARAM)?;
        tr.j = if tr.cartesian {
            Computation::at(if tr.points.is_empty() { 5 } else { 4 })
        } else if tr.points.len() < 2 || !tr.points.iter().all(|q| limits.contains(q)) {
            Computation::at(5)
        } else {
            Computation::compute(now, took, (3, 0))
        };
        done()
    }

    pub(super) fn move_path(&mut self, c: &rq::MovePath, now: f64) -> Outcome<'_> {
        let tr = match self.tracks.get(c.track) {
            Some(t) if !t.cartesian && t.j.state == 3 => t.clone(),
            _ => return Err(PATH_NOT_READY),
        };
        self.need_motion(now)?;
        let mut pts = vec![self.plan_start()];
        pts.extend_from_slice(&tr.points);
        let path = Path::joint_polyline(&pts);
        let ratio = tr.speed_ratio.max(0.01) * self.override_ratio;
        let vmax = self
            .joint_max_vel
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
        let amax = self
            .joint_max_acc
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
        let plan = Planned {
            path,
            speed: Speed::Trap {
                v: (vmax * ratio).max(1e-3),
                a: (amax * ratio).max(1e-3),
            },
            cmd_id: None,
            seek: None,
            kind: MoveKind::Move,
        };
        self.accept(plan, now)
    }

    pub(super) fn read_move_path_state(&self, c: &rq::ReadMovePathState) -> Outcome<'_> {
        values(rs::ReadMovePathState {
            state: self.tracks.get(c.track).map_or(0, |t| t.j.state),
        })
    }

    pub(super) fn update_move_path_name(&mut self, c: &rq::UpdateMovePathName) -> Outcome<'_> {
        let tr = self.tracks.remove(c.track).ok_or(PARAM)?;
        self.tracks.insert(c.new_name.to_string(), tr);
        done()
    }

    pub(super) fn del_move_path(&mut self, c: &rq::DelMovePath) -> Outcome<'_> {
        self.tracks.remove(c.track).ok_or(PARAM)?;
        done()
    }

    pub(super) fn read_soft_motion_progress(&self, now: f64) -> Outcome<'_> {
        let (p, i) = match &self.active {
            Some(seg) => match seg.plan.kind {
                MoveKind::PathL(n) => {
                    let len = seg.plan.path.length();
                    let p = if len > 0.0 {
                        (seg.s_at(now).0 / len).clamp(0.0, 1.0)
                    } else {
                        0.0
                    };
                    (p, (p * n as f64).floor() as i32)
                }
                MoveKind::Dwell => (0.0, 0),
                MoveKind::Move | MoveKind::Hold | MoveKind::Velocity | MoveKind::Online => {
                    self.last_path_l.unwrap_or((0.0, 0))
                }
            },
            None => self.last_path_l.unwrap_or((0.0, 0)),
        };
        values(rs::ReadSoftMotionProgress {
            progress: Decimal::from_f64(p, 6).unwrap_or(Decimal::ZERO),
            index: i,
        })
    }

    pub(super) fn init_move_path_l(&mut self, c: &rq::InitMovePathL) -> Outcome<'_> {
        let tcp = self.tcp_named(c.tcp_name)?;
        let ucs = self.ucs_named(c.ucs_name)?;
        let (v, a) = (f(c.velocity), f(c.acc));
        if !(v > 0.0 && a > 0.0) {
            return Err(PARAM);
        }
        let mut t = self.blank_track(true);
        t.vel = v;
        t.acc = a;
        t.tcp = tcp;
        t.ucs = ucs;
        self.new_track(c.track, t)?;
        done()
    }

    pub(super) fn push_move_path_l(&mut self, c: &rq::PushMovePathL) -> Outcome<'_> {
        if !self.tracks.contains_key(c.track) {
            return Err(PARAM);
        }
        self.push_points(c.track, true, &[fs(c.pose)])
    }

    pub(super) fn push_move_paths(&mut self, c: &rq::PushMovePaths) -> Outcome<'_> {
        let pts: Vec<[f64; 6]> = c.points.iter().map(fs).collect();
        if pts.is_empty() {
            return Err(PARAM);
        }
        self.push_points(c.track, c.move_type == 1, &pts)
    }

    /// The TCP frames (base) a Cartesian run of `tr` goes through: its
    /// points in its user frame, or the poses of its joint points.
    pub(super) fn path_frames(tr: &Track) -> Vec<Frame> {
        if tr.cartesian {
            let u = Frame::from_pose(&tr.ucs);
            tr.points.iter().map(|p| u * Frame::from_pose(p)).collect()
        } else {
            let tool = Frame::from_pose(&tr.tcp);
            tr.points.iter().map(|q| k::forward(q) * tool).collect()
        }
    }

    /// `MovePathL`: an HR-TCP path (`InitMovePathL`) computes for
    /// [`Timing::path_l_compute`](super::Timing::path_l_compute) first,
    /// counted as motion; a path of `InitPath` runs at once when its
    /// Cartesian computation is ready (`stateL` 3).
    pub(super) fn move_path_l(&mut self, c: &rq::MovePathL, now: f64) -> Outcome<'_> {
        let tr = match self.tracks.get(c.track) {
            Some(t) if t.l.is_some_and(|l| l.state == 3) => t.clone(),
            Some(t)
                if t.l.is_none()
                    && t.cartesian
                    && matches!(t.j.state, 1 | 4)
                    && !t.points.is_empty() =>
            {
                t.clone()
            }
            _ => return Err(PATH_NOT_READY),
        };
        self.need_motion(now)?;
        let frames = Self::path_frames(&tr);
        let mut plan = self.linear_move(&frames, &tr.tcp, tr.vel, tr.acc, None, None)?;
        plan.kind = MoveKind::PathL(tr.points.len());
        if tr.l.is_some() {
            self.last_path_l = Some((0.0, 0));
            return self.accept(plan, now);
        }
        let dwell = Planned {
            path: Path::dwell(self.plan_start()),
            speed: Speed::Timed(self.timing.path_l_compute.as_secs_f64()),
            cmd_id: None,
            seek: None,
            kind: MoveKind::Dwell,
        };
        if self.queue.len() + 2 > MAX_QUEUE {
            return Err(STATE);
        }
        self.last_path_l = Some((0.0, 0));
        self.push_move(dwell, now);
        self.accept(plan, now)
    }
}
