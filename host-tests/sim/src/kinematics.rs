//! Kinematics of the simulated 6-axis arm and the pose arithmetic of
//! section 4.7.
//!
//! # The arm
//! The dimensions are derived from the document's own examples, not from a
//! data sheet: `GetForwardKin` of `0,0,90,0,90,0` is `420,0,445,-180,0,180`
//! and `ReadActPos` pairs joints `10.759,0,37.828,0,37.828,0` with the pose
//! `400.581,76.115,970.143,0,75.655,10.759`. Both are met by an arm without
//! lateral offsets (like the Elfin): J1 turns about the vertical axis, J2,
//! J3 and J5 tilt about the (J1-rotated) Y axis, J4 and J6 roll about the
//! link that carries them; at all-zero joints the arm points straight up.
//!
//! | link | length |
//! |---|---|
//! | base to shoulder (`D1`) + upper arm (`L2`) | 220 + 380 = 600 mm |
//! | forearm (`L3`, shoulder of J3 to the wrist centre) | 420 mm |
//! | wrist centre to flange (`L6`) | 155 mm |
//!
//! Rotation: `R = Rz(J1)·Ry(J2+J3)·Rz(J4)·Ry(J5)·Rz(J6)`.
//!
//! # Poses
//! A pose is `X, Y, Z` in mm and `Rx, Ry, Rz` in degrees, the rotation being
//! `Rz(Rz)·Ry(Ry)·Rx(Rx)` (fixed-axis roll-pitch-yaw), as every example of
//! the document agrees. At `Ry = ±90°` (gimbal lock) `Rx` is reported as 0.
//!
//! # What is nalgebra's and what is ours
//! Rotations, quaternions, vectors, rigid transforms ([`Frame`]) and
//! spherical interpolation are nalgebra's. Ours: the arm (link lengths,
//! [`forward`], [`inverse`]), the document's pose convention ([`PoseFrame`],
//! [`rot_to_rpy`]: `Rx` = 0 at gimbal lock, +180 rather than -180) and the
//! one sign of a quaternion the controller prints ([`rot_to_quat`]).

use nalgebra::{Matrix3, Quaternion, Rotation3, Translation3, UnitQuaternion, Vector3};

/// A rotation (nalgebra's 3×3 rotation matrix).
pub type Rotation = Rotation3<f64>;
/// A position or direction (mm).
pub type Vec3 = Vector3<f64>;
/// A rigid transform, rotation then translation (nalgebra's isometry with
/// a rotation matrix). [`PoseFrame`] converts it to and from a pose.
pub type Frame = nalgebra::IsometryMatrix3<f64>;
/// `X, Y, Z` (mm), `Rx, Ry, Rz` (°).
pub type Pose = [f64; 6];
/// Six joint angles (°).
pub type Joints = [f64; 6];

/// Height of the shoulder (J2 axis) above the base.
pub const D1: f64 = 220.0;
/// Upper arm, J2 to J3.
pub const L2: f64 = 380.0;
/// Forearm, J3 to the wrist centre (J4/J5/J6 axes meet there).
pub const L3: f64 = 420.0;
/// Wrist centre to the flange.
pub const L6: f64 = 155.0;

const EPS: f64 = 1e-9;

fn rad(d: f64) -> f64 {
    d.to_radians()
}

fn deg(r: f64) -> f64 {
    r.to_degrees()
}

/// Rounds values within 1e-9 of zero to +0, so that the sign of an angle
/// at ±180° does not depend on rounding noise.
fn clean(v: f64) -> f64 {
    if v.abs() < 1e-9 {
        0.0
    } else {
        v
    }
}

/// Rotation about X by `a` degrees.
pub fn rot_x(a: f64) -> Rotation {
    Rotation::from_axis_angle(&Vec3::x_axis(), rad(a))
}

/// Rotation about Y by `a` degrees.
pub fn rot_y(a: f64) -> Rotation {
    Rotation::from_axis_angle(&Vec3::y_axis(), rad(a))
}

