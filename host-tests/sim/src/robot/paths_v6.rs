//! The path commands of the V6 document (4.11.1-4.11.11, 4.11.24, from
//! `HR6.3.3`): `InitPath`, `PushPathPoints`, `EndPushPathPoints`,
//! `DelPath`, `ReadPath`, `UpdatePathName`, `ReadPathState`, `MovePathJ`
//! (and `MovePathL` in `paths`), `MovePathJOL`, `GetMovePathJOLIndex`,
//! `SetPathRefJoints`.
//!
//! A path made by `InitPath` is teaching (both states 1). After
//! `EndPushPathPoints` it is computed twice, as the document says: for
//! `MovePathJ` in [`Timing::path_compute`] (`stateJ` 2 → 3) and for
//! `MovePathL` in [`Timing::path_l_compute`] (`stateL` 2 → 3). A
//! computation that fails ends in state 5 with error 20046 (the code of the
//! document's example): joint points outside the limits, or Cartesian points
//! the arm cannot reach (solved from `SetPathRefJoints`' joints, else from
//! where the robot is). A path without points goes back to 0. A path that is
//! computing cannot be changed or deleted (`Fail,20018`); a command on a
//! path that does not exist is `Fail,20006`; running a path that is not
//! ready is `Fail,20042`. Names: letters, digits and `_`, at most 29.
//!
//! `MovePathJOL` runs 2-5000 joint points at once (in StandBy only), setting
//! each point's outputs when it passes the point; `GetMovePathJOLIndex`
//! replies how many points it has passed, and how many there are.
//!
//! [`Timing::path_compute`]: super::Timing::path_compute
//! [`Timing::path_l_compute`]: super::Timing::path_l_compute

use hans_codec::path::{PathInfo, PathReply};
use hans_codec::{request as rq, response as rs, Decimal, ErrorCode, TextList};

use super::dispatch::{done, values, Answer, Outcome, PARAM, STATE};
use super::io_commands::Outputs;
use super::motion::Path;
use super::paths::{Computation, Track, PATH_NOT_READY};
use super::values::{dec, decs, f, fs};
use super::{MoveKind, Planned, Robot, Speed, MAX_PATH_POINTS};
use crate::kinematics::{self as k, Joints};

/// A path computation that failed (the document's example code).
const PATH_ERROR: i32 = 20046;
/// Longest path name.
const MAX_NAME: usize = 29;

/// A `MovePathJOL` run.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct OnlinePath {
    /// Where each point is along the path (`s`).
    marks: Vec<f64>,
    /// The outputs to set at each point.
    outputs: Vec<Option<Outputs>>,
    /// Points passed.
    passed: usize,
}

/// `Fail,20006` unless `name` is a valid path name.
fn check_name(name: &str) -> Result<(), i32> {
    let ok = !name.is_empty()
        && name.len() <= MAX_NAME
        && name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_');
    if ok {
        Ok(())
    } else {
        Err(PARAM)
    }
}

impl Robot {
    /// A path of `InitPath` by name.
    fn v6_path(&mut self, name: &str) -> Result<&mut Track, i32> {
        match self.tracks.get_mut(name) {
            Some(t) if t.l.is_some() => Ok(t),
            _ => Err(PARAM),
        }
    }

    fn computing(t: &Track) -> bool {
        t.j.state == 2 || t.l.is_some_and(|l| l.state == 2)
    }

