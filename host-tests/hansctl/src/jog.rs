//! `hansctl jog`: jogging with the V6 document's commands (4.10.14-18).
//!
//! A long jog is `LongJogJ`/`LongJogL` with state 1, then `LongMoveEvent`
//! every [`EVENT_PERIOD`] (the document: at least every 200 ms, or the
//! controller stops the jog), then the same jog with state 0. If hansctl
//! dies or the link drops, the events stop and so does the robot. A short
//! jog is one `ShortJogJ`/`ShortJogL` (2° or 2 mm).
//!
//! From a terminal the jog runs while a key is held. A terminal reports key
//! presses, not releases: holding a key makes the keyboard repeat it, after
//! a delay (250-600 ms on common systems) and then some 25-30 times a
//! second. So the jog starts at the first key, is held while the repeats
//! come, and stops when none has come for [`RELEASE_GAP`] ([`FIRST_REPEAT`]
//! before the first repeat): about 0.15-0.25 s after the key is released.
//! `q`, Esc and Ctrl-C stop at once.

use std::io::{IsTerminal, Read};
use std::process::{Command as Process, Stdio};
use std::time::{Duration, Instant};

use hans_codec::{request as rq, CommandId, Decimal, FsmState, ProtocolLevel, RobotId};

use crate::client::{Client, ClientError};
use crate::{fmt6, fsm_name, obj, read_act_pos, read_fsm, Exit};

/// How often `LongMoveEvent` goes out: half the document's 200 ms, so one
/// late event does not stop the jog.
pub const EVENT_PERIOD: Duration = Duration::from_millis(100);
/// Longest wait for the keyboard's first repeat after the key went down.
pub const FIRST_REPEAT: Duration = Duration::from_millis(700);
/// Longest gap between two repeats while a key is held.
pub const RELEASE_GAP: Duration = Duration::from_millis(150);

/// What to jog: a joint, or a direction of the user (or tool) frame.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Axis {
    /// X, Y, Z, Rx, Ry, Rz (`true`) or a joint.
    pub cartesian: bool,
    /// 0-5: J1-J6 or X-Rz.
    pub index: i32,
    /// The positive direction.
    pub positive: bool,
}

impl Axis {
    /// `j1+` .. `j6-`, `x+`, `rz-`, ... (case-insensitive).
    pub fn parse(text: &str) -> Result<Axis, String> {
        let t = text.trim().to_ascii_lowercase();
        let bad = || format!("{text:?}: expected j1..j6 or x, y, z, rx, ry, rz, then + or -");
        let (name, positive) = match (t.strip_suffix('+'), t.strip_suffix('-')) {
            (Some(n), _) => (n, true),
            (_, Some(n)) => (n, false),
            _ => return Err(bad()),
        };
        let cartesian = ["x", "y", "z", "rx", "ry", "rz"];
        let joints = ["j1", "j2", "j3", "j4", "j5", "j6"];
        let (cartesian, index) = match (
            cartesian.iter().position(|a| *a == name),
            joints.iter().position(|a| *a == name),
        ) {
            (Some(i), _) => (true, i),
            (_, Some(i)) => (false, i),
            _ => return Err(bad()),
        };
        Ok(Axis {
            cartesian,
            index: i32::try_from(index).map_err(|_| bad())?,
            positive,
        })
    }

    /// `J2+`, `Rz-`.
    pub fn label(&self) -> String {
        let names = if self.cartesian {
            ["X", "Y", "Z", "Rx", "Ry", "Rz"]
        } else {
            ["J1", "J2", "J3", "J4", "J5", "J6"]
        };
        let name = usize::try_from(self.index)
            .ok()
            .and_then(|i| names.get(i))
            .copied()
            .unwrap_or("?");
        format!("{name}{}", if self.positive { '+' } else { '-' })
    }

    fn direction(&self) -> i32 {
        i32::from(self.positive)
    }
}

/// How long the jog runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// One short step.
    Short,
    /// A long jog for this long.
    For(Duration),
    /// A long jog while a key is held.
    Held,
}