/// Rotation about Z by `a` degrees.
pub fn rot_z(a: f64) -> Rotation {
    Rotation::from_axis_angle(&Vec3::z_axis(), rad(a))
}

/// The frame of a rotation and a position.
pub fn frame_at(r: Rotation, p: Vec3) -> Frame {
    Frame::from_parts(Translation3::from(p), r)
}

/// The rotation of roll-pitch-yaw angles (°): `Rz(rz)·Ry(ry)·Rx(rx)`
/// (nalgebra's Euler angles are this convention).
pub fn rpy_to_rot(rx: f64, ry: f64, rz: f64) -> Rotation {
    Rotation::from_euler_angles(rad(rx), rad(ry), rad(rz))
}

/// Roll-pitch-yaw angles (°) of a rotation as the controller prints them:
/// each in -180..=180, `ry` in -90..=90, `rx = 0` at gimbal lock, and
/// +180 rather than -180 where rounding noise would decide the sign. (The
/// document's convention, so not nalgebra's `euler_angles`, which puts the
/// angle in `rx` at gimbal lock.)
pub fn rot_to_rpy(r: &Rotation) -> [f64; 3] {
    let m = r.matrix();
    let sy = (-m[(2, 0)]).clamp(-1.0, 1.0);
    if sy.abs() > 1.0 - 1e-10 {
        let ry = if sy > 0.0 { 90.0 } else { -90.0 };
        let rz = deg(clean(-m[(0, 1)]).atan2(clean(m[(1, 1)])));
        [0.0, ry, rz]
    } else {
        let ry = deg(sy.asin());
        let rx = deg(clean(m[(2, 1)]).atan2(clean(m[(2, 2)])));
        let rz = deg(clean(m[(1, 0)]).atan2(clean(m[(0, 0)])));
        [rx, ry, rz]
    }
}

/// The unit quaternion `[w, x, y, z]` of a rotation, with one sign chosen
/// for the two that describe it: `w > 0`, or for a half turn (`w = 0`) its
/// largest component positive.
pub fn rot_to_quat(r: &Rotation) -> [f64; 4] {
    let q = UnitQuaternion::from_rotation_matrix(r);
    let mut v = [q.w, q.i, q.j, q.k];
    let largest = v[1..]
        .iter()
        .copied()
        .fold(0.0_f64, |m, x| if x.abs() > m.abs() { x } else { m });
    if v[0] < -EPS || (v[0].abs() <= EPS && largest < 0.0) {
        v = v.map(|x| -x);
    }
    v.map(clean)
}

/// The rotation of a quaternion `[w, x, y, z]`; `None` for a zero (or not
/// finite) quaternion. Quaternions that are not unit length are normalised.
pub fn quat_to_rot(q: [f64; 4]) -> Option<Rotation> {
    let [w, x, y, z] = q;
    let q = Quaternion::new(w, x, y, z);
    let n = q.norm();
    if n < EPS || !n.is_finite() {
        return None;
    }
    Some(UnitQuaternion::from_quaternion(q).to_rotation_matrix())
}

/// The angle (°, 0..=180) of a rotation (through its quaternion, which
/// stays exact near 0° and 180° where the matrix trace does not).
pub fn rotation_angle(r: &Rotation) -> f64 {
    deg(UnitQuaternion::from_rotation_matrix(r).angle())
}

/// The angle (°) of the rotation from `a` to `b`.
pub fn angle_between(a: &Rotation, b: &Rotation) -> f64 {
    rotation_angle(&(a.inverse() * b))
}

/// Spherical interpolation between two rotations (`t` = 0 gives `a`), the
/// short way round.
pub fn slerp(a: &Rotation, b: &Rotation, t: f64) -> Rotation {
    let qa = UnitQuaternion::from_rotation_matrix(a);
    let qb = UnitQuaternion::from_rotation_matrix(b);
    // `None` when the two are (nearly) equal: then the straight line is
    // the same.
    qa.try_slerp(&qb, t, 1e-12)
        .unwrap_or_else(|| qa.nlerp(&qb, t))
        .to_rotation_matrix()
}