    pub(super) fn init_path(&mut self, c: &rq::InitPath) -> Outcome<'_> {
        check_name(c.path)?;
        let cartesian = c.raw_data_type == 1;
        let (vel, acc, jerk, tcp, ucs) = match &c.cartesian {
            Some(p) => (
                f(p.velocity),
                f(p.acc),
                f(p.jerk),
                self.tcp_named(p.tcp_name)?,
                self.ucs_named(p.ucs_name)?,
            ),
            // Required with Cartesian points; else the maximum values, TCP
            // and Base.
            None if cartesian => return Err(PARAM),
            None => (
                self.linear_max[0],
                self.linear_max[1],
                self.linear_max[2],
                self.tcp_named("TCP")?,
                self.ucs_named("Base")?,
            ),
        };
        if !(vel > 0.0 && acc > 0.0) {
            return Err(PARAM);
        }
        if self.tracks.get(c.path).is_some_and(Self::computing) {
            return Err(STATE);
        }
        let t = Track {
            cartesian,
            points: Vec::new(),
            j: Computation::at(1),
            l: Some(Computation::at(1)),
            joint_targets: Vec::new(),
            speed_ratio: f(c.speed_ratio),
            radius: f(c.radius),
            vel,
            acc,
            jerk,
            tcp,
            ucs,
            ref_joints: None,
        };
        self.new_track(c.path, t)?;
        done()
    }

    pub(super) fn push_path_points(&mut self, c: &rq::PushPathPoints) -> Outcome<'_> {
        let t = self.v6_path(c.path)?;
        if Self::computing(t) {
            return Err(STATE);
        }
        let pts: Vec<[f64; 6]> = c.points.iter().map(fs).collect();
        // Too many: none of this batch is added (the document's rule).
        if pts.is_empty() || t.points.len() + pts.len() > MAX_PATH_POINTS {
            return Err(PARAM);
        }
        t.points.extend_from_slice(&pts);
        t.j = Computation::at(1);
        t.l = Some(Computation::at(1));
        t.joint_targets.clear();
        done()
    }

    /// The joints of each point of a Cartesian path, solved one after the
    /// other from `reference`; `None` when one is out of reach.
    fn solve_points(&self, t: &Track, reference: Joints) -> Option<Vec<Joints>> {
        let mut q = reference;
        let mut out = Vec::with_capacity(t.points.len());
        for p in &t.points {
            let flange = k::flange_of(p, &t.tcp, &t.ucs);
            q = k::inverse(&flange, &q, &self.limits)?;
            out.push(q);
        }
        Some(out)
    }

    pub(super) fn end_push_path_points(
        &mut self,
        c: &rq::EndPushPathPoints,
        now: f64,
    ) -> Outcome<'_> {
        let t = self.v6_path(c.path)?.clone();
        if t.j.state != 1 {
            return Err(STATE);
        }
        let mut t = t;
        if t.points.is_empty() {
            t.j = Computation::at(0);
            t.l = Some(Computation::at(0));
        } else {
            let ok = (3, 0);
            let failed = (5, PATH_ERROR);
            let (on_j, on_l) = if t.cartesian {
                let reference = t.ref_joints.unwrap_or_else(|| self.plan_start());
                match self.solve_points(&t, reference) {
                    Some(q) => {
                        t.joint_targets = q;
                        (ok, ok)
                    }
                    None => (failed, failed),
                }
            } else if t.points.iter().all(|q| self.limits.contains(q)) {
                t.joint_targets = t.points.clone();
                (ok, ok)
            } else {
                (failed, failed)
            };
            let took = |d: std::time::Duration| d.as_secs_f64();
            t.j = Computation::compute(now, took(self.timing.path_compute), on_j);
            t.l = Some(Computation::compute(
                now,
                took(self.timing.path_l_compute),
                on_l,
            ));
        }
        self.tracks.insert(c.path.to_string(), t);
        done()
    }

    pub(super) fn del_path(&mut self, c: &rq::DelPath) -> Outcome<'_> {
        let t = self.tracks.get(c.path).ok_or(PARAM)?;
        if Self::computing(t) {
            return Err(STATE);
        }
        self.tracks.remove(c.path);
        done()
    }

    pub(super) fn update_path_name(&mut self, c: &rq::UpdatePathName) -> Outcome<'_> {
        check_name(c.new_name)?;
        if self.tracks.contains_key(c.new_name) {
            return Err(PARAM);
        }
        let t = self.tracks.remove(c.path).ok_or(PARAM)?;
        self.tracks.insert(c.new_name.to_string(), t);
        done()
    }

    pub(super) fn read_path_state(&self, c: &rq::ReadPathState) -> Outcome<'_> {
        let (j, l) = match self.tracks.get(c.path) {
            Some(t) => (t.j, t.l.unwrap_or(Computation::at(0))),
            None => (Computation::at(0), Computation::at(0)),
        };
        values(rs::ReadPathState {
            state_j: j.state,
            error_j: ErrorCode::from(j.error),
            state_l: l.state,
            error_l: ErrorCode::from(l.error),
        })
    }

    /// `ReadPath`: every path's name, or one path's details. The names are
    /// the robot's, so the reply is written here.
    pub(super) fn read_path(&self, c: &rq::ReadPath) -> Outcome<'static> {
        let Some(name) = c.path else {
            let names: Vec<&str> = self.tracks.keys().map(String::as_str).collect();
            return Answer::encoded(rs::ReadPath {
                path: PathReply::Names(TextList::new(&names)),
            });
        };
        let t = self.tracks.get(name).ok_or(PARAM)?;
        let l = t.l.unwrap_or(Computation::at(0));
        let info = PathInfo {
            raw_data_type: i32::from(t.cartesian),
            state_j: t.j.state,
            error_j: ErrorCode::from(t.j.error),
            state_l: l.state,
            error_l: ErrorCode::from(l.error),
            speed_ratio: dec(t.speed_ratio),
            radius: dec(t.radius),
            velocity: dec(t.vel),
            acc: dec(t.acc),
            jerk: dec(t.jerk),
            ucs: decs(t.ucs),
            tcp: decs(t.tcp),
            raw_points: i32::try_from(t.points.len()).unwrap_or(i32::MAX),
            first_point: t.points.first().map(|p| decs(*p)),
        };
        Answer::encoded(rs::ReadPath {
            path: PathReply::Info(info),
        })
    }

    /// The speed of a joint path run at `ratio` of the joints' maxima.
    fn path_speed(&self, ratio: f64) -> Speed {
        let min = |v: &Joints| v.iter().copied().fold(f64::INFINITY, f64::min);
        let ratio = ratio.max(0.01) * self.override_ratio;
        Speed::Trap {
            v: (min(&self.joint_max_vel) * ratio).max(1e-3),
            a: (min(&self.joint_max_acc) * ratio).max(1e-3),
        }
    }

    pub(super) fn move_path_j(&mut self, c: &rq::MovePathJ, now: f64) -> Outcome<'_> {
        let t = match self.tracks.get(c.path) {
            Some(t) if t.j.state == 3 => t.clone(),
            _ => return Err(PATH_NOT_READY),
        };
        self.need_motion(now)?;
        let targets = if t.joint_targets.is_empty() {
            &t.points
        } else {
            &t.joint_targets
        };
        let mut pts = vec![self.plan_start()];
        pts.extend_from_slice(targets);
        let plan = Planned {
            path: Path::joint_polyline(&pts),
            speed: self.path_speed(t.speed_ratio),
            cmd_id: None,
            seek: None,
            kind: MoveKind::Move,
        };
        self.accept(plan, now)
    }

    pub(super) fn set_path_ref_joints(&mut self, c: &rq::SetPathRefJoints) -> Outcome<'_> {
        let q = fs(c.joints);
        if !self.limits.contains(&q) {
            return Err(PARAM);
        }
        self.tracks.get_mut(c.path).ok_or(PARAM)?.ref_joints = Some(q);
        done()
    }

    pub(super) fn move_path_jol(&mut self, c: &rq::MovePathJOL, now: f64) -> Outcome<'_> {
        self.need_standby(now)?;
        let (v, a) = (f(c.velocity), f(c.acc));
        let n = c.points.len();
        if !(v > 0.0 && a > 0.0 && (2..=5000).contains(&n)) {
            return Err(PARAM);
        }
        let mut pts = vec![self.plan_start()];
        let mut outputs = Vec::with_capacity(n);
        for g in c.points.iter() {
            let mut q = [Decimal::ZERO; 6];
            q.copy_from_slice(&g[..6]);
            let q = fs(q);
            if !self.limits.contains(&q) {
                return Err(PARAM);
            }
            pts.push(q);
            let mut io = [Decimal::ZERO; 12];
            io.copy_from_slice(&g[7..]);
            outputs.push((f(g[6]) == 1.0).then(|| Outputs::from_fields(&io)));
        }
        let mut marks = Vec::with_capacity(n);
        let mut s = 0.0;
        for w in pts.windows(2) {
            s += Path::joint_line(w[0], w[1]).length();
            marks.push(s);
        }
        let ov = self.override_ratio;
        let plan = Planned {
            path: Path::joint_polyline(&pts),
            speed: Speed::Trap {
                v: (v * ov).max(1e-3),
                a: (a * ov).max(1e-3),
            },
            cmd_id: None,
            seek: None,
            kind: MoveKind::Online,
        };
        self.online_path = Some(OnlinePath {
            marks,
            outputs,
            passed: 0,
        });
        self.accept(plan, now)
    }

    pub(super) fn get_move_path_jol_index(&self) -> Outcome<'_> {
        let (passed, total) = self
            .online_path
            .as_ref()
            .map_or((0, 0), |o| (o.passed, o.marks.len()));
        let int = |v: usize| i32::try_from(v).unwrap_or(i32::MAX);
        values(rs::GetMovePathJOLIndex {
            index: int(passed),
            total: int(total),
        })
    }

    /// Counts the `MovePathJOL` points passed by `now` and sets their
    /// outputs. Called before the motion advances, while the run is still
    /// the active segment.
    pub(super) fn apply_online_path_outputs(&mut self, now: f64) {
        let s = match &self.active {
            Some(seg) if seg.plan.kind == MoveKind::Online => seg.s_at(now).0,
            _ => return,
        };
        let Some(mut run) = self.online_path.take() else {
            return;
        };
        while run.marks.get(run.passed).is_some_and(|&m| s + 1e-9 >= m) {
            if let Some(Some(o)) = run.outputs.get(run.passed) {
                self.apply_outputs(o);
            }
            run.passed += 1;
        }
        self.online_path = Some(run);
    }
}
