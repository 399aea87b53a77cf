//! Geometry of the shaped moves: arcs and full circles (`MoveC`,
//! `WayPoint2`), zig-zags (`MoveZ`) and spirals (`MoveS`), as TCP frames
//! for a Cartesian path. Approximations: the document gives no formulas.

use crate::kinematics::{self as k, Frame};

/// TCP frames along an arc from `start` through `aux` to `end` (the start
/// itself excluded), or `turns` full circles when `full`. Orientation is
/// interpolated from start to end, or kept when `fixed`.
pub(super) fn arc_frames(
    start: &Frame,
    aux: &Frame,
    end: &Frame,
    full: bool,
    turns: f64,
    fixed: bool,
) -> Option<Vec<Frame>> {
    let (c, r, u, v, ang) = k::circle_through(start.p, aux.p, end.p)?;
    let total = if full {
        turns * 2.0 * std::f64::consts::PI
    } else {
        ang
    };
    let n = ((total * r / 5.0).ceil() as usize).clamp(8, 720);
    Some(
        (1..=n)
            .map(|i| {
                let t = total * i as f64 / n as f64;
                let frac = i as f64 / n as f64;
                Frame {
                    r: if fixed {
                        start.r
                    } else {
                        k::slerp(&start.r, &end.r, frac)
                    },
                    p: k::circle_point(c, r, u, v, t),
                }
            })
            .collect(),
    )
}

/// A zig-zag from `start` to `end`, `width` wide, one turn every `pitch` mm
/// of advance, in the plane through start, end and `plane` (or the user
/// frame's XY plane).
pub(super) fn zigzag_frames(
    start: &Frame,
    end: &Frame,
    plane: Option<&Frame>,
    ucs: &Frame,
    width: f64,
    pitch: f64,
) -> Option<Vec<Frame>> {
    let d = [
        end.p[0] - start.p[0],
        end.p[1] - start.p[1],
        end.p[2] - start.p[2],
    ];
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    if len < 1e-6 {
        return None;
    }
    let dir = [d[0] / len, d[1] / len, d[2] / len];
    let normal = match plane {
        Some(p) => {
            let w = [
                p.p[0] - start.p[0],
                p.p[1] - start.p[1],
                p.p[2] - start.p[2],
            ];
            let n = [
                dir[1] * w[2] - dir[2] * w[1],
                dir[2] * w[0] - dir[0] * w[2],
                dir[0] * w[1] - dir[1] * w[0],
            ];
            let nn = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if nn < 1e-6 {
                return None;
            }
            [n[0] / nn, n[1] / nn, n[2] / nn]
        }
        None => [ucs.r[0][2], ucs.r[1][2], ucs.r[2][2]],
    };
    // Sideways direction: in the plane, across the travel.
    let side = [
        normal[1] * dir[2] - normal[2] * dir[1],
        normal[2] * dir[0] - normal[0] * dir[2],
        normal[0] * dir[1] - normal[1] * dir[0],
    ];
    let n = ((len / pitch.max(0.1)).ceil() as usize).clamp(1, 500);
    let mut frames = Vec::with_capacity(n + 1);
    for i in 1..=n {
        let t = i as f64 / n as f64;
        let off = if i == n {
            0.0
        } else if i % 2 == 1 {
            width / 2.0
        } else {
            -width / 2.0
        };
        frames.push(Frame {
            r: k::slerp(&start.r, &end.r, t),
            p: [
                start.p[0] + d[0] * t + side[0] * off,
                start.p[1] + d[1] * t + side[1] * off,
                start.p[2] + d[2] * t + side[2] * off,
            ],
        });
    }
    let mut all = vec![*start];
    all.extend(frames);
    Some(all)
}

/// An Archimedean spiral in the user frame's XY plane around the start:
/// radius from 1 mm growing by `incr` per turn up to `end_radius`. Returns
/// the frames, the path length (mm) and the total turning (°).
pub(super) fn spiral_frames(
    start: &Frame,
    ucs: &Frame,
    incr: f64,
    end_radius: f64,
) -> (Vec<Frame>, f64, f64) {
    let turns = ((end_radius - 1.0) / incr.max(1e-3)).clamp(0.0, 200.0);
    let total = turns * 2.0 * std::f64::consts::PI;
    let n = ((turns * 72.0).ceil() as usize).clamp(2, 3000);
    let (ux, uy) = (
        [ucs.r[0][0], ucs.r[1][0], ucs.r[2][0]],
        [ucs.r[0][1], ucs.r[1][1], ucs.r[2][1]],
    );
    let mut frames = Vec::with_capacity(n);
    let mut length = 0.0;
    let mut prev = start.p;
    for i in 0..=n {
        let th = total * i as f64 / n as f64;
        let r = 1.0 + incr * th / (2.0 * std::f64::consts::PI);
        let (s, c) = th.sin_cos();
        let p = [
            start.p[0] + r * (c * ux[0] + s * uy[0]),
            start.p[1] + r * (c * ux[1] + s * uy[1]),
            start.p[2] + r * (c * ux[2] + s * uy[2]),
        ];
        length += k::distance(prev, p);
        prev = p;
        frames.push(Frame { r: start.r, p });
    }
    (frames, length, total.to_degrees())
}