/// A frame from a pose and back: the pose convention of the document
/// (`Rz·Ry·Rx` roll-pitch-yaw in degrees, see [`rot_to_rpy`]).
pub trait PoseFrame {
    /// The frame of a pose.
    fn from_pose(p: &Pose) -> Self;
    /// The pose of this frame.
    fn to_pose(&self) -> Pose;
}

impl PoseFrame for Frame {
    fn from_pose(p: &Pose) -> Frame {
        frame_at(rpy_to_rot(p[3], p[4], p[5]), Vec3::new(p[0], p[1], p[2]))
    }

    fn to_pose(&self) -> Pose {
        let [rx, ry, rz] = rot_to_rpy(&self.rotation);
        let p = &self.translation.vector;
        [clean(p.x), clean(p.y), clean(p.z), rx, ry, rz]
    }
}

/// The flange frame of joint angles, in the base frame.
pub fn forward(q: &Joints) -> Frame {
    let r1 = rot_z(q[0]);
    let r12 = r1 * rot_y(q[1]);
    let r13 = r1 * rot_y(q[1] + q[2]);
    let r = r13 * rot_z(q[3]) * rot_y(q[4]) * rot_z(q[5]);
    let p = Vec3::new(0.0, 0.0, D1)
        + r12 * Vec3::new(0.0, 0.0, L2)
        + r13 * Vec3::new(0.0, 0.0, L3)
        + r * Vec3::new(0.0, 0.0, L6);
    frame_at(r, p)
}

/// The TCP pose of joints `q` with tool `tcp`, in user frame `ucs`
/// (`inv(UCS)·F(q)·TCP`): what `GetForwardKin` and `ReadActPos` report.
pub fn forward_pose(q: &Joints, tcp: &Pose, ucs: &Pose) -> Pose {
    (Frame::from_pose(ucs).inverse() * forward(q) * Frame::from_pose(tcp)).to_pose()
}

/// Joint limits, degrees: `min[i] <= q[i] <= max[i]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Upper limits.
    pub max: Joints,
    /// Lower limits.
    pub min: Joints,
}

impl Default for Limits {
    /// The limits of the document's `SetMaxAcsRange` example.
    fn default() -> Self {
        Limits {
            max: [360.0, 135.0, 153.0, 360.0, 180.0, 360.0],
            min: [-360.0, -135.0, -153.0, -360.0, -180.0, -360.0],
        }
    }
}

impl Limits {
    /// `true` when every joint is inside its limits (with a 1e-6° margin).
    pub fn contains(&self, q: &Joints) -> bool {
        (0..6).all(|i| q[i] >= self.min[i] - 1e-6 && q[i] <= self.max[i] + 1e-6)
    }
}

/// `a + k·360` closest to `reference` inside `min..=max`, if any.
fn wrap_near(a: f64, reference: f64, min: f64, max: f64) -> Option<f64> {
    let k = ((reference - a) / 360.0).round();
    [k, k - 1.0, k + 1.0]
        .iter()
        .map(|k| a + k * 360.0)
        .filter(|v| *v >= min - 1e-6 && *v <= max + 1e-6)
        .min_by(|x, y| {
            (x - reference)
                .abs()
                .partial_cmp(&(y - reference).abs())
                .unwrap_or(std::cmp::Ordering::Equal)
        })
}

