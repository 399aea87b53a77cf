//! Motion: geometric paths in joint space and the velocity profiles that
//! move along them in time.
//!
//! A move is planned once, when it is accepted: the path is sampled into a
//! table of joint positions at equal steps of its length `s` (degrees of the
//! leading joint for joint moves, millimetres of TCP travel for Cartesian
//! ones; every sample solved by inverse kinematics from the previous one).
//! A [`Profile`] then gives `s(t)`. Stopping, pausing and continuing replace
//! the profile, never the path, so the robot always stays on its path.

use crate::kinematics::{self as k, Frame, Joints, Limits};

/// Longest step between two samples of a Cartesian path (mm or °).
const STEP: f64 = 2.0;
/// Most samples in one path; longer paths use longer steps.
const MAX_SAMPLES: usize = 4000;

/// A path through joint space, sampled at equal steps of `s`.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Path {
    samples: Vec<Joints>,
    length: f64,
}

/// Why a move cannot be planned.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum PlanError {
    /// A point is out of reach or outside the joint limits.
    Unreachable,
}

impl Path {
    /// A straight line in joint space; `s` is the travel of the joint that
    /// moves most.
    pub fn joint_line(a: Joints, b: Joints) -> Path {
        let length = (0..6).map(|i| (b[i] - a[i]).abs()).fold(0.0, f64::max);
        Path {
            samples: vec![a, b],
            length,
        }
    }

    /// A polyline through joint points, each leg a joint-space line; `s`
    /// adds up the legs' leading-joint travel.
    pub fn joint_polyline(points: &[Joints]) -> Path {
        // Resample at 1° steps of the leading joint so that `at` stays a
        // uniform table.
        let mut legs = Vec::new();
        let mut total = 0.0;
        for w in points.windows(2) {
            let l = Path::joint_line(w[0], w[1]).length;
            legs.push(l);
            total += l;
        }
        if total <= 0.0 {
            let p = points.first().copied().unwrap_or([0.0; 6]);
            return Path {
                samples: vec![p, p],
                length: 0.0,
            };
        }
        let n = ((total / 1.0).ceil() as usize).clamp(1, MAX_SAMPLES);
        let mut samples = Vec::with_capacity(n + 1);
        for i in 0..=n {
            let mut s = total * i as f64 / n as f64;
            let mut leg = 0;
            while leg + 1 < legs.len() && s > legs[leg] {
                s -= legs[leg];
                leg += 1;
            }
            let (a, b) = (points[leg], points[leg + 1]);
            let f = if legs[leg] > 0.0 {
                (s / legs[leg]).clamp(0.0, 1.0)
            } else {
                1.0
            };
            samples.push(lerp(&a, &b, f));
        }
        Path {
            samples,
            length: total,
        }
    }

    /// A Cartesian path through TCP frames (in the base frame), straight
    /// lines between them with spherical interpolation of the orientation,
    /// for tool `tcp`, starting from joints `start`. A leg whose positions
    /// coincide counts its rotation angle (°) as its length.
    pub fn cartesian(
        start: Joints,
        waypoints: &[Frame],
        tcp: &Frame,
        limits: &Limits,
    ) -> Result<Path, PlanError> {
        Path::cartesian_upto(start, waypoints, tcp, limits, false)
    }

    /// As [`Path::cartesian`], but a path that leaves the reachable space
    /// (or would flip through a singularity) ends at its last reachable
    /// sample instead of failing: how far a jog along a line can go.
    pub fn cartesian_reachable(
        start: Joints,
        waypoints: &[Frame],
        tcp: &Frame,
        limits: &Limits,
    ) -> Path {
        Path::cartesian_upto(start, waypoints, tcp, limits, true)
            .unwrap_or_else(|_| Path::dwell(start))
    }

