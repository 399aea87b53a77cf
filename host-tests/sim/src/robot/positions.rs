//! Section 4.6: positions, velocities and currents, command and actual.
//! Velocities are differences over 1 ms of simulated time.

use hans_codec::response as rs;

use super::dispatch::{values, Outcome};
use super::values::{dec, decs, wrap};
use super::Robot;
use crate::kinematics::{self as k, Joints, Pose};

/// The time step of the velocity estimates (s).
const DT: f64 = 0.001;

impl Robot {
    /// TCP velocity (mm/s, °/s) in the current frames.
    pub(super) fn tcp_velocity(&self, now: f64, actual: bool) -> Pose {
        let q = |t| {
            if actual {
                self.act_joints(t)
            } else {
                self.cmd_joints(t)
            }
        };
        let p1 = k::forward_pose(&q(now), &self.tcp, &self.ucs);
        let p0 = k::forward_pose(&q(now - DT), &self.tcp, &self.ucs);
        let mut v = [0.0; 6];
        for i in 0..6 {
            let d = if i < 3 {
                p1[i] - p0[i]
            } else {
                wrap(p1[i] - p0[i])
            };
            v[i] = d / DT;
        }
        v
    }

    /// Joint velocities (°/s).
    pub(super) fn joint_vel(&self, now: f64, actual: bool) -> Joints {
        let (a, b) = if actual {
            (self.act_joints(now), self.act_joints(now - DT))
        } else {
            (self.cmd_joints(now), self.cmd_joints(now - DT))
        };
        let mut v = [0.0; 6];
        for i in 0..6 {
            v[i] = (a[i] - b[i]) / DT;
        }
        v
    }

    /// The speed (mm/s) of a TCP velocity.
    pub(super) fn tcp_speed(v: Pose) -> f64 {
        (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
    }

    pub(super) fn read_act_pos(&self, now: f64) -> Outcome<'_> {
        let q = self.act_joints(now);
        values(rs::ReadActPos {
            joints: decs(q),
            pose: decs(k::forward_pose(&q, &self.tcp, &self.ucs)),
            tcp: decs(self.tcp),
            ucs: decs(self.ucs),
        })
    }

    pub(super) fn read_cmd_pos(&self, now: f64) -> Outcome<'_> {
        let q = self.cmd_joints(now);
        values(rs::ReadCmdPos {
            joints: decs(q),
            pose: decs(k::forward_pose(&q, &self.tcp, &self.ucs)),
        })
    }

    pub(super) fn read_tcp_velocity(&self, now: f64) -> Outcome<'_> {
        values(rs::ReadTcpVelocity {
            cmd: dec(Self::tcp_speed(self.tcp_velocity(now, false))),
            act: dec(Self::tcp_speed(self.tcp_velocity(now, true))),
        })
    }

    /// `ReadTcpVel` (V6 document 4.6.10): command and actual TCP speed,
    /// mm/s.
    pub(super) fn read_tcp_vel(&self, now: f64) -> Outcome<'_> {
        values(rs::ReadTcpVel {
            cmd: dec(Self::tcp_speed(self.tcp_velocity(now, false))),
            act: dec(Self::tcp_speed(self.tcp_velocity(now, true))),
        })
    }
}
