//! The simulated robot: state machine, motion, frames, I/O.
//!
//! Everything here is a function of simulated time (seconds since start,
//! `f64`): every entry point first calls `Robot::update` to bring the
//! state to `now`, so the same commands at the same simulated times always
//! give the same answers. Event times are sums of `f64` durations, so every
//! comparison of `now` with one goes through `reached`, which allows for
//! the rounding.
//!
//! # State machine
//! The FSM state (`ReadCurFSM`, DataSheet `robotState`) is derived, in this
//! order of precedence, from:
//!
//! | condition | state |
//! |---|---|
//! | emergency stop active | 5 EmergencyStop |
//! | box not connected (connecting) | 2 ElectricBoxDisconnect (3 ElectricBoxConnecting) |
//! | 48 V off (switching on / off) | 7 Blackout48V (8 Electrifying48V / 6 Blackouting48V) |
//! | master not started (starting / closing) | 14 ControllerDisconnect (15 ControllerConnecting / 13 ControllerDisconnecting) |
//! | safety guard active | 12 SafetyGuard |
//! | robot error | 22 Error |
//! | resetting | 19 Reseting |
//! | not enabled (enabling / disabling) | 24 Disable (23 Enabling / 28 Disabling) |
//! | free drive (opening / closing) | 31 FreeDriver (29 / 30) |
//! | force-control free drive (opening / closing) | 46 FTFreeDriver (44 / 45) |
//! | script running / pausing / paused / stopping | 34 / 35 / 36 / 37 |
//! | stopping a motion | 27 RobotStopping |
//! | motion paused | 32 RobotHolding |
//! | motion running, or force control on | 25 Moving |
//! | otherwise | 33 StandBy |
//!
//! Bring-up steps take the times of [`Timing`]. A step asked for while the
//! step before it is still in progress is accepted and starts when that one
//! completes, so `ConnectToBox`, `Electrify`, `StartMaster`, `GrpEnable`
//! sent back to back end in StandBy.

pub(crate) mod dispatch;
pub mod io;
pub(crate) mod motion;

use std::collections::{BTreeMap, VecDeque};
use std::time::Duration;

use hans_codec::FsmState;

use crate::kinematics::{self as k, Joints, Limits, Pose};
use io::Io;
use motion::{Path, Profile};

/// Most motion commands waiting behind the running one; more are refused
/// with `Fail,20018`.
pub const MAX_QUEUE: usize = 64;
/// Most stored paths (`StartPushMovePath`, `InitMovePathL`); more are
/// refused with `Fail,20006`.
pub const MAX_PATHS: usize = 32;
/// Most points of one stored path; more are refused with `Fail,20006`.
pub const MAX_PATH_POINTS: usize = 10_000;

/// How long the controller's slow operations take, in simulated time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    /// `ConnectToBox`: FSM 3 ElectricBoxConnecting for this long.
    pub box_connect: Duration,
    /// `Electrify`: FSM 8 Electrifying48V.
    pub electrify: Duration,
    /// `BlackOut` / `OSCmd`: FSM 6 Blackouting48V.
    pub blackout: Duration,
    /// `StartMaster`: FSM 15 ControllerConnecting.
    pub start_master: Duration,
    /// `CloseMaster`: FSM 13 ControllerDisconnecting.
    pub close_master: Duration,
    /// `GrpEnable`: FSM 23 Enabling.
    pub enable: Duration,
    /// `GrpDisable`: FSM 28 Disabling.
    pub disable: Duration,
    /// `GrpReset` of an error: FSM 19 Reseting.
    pub reset: Duration,
    /// Opening / closing free drive (FSM 29 / 30, 44 / 45).
    pub free_drive: Duration,
    /// How long `StartScript` / `RunFunc` run (FSM 34).
    pub script: Duration,
    /// Pausing / stopping a script (FSM 35 / 37).
    pub script_transition: Duration,
    /// `EndPushMovePath`: path state 2 (computing) before 3 (ready).
    pub path_compute: Duration,
    /// `MovePathL`: computing before the motion starts (the robot counts as
    /// moving meanwhile; the document says 2-4 s).
    pub path_l_compute: Duration,
    /// Force control: searching (state 1) before search done (state 2).
    pub force_search: Duration,
    /// `ReadRobotState`'s moving flag follows the motion this much later
    /// (the vendor documents ~50 ms); the FSM state changes at once.
    pub moving_flag_lag: Duration,
    /// The actual position follows the command position this much later;
    /// `nInPos` becomes 1 this long after the command position stops.
    pub actual_lag: Duration,
}