/// Inverse kinematics: the joint solution for flange frame `target` that is
/// inside `limits` and closest to `reference` (largest single-joint
/// difference, then the sum). `None` when the frame is out of reach or no
/// solution is inside the limits.
pub fn inverse(target: &Frame, reference: &Joints, limits: &Limits) -> Option<Joints> {
    let z = target.rotation * Vec3::z();
    let w = target.translation.vector - z * L6;
    let rho = (w.x * w.x + w.y * w.y).sqrt();
    let h = w.z - D1;
    let mut best: Option<(f64, f64, Joints)> = None;
    let base_q1 = if rho < 1e-6 {
        rad(reference[0])
    } else {
        w.y.atan2(w.x)
    };
    for flip in [false, true] {
        let q1 = if flip {
            base_q1 + std::f64::consts::PI
        } else {
            base_q1
        };
        let r = if flip { -rho } else { rho };
        let c3 = (r * r + h * h - L2 * L2 - L3 * L3) / (2.0 * L2 * L3);
        if c3.abs() > 1.0 + 1e-9 {
            continue;
        }
        let c3 = c3.clamp(-1.0, 1.0);
        for elbow in [1.0, -1.0] {
            let q3 = elbow * c3.acos();
            let q2 = r.atan2(h) - (L3 * q3.sin()).atan2(L2 + L3 * q3.cos());
            let r03 = rot_z(deg(q1)) * rot_y(deg(q2 + q3));
            let m = (r03.inverse() * target.rotation).into_inner();
            let sb = (m[(0, 2)] * m[(0, 2)] + m[(1, 2)] * m[(1, 2)]).sqrt();
            let wrists: Vec<(f64, f64, f64)> = if sb < 1e-9 {
                // q5 = 0 or 180: only q4 ± q6 is determined; keep q4.
                let q4 = rad(reference[3]);
                if m[(2, 2)] > 0.0 {
                    let q46 = m[(1, 0)].atan2(m[(0, 0)]);
                    vec![(q4, 0.0, q46 - q4)]
                } else {
                    let q46 = (-m[(1, 0)]).atan2(-m[(0, 0)]);
                    vec![(q4, std::f64::consts::PI, q4 - q46)]
                }
            } else {
                let b = sb.atan2(m[(2, 2)]);
                let a = m[(1, 2)].atan2(m[(0, 2)]);
                let c = m[(2, 1)].atan2(-m[(2, 0)]);
                let pi = std::f64::consts::PI;
                vec![(a, b, c), (a + pi, -b, c + pi)]
            };
            for (q4, q5, q6) in wrists {
                let raw = [q1, q2, q3, q4, q5, q6].map(deg);
                let mut q = [0.0; 6];
                let mut ok = true;
                for i in 0..6 {
                    match wrap_near(raw[i], reference[i], limits.min[i], limits.max[i]) {
                        Some(v) => q[i] = v,
                        None => ok = false,
                    }
                }
                if !ok {
                    continue;
                }
                let diff_max = (0..6)
                    .map(|i| (q[i] - reference[i]).abs())
                    .fold(0.0, f64::max);
                let diff_sum: f64 = (0..6).map(|i| (q[i] - reference[i]).abs()).sum();
                let better = match &best {
                    None => true,
                    Some((m, s, _)) => {
                        diff_max < m - 1e-9 || ((diff_max - m).abs() <= 1e-9 && diff_sum < *s)
                    }
                };
                if better {
                    best = Some((diff_max, diff_sum, q.map(clean)));
                }
            }
        }
    }
    let q = best.map(|(_, _, q)| q)?;
    // Guard against numerical trouble: the solution must reproduce the target.
    let f = forward(&q);
    (distance(&f.translation.vector, &target.translation.vector) < 1e-3
        && angle_between(&f.rotation, &target.rotation) < 1e-3)
        .then_some(q)
}

/// `PoseAdd`: positions add, the second rotation left-multiplies the first
/// (`840,200,890,0,0,0` for the document's example).
pub fn pose_add(a: &Pose, b: &Pose) -> Pose {
    let (fa, fb) = (Frame::from_pose(a), Frame::from_pose(b));
    frame_at(
        fb.rotation * fa.rotation,
        fa.translation.vector + fb.translation.vector,
    )
    .to_pose()
}

/// `PoseSub`: the inverse of [`pose_add`]: positions subtract, the first
/// rotation relative to the second (`R2ᵀ·R1`).
pub fn pose_sub(a: &Pose, b: &Pose) -> Pose {
    let (fa, fb) = (Frame::from_pose(a), Frame::from_pose(b));
    frame_at(
        fb.rotation.inverse() * fa.rotation,
        fa.translation.vector - fb.translation.vector,
    )
    .to_pose()
}

/// `PoseTrans`: pose 2 expressed in frame pose 1 (`P1·P2`).
pub fn pose_trans(a: &Pose, b: &Pose) -> Pose {
    (Frame::from_pose(a) * Frame::from_pose(b)).to_pose()
}