/// The commands a jog of `axis` sends, checked against `level` before
/// anything is sent.
pub fn check_level(
    level: Option<ProtocolLevel>,
    axis: &Axis,
    short: bool,
) -> Result<(), ClientError> {
    let Some(level) = level else {
        return Ok(());
    };
    let ids: &[CommandId] = match (axis.cartesian, short) {
        (false, true) => &[CommandId::ShortJogJ],
        (true, true) => &[CommandId::ShortJogL],
        (false, false) => &[CommandId::LongJogJ, CommandId::LongMoveEvent],
        (true, false) => &[CommandId::LongJogL, CommandId::LongMoveEvent],
    };
    for id in ids {
        id.check_level(level).map_err(ClientError::Level)?;
    }
    Ok(())
}

/// Starts (`on`) or ends a long jog of `axis`.
fn long_jog(c: &mut Client, axis: &Axis, on: bool) -> Result<String, ClientError> {
    let (axis_id, direction, state) = (axis.index, axis.direction(), i32::from(on));
    if axis.cartesian {
        c.call(&rq::LongJogL {
            rbt_id: RobotId(0),
            axis: axis_id,
            direction,
            state,
        })
    } else {
        c.call(&rq::LongJogJ {
            rbt_id: RobotId(0),
            axis: axis_id,
            direction,
            state,
        })
    }
}

/// Prints where the robot is.
fn report(json: bool, c: &mut Client, axis: &Axis, t: Duration, done: bool) -> Result<(), Exit> {
    let fsm = read_fsm(c)?;
    let p = read_act_pos(c)?;
    if json {
        println!(
            "{}",
            obj! {
                "jog" => axis.label(), "t" => Decimal::from_f64(t.as_secs_f64(), 3),
                "fsm" => fsm.code(), "done" => done,
                "joints" => &p.joints, "pose" => &p.pose,
            }
        );
    } else {
        println!(
            "{:6.2}s  {}  FSM {:<18} joints [{}]  pose [{}]",
            t.as_secs_f64(),
            axis.label(),
            fsm_name(fsm),
            fmt6(&p.joints),
            fmt6(&p.pose)
        );
    }
    Ok(())
}

/// `hansctl jog`.
pub fn run(json: bool, c: &mut Client, axis: &Axis, mode: Mode) -> Result<(), Exit> {
    match mode {
        Mode::Short => short(json, c, axis),
        Mode::For(d) => {
            let start = Instant::now();
            hold(json, c, axis, || start.elapsed() >= d)
        }
        Mode::Held => held(json, c, axis),
    }
}