impl Default for Timing {
    fn default() -> Self {
        let ms = Duration::from_millis;
        Timing {
            box_connect: ms(200),
            electrify: ms(500),
            blackout: ms(300),
            start_master: ms(300),
            close_master: ms(200),
            enable: ms(200),
            disable: ms(100),
            reset: ms(100),
            free_drive: ms(100),
            script: ms(3000),
            script_transition: ms(100),
            path_compute: ms(300),
            path_l_compute: ms(2000),
            force_search: ms(500),
            moving_flag_lag: ms(50),
            actual_lag: ms(20),
        }
    }
}

impl Timing {
    /// Every operation completes at once and no flag lags (scripts still run
    /// for [`Timing::script`]).
    pub fn instant() -> Timing {
        let z = Duration::ZERO;
        Timing {
            box_connect: z,
            electrify: z,
            blackout: z,
            start_master: z,
            close_master: z,
            enable: z,
            disable: z,
            reset: z,
            free_drive: z,
            script_transition: z,
            path_compute: z,
            path_l_compute: z,
            force_search: z,
            moving_flag_lag: z,
            actual_lag: z,
            ..Timing::default()
        }
    }
}

/// Where the robot is when the simulator starts.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Initial {
    /// Box disconnected, 48 V off (FSM 2): the client runs the bring-up.
    #[default]
    PoweredOff,
    /// Brought up and enabled (FSM 33 StandBy).
    StandBy,
}

/// Slack when comparing simulated times: sums of durations in `f64` seconds
/// are not exact (0.2 + 0.1 > 0.3).
const SLACK: f64 = 1e-9;

/// Whether simulated time `now` has reached the event time `at`, give or take
/// [`SLACK`]. Every comparison of a clock reading with an event time goes
/// through here, so a test that advances the manual clock exactly to an
/// event sees it happen even when `at` is a sum of durations one ulp above.
fn reached(now: f64, at: f64) -> bool {
    now + SLACK >= at
}

/// A power/connection stage of the bring-up chain.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Stage {
    Off,
    Rising { done: f64 },
    On,
    Falling { done: f64 },
}

impl Stage {
    fn settle(&mut self, now: f64) {
        match *self {
            Stage::Rising { done } if reached(now, done) => *self = Stage::On,
            Stage::Falling { done } if reached(now, done) => *self = Stage::Off,
            _ => {}
        }
    }

    fn is_on(&self) -> bool {
        *self == Stage::On
    }

    /// On or on its way there.
    fn coming(&self) -> bool {
        matches!(self, Stage::On | Stage::Rising { .. })
    }

    /// When it is (or will be) on.
    fn ready_at(&self, now: f64) -> f64 {
        match *self {
            Stage::Rising { done } => done.max(now),
            _ => now,
        }
    }

    /// Starts rising after `after`, unless already on or rising.
    fn raise(&mut self, after: f64, took: Duration) {
        if !self.coming() {
            *self = Stage::Rising {
                done: after + took.as_secs_f64(),
            };
        }
    }

    /// Starts falling now, unless already off or falling.
    fn lower(&mut self, now: f64, took: Duration) {
        if matches!(self, Stage::On | Stage::Rising { .. }) {
            *self = Stage::Falling {
                done: now + took.as_secs_f64(),
            };
        }
    }
}

