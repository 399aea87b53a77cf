//! Geometry of the shaped moves: arcs and full circles (`MoveC`,
//! `WayPoint2`), zig-zags (`MoveZ`) and spirals (`MoveS`), as TCP frames
//! for a Cartesian path. Approximations: the document gives no formulas.

use std::f64::consts::PI;

use crate::kinematics::{self as k, Frame, Vec3};

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
    let (c, r, u, v, ang) = k::circle_through(
        start.translation.vector,
        aux.translation.vector,
        end.translation.vector,
    )?;
    let total = if full { turns * 2.0 * PI } else { ang };
    let n = ((total * r / 5.0).ceil() as usize).clamp(8, 720);
    Some(
        (1..=n)
            .map(|i| {
                let t = total * i as f64 / n as f64;
                let frac = i as f64 / n as f64;
                let rot = if fixed {
                    start.rotation
                } else {
                    k::slerp(&start.rotation, &end.rotation, frac)
                };
                k::frame_at(rot, k::circle_point(c, r, u, v, t))
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
    let from = start.translation.vector;
    let d = end.translation.vector - from;
    let len = d.norm();
    if len < 1e-6 {
        return None;
    }
    let dir = d / len;
    let normal = match plane {
        Some(p) => {
            let n = dir.cross(&(p.translation.vector - from));
            let nn = n.norm();
            if nn < 1e-6 {
                return None;
            }
            n / nn
        }
        None => ucs.rotation * Vec3::z(),
    };
    // Sideways direction: in the plane, across the travel.
    let side = normal.cross(&dir);
    let n = ((len / pitch.max(0.1)).ceil() as usize).clamp(1, 500);
    let mut frames = Vec::with_capacity(n + 1);
    frames.push(*start);
    for i in 1..=n {
        let t = i as f64 / n as f64;
        let off = if i == n {
            0.0
        } else if i % 2 == 1 {
            width / 2.0
        } else {
            -width / 2.0
        };
        frames.push(k::frame_at(
            k::slerp(&start.rotation, &end.rotation, t),
            from + d * t + side * off,
        ));
    }
    Some(frames)
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
    let total = turns * 2.0 * PI;
    let n = ((turns * 72.0).ceil() as usize).clamp(2, 3000);
    let (ux, uy) = (ucs.rotation * Vec3::x(), ucs.rotation * Vec3::y());
    let centre = start.translation.vector;
    let mut frames = Vec::with_capacity(n);
    let mut length = 0.0;
    let mut prev = centre;
    for i in 0..=n {
        let th = total * i as f64 / n as f64;
        let r = 1.0 + incr * th / (2.0 * PI);
        let (s, c) = th.sin_cos();
        let p = centre + (ux * c + uy * s) * r;
        length += k::distance(&prev, &p);
        prev = p;
        frames.push(k::frame_at(start.rotation, p));
    }
    (frames, length, total.to_degrees())
}