    fn cartesian_upto(
        start: Joints,
        waypoints: &[Frame],
        tcp: &Frame,
        limits: &Limits,
        partial: bool,
    ) -> Result<Path, PlanError> {
        let tcp_inv = tcp.inverse();
        let from = k::forward(&start) * tcp;
        let mut frames = vec![from];
        frames.extend_from_slice(waypoints);
        let legs: Vec<f64> = frames
            .windows(2)
            .map(|w| {
                let d = k::distance(&w[0].translation.vector, &w[1].translation.vector);
                if d > 1e-3 {
                    d
                } else {
                    k::angle_between(&w[0].rotation, &w[1].rotation)
                }
            })
            .collect();
        let total: f64 = legs.iter().sum();
        let mut samples = vec![start];
        let mut q = start;
        if total > 1e-9 {
            let n = ((total / STEP).ceil() as usize).clamp(1, MAX_SAMPLES);
            let mut leg = 0;
            let mut leg_start = 0.0;
            for i in 1..=n {
                let s = total * i as f64 / n as f64;
                while leg + 1 < legs.len() && s > leg_start + legs[leg] + 1e-12 {
                    leg_start += legs[leg];
                    leg += 1;
                }
                let f = if legs[leg] > 0.0 {
                    ((s - leg_start) / legs[leg]).clamp(0.0, 1.0)
                } else {
                    1.0
                };
                let (a, b) = (&frames[leg], &frames[leg + 1]);
                let (pa, pb) = (a.translation.vector, b.translation.vector);
                let tcp_frame =
                    k::frame_at(k::slerp(&a.rotation, &b.rotation, f), pa + (pb - pa) * f);
                let flange = tcp_frame * tcp_inv;
                // A jump means the solution flipped (a singularity): the
                // controller would refuse such a straight line too.
                let next = k::inverse(&flange, &q, limits)
                    .filter(|next| (0..6).all(|j| (next[j] - q[j]).abs() <= 45.0));
                match next {
                    Some(next) => q = next,
                    None if partial => {
                        // Samples stay equally spaced: the path is the
                        // first `i - 1` steps.
                        let length = total * (i - 1) as f64 / n as f64;
                        if samples.len() < 2 {
                            samples.push(start);
                        }
                        return Ok(Path { samples, length });
                    }
                    None => return Err(PlanError::Unreachable),
                }
                samples.push(q);
            }
        } else {
            samples.push(start);
        }
        Ok(Path {
            samples,
            length: total,
        })
    }

    /// A path that stays at `q` (used to wait, e.g. while a path computes).
    pub fn dwell(q: Joints) -> Path {
        Path {
            samples: vec![q, q],
            length: 0.0,
        }
    }

    /// Length in `s` units.
    pub fn length(&self) -> f64 {
        self.length
    }

    /// The first point.
    pub fn start(&self) -> Joints {
        self.samples.first().copied().unwrap_or([0.0; 6])
    }

    /// The last point.
    pub fn end(&self) -> Joints {
        self.samples.last().copied().unwrap_or([0.0; 6])
    }

    /// The joints at `s` (clamped to the path).
    pub fn at(&self, s: f64) -> Joints {
        let n = self.samples.len();
        if n < 2 || self.length <= 0.0 {
            return self.end();
        }
        let x = (s / self.length).clamp(0.0, 1.0) * (n - 1) as f64;
        let i = (x.floor() as usize).min(n - 2);
        lerp(&self.samples[i], &self.samples[i + 1], x - i as f64)
    }
}

fn lerp(a: &Joints, b: &Joints, f: f64) -> Joints {
    let mut q = [0.0; 6];
    for i in 0..6 {
        q[i] = a[i] + (b[i] - a[i]) * f;
    }
    q
}

/// `s(t)` along a path. Times are simulated seconds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Profile {
    /// Rest to rest: accelerate at `a`, cruise at `v`, decelerate at `a`
    /// (a triangle when the distance is too short to reach `v`).
    Trap {
        t0: f64,
        s0: f64,
        s1: f64,
        v: f64,
        a: f64,
    },
    /// Constant speed from `s0` to `s1` in `dur` (servo streaming).
    Linear { t0: f64, s0: f64, s1: f64, dur: f64 },
    /// Decelerate from `v0` at `a` until at rest (never past `s_max`).
    Brake {
        t0: f64,
        s0: f64,
        v0: f64,
        a: f64,
        s_max: f64,
    },
    /// At rest at `s`.
    Hold { s: f64 },
}

impl Profile {
    /// Trapezoid timings: (accel time, cruise time, peak speed).
    fn trap_times(d: f64, v: f64, a: f64) -> (f64, f64, f64) {
        let da = v * v / (2.0 * a);
        if 2.0 * da >= d {
            let vp = (d * a).sqrt();
            (vp / a, 0.0, vp)
        } else {
            (v / a, (d - 2.0 * da) / v, v)
        }
    }