/// `PoseInverse`: the inverse transform.
pub fn pose_inverse(a: &Pose) -> Pose {
    Frame::from_pose(a).inverse().to_pose()
}

/// `PoseDist`: distance of the positions (mm) and angle between the
/// orientations (°).
pub fn pose_dist(a: &Pose, b: &Pose) -> (f64, f64) {
    let (fa, fb) = (Frame::from_pose(a), Frame::from_pose(b));
    (
        distance(&fa.translation.vector, &fb.translation.vector),
        angle_between(&fa.rotation, &fb.rotation),
    )
}

/// `PoseInterpolate`: straight line between the positions, spherical
/// interpolation between the orientations.
pub fn pose_interpolate(a: &Pose, b: &Pose, t: f64) -> Pose {
    let (fa, fb) = (Frame::from_pose(a), Frame::from_pose(b));
    let (pa, pb) = (fa.translation.vector, fb.translation.vector);
    frame_at(slerp(&fa.rotation, &fb.rotation, t), pa + (pb - pa) * t).to_pose()
}

/// An orthonormal frame from three points: origin `a`, X towards `b`, Z
/// normal to the plane `a, b, c`.
fn frame_of(a: Vec3, b: Vec3, c: Vec3) -> Option<Frame> {
    let x = unit(b - a)?;
    let z = unit(x.cross(&(c - a)))?;
    let y = z.cross(&x);
    let r = Rotation::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z]));
    Some(frame_at(r, a))
}

/// `PoseDefdFrame`: points 1-3 are features before a rotation, 4-6 the same
/// features after it. The result is the user frame `M⁻¹`, where `M` is the
/// rigid motion taking 1-3 onto 4-6 (this reproduces the document's
/// example `420,-445,25,0,-90,-90`). `None` if a triangle is degenerate.
pub fn pose_defd_frame(p: &[[f64; 3]; 6]) -> Option<Pose> {
    let v = p.map(Vec3::from);
    let before = frame_of(v[0], v[1], v[2])?;
    let after = frame_of(v[3], v[4], v[5])?;
    let motion = after * before.inverse();
    Some(motion.inverse().to_pose())
}

/// `Base2UcsTcp`: a flange pose in the base frame as a TCP pose in `ucs`
/// (`inv(UCS)·P·TCP`).
pub fn base_to_ucs_tcp(p: &Pose, tcp: &Pose, ucs: &Pose) -> Pose {
    (Frame::from_pose(ucs).inverse() * Frame::from_pose(p) * Frame::from_pose(tcp)).to_pose()
}

/// `UcsTcp2Base`: a TCP pose in `ucs` as a flange pose in the base frame
/// (`UCS·P·inv(TCP)`), the inverse of [`base_to_ucs_tcp`].
pub fn ucs_tcp_to_base(p: &Pose, tcp: &Pose, ucs: &Pose) -> Pose {
    (Frame::from_pose(ucs) * Frame::from_pose(p) * Frame::from_pose(tcp).inverse()).to_pose()
}

/// The flange frame that puts the TCP `tcp` at `pose` in user frame `ucs`.
pub fn flange_of(pose: &Pose, tcp: &Pose, ucs: &Pose) -> Frame {
    Frame::from_pose(ucs) * Frame::from_pose(pose) * Frame::from_pose(tcp).inverse()
}

/// Distance between two positions.
pub fn distance(a: &Vec3, b: &Vec3) -> f64 {
    (a - b).norm()
}

fn unit(a: Vec3) -> Option<Vec3> {
    let n = a.norm();
    (n > EPS).then(|| a / n)
}