/// How a planned move runs in time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Speed {
    /// Trapezoid with this speed and acceleration (path units per s, s²).
    Trap { v: f64, a: f64 },
    /// Constant speed, taking exactly this long (s).
    Timed(f64),
}

/// What kind of move, for the progress commands.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum MoveKind {
    /// A way point or other single move.
    Move,
    /// A `MovePathL` run through this many points.
    PathL(usize),
    /// Standing still (path computation).
    Dwell,
}

/// A move that has been accepted.
#[derive(Clone, Debug)]
pub(crate) struct Planned {
    pub path: Path,
    pub speed: Speed,
    pub cmd_id: Option<String>,
    /// Stop when box DI `.0` reads `.1`.
    pub seek: Option<(usize, bool)>,
    pub kind: MoveKind,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    Run,
    Stop,
    Pause,
}

#[derive(Clone, Debug)]
struct Segment {
    plan: Planned,
    profile: Profile,
    phase: Phase,
    started: f64,
}

impl Segment {
    fn s_at(&self, t: f64) -> (f64, f64) {
        self.profile.sample(t)
    }

    fn decel(&self) -> f64 {
        match self.plan.speed {
            Speed::Trap { a, .. } => a,
            Speed::Timed(_) => 1000.0,
        }
    }

    /// Decelerates from where it is at `t` (stop, pause, an I/O seek) and
    /// enters `phase`.
    fn brake(&mut self, t: f64, phase: Phase) {
        let (s, v) = self.s_at(t);
        self.profile = Profile::Brake {
            t0: t,
            s0: s,
            v0: v,
            a: self.decel(),
            s_max: self.plan.path.length(),
        };
        self.phase = phase;
    }
}

#[derive(Clone, Debug, PartialEq)]
enum Script {
    Running { until: f64 },
    Pausing { until: f64, remaining: f64 },
    Held { remaining: f64 },
    Stopping { until: f64 },
}

/// A stored path of section 4.11.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Track {
    /// Joint points (`false`) or Cartesian points (`true`).
    pub cartesian: bool,
    pub points: Vec<[f64; 6]>,
    /// 0 not taught, 1 teaching, 2 computing (until `ready_at`), 3 ready,
    /// 4 teaching ended, 5 error.
    pub state: i32,
    pub ready_at: f64,
    pub speed_ratio: f64,
    pub vel: f64,
    pub acc: f64,
    pub tcp: Pose,
    pub ucs: Pose,
}

/// A robot error set from a test (`Sim::set_error`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RobotError {
    /// The error code (`nErrorCode`).
    pub code: i32,
    /// The axis (`nErrorAxis`, 0-5).
    pub axis: i32,
}

/// The `ReadRobotState` flags.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Flags {
    /// `nMovingState` (lags the motion by [`Timing::moving_flag_lag`]).
    pub moving: bool,
    /// `nEnableState`.
    pub enabled: bool,
    /// `nErrorState`.
    pub error: bool,
    /// `nErrorCode`.
    pub error_code: i32,
    /// `nErrorAxis`.
    pub error_axis: i32,
    /// `nBreaking`: true = brakes released.
    pub brake_released: bool,
    /// `nPause`.
    pub paused: bool,
    /// `nEmergencyStop`.
    pub emergency_stop: bool,
    /// `nSaftyGuard`.
    pub safety_guard: bool,
    /// `nElectrify`.
    pub powered: bool,
    /// `nIsConnectToBox`.
    pub box_connected: bool,
    /// `nBlendingDone`: no way point running or waiting.
    pub blending_done: bool,
    /// `nInPos`: the actual position has reached the command position.
    pub in_position: bool,
}

