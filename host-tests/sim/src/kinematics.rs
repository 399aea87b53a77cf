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

/// A 3×3 rotation matrix, row-major.
pub type Mat3 = [[f64; 3]; 3];
/// A position or direction.
pub type Vec3 = [f64; 3];
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
pub fn rot_x(a: f64) -> Mat3 {
    let (s, c) = rad(a).sin_cos();
    [[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]]
}

/// Rotation about Y by `a` degrees.
pub fn rot_y(a: f64) -> Mat3 {
    let (s, c) = rad(a).sin_cos();
    [[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]]
}

/// Rotation about Z by `a` degrees.
pub fn rot_z(a: f64) -> Mat3 {
    let (s, c) = rad(a).sin_cos();
    [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
}

/// `a · b`.
pub fn mat_mul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, cell) in row.iter_mut().enumerate() {
            *cell = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

/// `m · v`.
pub fn mat_vec(m: &Mat3, v: &Vec3) -> Vec3 {
    [
        m[0][0] * v[0] + m[0][1] * v[1] + m[0][2] * v[2],
        m[1][0] * v[0] + m[1][1] * v[1] + m[1][2] * v[2],
        m[2][0] * v[0] + m[2][1] * v[1] + m[2][2] * v[2],
    ]
}

/// The transpose (= inverse of a rotation).
pub fn transpose(m: &Mat3) -> Mat3 {
    let mut t = [[0.0; 3]; 3];
    for (i, row) in m.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            t[j][i] = *v;
        }
    }
    t
}

fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn scale(a: Vec3, k: f64) -> Vec3 {
    [a[0] * k, a[1] * k, a[2] * k]
}

fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}

fn unit(a: Vec3) -> Option<Vec3> {
    let n = norm(a);
    (n > EPS).then(|| scale(a, 1.0 / n))
}

/// The rotation of roll-pitch-yaw angles (°): `Rz(rz)·Ry(ry)·Rx(rx)`.
pub fn rpy_to_mat(rx: f64, ry: f64, rz: f64) -> Mat3 {
    mat_mul(&rot_z(rz), &mat_mul(&rot_y(ry), &rot_x(rx)))
}

/// Roll-pitch-yaw angles (°) of a rotation, each in -180..=180, `ry` in
/// -90..=90; `rx = 0` at gimbal lock.
pub fn mat_to_rpy(m: &Mat3) -> [f64; 3] {
    let sy = (-m[2][0]).clamp(-1.0, 1.0);
    if sy.abs() > 1.0 - 1e-10 {
        let ry = if sy > 0.0 { 90.0 } else { -90.0 };
        let rz = deg(clean(-m[0][1]).atan2(clean(m[1][1])));
        [0.0, ry, rz]
    } else {
        let ry = deg(sy.asin());
        let rx = deg(clean(m[2][1]).atan2(clean(m[2][2])));
        let rz = deg(clean(m[1][0]).atan2(clean(m[0][0])));
        [rx, ry, rz]
    }
}

/// A unit quaternion `[w, x, y, z]` of a rotation (w >= 0).
pub fn mat_to_quat(m: &Mat3) -> [f64; 4] {
    let tr = m[0][0] + m[1][1] + m[2][2];
    let q = if tr > 0.0 {
        let s = (tr + 1.0).sqrt() * 2.0;
        [
            0.25 * s,
            (m[2][1] - m[1][2]) / s,
            (m[0][2] - m[2][0]) / s,
            (m[1][0] - m[0][1]) / s,
        ]
    } else if m[0][0] > m[1][1] && m[0][0] > m[2][2] {
        let s = (1.0 + m[0][0] - m[1][1] - m[2][2]).sqrt() * 2.0;
        [
            (m[2][1] - m[1][2]) / s,
            0.25 * s,
            (m[0][1] + m[1][0]) / s,
            (m[0][2] + m[2][0]) / s,
        ]
    } else if m[1][1] > m[2][2] {
        let s = (1.0 + m[1][1] - m[0][0] - m[2][2]).sqrt() * 2.0;
        [
            (m[0][2] - m[2][0]) / s,
            (m[0][1] + m[1][0]) / s,
            0.25 * s,
            (m[1][2] + m[2][1]) / s,
        ]
    } else {
        let s = (1.0 + m[2][2] - m[0][0] - m[1][1]).sqrt() * 2.0;
        [
            (m[1][0] - m[0][1]) / s,
            (m[0][2] + m[2][0]) / s,
            (m[1][2] + m[2][1]) / s,
            0.25 * s,
        ]
    };
    let q = if q[0] < 0.0 {
        [-q[0], -q[1], -q[2], -q[3]]
    } else {
        q
    };
    q.map(clean)
}