/// The circle through `a`, `b`, `c`: returns centre, radius, the in-plane
/// unit vectors `u` (towards `a`) and `v`, and the angle from `a` to `c`
/// passing through `b` (radians, positive). `None` when the points are
/// collinear.
pub fn circle_through(a: Vec3, b: Vec3, c: Vec3) -> Option<(Vec3, f64, Vec3, Vec3, f64)> {
    let ab = b - a;
    let ac = c - a;
    let n = ab.cross(&ac);
    let nn = n.dot(&n);
    if nn < 1e-6 {
        return None;
    }
    // Circumcentre: a + (|ac|²(n×ab) + |ab|²(ac×n)) / (2|n|²)
    let t1 = n.cross(&ab) * ac.dot(&ac);
    let t2 = ac.cross(&n) * ab.dot(&ab);
    let centre = a + (t1 + t2) / (2.0 * nn);
    let radius = (a - centre).norm();
    let u = unit(a - centre)?;
    let nz = unit(n)?;
    let v = nz.cross(&u);
    let angle_of = |p: Vec3| {
        let d = p - centre;
        let ang = d.dot(&v).atan2(d.dot(&u));
        if ang < 0.0 {
            ang + 2.0 * std::f64::consts::PI
        } else {
            ang
        }
    };
    Some((centre, radius, u, v, angle_of(c)))
}