/// Everything a client can observe at one instant (also what `Sim::state()`
/// returns).
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    /// Simulated time of the snapshot.
    pub time: Duration,
    /// FSM state.
    pub fsm: FsmState,
    /// `ReadRobotState` flags.
    pub flags: Flags,
    /// Command joints (°).
    pub cmd_joints: Joints,
    /// Actual joints (°).
    pub act_joints: Joints,
    /// Actual TCP pose in the current UCS.
    pub act_pose: Pose,
    /// Actual flange pose in the base frame.
    pub act_pose_base: Pose,
    /// Actual joint velocities (°/s).
    pub act_joint_vel: Joints,
    /// Actual joint accelerations (°/s²).
    pub act_joint_acc: Joints,
    /// Actual joint currents (A).
    pub act_joint_cur: Joints,
    /// Current tool frame.
    pub tcp: Pose,
    /// Current user frame.
    pub ucs: Pose,
    /// Speed override 0.01-1.
    pub override_ratio: f64,
    /// The `strCmdID` of the current (or last) way point.
    pub waypoint_id: String,
    /// Force-control state (`ReadFTControlState`).
    pub ft_state: i32,
    /// Calibrated force data.
    pub ft_data: [f64; 6],
    /// All I/O.
    pub io: Io,
}

/// The robot.
#[derive(Debug)]
pub(crate) struct Robot {
    pub timing: Timing,
    pub model: String,
    pub script_functions: Vec<String>,

    box_: Stage,
    power: Stage,
    master: Stage,
    enable: Stage,
    free_drive: Stage,
    ft_free: Stage,
    estop: bool,
    guard: bool,
    error: Option<RobotError>,
    resetting_until: f64,
    script: Option<Script>,
    ft_on: Option<f64>,

    rest: Joints,
    active: Option<Segment>,
    queue: VecDeque<Planned>,
    busy_since: f64,
    idle_since: f64,
    waypoint_id: String,
    last_path_l: Option<(f64, i32)>,
    servo: Option<f64>,

    pub override_ratio: f64,
    pub tool_motion: bool,
    pub joint_max_vel: Joints,
    pub joint_max_acc: Joints,
    pub joint_max_jerk: Joints,
    pub linear_max: [f64; 3],
    pub limits: Limits,
    pub tcp: Pose,
    pub ucs: Pose,
    pub tcps: BTreeMap<String, Pose>,
    pub ucss: BTreeMap<String, Pose>,
    pub tracks: BTreeMap<String, Track>,
    pub io: Io,
    pub ft_data: [f64; 6],
    pub end_io_ethercat: bool,
}

/// Where the robot starts: the pose of the document's examples (tool down
/// at 420, 0, 445).
pub const HOME: Joints = [0.0, 0.0, 90.0, 0.0, 90.0, 0.0];

impl Robot {
    pub fn new(timing: Timing, initial: Initial) -> Robot {
        let on = initial == Initial::StandBy;
        let st = |b| if b { Stage::On } else { Stage::Off };
        let mut tcps = BTreeMap::new();
        tcps.insert("TCP".to_string(), [0.0; 6]);
        tcps.insert("Tool".to_string(), [0.0; 6]);
        tcps.insert("TCP_1".to_string(), [60.0, 80.0, 120.0, 50.0, 0.0, 0.0]);
        let mut ucss = BTreeMap::new();
        ucss.insert("Base".to_string(), [0.0; 6]);
        ucss.insert(
            "Point_1".to_string(),
            [420.0, 0.0, 445.0, 180.0, 0.0, 180.0],
        );
        Robot {
            timing,
            model: "5KG".into(),
            script_functions: ["Func_main", "Func_1", "Func_2", "Func_3"]
                .iter()
                .map(|s| s.to_string())
                .collect(),
            box_: st(on),
            power: st(on),
            master: st(on),
            enable: st(on),
            free_drive: Stage::Off,
            ft_free: Stage::Off,
            estop: false,
            guard: false,
            error: None,
            resetting_until: 0.0,
            script: None,
            ft_on: None,
            rest: HOME,
            active: None,
            queue: VecDeque::new(),
            busy_since: f64::NEG_INFINITY,
            idle_since: f64::NEG_INFINITY,
            waypoint_id: "0".into(),
            last_path_l: None,
            servo: None,
            override_ratio: 1.0,
            tool_motion: false,
            joint_max_vel: [170.0, 170.0, 170.0, 170.0, 180.0, 180.0],
            joint_max_acc: [360.0; 6],
            joint_max_jerk: [3600.0; 6],
            linear_max: [2000.0, 2500.0, 10_000_000.0],
            limits: Limits::default(),
            tcp: [0.0; 6],
            ucs: [0.0; 6],
            tcps,
            ucss,
            tracks: BTreeMap::new(),
            io: Io::default(),
            ft_data: [0.0; 6],
            end_io_ethercat: true,
        }
    }