/// The rotation of a quaternion `[w, x, y, z]`; `None` for a zero quaternion.
/// Quaternions that are not unit length are normalised first.
pub fn quat_to_mat(q: [f64; 4]) -> Option<Mat3> {
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    if n < EPS || !n.is_finite() {
        return None;
    }
    let [w, x, y, z] = q.map(|v| v / n);
    Some([
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ])
}

/// The angle (°, 0..=180) of a rotation.
pub fn rotation_angle(m: &Mat3) -> f64 {
    let c = ((m[0][0] + m[1][1] + m[2][2] - 1.0) / 2.0).clamp(-1.0, 1.0);
    deg(c.acos())
}

/// Spherical interpolation between two rotations (`t` = 0 gives `a`).
pub fn slerp(a: &Mat3, b: &Mat3, t: f64) -> Mat3 {
    let qa = mat_to_quat(a);
    let mut qb = mat_to_quat(b);
    let mut d: f64 = qa.iter().zip(&qb).map(|(x, y)| x * y).sum();
    if d < 0.0 {
        qb = qb.map(|v| -v);
        d = -d;
    }
    let q = if d > 0.9995 {
        let mut q = [0.0; 4];
        for i in 0..4 {
            q[i] = qa[i] + t * (qb[i] - qa[i]);
        }
        q
    } else {
        let th = d.clamp(-1.0, 1.0).acos();
        let (s0, s1) = (((1.0 - t) * th).sin(), (t * th).sin());
        let s = th.sin();
        let mut q = [0.0; 4];
        for i in 0..4 {
            q[i] = (s0 * qa[i] + s1 * qb[i]) / s;
        }
        q
    };
    quat_to_mat(q).unwrap_or(*a)
}

/// A rigid transform: rotation then translation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// Rotation.
    pub r: Mat3,
    /// Translation (mm).
    pub p: Vec3,
}

impl Frame {
    /// The identity.
    pub const IDENTITY: Frame = Frame {
        r: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        p: [0.0; 3],
    };

    /// The frame of a pose.
    pub fn from_pose(p: &Pose) -> Frame {
        Frame {
            r: rpy_to_mat(p[3], p[4], p[5]),
            p: [p[0], p[1], p[2]],
        }
    }

    /// The pose of this frame.
    pub fn to_pose(&self) -> Pose {
        let [rx, ry, rz] = mat_to_rpy(&self.r);
        [
            clean(self.p[0]),
            clean(self.p[1]),
            clean(self.p[2]),
            rx,
            ry,
            rz,
        ]
    }

    /// `self · o`.
    pub fn mul(&self, o: &Frame) -> Frame {
        Frame {
            r: mat_mul(&self.r, &o.r),
            p: add(mat_vec(&self.r, &o.p), self.p),
        }
    }

    /// The inverse transform.
    pub fn inverse(&self) -> Frame {
        let rt = transpose(&self.r);
        Frame {
            r: rt,
            p: scale(mat_vec(&rt, &self.p), -1.0),
        }
    }
}

/// The flange frame of joint angles, in the base frame.
pub fn forward(q: &Joints) -> Frame {
    let r1 = rot_z(q[0]);
    let r12 = mat_mul(&r1, &rot_y(q[1]));
    let r13 = mat_mul(&r1, &rot_y(q[1] + q[2]));
    let r = mat_mul(
        &r13,
        &mat_mul(&rot_z(q[3]), &mat_mul(&rot_y(q[4]), &rot_z(q[5]))),
    );
    let mut p = [0.0, 0.0, D1];
    p = add(p, mat_vec(&r12, &[0.0, 0.0, L2]));
    p = add(p, mat_vec(&r13, &[0.0, 0.0, L3]));
    p = add(p, mat_vec(&r, &[0.0, 0.0, L6]));
    Frame { r, p }
}

