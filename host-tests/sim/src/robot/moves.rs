//! Section 4.10: the moves (way points, `MoveJ`/`MoveL`, arcs, zig-zags,
//! spirals, relative moves) and the planning they share. A move is planned
//! when it is accepted ([`Planned`]) and runs after the moves before it
//! (see `queue`); an unreachable target or a speed of 0 is `Fail,20006`.

use hans_codec::request as rq;

use super::dispatch::{done, Outcome, PARAM, STATE};
use super::motion::Path;
use super::shapes::{arc_frames, spiral_frames, zigzag_frames};
use super::values::{f, fs, idx};
use super::{MoveKind, Planned, Robot, Speed};
use crate::kinematics::{self as k, Frame, Joints, Pose, PoseFrame, Vec3};

/// Speed and acceleration of the relative moves (`MoveRelJ`, `MoveRelL`),
/// which carry none: joints (°/s, °/s²) and linear (mm/s, mm/s²).
const REL_JOINT_VEL: f64 = 30.0;
const REL_JOINT_ACC: f64 = 90.0;
const REL_LINEAR_VEL: f64 = 50.0;
const REL_LINEAR_ACC: f64 = 200.0;

impl Robot {
    /// `nIsSeek`, `nIOBit`, `nIOState` as a seek condition.
    fn seek(seek: i32, bit: i32, state: i32) -> Option<(usize, bool)> {
        (seek == 1).then(|| (idx(bit), state == 1))
    }