    fn secs(d: Duration) -> f64 {
        d.as_secs_f64()
    }

    /// Brings everything to time `now`.
    pub fn update(&mut self, now: f64) {
        for s in [
            &mut self.box_,
            &mut self.power,
            &mut self.master,
            &mut self.enable,
            &mut self.free_drive,
            &mut self.ft_free,
        ] {
            s.settle(now);
        }
        self.script = match self.script.take() {
            Some(Script::Running { until }) if reached(now, until) => None,
            Some(Script::Stopping { until }) if reached(now, until) => None,
            Some(Script::Pausing { until, remaining }) if reached(now, until) => {
                Some(Script::Held { remaining })
            }
            other => other,
        };
        for t in self.tracks.values_mut() {
            if t.state == 2 && reached(now, t.ready_at) {
                t.state = 3;
            }
        }
        self.advance_motion(now);
    }

    fn advance_motion(&mut self, now: f64) {
        loop {
            if let Some(seg) = self.active.as_mut() {
                let Some(end) = seg.profile.end() else {
                    break;
                };
                // A seek input that matches ends the way point early.
                if let (Phase::Run, Some((bit, level))) = (seg.phase, seg.plan.seek) {
                    if self.io.di.get(bit).copied() == Some(level) {
                        let t = seg.started.max(now.min(end));
                        seg.brake(t, Phase::Stop);
                        self.queue.clear();
                        continue;
                    }
                }
                if !reached(now, end) {
                    break;
                }
                let q = seg.plan.path.at(seg.profile.final_s());
                match seg.phase {
                    Phase::Run => {
                        if let MoveKind::PathL(n) = seg.plan.kind {
                            self.last_path_l = Some((1.0, i32::try_from(n).unwrap_or(i32::MAX)));
                        }
                        self.rest = q;
                        self.active = None;
                        match self.queue.pop_front() {
                            Some(next) => self.start(next, end, true),
                            None => self.idle_since = end,
                        }
                    }
                    Phase::Stop => {
                        self.rest = q;
                        self.active = None;
                        self.queue.clear();
                        self.idle_since = end;
                    }
                    Phase::Pause => {
                        seg.profile = Profile::Hold {
                            s: seg.profile.final_s(),
                        };
                        self.idle_since = end;
                    }
                }
            } else {
                match self.queue.pop_front() {
                    Some(next) => self.start(next, now, false),
                    None => break,
                }
            }
        }
    }

    /// Starts `plan` at `t`; `chained` when it follows a move that ended at
    /// `t` (the robot never came to rest in between).
    fn start(&mut self, plan: Planned, t: f64, chained: bool) {
        if !chained {
            self.busy_since = t;
        }
        let len = plan.path.length();
        let profile = match plan.speed {
            Speed::Trap { v, a } => Profile::Trap {
                t0: t,
                s0: 0.0,
                s1: len,
                v,
                a,
            },
            Speed::Timed(dur) => Profile::Linear {
                t0: t,
                s0: 0.0,
                s1: len,
                dur,
            },
        };
        if let Some(id) = &plan.cmd_id {
            self.waypoint_id = id.clone();
        }
        self.active = Some(Segment {
            plan,
            profile,
            phase: Phase::Run,
            started: t,
        });
    }

