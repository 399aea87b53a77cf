//! The motion the robot executes: the running segment and the moves
//! queued behind it ([`MAX_QUEUE`]). Stopping, pausing and continuing
//! replace a segment's profile, never its path (see `motion`).

use super::motion::{Path, Profile};
use super::{reached, Robot, MAX_QUEUE};
use crate::kinematics::Joints;

/// How a planned move runs in time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Speed {
    /// Trapezoid with this speed and acceleration (path units per s, s²).
    Trap { v: f64, a: f64 },
    /// Constant speed, taking exactly this long (s).
    Timed(f64),
}

/// What kind of move: for the progress commands, the FSM state, and the
/// moves that only run while the client keeps asking.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum MoveKind {
    /// A way point or other single move.
    Move,
    /// A `MovePathL` run through this many points.
    PathL(usize),
    /// Standing still (path computation).
    Dwell,
    /// A hold-to-move motion (long jog, `MoveJTo`, `MoveLTo`,
    /// `MoveAlignToZ`): FSM 26 LongJogMoving, and it brakes when
    /// `LongMoveEvent` stops coming (`Robot::hold_until`).
    Hold,
    /// Velocity control (`SpeedJ`, `SpeedL`): a new one replaces it.
    Velocity,
    /// A `MovePathJOL` run (its points: `Robot::online_path`).
    Online,
}

/// A move that has been accepted.
#[derive(Clone, Debug)]
pub(crate) struct Planned {
    pub path: Path,
    pub speed: Speed,
    pub cmd_id: Option<String>,
    /// Stop when box DI `.0` reads `.1`.
    pub seek: Option<(usize, bool)>,
    pub kind: MoveKind,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Phase {
    Run,
    Stop,
    Pause,
}

#[derive(Clone, Debug)]
pub(super) struct Segment {
    pub plan: Planned,
    pub profile: Profile,
    pub phase: Phase,
    pub started: f64,
}

impl Segment {
    pub(super) fn s_at(&self, t: f64) -> (f64, f64) {
        self.profile.sample(t)
    }

    fn decel(&self) -> f64 {
        match self.plan.speed {
            Speed::Trap { a, .. } => a,
            Speed::Timed(_) => 1000.0,
        }
    }

    /// Decelerates from where it is at `t` (stop, pause, an I/O seek) and
    /// enters `phase`.
    pub(super) fn brake(&mut self, t: f64, phase: Phase) {
        let (s, v) = self.s_at(t);
        self.profile = Profile::Brake {
            t0: t,
            s0: s,
            v0: v,
            a: self.decel(),
            s_max: self.plan.path.length(),
        };
        self.phase = phase;
    }
}

impl Robot {
    pub(super) fn advance_motion(&mut self, now: f64) {
        let lapse = self.hold_until;
        loop {
            if let Some(seg) = self.active.as_mut() {
                let Some(end) = seg.profile.end() else {
                    break;
                };
                // A hold-to-move motion whose keep-alive lapsed brakes from
                // the instant it lapsed.
                if (seg.phase, seg.plan.kind) == (Phase::Run, MoveKind::Hold)
                    && reached(now, lapse)
                    && lapse < end
                {
                    seg.brake(seg.started.max(lapse), Phase::Stop);
                    continue;
                }
                // A seek input that matches ends the way point early.
                if let (Phase::Run, Some((bit, level))) = (seg.phase, seg.plan.seek) {
                    if self.io.di.get(bit).copied() == Some(level) {
                        let t = seg.started.max(now.min(end));
                        seg.brake(t, Phase::Stop);
                        self.queue.clear();
                        continue;
                    }
                }
                if !reached(now, end) {
                    break;
                }
                let q = seg.plan.path.at(seg.profile.final_s());
                match seg.phase {
                    Phase::Run => {
                        if let MoveKind::PathL(n) = seg.plan.kind {
                            self.last_path_l = Some((1.0, i32::try_from(n).unwrap_or(i32::MAX)));
                        }
                        // `cdsSetIO`: the motion has reached its target.
                        if let Some(o) = self.pending_outputs.take() {
                            self.apply_outputs(&o);
                        }
                        self.rest = q;
                        self.active = None;
                        match self.queue.pop_front() {
                            Some(next) => self.start(next, end, true),
                            None => self.idle_since = end,
                        }
                    }
                    Phase::Stop => {
                        self.rest = q;
                        self.active = None;
                        self.queue.clear();
                        self.idle_since = end;
                    }
                    Phase::Pause => {
                        seg.profile = Profile::Hold {
                            s: seg.profile.final_s(),
                        };
                        self.idle_since = end;
                    }
                }
            } else {
                match self.queue.pop_front() {
                    Some(next) => self.start(next, now, false),
                    None => break,
                }
            }
        }
    }