/// The TCP pose of joints `q` with tool `tcp`, in user frame `ucs`
/// (`inv(UCS)·F(q)·TCP`): what `GetForwardKin` and `ReadActPos` report.
pub fn forward_pose(q: &Joints, tcp: &Pose, ucs: &Pose) -> Pose {
    Frame::from_pose(ucs)
        .inverse()
        .mul(&forward(q))
        .mul(&Frame::from_pose(tcp))
        .to_pose()
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
    let z = [target.r[0][2], target.r[1][2], target.r[2][2]];
    let w = sub(target.p, scale(z, L6));
    let rho = (w[0] * w[0] + w[1] * w[1]).sqrt();
    let h = w[2] - D1;
    let mut best: Option<(f64, f64, Joints)> = None;
    let base_q1 = if rho < 1e-6 {
        rad(reference[0])
    } else {
        w[1].atan2(w[0])
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
            let r03 = mat_mul(&rot_z(deg(q1)), &rot_y(deg(q2 + q3)));
            let m = mat_mul(&transpose(&r03), &target.r);
            let sb = (m[0][2] * m[0][2] + m[1][2] * m[1][2]).sqrt();
            let wrists: Vec<(f64, f64, f64)> = if sb < 1e-9 {
                // q5 = 0 or 180: only q4 ± q6 is determined; keep q4.
                let q4 = rad(reference[3]);
                if m[2][2] > 0.0 {
                    let q46 = m[1][0].atan2(m[0][0]);
                    vec![(q4, 0.0, q46 - q4)]
                } else {
                    let q46 = (-m[1][0]).atan2(-m[0][0]);
                    vec![(q4, std::f64::consts::PI, q4 - q46)]
                }
            } else {
                let b = sb.atan2(m[2][2]);
                let a = m[1][2].atan2(m[0][2]);
                let c = m[2][1].atan2(-m[2][0]);
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
    (norm(sub(f.p, target.p)) < 1e-3
        && rotation_angle(&mat_mul(&transpose(&f.r), &target.r)) < 1e-3)
        .then_some(q)
}

/// `PoseAdd`: positions add, the second rotation left-multiplies the first
/// (`840,200,890,0,0,0` for the document's example).
pub fn pose_add(a: &Pose, b: &Pose) -> Pose {
    let (fa, fb) = (Frame::from_pose(a), Frame::from_pose(b));
    Frame {
        r: mat_mul(&fb.r, &fa.r),
        p: add(fa.p, fb.p),
    }
    .to_pose()
}

/// `PoseSub`: the inverse of [`pose_add`]: positions subtract, the first
/// rotation relative to the second (`R2ᵀ·R1`).
pub fn pose_sub(a: &Pose, b: &Pose) -> Pose {
    let (fa, fb) = (Frame::from_pose(a), Frame::from_pose(b));
    Frame {
        r: mat_mul(&transpose(&fb.r), &fa.r),
        p: sub(fa.p, fb.p),
    }
    .to_pose()
}

/// `PoseTrans`: pose 2 expressed in frame pose 1 (`P1·P2`).
pub fn pose_trans(a: &Pose, b: &Pose) -> Pose {
    Frame::from_pose(a).mul(&Frame::from_pose(b)).to_pose()
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
        norm(sub(fa.p, fb.p)),
        rotation_angle(&mat_mul(&transpose(&fa.r), &fb.r)),
    )
}

/// `PoseInterpolate`: straight line between the positions, spherical
/// interpolation between the orientations.
pub fn pose_interpolate(a: &Pose, b: &Pose, t: f64) -> Pose {
    let (fa, fb) = (Frame::from_pose(a), Frame::from_pose(b));
    Frame {
        r: slerp(&fa.r, &fb.r, t),
        p: add(fa.p, scale(sub(fb.p, fa.p), t)),
    }
    .to_pose()
}

/// An orthonormal frame from three points: origin `a`, X towards `b`, Z
/// normal to the plane `a, b, c`.
fn frame_of(a: Vec3, b: Vec3, c: Vec3) -> Option<Frame> {
    let x = unit(sub(b, a))?;
    let z = unit(cross(x, sub(c, a)))?;
    let y = cross(z, x);
    Some(Frame {
        r: [[x[0], y[0], z[0]], [x[1], y[1], z[1]], [x[2], y[2], z[2]]],
        p: a,
    })
}

/// `PoseDefdFrame`: points 1-3 are features before a rotation, 4-6 the same
/// features after it. The result is the user frame `M⁻¹`, where `M` is the
/// rigid motion taking 1-3 onto 4-6 (this reproduces the document's
/// example `420,-445,25,0,-90,-90`). `None` if a triangle is degenerate.
pub fn pose_defd_frame(p: &[Vec3; 6]) -> Option<Pose> {
    let before = frame_of(p[0], p[1], p[2])?;
    let after = frame_of(p[3], p[4], p[5])?;
    let motion = after.mul(&before.inverse());
    Some(motion.inverse().to_pose())
}

/// `Base2UcsTcp`: a flange pose in the base frame as a TCP pose in `ucs`
/// (`inv(UCS)·P·TCP`).
pub fn base_to_ucs_tcp(p: &Pose, tcp: &Pose, ucs: &Pose) -> Pose {
    Frame::from_pose(ucs)
        .inverse()
        .mul(&Frame::from_pose(p))
        .mul(&Frame::from_pose(tcp))
        .to_pose()
}

/// `UcsTcp2Base`: a TCP pose in `ucs` as a flange pose in the base frame
/// (`UCS·P·inv(TCP)`), the inverse of [`base_to_ucs_tcp`].
pub fn ucs_tcp_to_base(p: &Pose, tcp: &Pose, ucs: &Pose) -> Pose {
    Frame::from_pose(ucs)
        .mul(&Frame::from_pose(p))
        .mul(&Frame::from_pose(tcp).inverse())
        .to_pose()
}

/// The flange frame that puts the TCP `tcp` at `pose` in user frame `ucs`.
pub fn flange_of(pose: &Pose, tcp: &Pose, ucs: &Pose) -> Frame {
    Frame::from_pose(ucs)
        .mul(&Frame::from_pose(pose))
        .mul(&Frame::from_pose(tcp).inverse())
}

/// Distance between two positions.
pub fn distance(a: Vec3, b: Vec3) -> f64 {
    norm(sub(a, b))
}

/// A point on the circle through `a`, `b`, `c`: returns centre, radius,
/// the in-plane unit vectors `u` (towards `a`) and `v`, and the angle from
/// `a` to `c` passing through `b` (radians, positive). `None` when the points
/// are collinear.
pub fn circle_through(a: Vec3, b: Vec3, c: Vec3) -> Option<(Vec3, f64, Vec3, Vec3, f64)> {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let n = cross(ab, ac);
    let nn = dot(n, n);
    if nn < 1e-6 {
        return None;
    }
    // Circumcentre: a + (|ac|²(n×ab) + |ab|²(ac×n)) / (2|n|²)
    let t1 = scale(cross(n, ab), dot(ac, ac));
    let t2 = scale(cross(ac, n), dot(ab, ab));
    let centre = add(a, scale(add(t1, t2), 1.0 / (2.0 * nn)));
    let radius = norm(sub(a, centre));
    let u = unit(sub(a, centre))?;
    let nz = unit(n)?;
    let v = cross(nz, u);
    let angle_of = |p: Vec3| {
        let d = sub(p, centre);
        let ang = dot(d, v).atan2(dot(d, u));
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
    add(
        centre,
        add(scale(u, radius * t.cos()), scale(v, radius * t.sin())),
    )
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
        let m = rpy_to_mat(180.0, 0.0, 180.0);
        let q = mat_to_quat(&m);
        assert!(close(&q, &[0.0, 0.0, 1.0, 0.0], 1e-9), "{q:?}");
        let back = mat_to_rpy(&quat_to_mat(q).unwrap());
        assert!(same_angle(back[0], 180.0) && same_angle(back[2], 180.0));
        assert!(quat_to_mat([0.0; 4]).is_none());
    }
}