    /// Accepts a planned move: runs now or after the moves before it.
    /// `false` when the queue is full.
    pub fn push_move(&mut self, plan: Planned, now: f64) -> bool {
        if self.active.is_none() && self.queue.is_empty() {
            self.start(plan, now, false);
            self.advance_motion(now);
            return true;
        }
        if self.queue.len() >= MAX_QUEUE {
            return false;
        }
        self.queue.push_back(plan);
        true
    }

    /// Where the next accepted move starts: the end of the last one.
    pub fn plan_start(&self) -> Joints {
        if let Some(p) = self.queue.back() {
            return p.path.end();
        }
        match &self.active {
            Some(seg) if seg.phase == Phase::Run => seg.plan.path.end(),
            Some(seg) => seg.plan.path.at(seg.profile.final_s()),
            None => self.rest,
        }
    }

    /// Command joints at `now`.
    pub fn cmd_joints(&self, now: f64) -> Joints {
        match &self.active {
            Some(seg) => seg.plan.path.at(seg.s_at(now).0),
            None => self.rest,
        }
    }

    /// Actual joints at `now` (the command position `actual_lag` ago).
    pub fn act_joints(&self, now: f64) -> Joints {
        let t = now - Self::secs(self.timing.actual_lag);
        match &self.active {
            Some(seg) if t >= seg.started => seg.plan.path.at(seg.s_at(t).0),
            Some(seg) => seg.plan.path.start(),
            None => self.rest,
        }
    }

    fn motion_running(&self) -> bool {
        self.active
            .as_ref()
            .is_some_and(|s| !matches!(s.profile, Profile::Hold { .. }))
    }

    /// Stops every motion at once where it is (emergency stop, disable,
    /// errors).
    fn abort_motion(&mut self, now: f64) {
        if self.active.is_some() {
            self.rest = self.cmd_joints(now);
            self.active = None;
            self.idle_since = now;
        }
        self.queue.clear();
        self.servo = None;
        if self.ft_on.take().is_some() {
            self.idle_since = self.idle_since.max(now);
        }
    }

    /// `GrpStop`: decelerate to a stop, drop queued moves.
    pub fn stop(&mut self, now: f64) {
        self.queue.clear();
        self.servo = None;
        if self.ft_on.take().is_some() && self.active.is_none() {
            self.idle_since = now;
        }
        let Some(seg) = self.active.as_mut() else {
            return;
        };
        match seg.profile {
            Profile::Hold { .. } => {
                self.rest = seg.plan.path.at(seg.profile.final_s());
                self.active = None;
            }
            _ if seg.phase == Phase::Stop => {}
            _ => {
                seg.brake(now, Phase::Stop);
            }
        }
        self.advance_motion(now);
    }

    /// `GrpInterrupt`: decelerate and hold; `false` when nothing runs.
    pub fn pause(&mut self, now: f64) -> bool {
        let Some(seg) = self.active.as_mut() else {
            return false;
        };
        if seg.phase != Phase::Run {
            return false;
        }
        seg.brake(now, Phase::Pause);
        self.advance_motion(now);
        true
    }

    /// `GrpContinue`: `Err(40014)` while still braking, `Err(20018)` when
    /// not paused.
    pub fn resume(&mut self, now: f64) -> Result<(), i32> {
        let Some(seg) = self.active.as_mut() else {
            return Err(20018);
        };
        if seg.phase != Phase::Pause {
            return Err(20018);
        }
        let Profile::Hold { s } = seg.profile else {
            return Err(40014);
        };
        let len = seg.plan.path.length();
        seg.profile = match seg.plan.speed {
            Speed::Trap { v, a } => Profile::Trap {
                t0: now,
                s0: s,
                s1: len,
                v,
                a,
            },
            Speed::Timed(dur) => {
                let left = if len > 0.0 { (len - s) / len } else { 0.0 };
                Profile::Linear {
                    t0: now,
                    s0: s,
                    s1: len,
                    dur: dur * left,
                }
            }
        };
        seg.phase = Phase::Run;
        self.busy_since = now;
        self.advance_motion(now);
        Ok(())
    }

