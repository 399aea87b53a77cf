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
//! | payload identification (`LoadIdentify`) | 41 RobotLoadIdentify |
//! | stopping a motion | 27 RobotStopping |
//! | motion paused | 32 RobotHolding |
//! | a hold-to-move motion (long jog, `MoveJTo`, `MoveLTo`, `MoveAlignToZ`) | 26 LongJogMoving |
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

// The command handlers, one file per section of the document (see
// `dispatch`).
mod force;
mod frames;
mod geometry;
mod io_commands;
mod moves;
mod paths;
mod positions;
mod power;
mod scripts;
mod servo;
mod settings;
mod shapes;
mod values;
// The commands the V6 document adds, where they have a section of their own.
mod errors;
mod jog;
mod paths_v6;

// The robot's own state.
mod queue;
mod stage;
mod state;
mod timing;

use std::collections::{BTreeMap, VecDeque};
use std::time::Duration;

use hans_codec::{FsmState, ProtocolLevel};

use crate::kinematics::{self as k, Joints, Limits, Pose, PoseFrame};
use io::Io;
use jog::Hold;
use paths::Track;
use paths_v6::OnlinePath;
use queue::{MoveKind, Planned, Segment, Speed};
use stage::Stage;
pub use state::Flags;
pub use timing::{Initial, Timing};

/// Most motion commands waiting behind the running one; more are refused
/// with `Fail,20018`.
pub const MAX_QUEUE: usize = 64;
/// Most stored paths (`StartPushMovePath`, `InitMovePathL`); more are
/// refused with `Fail,20006`.
pub const MAX_PATHS: usize = 32;
/// Most points of one stored path; more are refused with `Fail,20006`.
pub const MAX_PATH_POINTS: usize = 10_000;

/// The first controller of the V6 document (`HR5.50.3`): from it on the
/// replies take the V6 document's forms (`ReadBoxAO` with modes, ...).
const FIRST_V6: ProtocolLevel = ProtocolLevel::new(5, 50, 3);

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

#[derive(Clone, Debug, PartialEq)]
enum Script {
    Running { until: f64 },
    Pausing { until: f64, remaining: f64 },
    Held { remaining: f64 },
    Stopping { until: f64 },
}

/// A robot error set from a test (`Sim::set_error`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RobotError {
    /// The error code (`nErrorCode`).
    pub code: i32,
    /// The axis (`nErrorAxis`, 0-5).
    pub axis: i32,
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

    /// The protocol level the controller speaks.
    pub level: ProtocolLevel,
    /// `PackageVersion`: the level's version and a build date.
    pub package_version: String,
    /// The fast command port, when it listens (`ReadFastCmdPort`).
    pub fast_port: Option<u16>,
    /// The hold-to-move motion running (long jog, `MoveJTo`, ...), and
    /// when it stops unless `LongMoveEvent` comes first.
    hold: Option<Hold>,
    hold_until: f64,
    /// A `MovePathJOL` run: its points, for the index and their outputs.
    online_path: Option<OnlinePath>,
    /// Payload: mass (kg) and centre of mass (mm).
    pub payload: (f64, [f64; 3]),
    /// Payload identification (`LoadIdentify`).
    load_identify: Option<settings::Identification>,
    /// `cdsSetIO` during a motion: set when the motion reaches its target.
    pending_outputs: Option<io_commands::Outputs>,
    /// Taught points by name (`ReadPointByName`): joints, tool, user frame.
    pub points: BTreeMap<String, (Joints, Pose, Pose)>,
    /// Settings the V6 document adds that are stored and read back.
    pub stored: Stored,
}

/// Settings that are stored and read back, without behaviour of their own.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Stored {
    /// `SwitchScript`: the script file applied.
    pub script_file: String,
    /// `EnableRunningUnsavedProgram`.
    pub run_unsaved: bool,
    /// `SetTriStageSwitch`: enable, mode.
    pub tri_stage: (i32, i32),
    /// `SetCIConfig`: function and trigger of each CI.
    pub ci_config: [(i32, i32); 8],
    /// `SetCOConfig`: function of each CO.
    pub co_config: [i32; 8],
    /// `SetCollideLevel`.
    pub collide_level: i32,
    /// `SetSafeGuardConfig`: enable, mode, bit 1, bit 2.
    pub safe_guard: [i32; 4],
    /// `SetBaseInstallingAngle`: rotation, tilt.
    pub base_angle: (i32, i32),
    /// `SetFTMotionFreedom`.
    pub ft_freedom: [i32; 6],
    /// `SetFTFreeDriveSpeedMode`.
    pub ft_speed_mode: i32,
    /// `SetFTFreeFactor`: linear, angular.
    pub ft_free_factor: (f64, f64),
    /// `SetFTUCS`.
    pub ft_ucs: Pose,
    /// `SetEndModbusInfo`: baud rate, data bits, parity, stop bits.
    pub end_modbus: [i32; 4],
    /// `SetPoseTrackingState`.
    pub pose_tracking: bool,
}

impl Default for Stored {
    fn default() -> Self {
        Stored {
            script_file: "default.JSON".into(),
            run_unsaved: false,
            tri_stage: (0, 0),
            ci_config: [(-1, -1); 8],
            co_config: [-1; 8],
            collide_level: 2,
            safe_guard: [0, 0, 0, 1],
            base_angle: (0, 0),
            ft_freedom: [1; 6],
            ft_speed_mode: 0,
            ft_free_factor: (50.0, 50.0),
            ft_ucs: [0.0; 6],
            end_modbus: [115_200, 8, 78, 1],
            pose_tracking: false,
        }
    }
}

/// Where the robot starts: the pose of the document's examples (tool down
/// at 420, 0, 445).
pub const HOME: Joints = [0.0, 0.0, 90.0, 0.0, 90.0, 0.0];

impl Robot {
    pub fn new(timing: Timing, initial: Initial, level: ProtocolLevel) -> Robot {
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
        // The point of the V6 document's `ReadPointByName` example.
        let mut points = BTreeMap::new();
        points.insert(
            "Point_3".to_string(),
            ([0.0, 0.0, 45.0, 0.0, 90.0, 0.0], [0.0; 6], [0.0; 6]),
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
            level,
            package_version: {
                let (a, b, c) = level.parts();
                format!("{a}.{b}.{c}.20250805")
            },
            fast_port: None,
            hold: None,
            hold_until: f64::NEG_INFINITY,
            online_path: None,
            payload: (0.0, [0.0; 3]),
            load_identify: None,
            pending_outputs: None,
            points,
            stored: Stored::default(),
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
            t.settle(now);
        }
        self.apply_online_path_outputs(now);
        self.advance_motion(now);
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