    /// Accepts a planned move: runs now or after the moves before it;
    /// `Fail,20018` when the queue is full.
    pub(super) fn accept(&mut self, plan: Planned, now: f64) -> Outcome<'static> {
        if self.push_move(plan, now) {
            done()
        } else {
            Err(STATE)
        }
    }

    /// A joint move to `target` at `v` °/s, `a` °/s² (before the override).
    pub(super) fn joint_move(
        &self,
        target: Joints,
        v: f64,
        a: f64,
        cmd_id: Option<&str>,
        seek: Option<(usize, bool)>,
    ) -> Result<Planned, i32> {
        if !(v > 0.0 && a > 0.0 && self.limits.contains(&target)) {
            return Err(PARAM);
        }
        let start = self.plan_start();
        let path = Path::joint_line(start, target);
        let len = path.length();
        let mut v = v;
        for i in 0..6 {
            let d = (target[i] - start[i]).abs();
            if d > 1e-9 {
                v = v.min(self.joint_max_vel[i] * len / d);
            }
        }
        let ov = self.override_ratio;
        Ok(Planned {
            path,
            speed: Speed::Trap {
                v: (v * ov).max(1e-3),
                a: (a * ov).max(1e-3),
            },
            cmd_id: cmd_id.map(str::to_string),
            seek,
            kind: MoveKind::Move,
        })
    }

    /// A Cartesian move through TCP frames (base frame) with tool `tcp`.
    pub(super) fn linear_move(
        &self,
        frames: &[Frame],
        tcp: &Pose,
        v: f64,
        a: f64,
        cmd_id: Option<&str>,
        seek: Option<(usize, bool)>,
    ) -> Result<Planned, i32> {
        if !(v > 0.0 && a > 0.0) {
            return Err(PARAM);
        }
        let path = Path::cartesian(
            self.plan_start(),
            frames,
            &Frame::from_pose(tcp),
            &self.limits,
        )
        .map_err(|_| PARAM)?;
        let ov = self.override_ratio;
        Ok(Planned {
            path,
            speed: Speed::Trap {
                v: (v.min(self.linear_max[0]) * ov).max(1e-3),
                a: (a.min(self.linear_max[1]) * ov).max(1e-3),
            },
            cmd_id: cmd_id.map(str::to_string),
            seek,
            kind: MoveKind::Move,
        })
    }

    /// The TCP frame (base) where the next move starts, for tool `tcp`.
    pub(super) fn start_tcp_frame(&self, tcp: &Pose) -> Frame {
        k::forward(&self.plan_start()) * Frame::from_pose(tcp)
    }

    /// The TCP frame `delta` away from `start` along or about one axis:
    /// in the tool frame (`tool`), or along the user frame's axes with
    /// rotations about the TCP point.
    pub(super) fn shifted_frame(&self, start: &Frame, delta: &Pose, tool: bool) -> Frame {
        if tool {
            return start * Frame::from_pose(delta);
        }
        // The rotation about the user frame's axes, applied at the TCP.
        let ucs = Frame::from_pose(&self.ucs).rotation;
        let turn = ucs * k::rpy_to_rot(delta[3], delta[4], delta[5]) * ucs.inverse();
        let shift = ucs * Vec3::new(delta[0], delta[1], delta[2]);
        k::frame_at(turn * start.rotation, start.translation.vector + shift)
    }

    /// A way-point style move: joint (`linear == false`) or linear.
    #[allow(clippy::too_many_arguments)]
    fn plan_way_point(
        &mut self,
        now: f64,
        pose: &Pose,
        joints: &Joints,
        tcp: Pose,
        ucs: Pose,
        v: f64,
        a: f64,
        linear: bool,
        use_joint: bool,
        cmd_id: &str,
        seek: Option<(usize, bool)>,
    ) -> Outcome<'static> {
        self.need_motion(now)?;
        let plan = if linear {
            let target = Frame::from_pose(&ucs) * Frame::from_pose(pose);
            self.linear_move(&[target], &tcp, v, a, Some(cmd_id), seek)?
        } else {
            let target = if use_joint {
                *joints
            } else {
                k::inverse(&k::flange_of(pose, &tcp, &ucs), joints, &self.limits).ok_or(PARAM)?
            };
            self.joint_move(target, v, a, Some(cmd_id), seek)?
        };
        self.accept(plan, now)
    }

    pub(super) fn move_rel_j(&mut self, c: &rq::MoveRelJ, now: f64) -> Outcome<'_> {
        self.need_motion(now)?;
        let mut target = self.plan_start();
        let d = f(c.distance);
        target[idx(c.axis)] += if c.direction == 1 { d } else { -d };
        let plan = self.joint_move(target, REL_JOINT_VEL, REL_JOINT_ACC, None, None)?;
        self.accept(plan, now)
    }

    pub(super) fn move_rel_l(&mut self, c: &rq::MoveRelL, now: f64) -> Outcome<'_> {
        self.need_motion(now)?;
        let d = f(c.distance) * if c.direction == 1 { 1.0 } else { -1.0 };
        let tool = c.tool_motion.map_or(self.tool_motion, |m| m == 1);
        let tcp = self.tcp;
        let start = self.start_tcp_frame(&tcp);
        let axis = idx(c.axis);
        let mut delta = [0.0; 6];
        delta[axis] = d;
        let target = self.shifted_frame(&start, &delta, tool);
        let (v, a) = if axis < 3 {
            (REL_LINEAR_VEL, REL_LINEAR_ACC)
        } else {
            (REL_JOINT_VEL, REL_JOINT_ACC)
        };
        let plan = self.linear_move(&[target], &tcp, v, a, None, None)?;
        self.accept(plan, now)
    }

    pub(super) fn way_point_rel(&mut self, c: &rq::WayPointRel, now: f64) -> Outcome<'_> {
        self.need_motion(now)?;
        let tcp = self.tcp_named(c.tcp_name)?;
        let ucs = self.ucs_named(c.ucs_name)?;
        let add = c.rel_move_type == 1;
        let target = fs(c.target);
        let seek = Self::seek(c.seek, c.io_bit, c.io_state);
        let (v, a) = (f(c.velocity), f(c.acc));
        if c.move_type == 0 {
            let mut q = if c.use_point_list == 1 {
                fs(c.joints)
            } else {
                self.plan_start()
            };
            for i in 0..6 {
                if c.axis_mask[i] == 1 {
                    q[i] = if add { q[i] + target[i] } else { target[i] };
                }
            }
            let plan = self.joint_move(q, v, a, Some(c.cmd_id), seek)?;
            self.accept(plan, now)
        } else {
            let mut p = if c.use_point_list == 1 {
                fs(c.pose)
            } else {
                let q = self.plan_start();
                k::forward_pose(&q, &tcp, &ucs)
            };
            for i in 0..6 {
                if c.axis_mask[i] == 1 {
                    p[i] = if add { p[i] + target[i] } else { target[i] };
                }
            }
            let frame = Frame::from_pose(&ucs) * Frame::from_pose(&p);
            let plan = self.linear_move(&[frame], &tcp, v, a, Some(c.cmd_id), seek)?;
            self.accept(plan, now)
        }
    }

    pub(super) fn way_point_ex(&mut self, c: &rq::WayPointEx, now: f64) -> Outcome<'_> {
        self.plan_way_point(
            now,
            &fs(c.pose),
            &fs(c.joints),
            fs(c.tcp),
            fs(c.ucs),
            f(c.velocity),
            f(c.acc),
            c.move_type == 1,
            c.use_joint == 1,
            c.cmd_id,
            Self::seek(c.seek, c.io_bit, c.io_state),
        )
    }

    pub(super) fn way_point(&mut self, c: &rq::WayPoint, now: f64) -> Outcome<'_> {
        let tcp = self.tcp_named(c.tcp_name)?;
        let ucs = self.ucs_named(c.ucs_name)?;
        self.plan_way_point(
            now,
            &fs(c.pose),
            &fs(c.joints),
            tcp,
            ucs,
            f(c.velocity),
            f(c.acc),
            c.move_type == 1,
            c.use_joint == 1,
            c.cmd_id,
            Self::seek(c.seek, c.io_bit, c.io_state),
        )
    }

    pub(super) fn way_point2(&mut self, c: &rq::WayPoint2, now: f64) -> Outcome<'_> {
        let tcp = self.tcp_named(c.tcp_name)?;
        let ucs = self.ucs_named(c.ucs_name)?;
        let seek = Self::seek(c.seek, c.io_bit, c.io_state);
        if c.move_type == 2 {
            self.need_motion(now)?;
            let u = Frame::from_pose(&ucs);
            let start = self.start_tcp_frame(&tcp);
            let aux = u * Frame::from_pose(&fs(c.aux_pose));
            let end = u * Frame::from_pose(&fs(c.end_pose));
            let frames = arc_frames(&start, &aux, &end, false, 1.0, false).ok_or(PARAM)?;
            let plan =
                self.linear_move(&frames, &tcp, f(c.velocity), f(c.acc), Some(c.cmd_id), seek)?;
            self.accept(plan, now)
        } else {
            self.plan_way_point(
                now,
                &fs(c.end_pose),
                &fs(c.joints),
                tcp,
                ucs,
                f(c.velocity),
                f(c.acc),
                c.move_type == 1,
                c.use_joint == 1,
                c.cmd_id,
                seek,
            )
        }
    }

    pub(super) fn move_j(&mut self, c: &rq::MoveJ, now: f64) -> Outcome<'_> {
        let tcp = self.tcp_named(c.tcp_name)?;
        let ucs = self.ucs_named(c.ucs_name)?;
        self.plan_way_point(
            now,
            &fs(c.pose),
            &fs(c.joints),
            tcp,
            ucs,
            f(c.velocity),
            f(c.acc),
            false,
            c.use_joint == 1,
            c.cmd_id,
            Self::seek(c.seek, c.io_bit, c.io_state),
        )
    }

    pub(super) fn move_l(&mut self, c: &rq::MoveL, now: f64) -> Outcome<'_> {
        let tcp = self.tcp_named(c.tcp_name)?;
        let ucs = self.ucs_named(c.ucs_name)?;
        self.plan_way_point(
            now,
            &fs(c.pose),
            &fs(c.joints),
            tcp,
            ucs,
            f(c.velocity),
            f(c.acc),
            true,
            false,
            c.cmd_id,
            Self::seek(c.seek, c.io_bit, c.io_state),
        )
    }

    pub(super) fn move_c(&mut self, c: &rq::MoveC, now: f64) -> Outcome<'_> {
        self.need_motion(now)?;
        let tcp = self.tcp_named(c.tcp_name)?;
        let ucs = Frame::from_pose(&self.ucs_named(c.ucs_name)?);
        let start = ucs * Frame::from_pose(&fs(c.start));
        let aux = ucs * Frame::from_pose(&fs(c.aux));
        let end = ucs * Frame::from_pose(&fs(c.end));
        let turns = f(c.rad_len).trunc().max(1.0);
        let mut frames = vec![start];
        frames.extend(
            arc_frames(
                &start,
                &aux,
                &end,
                c.circle_type == 0,
                turns,
                c.fixed_posture == 1,
            )
            .ok_or(PARAM)?,
        );
        let plan =
            self.linear_move(&frames, &tcp, f(c.velocity), f(c.acc), Some(c.cmd_id), None)?;
        self.accept(plan, now)
    }

    pub(super) fn move_z(&mut self, c: &rq::MoveZ, now: f64) -> Outcome<'_> {
        self.need_motion(now)?;
        let tcp = self.tcp_named(c.tcp_name)?;
        let ucs = Frame::from_pose(&self.ucs_named(c.ucs_name)?);
        let start = ucs * Frame::from_pose(&fs(c.start));
        let end = ucs * Frame::from_pose(&fs(c.end));
        let plane = (c.enable_plane == 1).then(|| ucs * Frame::from_pose(&fs(c.plane)));
        let pitch = if c.enable_density == 1 && f(c.density) > 0.0 {
            f(c.density)
        } else {
            f(c.width).abs().max(1.0)
        };
        let frames =
            zigzag_frames(&start, &end, plane.as_ref(), &ucs, f(c.width), pitch).ok_or(PARAM)?;
        let plan =
            self.linear_move(&frames, &tcp, f(c.velocity), f(c.acc), Some(c.cmd_id), None)?;
        self.accept(plan, now)
    }

    pub(super) fn move_e(&mut self, c: &rq::MoveE, now: f64) -> Outcome<'_> {
        self.need_motion(now)?;
        let tcp = self.tcp_named(c.tcp_name)?;
        let ucs = Frame::from_pose(&self.ucs_named(c.ucs_name)?);
        let mut frames: Vec<Frame> = [c.p1, c.p2, c.p3, c.p4, c.p5]
            .iter()
            .map(|p| ucs * Frame::from_pose(&fs(*p)))
            .collect();
        if c.orient_mode == 1 {
            frames.push(frames[0]);
        }
        if c.move_type == 1 {
            let r = frames[0].rotation;
            for fr in &mut frames {
                fr.rotation = r;
            }
        }
        let plan =
            self.linear_move(&frames, &tcp, f(c.velocity), f(c.acc), Some(c.cmd_id), None)?;
        self.accept(plan, now)
    }

    pub(super) fn move_s(&mut self, c: &rq::MoveS, now: f64) -> Outcome<'_> {
        self.need_motion(now)?;
        let tcp = self.tcp_named(c.tcp_name)?;
        let ucs = Frame::from_pose(&self.ucs_named(c.ucs_name)?);
        let start = self.start_tcp_frame(&tcp);
        let (frames, length, turn_deg) = spiral_frames(&start, &ucs, f(c.increment), f(c.diameter));
        // The document gives the spiral's speed in °/s of turning.
        let per_deg = if turn_deg > 0.0 {
            length / turn_deg
        } else {
            1.0
        };
        let plan = self.linear_move(
            &frames,
            &tcp,
            f(c.velocity) * per_deg,
            f(c.acc) * per_deg,
            Some(c.cmd_id),
            None,
        )?;
        self.accept(plan, now)
    }
}