    /// The FSM state at `now` (after [`Robot::update`]).
    pub fn fsm(&self, now: f64) -> FsmState {
        use FsmState as F;
        if self.estop {
            return F::EmergencyStop;
        }
        match self.box_ {
            Stage::On => {}
            Stage::Rising { .. } => return F::ElectricBoxConnecting,
            _ => return F::ElectricBoxDisconnect,
        }
        match self.power {
            Stage::On => {}
            Stage::Rising { .. } => return F::Electrifying48V,
            Stage::Falling { .. } => return F::Blackouting48V,
            Stage::Off => return F::Blackout48V,
        }
        match self.master {
            Stage::On => {}
            Stage::Rising { .. } => return F::ControllerConnecting,
            Stage::Falling { .. } => return F::ControllerDisconnecting,
            Stage::Off => return F::ControllerDisconnect,
        }
        if self.guard {
            return F::SafetyGuard;
        }
        if self.error.is_some() {
            return F::Error;
        }
        if !reached(now, self.resetting_until) {
            return F::Reseting;
        }
        match self.enable {
            Stage::On => {}
            Stage::Rising { .. } => return F::Enabling,
            Stage::Falling { .. } => return F::Disabling,
            Stage::Off => return F::Disable,
        }
        match self.free_drive {
            Stage::Rising { .. } => return F::RobotOpeningFreeDriver,
            Stage::On => return F::FreeDriver,
            Stage::Falling { .. } => return F::RobotClosingFreeDriver,
            Stage::Off => {}
        }
        match self.ft_free {
            Stage::Rising { .. } => return F::FTOpeningFreeDriver,
            Stage::On => return F::FTFreeDriver,
            Stage::Falling { .. } => return F::FTClosingFreeDriver,
            Stage::Off => {}
        }
        match self.script {
            Some(Script::Running { .. }) => return F::ScriptRunning,
            Some(Script::Pausing { .. }) => return F::ScriptHoldHandling,
            Some(Script::Held { .. }) => return F::ScriptHolding,
            Some(Script::Stopping { .. }) => return F::ScriptStopping,
            None => {}
        }
        match &self.active {
            Some(seg) => match seg.phase {
                Phase::Stop => F::RobotStopping,
                Phase::Pause => F::RobotHolding,
                Phase::Run => F::Moving,
            },
            None if !self.queue.is_empty() || self.ft_on.is_some() => F::Moving,
            None => F::StandBy,
        }
    }

    /// The `ReadRobotState` flags at `now`.
    pub fn flags(&self, now: f64) -> Flags {
        let lagged = now - Self::secs(self.timing.moving_flag_lag);
        let moving = if self.motion_running() {
            reached(lagged, self.busy_since)
        } else {
            reached(lagged, self.busy_since) && !reached(lagged, self.idle_since)
        } || self.ft_on.is_some_and(|since| reached(lagged, since));
        let enabled = self.enable.is_on() && !self.estop;
        let settled = !self.motion_running()
            && reached(now, self.idle_since + Self::secs(self.timing.actual_lag));
        Flags {
            moving,
            enabled,
            error: self.error.is_some(),
            error_code: self.error.map_or(0, |e| e.code),
            error_axis: self.error.map_or(0, |e| e.axis),
            brake_released: enabled,
            paused: self
                .active
                .as_ref()
                .is_some_and(|s| s.phase == Phase::Pause),
            emergency_stop: self.estop,
            safety_guard: self.guard,
            powered: self.power.is_on() && !self.estop,
            box_connected: self.box_.is_on(),
            blending_done: self.active.is_none() && self.queue.is_empty(),
            in_position: settled,
        }
    }