/// The point at angle `t` (radians) on a circle from [`circle_through`].
pub fn circle_point(centre: Vec3, radius: f64, u: Vec3, v: Vec3, t: f64) -> Vec3 {
    centre + u * (radius * t.cos()) + v * (radius * t.sin())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &[f64], b: &[f64], tol: f64) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
    }

    /// Angles equal modulo 360.
    fn same_angle(a: f64, b: f64) -> bool {
        let d = (a - b).rem_euclid(360.0);
        !(1e-3..=360.0 - 1e-3).contains(&d)
    }

    #[test]
    fn forward_matches_the_document() {
        let p = forward_pose(&[0.0, 0.0, 90.0, 0.0, 90.0, 0.0], &[0.0; 6], &[0.0; 6]);
        assert!(close(&p[..3], &[420.0, 0.0, 445.0], 1e-9), "{p:?}");
        assert!(same_angle(p[3], -180.0) && same_angle(p[4], 0.0) && same_angle(p[5], 180.0));
        let p = forward_pose(
            &[10.759, 0.0, 37.828, 0.0, 37.828, 0.0],
            &[0.0; 6],
            &[0.0; 6],
        );
        // The example's joints are rounded to 0.001°, which moves a point
        // ~1 m from the base by up to ~0.01 mm.
        let doc = [400.581, 76.115, 970.143, 0.0, 75.655, 10.759];
        assert!(close(&p, &doc, 1e-2), "{p:?}");
    }

    #[test]
    fn inverse_round_trips_and_picks_the_reference() {
        let lim = Limits::default();
        let q = inverse(
            &Frame::from_pose(&[420.0, 0.0, 445.0, 180.0, 0.0, 180.0]),
            &[0.0, 0.0, 90.0, 0.0, 90.0, 0.0],
            &lim,
        )
        .unwrap();
        assert!(close(&q, &[0.0, 0.0, 90.0, 0.0, 90.0, 0.0], 1e-6), "{q:?}");
        for q0 in [
            [10.0, 20.0, 30.0, 40.0, 50.0, 60.0],
            [-100.0, -30.0, 120.0, -170.0, -45.0, 200.0],
            [45.0, 10.0, 60.0, 0.0, 0.5, 0.0],
        ] {
            let q = inverse(&forward(&q0), &q0, &lim).unwrap();
            assert!(close(&q, &q0, 1e-6), "{q:?} vs {q0:?}");
        }
        assert!(inverse(
            &Frame::from_pose(&[5000.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            &[0.0; 6],
            &lim
        )
        .is_none());
    }

    #[test]
    fn pose_math_matches_the_document() {
        let a = [420.0, 0.0, 445.0, 180.0, 0.0, 180.0];
        let b = [420.0, 100.0, 445.0, 180.0, 0.0, 180.0];
        let z = |p: Pose, want: [f64; 6]| {
            assert!(close(&p[..3], &want[..3], 1e-9), "{p:?}");
            for i in 3..6 {
                assert!(same_angle(p[i], want[i]), "{p:?}");
            }
        };
        z(pose_add(&b, &b), [840.0, 200.0, 890.0, 0.0, 0.0, 0.0]);
        z(pose_sub(&a, &b), [0.0, -100.0, 0.0, 0.0, 0.0, 0.0]);
        z(pose_trans(&a, &b), [0.0, 100.0, 0.0, 0.0, 0.0, 0.0]);
        z(pose_inverse(&a), a);
        let (d, ang) = pose_dist(&a, &b);
        assert!((d - 100.0).abs() < 1e-9 && ang.abs() < 1e-6);
        z(
            pose_interpolate(&[420.0, 0.0, 445.0, 0.0, 0.0, 180.0], &b, 0.5),
            [420.0, 50.0, 445.0, 90.0, 0.0, 180.0],
        );
        z(
            base_to_ucs_tcp(&a, &[0.0; 6], &b),
            [0.0, -100.0, 0.0, 0.0, 0.0, 0.0],
        );
        z(
            ucs_tcp_to_base(&[0.0, -100.0, 0.0, 0.0, 0.0, 0.0], &[0.0; 6], &b),
            a,
        );
        let pts = [
            [420.0, 0.0, 445.0],
            [420.0, 50.0, 445.0],
            [470.0, 50.0, 445.0],
            [420.0, 0.0, 445.0],
            [420.0, 0.0, 495.0],
            [420.0, 50.0, 495.0],
        ];
        z(
            pose_defd_frame(&pts).unwrap(),
            [420.0, -445.0, 25.0, 0.0, -90.0, -90.0],
        );
    }

    #[test]
    fn quaternions_round_trip() {
        let m = rpy_to_rot(180.0, 0.0, 180.0);
        let q = rot_to_quat(&m);
        assert!(close(&q, &[0.0, 0.0, 1.0, 0.0], 1e-9), "{q:?}");
        let back = rot_to_rpy(&quat_to_rot(q).unwrap());
        assert!(same_angle(back[0], 180.0) && same_angle(back[2], 180.0));
        assert!(quat_to_rot([0.0; 4]).is_none());
        assert!(quat_to_rot([f64::NAN, 0.0, 0.0, 1.0]).is_none());
        // A half turn about -Y is written with its largest component positive.
        let q = rot_to_quat(&rot_y(-180.0));
        assert!(close(&q, &[0.0, 0.0, 1.0, 0.0], 1e-9), "{q:?}");
        let q = rot_to_quat(&rot_z(-90.0));
        assert!(q[0] > 0.0 && q[3] < 0.0, "{q:?}");
    }

    #[test]
    fn rpy_is_rz_ry_rx_and_reads_back() {
        for (rx, ry, rz) in [(10.0, 20.0, 30.0), (-170.0, 80.0, 5.0), (180.0, 0.0, 180.0)] {
            let m = rpy_to_rot(rx, ry, rz);
            let by_hand = rot_z(rz) * rot_y(ry) * rot_x(rx);
            assert!(angle_between(&m, &by_hand) < 1e-9);
            let back = rot_to_rpy(&m);
            assert!(angle_between(&rpy_to_rot(back[0], back[1], back[2]), &m) < 1e-9);
        }
        // Gimbal lock: the document's convention puts 0 in Rx.
        let [rx, ry, _] = rot_to_rpy(&rpy_to_rot(30.0, 90.0, 10.0));
        assert_eq!((rx, ry), (0.0, 90.0));
    }

    #[test]
    fn angles_and_slerp_stay_exact_at_the_extremes() {
        let a = rot_z(0.0);
        assert!(angle_between(&a, &rot_z(1e-7)) > 0.0);
        assert!((angle_between(&a, &rot_z(180.0)) - 180.0).abs() < 1e-9);
        let half = slerp(&a, &rot_z(90.0), 0.5);
        assert!(angle_between(&half, &rot_z(45.0)) < 1e-9);
        // The short way round, and equal ends give that rotation.
        let mid = slerp(&rot_z(170.0), &rot_z(-170.0), 0.5);
        assert!(angle_between(&mid, &rot_z(180.0)) < 1e-9);
        assert!(angle_between(&slerp(&a, &a, 0.3), &a) < 1e-12);
    }
}