fn short(json: bool, c: &mut Client, axis: &Axis) -> Result<(), Exit> {
    let (axis_id, direction) = (axis.index, axis.direction());
    if axis.cartesian {
        c.call(&rq::ShortJogL {
            rbt_id: RobotId(0),
            axis: axis_id,
            direction,
        })?;
    } else {
        c.call(&rq::ShortJogJ {
            rbt_id: RobotId(0),
            axis: axis_id,
            direction,
        })?;
    }
    // A step takes well under a second; wait for it, bounded.
    let start = Instant::now();
    while read_fsm(c)? == FsmState::Moving {
        if start.elapsed() > Duration::from_secs(10) {
            return Err(Exit(3, "the step is still running after 10 s".into()));
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    report(json, c, axis, start.elapsed(), true)
}

/// A long jog, kept alive until `released()` says so.
fn hold(
    json: bool,
    c: &mut Client,
    axis: &Axis,
    mut released: impl FnMut() -> bool,
) -> Result<(), Exit> {
    long_jog(c, axis, true)?;
    let start = Instant::now();
    let mut events = Events::starting(start);
    let mut next_report = start + Duration::from_millis(500);
    let outcome = loop {
        if released() {
            break Ok(());
        }
        let now = Instant::now();
        if events.due(now) {
            match c.call(&rq::LongMoveEvent::default()) {
                Ok(_) => {}
                // The controller stopped the jog itself (a limit, a late
                // event, a stop from elsewhere).
                Err(ClientError::Fail(_, code, _)) if code.code() == 20018 => {
                    break Err(Exit(
                        1,
                        "the controller ended the jog (a limit, or it was stopped)".into(),
                    ));
                }
                Err(e) => break Err(Exit::from(e)),
            }
        }
        if now >= next_report {
            next_report += Duration::from_millis(500);
            if let Err(e) = report(json, c, axis, start.elapsed(), false) {
                break Err(e);
            }
        }
        let wait = events.next().saturating_duration_since(Instant::now());
        std::thread::sleep(wait.min(Duration::from_millis(10)));
    };
    // Always ask for the stop, also after an error (the controller stops
    // by itself too, when the events stop).
    let stopped = long_jog(c, axis, false);
    outcome?;
    stopped?;
    // Braking takes a moment; report where it ends, bounded.
    let braking = Instant::now();
    while matches!(
        read_fsm(c)?,
        FsmState::RobotStopping | FsmState::LongJogMoving
    ) && braking.elapsed() < Duration::from_secs(5)
    {
        std::thread::sleep(Duration::from_millis(20));
    }
    report(json, c, axis, start.elapsed(), true)
}

/// When the `LongMoveEvent`s of a long jog are due: every
/// [`EVENT_PERIOD`] from the jog's start, on a fixed schedule (one that
/// went late does not push the next ones back).
#[derive(Clone, Copy, Debug)]
pub struct Events {
    next: Instant,
}

impl Events {
    /// For a jog the robot accepted at `start`.
    pub fn starting(start: Instant) -> Events {
        Events {
            next: start + EVENT_PERIOD,
        }
    }

    /// When the next one is due.
    pub fn next(&self) -> Instant {
        self.next
    }

    /// Whether one is due at `now`; if so, it counts as sent.
    pub fn due(&mut self, now: Instant) -> bool {
        if now < self.next {
            return false;
        }
        self.next += EVENT_PERIOD;
        true
    }
}

/// Decides from key presses when a held key was released (see the module
/// documentation).
#[derive(Clone, Copy, Debug)]
pub struct KeyHold {
    last: Instant,
    repeats: u32,
}

impl KeyHold {
    /// The key went down at `at`.
    pub fn pressed(at: Instant) -> KeyHold {
        KeyHold {
            last: at,
            repeats: 0,
        }
    }

    /// A repeat of the key at `at`.
    pub fn repeat(&mut self, at: Instant) {
        self.last = at;
        self.repeats = self.repeats.saturating_add(1);
    }

    /// Whether the key counts as released at `now`.
    pub fn released(&self, now: Instant) -> bool {
        let gap = if self.repeats == 0 {
            FIRST_REPEAT
        } else {
            RELEASE_GAP
        };
        now.saturating_duration_since(self.last) > gap
    }
}

/// The terminal in a mode that hands over each key at once, without echo,
/// with reads that return after 0.1 s without input; restored on drop.
struct RawTerminal {
    saved: String,
}

impl RawTerminal {
    fn enter() -> Result<RawTerminal, Exit> {
        let stty = |args: &[&str]| {
            Process::new("stty")
                .args(args)
                .stdin(Stdio::inherit())
                .stderr(Stdio::null())
                .output()
                .ok()
                .filter(|o| o.status.success())
        };
        let saved = stty(&["-g"])
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
            .ok_or_else(|| Exit(3, "cannot read the terminal's settings (stty -g)".into()))?;
        stty(&["-icanon", "-echo", "-isig", "min", "0", "time", "1"])
            .ok_or_else(|| Exit(3, "cannot set the terminal (stty)".into()))?;
        Ok(RawTerminal { saved })
    }

    /// The keys typed within 0.1 s (none: empty).
    fn keys(&self) -> Vec<u8> {
        let mut buf = [0u8; 64];
        match std::io::stdin().read(&mut buf) {
            Ok(n) => buf.get(..n).unwrap_or(&[]).to_vec(),
            Err(_) => Vec::new(),
        }
    }
}

impl Drop for RawTerminal {
    fn drop(&mut self) {
        let _ = Process::new("stty")
            .arg(&self.saved)
            .stdin(Stdio::inherit())
            .status();
    }
}

/// `q`, Esc, Ctrl-C.
fn is_quit(b: u8) -> bool {
    matches!(b, b'q' | b'Q' | 0x1b | 0x03)
}

fn held(json: bool, c: &mut Client, axis: &Axis) -> Result<(), Exit> {
    if !std::io::stdin().is_terminal() {
        return Err(Exit(
            2,
            "holding a key needs a terminal: use --for DURATION or --short".into(),
        ));
    }
    let term = RawTerminal::enter()?;
    if !json {
        println!(
            "hold any key to jog {}; release it to stop (q, Esc or Ctrl-C: quit)",
            axis.label()
        );
    }
    // Wait for the key (until the user quits).
    let first = loop {
        let keys = term.keys();
        if keys.iter().any(|&b| is_quit(b)) {
            return Ok(());
        }
        if !keys.is_empty() {
            break Instant::now();
        }
    };
    let mut key = KeyHold::pressed(first);
    let mut quit = false;
    let outcome = hold(json, c, axis, || {
        // At most 0.1 s: the events keep their period (100 ms).
        let keys = term.keys();
        let now = Instant::now();
        if keys.iter().any(|&b| is_quit(b)) {
            quit = true;
        } else if !keys.is_empty() {
            key.repeat(now);
        }
        quit || key.released(now)
    });
    drop(term);
    outcome
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axes_read_as_joints_or_directions() {
        let a = Axis::parse("j2+").unwrap();
        assert_eq!((a.cartesian, a.index, a.positive), (false, 1, true));
        assert_eq!(a.label(), "J2+");
        let a = Axis::parse("RZ-").unwrap();
        assert_eq!((a.cartesian, a.index, a.positive), (true, 5, false));
        assert_eq!(a.label(), "Rz-");
        for bad in ["j7+", "j2", "w+", "+", "", "x+-"] {
            assert!(Axis::parse(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn a_held_key_is_released_when_its_repeats_stop() {
        let t0 = Instant::now();
        let ms = |v| t0 + Duration::from_millis(v);
        let mut k = KeyHold::pressed(t0);
        // Before the keyboard starts repeating: the longer wait.
        assert!(!k.released(ms(600)));
        assert!(k.released(ms(701)));
        k.repeat(ms(500));
        k.repeat(ms(540));
        assert!(!k.released(ms(680)));
        assert!(k.released(ms(691)), "150 ms without a repeat");
    }

    #[test]
    fn the_events_go_every_period_from_the_start() {
        let t0 = Instant::now();
        let ms = |v| t0 + Duration::from_millis(v);
        let mut e = Events::starting(t0);
        assert!(!e.due(ms(99)));
        assert!(e.due(ms(100)));
        assert!(!e.due(ms(100)), "one per period");
        assert!(!e.due(ms(199)));
        assert_eq!(e.next(), ms(200));
        // Sent late (at 230): the next is still due at 300.
        assert!(e.due(ms(230)));
        assert!(!e.due(ms(299)));
        assert!(e.due(ms(300)));
        // Over 600 ms, looked at every millisecond: six.
        let mut e = Events::starting(t0);
        assert_eq!((0..=600).filter(|&t| e.due(ms(t))).count(), 6);
    }

    #[test]
    fn the_level_refuses_jogging_before_v6() {
        let j = Axis::parse("j1+").unwrap();
        let e = check_level(Some(ProtocolLevel::V5), &j, false).unwrap_err();
        assert_eq!(
            e.to_string(),
            "LongJogJ needs HR6.2.17 (level V5): not sent"
        );
        assert!(check_level(Some(ProtocolLevel::V6), &j, true).is_ok());
        assert!(check_level(None, &j, false).is_ok());
    }
}