    /// Starts `plan` at `t`; `chained` when it follows a move that ended at
    /// `t` (the robot never came to rest in between).
    pub(super) fn start(&mut self, plan: Planned, t: f64, chained: bool) {
        if !chained {
            self.busy_since = t;
        }
        let len = plan.path.length();
        let profile = match plan.speed {
            Speed::Trap { v, a } => Profile::Trap {
                t0: t,
                s0: 0.0,
                s1: len,
                v,
                a,
            },
            Speed::Timed(dur) => Profile::Linear {
                t0: t,
                s0: 0.0,
                s1: len,
                dur,
            },
        };
        if let Some(id) = &plan.cmd_id {
            self.waypoint_id = id.clone();
        }
        self.active = Some(Segment {
            plan,
            profile,
            phase: Phase::Run,
            started: t,
        });
    }

    /// Accepts a planned move: runs now or after the moves before it.
    /// `false` when the queue is full.
    pub fn push_move(&mut self, plan: Planned, now: f64) -> bool {
        if self.active.is_none() && self.queue.is_empty() {
            self.start(plan, now, false);
            self.advance_motion(now);
            return true;
        }
        if self.queue.len() >= MAX_QUEUE {
            return false;
        }
        self.queue.push_back(plan);
        true
    }

    /// Where the next accepted move starts: the end of the last one.
    pub fn plan_start(&self) -> Joints {
        if let Some(p) = self.queue.back() {
            return p.path.end();
        }
        match &self.active {
            Some(seg) if seg.phase == Phase::Run => seg.plan.path.end(),
            Some(seg) => seg.plan.path.at(seg.profile.final_s()),
            None => self.rest,
        }
    }

    /// Command joints at `now`.
    pub fn cmd_joints(&self, now: f64) -> Joints {
        match &self.active {
            Some(seg) => seg.plan.path.at(seg.s_at(now).0),
            None => self.rest,
        }
    }

    /// Actual joints at `now` (the command position `actual_lag` ago).
    pub fn act_joints(&self, now: f64) -> Joints {
        let t = now - Self::secs(self.timing.actual_lag);
        match &self.active {
            Some(seg) if t >= seg.started => seg.plan.path.at(seg.s_at(t).0),
            Some(seg) => seg.plan.path.start(),
            None => self.rest,
        }
    }

    pub(super) fn motion_running(&self) -> bool {
        self.active
            .as_ref()
            .is_some_and(|s| !matches!(s.profile, Profile::Hold { .. }))
    }

    /// Stops every motion at once where it is (emergency stop, disable,
    /// errors).
    pub(super) fn abort_motion(&mut self, now: f64) {
        if self.active.is_some() {
            self.rest = self.cmd_joints(now);
            self.active = None;
            self.idle_since = now;
        }
        self.queue.clear();
        self.servo = None;
        self.pending_outputs = None;
        self.stop_load_identify(now);
        if self.ft_on.take().is_some() {
            self.idle_since = self.idle_since.max(now);
        }
    }

    /// `GrpStop`: decelerate to a stop, drop queued moves.
    pub fn stop(&mut self, now: f64) {
        self.queue.clear();
        self.servo = None;
        self.pending_outputs = None;
        self.stop_load_identify(now);
        if self.ft_on.take().is_some() && self.active.is_none() {
            self.idle_since = now;
        }
        let Some(seg) = self.active.as_mut() else {
            return;
        };
        match seg.profile {
            Profile::Hold { .. } => {
                self.rest = seg.plan.path.at(seg.profile.final_s());
                self.active = None;
            }
            _ if seg.phase == Phase::Stop => {}
            _ => {
                seg.brake(now, Phase::Stop);
            }
        }
        self.advance_motion(now);
    }

    /// `GrpInterrupt`: decelerate and hold; `false` when nothing runs.
    pub fn pause(&mut self, now: f64) -> bool {
        let Some(seg) = self.active.as_mut() else {
            return false;
        };
        if seg.phase != Phase::Run {
            return false;
        }
        seg.brake(now, Phase::Pause);
        self.advance_motion(now);
        true
    }

    /// `GrpContinue`: `Err(40014)` while still braking, `Err(20018)` when
    /// not paused.
    pub fn resume(&mut self, now: f64) -> Result<(), i32> {
        let Some(seg) = self.active.as_mut() else {
            return Err(20018);
        };
        if seg.phase != Phase::Pause {
            return Err(20018);
        }
        let Profile::Hold { s } = seg.profile else {
            return Err(40014);
        };
        let len = seg.plan.path.length();
        seg.profile = match seg.plan.speed {
            Speed::Trap { v, a } => Profile::Trap {
                t0: now,
                s0: s,
                s1: len,
                v,
                a,
            },
            Speed::Timed(dur) => {
                let left = if len > 0.0 { (len - s) / len } else { 0.0 };
                Profile::Linear {
                    t0: now,
                    s0: s,
                    s1: len,
                    dur: dur * left,
                }
            }
        };
        seg.phase = Phase::Run;
        self.busy_since = now;
        self.advance_motion(now);
        Ok(())
    }
}