    /// A full snapshot at `now` (after [`Robot::update`]).
    pub fn snapshot(&self, now: f64) -> Snapshot {
        let dt = 0.001;
        let a0 = self.act_joints(now);
        let a1 = self.act_joints(now - dt);
        let a2 = self.act_joints(now - 2.0 * dt);
        let mut vel = [0.0; 6];
        let mut acc = [0.0; 6];
        let mut cur = [0.0; 6];
        for i in 0..6 {
            vel[i] = (a0[i] - a1[i]) / dt;
            acc[i] = (a0[i] - 2.0 * a1[i] + a2[i]) / (dt * dt);
        }
        // Currents: a gravity term on the pitch joints plus an inertia term;
        // no model of a real arm, only something that moves plausibly.
        if self.enable.is_on() && !self.estop {
            let g2 = (a0[1]).to_radians().sin();
            let g3 = (a0[1] + a0[2]).to_radians().sin();
            cur = [
                0.002 * acc[0],
                2.0 * g2 + 1.0 * g3 + 0.004 * acc[1],
                1.0 * g3 + 0.003 * acc[2],
                0.001 * acc[3],
                0.3 * (a0[1] + a0[2] + a0[4]).to_radians().sin() + 0.001 * acc[4],
                0.0005 * acc[5],
            ];
        }
        Snapshot {
            time: Duration::from_secs_f64(now.max(0.0)),
            fsm: self.fsm(now),
            flags: self.flags(now),
            cmd_joints: self.cmd_joints(now),
            act_joints: a0,
            act_pose: k::forward_pose(&a0, &self.tcp, &self.ucs),
            act_pose_base: k::forward(&a0).to_pose(),
            act_joint_vel: vel,
            act_joint_acc: acc,
            act_joint_cur: cur,
            tcp: self.tcp,
            ucs: self.ucs,
            override_ratio: self.override_ratio,
            waypoint_id: self.waypoint_id.clone(),
            ft_state: self.ft_state(now),
            ft_data: self.ft_data,
            io: self.io.clone(),
        }
    }

    /// `ReadFTControlState`: 0 off, 1 searching, 2 search done, 3 free drive.
    pub fn ft_state(&self, now: f64) -> i32 {
        if self.ft_free.coming() {
            return 3;
        }
        match self.ft_on {
            Some(since) if reached(now, since + Self::secs(self.timing.force_search)) => 2,
            Some(_) => 1,
            None => 0,
        }
    }

    // ----------------------------------------------------------- test hooks

    pub fn set_estop(&mut self, on: bool, now: f64) {
        if on && !self.estop {
            self.abort_motion(now);
            self.enable = Stage::Off;
            self.power = Stage::Off;
            self.free_drive = Stage::Off;
            self.ft_free = Stage::Off;
            self.script = None;
        }
        self.estop = on;
    }

    pub fn set_guard(&mut self, on: bool, now: f64) {
        if on && !self.guard {
            self.stop(now);
            self.script = None;
        }
        self.guard = on;
    }

    pub fn set_error(&mut self, e: Option<RobotError>, now: f64) {
        if e.is_some() {
            self.abort_motion(now);
            self.script = None;
        }
        self.error = e;
    }
}

#[cfg(test)]
mod tests {
    use super::reached;

    #[test]
    fn reached_absorbs_float_sums_but_not_real_gaps() {
        // 0.1 + 0.2 is one ulp above 0.3.
        let sum = std::hint::black_box(0.1) + 0.2;
        assert!(sum > 0.3);
        assert!(reached(0.3, sum));
        assert!(reached(0.4, 0.3));
        assert!(!reached(0.299, 0.3));
        assert!(!reached(0.3 - 1e-6, 0.3));
    }
}