    /// Position and speed at time `t`.
    pub fn sample(&self, t: f64) -> (f64, f64) {
        match *self {
            Profile::Trap { t0, s0, s1, v, a } => {
                let d = s1 - s0;
                if d <= 0.0 {
                    return (s1, 0.0);
                }
                let (ta, tc, vp) = Self::trap_times(d, v, a);
                let total = 2.0 * ta + tc;
                let tau = (t - t0).clamp(0.0, total);
                if tau < ta {
                    (s0 + 0.5 * a * tau * tau, a * tau)
                } else if tau < ta + tc {
                    (s0 + 0.5 * vp * ta + vp * (tau - ta), vp)
                } else {
                    let td = total - tau;
                    (s1 - 0.5 * a * td * td, a * td)
                }
            }
            Profile::Linear { t0, s0, s1, dur } => {
                if dur <= 0.0 {
                    return (s1, 0.0);
                }
                let f = ((t - t0) / dur).clamp(0.0, 1.0);
                let v = if f < 1.0 { (s1 - s0) / dur } else { 0.0 };
                (s0 + (s1 - s0) * f, v)
            }
            Profile::Brake {
                t0,
                s0,
                v0,
                a,
                s_max,
            } => {
                let tb = if a > 0.0 { v0 / a } else { 0.0 };
                let tau = (t - t0).clamp(0.0, tb);
                (
                    (s0 + v0 * tau - 0.5 * a * tau * tau).min(s_max),
                    v0 - a * tau,
                )
            }
            Profile::Hold { s } => (s, 0.0),
        }
    }

    /// When it comes to rest; `None` for [`Profile::Hold`].
    pub fn end(&self) -> Option<f64> {
        match *self {
            Profile::Trap { t0, s0, s1, v, a } => {
                let d = s1 - s0;
                if d <= 0.0 {
                    return Some(t0);
                }
                let (ta, tc, _) = Self::trap_times(d, v, a);
                Some(t0 + 2.0 * ta + tc)
            }
            Profile::Linear { t0, dur, .. } => Some(t0 + dur.max(0.0)),
            Profile::Brake { t0, v0, a, .. } => Some(t0 + if a > 0.0 { v0 / a } else { 0.0 }),
            Profile::Hold { .. } => None,
        }
    }

    /// Where it comes to rest.
    pub fn final_s(&self) -> f64 {
        match self.end() {
            Some(t) => self.sample(t).0,
            None => self.sample(0.0).0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::PoseFrame;

    #[test]
    fn trapezoid_reaches_the_end_at_the_computed_time() {
        // 90° at 50°/s, 100°/s²: 0.5 s up, 1.3 s cruise, 0.5 s down.
        let p = Profile::Trap {
            t0: 1.0,
            s0: 0.0,
            s1: 90.0,
            v: 50.0,
            a: 100.0,
        };
        let end = p.end().unwrap();
        assert!((end - 3.3).abs() < 1e-9, "{end}");
        assert_eq!(p.sample(0.5), (0.0, 0.0));
        let (s, v) = p.sample(1.5);
        assert!((s - 12.5).abs() < 1e-9 && (v - 50.0).abs() < 1e-9);
        assert_eq!(p.sample(10.0).0, 90.0);
        // Too short to cruise: a triangle.
        let p = Profile::Trap {
            t0: 0.0,
            s0: 0.0,
            s1: 1.0,
            v: 50.0,
            a: 100.0,
        };
        assert!((p.end().unwrap() - 0.2).abs() < 1e-9);
    }

    #[test]
    fn brake_stops_within_its_distance() {
        let p = Profile::Brake {
            t0: 0.0,
            s0: 10.0,
            v0: 50.0,
            a: 100.0,
            s_max: 100.0,
        };
        assert!((p.end().unwrap() - 0.5).abs() < 1e-9);
        assert!((p.final_s() - 22.5).abs() < 1e-9);
    }

    #[test]
    fn cartesian_line_keeps_the_tcp_on_the_line() {
        let start = [0.0, 0.0, 90.0, 0.0, 90.0, 0.0];
        let goal = Frame::from_pose(&[420.0, 100.0, 445.0, 180.0, 0.0, 180.0]);
        let path = Path::cartesian(start, &[goal], &Frame::identity(), &Limits::default()).unwrap();
        assert!((path.length() - 100.0).abs() < 1e-9);
        let mid = k::forward(&path.at(50.0)).translation.vector;
        assert!(
            (mid[0] - 420.0).abs() < 1e-6 && (mid[1] - 50.0).abs() < 1e-6,
            "{mid:?}"
        );
        let far = Frame::from_pose(&[2000.0, 0.0, 445.0, 180.0, 0.0, 180.0]);
        assert_eq!(
            Path::cartesian(start, &[far], &Frame::identity(), &Limits::default()),
            Err(PlanError::Unreachable)
        );
    }
}
