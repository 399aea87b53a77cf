//! Section 4.7: kinematics and pose arithmetic, answered by
//! [`crate::kinematics`] (which says where the document's examples
//! disagree with themselves and what is done about it).

use hans_codec::{request as rq, response as rs};

use super::dispatch::{values, Outcome, PARAM};
use super::values::{dec, decs, f, fs};
use super::Robot;
use crate::kinematics as k;

impl Robot {
    pub(super) fn quaternion_to_rpy(&self, c: &rq::Quaternion2RPY) -> Outcome<'_> {
        let m = k::quat_to_rot(fs(c.quaternion)).ok_or(PARAM)?;
        values(rs::Quaternion2RPY {
            rpy: decs(k::rot_to_rpy(&m)),
        })
    }

    pub(super) fn rpy_to_quaternion(&self, c: &rq::RPY2Quaternion) -> Outcome<'_> {
        let [rx, ry, rz] = fs(c.rpy);
        values(rs::RPY2Quaternion {
            quaternion: decs(k::rot_to_quat(&k::rpy_to_rot(rx, ry, rz))),
        })
    }

    pub(super) fn get_inverse_kin(&self, c: &rq::GetInverseKin) -> Outcome<'_> {
        let target = k::flange_of(&fs(c.pose), &fs(c.tcp), &fs(c.ucs));
        let q = k::inverse(&target, &fs(c.reference), &self.limits).ok_or(PARAM)?;
        values(rs::GetInverseKin { joints: decs(q) })
    }

    pub(super) fn get_forward_kin(&self, c: &rq::GetForwardKin) -> Outcome<'_> {
        values(rs::GetForwardKin {
            pose: decs(k::forward_pose(&fs(c.joints), &fs(c.tcp), &fs(c.ucs))),
        })
    }

    pub(super) fn base_to_ucs_tcp(&self, c: &rq::Base2UcsTcp) -> Outcome<'_> {
        values(rs::Base2UcsTcp {
            pose: decs(k::base_to_ucs_tcp(&fs(c.pose), &fs(c.tcp), &fs(c.ucs))),
        })
    }

    pub(super) fn ucs_tcp_to_base(&self, c: &rq::UcsTcp2Base) -> Outcome<'_> {
        values(rs::UcsTcp2Base {
            pose: decs(k::ucs_tcp_to_base(&fs(c.pose), &fs(c.tcp), &fs(c.ucs))),
        })
    }

    pub(super) fn pose_add(&self, c: &rq::PoseAdd) -> Outcome<'_> {
        values(rs::PoseAdd {
            pose: decs(k::pose_add(&fs(c.pose1), &fs(c.pose2))),
        })
    }

    pub(super) fn pose_sub(&self, c: &rq::PoseSub) -> Outcome<'_> {
        values(rs::PoseSub {
            pose: decs(k::pose_sub(&fs(c.pose1), &fs(c.pose2))),
        })
    }

    pub(super) fn pose_trans(&self, c: &rq::PoseTrans) -> Outcome<'_> {
        values(rs::PoseTrans {
            pose: decs(k::pose_trans(&fs(c.pose1), &fs(c.pose2))),
        })
    }

    pub(super) fn pose_inverse(&self, c: &rq::PoseInverse) -> Outcome<'_> {
        values(rs::PoseInverse {
            pose: decs(k::pose_inverse(&fs(c.pose))),
        })
    }

    pub(super) fn pose_dist(&self, c: &rq::PoseDist) -> Outcome<'_> {
        let (d, a) = k::pose_dist(&fs(c.pose1), &fs(c.pose2));
        values(rs::PoseDist {
            distance: dec(d),
            angle: dec(a),
        })
    }

    pub(super) fn pose_interpolate(&self, c: &rq::PoseInterpolate) -> Outcome<'_> {
        values(rs::PoseInterpolate {
            pose: decs(k::pose_interpolate(&fs(c.pose1), &fs(c.pose2), f(c.alpha))),
        })
    }

    pub(super) fn pose_defd_frame(&self, c: &rq::PoseDefdFrame) -> Outcome<'_> {
        let pts = [c.p1, c.p2, c.p3, c.p4, c.p5, c.p6].map(fs);
        values(rs::PoseDefdFrame {
            ucs: decs(k::pose_defd_frame(&pts).ok_or(PARAM)?),
        })
    }

    // ------------------------------------------------ V6 document 4.7

    pub(super) fn read_act_coord(&self, c: &rq::ReadActCoord, now: f64) -> Outcome<'_> {
        let ucs = self.ucs_named(c.ucs_name)?;
        let tcp = self.tcp_named(c.tcp_name)?;
        let q = self.act_joints(now);
        values(rs::ReadActCoord {
            joints: decs(q),
            pose: decs(k::forward_pose(&q, &tcp, &ucs)),
        })
    }

    /// `GetInverseDynamics`: the torques (N·m) of a rough model, a gravity
    /// term on the pitch joints (arm and payload) plus inertia and
    /// friction; no real arm's parameters.
    pub(super) fn get_inverse_dynamics(&self, c: &rq::GetInverseDynamics) -> Outcome<'_> {
        let (q, v, a) = (fs(c.joints), fs(c.velocities), fs(c.accelerations));
        let load = 1.0 + self.payload.0 / 5.0;
        let s = |deg: f64| deg.to_radians().sin();
        let gravity = [
            0.0,
            load * (40.0 * s(q[1]) + 20.0 * s(q[1] + q[2])),
            load * 20.0 * s(q[1] + q[2]),
            0.0,
            load * 2.0 * s(q[1] + q[2] + q[4]),
            0.0,
        ];
        let inertia = [0.05, 0.08, 0.04, 0.005, 0.005, 0.002];
        let friction = 0.02;
        let mut torques = [0.0; 6];
        for i in 0..6 {
            torques[i] = gravity[i] + inertia[i] * a[i] + friction * v[i];
        }
        values(rs::GetInverseDynamics {
            torques: decs(torques),
        })
    }
}
